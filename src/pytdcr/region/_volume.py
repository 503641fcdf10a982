"""The volume of a region with an error a user can trust: two estimators at three sample sizes."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._grid import Region, region_from_points

__all__ = ["VolumeEstimate", "estimate_volume", "nested_stages"]


@dataclass(frozen=True)
class VolumeEstimate:
    """The volume of a region of sampled points, at n/4, n/2 and n base samples.

    At each size two estimators: the occupied voxels' volume, whose faces enclose every boundary voxel whole
    (an outer bound of the sampled region at this resolution), and the volume inside the boundary surface
    (marching cubes) moved inward by half a voxel, through the boundary voxels' centres (Steiner: V - A h/2),
    where the true boundary lies on average when it crosses a voxel at random (a boundary along the voxel
    faces is the outer one; the staircase of a curved one makes the surface's area too large, so the inner
    estimate too small). The estimate is their mean at n. The error adds half their difference (the
    resolution) to the growth expected from n to 4n if each doubling of the samples adds ``ratio`` times what
    the last one added (the region fills in as samples grow).

    Attributes
    ----------
    volume_m3, error_m3 : float
    discretisation_m3, sampling_m3 : float
        The two parts of the error [m^3].
    ratio : float
        Growth of the last doubling over the one before, clipped to [0.5, 1.5] (1 when undefined).
    scales : tuple of dict
        Per size: ``n_base``, ``points``, ``voxel_m3``, ``centre_m3``, ``estimate_m3``.
    search_m3 : float
        The growth still expected of a boundary search stopped before it converged (its budget spent), added
        to the error [m^3]: its last round's growth continued geometrically (0 when it converged).
    """

    volume_m3: float
    error_m3: float
    discretisation_m3: float
    sampling_m3: float
    ratio: float
    scales: tuple[dict[str, float], ...]
    search_m3: float = 0.0

    def with_search_tail(self, tail_m3: float) -> VolumeEstimate:
        """This estimate with ``tail_m3`` [m^3] of unfinished search growth added to its error."""
        return VolumeEstimate(self.volume_m3, self.error_m3 + tail_m3, self.discretisation_m3, self.sampling_m3,
                              self.ratio, self.scales, tail_m3)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"volume_m3": self.volume_m3, "error_m3": self.error_m3, "discretisation_m3": self.discretisation_m3,
                "sampling_m3": self.sampling_m3, "search_m3": self.search_m3, "ratio": self.ratio,
                "scales": list(self.scales)}


def _both(region: Region) -> tuple[float, float]:
    """The outer (voxel) and centre (surface moved in by half a voxel) estimates [m^3]."""
    if not region.occupied.any():
        return 0.0, 0.0
    mesh = region.mesh()
    return region.voxel_volume, max(0.0, float(mesh.volume) - 0.5 * region.voxel * float(mesh.area))


def nested_stages(base_index: np.ndarray, n_base: int) -> np.ndarray:
    """Stages (K,) of int8 for points numbered ``base_index`` (K,) in a base sequence of ``n_base``: 0 for the
    first quarter (and for -1, points outside the sequence), 1 for the second, 2 for the second half."""
    b = np.asarray(base_index)
    stage = np.zeros(b.shape, dtype=np.int8)
    stage[b >= max(1, n_base // 4)] = 1
    stage[b >= max(1, n_base // 2)] = 2
    return stage


def estimate_volume(points: np.ndarray, stage: np.ndarray, n_base: int, voxel: float,
                    closing: int = 1) -> tuple[VolumeEstimate, Region]:
    """The volume of the region of ``points`` (K, 3) [m] and the region at n.

    ``stage`` (K,) says from which nested size each point counts (:func:`nested_stages`): the sizes are n/4,
    n/2 and n base samples (``n_base``), and a point of stage s counts at size s and above.
    """
    stage = np.asarray(stage)
    scales = []
    region = None
    for k, n in enumerate((max(1, n_base // 4), max(1, n_base // 2), n_base)):
        keep = stage <= k
        region = region_from_points(points[keep], voxel, closing)
        v, m = _both(region)
        scales.append({"n_base": int(n), "points": int(np.sum(keep & np.all(np.isfinite(points), axis=1))),
                       "voxel_m3": v, "centre_m3": m, "estimate_m3": 0.5 * (v + m)})
    e = [s["estimate_m3"] for s in scales]
    d1, d2 = e[1] - e[0], e[2] - e[1]
    ratio = float(np.clip(d2 / d1, 0.5, 1.5)) if d1 > 0 and d2 > 0 else 1.0
    sampling = abs(d2) * (ratio + ratio**2)
    disc = 0.5 * abs(scales[-1]["voxel_m3"] - scales[-1]["centre_m3"])
    est = VolumeEstimate(e[-1], disc + sampling, disc, sampling, ratio, tuple(scales))
    assert region is not None
    return est, region

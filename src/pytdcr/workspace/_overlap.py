"""How two regions differ: the distance between their boundaries and how much of each lies inside the other."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.distance import directed_hausdorff

from ..records import JsonDict
from ._grid import Region, inside

__all__ = ["RegionOverlap", "region_overlap"]


@dataclass(frozen=True)
class RegionOverlap:
    """Two regions compared (``a`` and ``b``, on voxels of one edge).

    Attributes
    ----------
    hausdorff_m : float or None
        The symmetric Hausdorff distance between their boundary surfaces [m]: the farthest any point of either
        boundary lies from the other (the vertices of the marching-cubes surfaces, :meth:`Region.mesh`, so to
        about half a voxel). None when either region has no boundary surface.
    a_to_b_m, b_to_a_m : float or None
        The two directed distances: the farthest a point of a's boundary lies from b's, and the reverse [m].
    a_in_b, b_in_a : float or None
        The share of a's occupied voxels whose centres lie in b's, and the reverse (None for an empty region).
    voxels_a, voxels_b : int
        Each region's occupied voxels.
    """

    hausdorff_m: float | None
    a_to_b_m: float | None
    b_to_a_m: float | None
    a_in_b: float | None
    b_in_a: float | None
    voxels_a: int
    voxels_b: int

    def to_dict(self) -> JsonDict:
        """JSON-ready form."""
        return asdict(self)


def _centres(region: Region) -> np.ndarray:
    """The occupied voxels' centres (K, 3) [m]."""
    return region.origin + (np.argwhere(region.occupied) + 0.5) * region.voxel


def _share_inside(a: Region, b: Region) -> float | None:
    c = _centres(a)
    return float(np.mean(inside(b, c))) if c.shape[0] else None


def region_overlap(a: Region, b: Region) -> RegionOverlap:
    """Compare the regions ``a`` and ``b``: the Hausdorff distance between their boundaries and the share of
    each inside the other (:class:`RegionOverlap`). They must have the same voxel edge (ValueError)."""
    if not np.isclose(a.voxel, b.voxel, rtol=1e-12, atol=0.0):
        raise ValueError(f"regions on different voxels ({a.voxel} m and {b.voxel} m) cannot be compared voxel by "
                         "voxel: give both one voxel edge")
    va, vb = a.mesh().vertices, b.mesh().vertices
    ab = ba = None
    if len(va) and len(vb):
        ab = float(directed_hausdorff(np.asarray(va), np.asarray(vb))[0])
        ba = float(directed_hausdorff(np.asarray(vb), np.asarray(va))[0])
    return RegionOverlap(None if ab is None else max(ab, ba), ab, ba, _share_inside(a, b), _share_inside(b, a),
                         int(a.occupied.sum()), int(b.occupied.sum()))

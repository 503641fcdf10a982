"""The volume of a region with an error a user can trust: two estimators at three sample sizes; and the
region's dimension, so that a flat region is measured by its area, not given a volume."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..records import JsonDict, JsonObject
from ._grid import Region, region_from_points

__all__ = ["MEASURES", "RegionDimension", "VolumeEstimate", "VolumeScale", "estimate_volume", "nested_stages",
           "region_dimension"]

#: the measure that applies to a region of each dimension 0..3
MEASURES = ("none", "length", "area", "volume")


@dataclass(frozen=True)
class RegionDimension:
    """How many dimensions the sampled tips span, at the voxel's resolution, and the measure that applies.

    The tips' principal axes (singular vectors of their spread about their mean); along each, the extent
    (largest minus smallest coordinate). A dimension counts when its extent is at least one voxel edge: a region
    thinner than a voxel has no volume at that resolution (a robot whose tendons all lie in one plane has a planar
    workspace, whatever the budget). The test is affine: a curved surface spans three axes and counts as 3-D.

    Attributes
    ----------
    dimension : int
        0 (a point or no tips), 1 (a segment), 2 (a plane region) or 3.
    extents_m : tuple of float
        The extent along each principal axis, largest first [m] (zeros without tips).
    axes : tuple of tuple of float
        The principal axes (unit vectors, base frame), in the order of ``extents_m``.
    length_m, length_err_m : float or None
        For dimension 1: the segment's length [m] and its resolution (a voxel edge).
    area_m2, area_err_m2 : float or None
        For dimension 2: the region's area in its plane [m^2] on pixels of the voxel's edge (closed over gaps as
        the voxels are): the interior pixels and half the boundary ones; half the boundary pixels' area is the
        error.
    """

    dimension: int
    extents_m: tuple[float, float, float]
    axes: tuple[tuple[float, ...], ...]
    length_m: float | None = None
    length_err_m: float | None = None
    area_m2: float | None = None
    area_err_m2: float | None = None

    @property
    def measure(self) -> str:
        """``"volume"``, ``"area"``, ``"length"`` or ``"none"``: what measures a region of this dimension."""
        return MEASURES[self.dimension]

    def to_dict(self) -> JsonDict:
        """JSON-ready form."""
        return {"dimension": self.dimension, "measure": self.measure, "extents_m": list(self.extents_m),
                "axes": [list(a) for a in self.axes], "length_m": self.length_m, "length_err_m": self.length_err_m,
                "area_m2": self.area_m2, "area_err_m2": self.area_err_m2}

    @classmethod
    def from_dict(cls, d: JsonObject) -> RegionDimension:
        """The dimension :meth:`to_dict` wrote (``measure`` is derived from ``dimension``); KeyError naming a
        missing key."""
        ext = tuple(float(x) for x in d["extents_m"])
        return cls(int(d["dimension"]), (ext[0], ext[1], ext[2]), tuple(tuple(float(x) for x in a) for a in d["axes"]),
                   d["length_m"], d["length_err_m"], d["area_m2"], d["area_err_m2"])


def _plane_area(coords: np.ndarray, voxel: float, closing: int) -> tuple[float, float]:
    """Area [m^2] of the region of the 2-D points ``coords`` (K, 2) on pixels of edge ``voxel``, closed as the
    voxels are: the interior pixels and half the boundary ones (the boundary crosses them, on average halfway),
    and half the boundary pixels' area as the error (the band the boundary lies in)."""
    origin = coords.min(axis=0) - (closing + 1) * voxel
    idx = np.floor((coords - origin) / voxel).astype(np.int64)
    occ = np.zeros(tuple(int(x) for x in idx.max(axis=0) + closing + 2), dtype=bool)
    occ[idx[:, 0], idx[:, 1]] = True
    cross = ndimage.generate_binary_structure(2, 1)
    if closing:
        occ = ndimage.binary_closing(occ, structure=cross, iterations=closing)
    boundary = occ & ~ndimage.binary_erosion(occ, structure=cross)
    band = 0.5 * float(boundary.sum()) * voxel**2
    return float(occ.sum()) * voxel**2 - band, band


def _curve_length(coords: np.ndarray) -> float:
    """Length [m] of the polyline through the points ``coords`` (K, 3) in the order of their first coordinate
    (a curve that runs along its principal axis, as one tendon's arc of tips does)."""
    if coords.shape[0] < 2:
        return 0.0
    c = coords[np.argsort(coords[:, 0], kind="stable")]
    return float(np.sum(np.linalg.norm(np.diff(c, axis=0), axis=1)))


def region_dimension(points: np.ndarray, voxel: float, closing: int = 1,
                     max_dimension: int = 3) -> RegionDimension:
    """The dimension of the region of tip ``points`` (K, 3) [m] (NaN rows left out) at voxel edge ``voxel`` [m],
    and its length or area when it is 1- or 2-D (:class:`RegionDimension`).

    ``max_dimension``: what the tips can span at most, whatever their extents: the tip is a smooth function of
    the tensions, so a region with k tensions free (the others fixed by their bounds) has dimension at most k
    (a curved arc of tips for one free tendon, which spans a plane, is 1-D; its length is then measured along
    the curve, as :func:`_curve_length` orders it)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if p.shape[0] == 0:
        return RegionDimension(0, (0.0, 0.0, 0.0), tuple(tuple(float(x) for x in row) for row in np.eye(3)))
    centred = p - p.mean(axis=0)
    # zero rows make at least three (they leave the singular vectors as they are): vt is always (3, 3)
    _, _, vt = np.linalg.svd(np.vstack([centred, np.zeros((3, 3))]), full_matrices=False)
    coords = centred @ vt.T
    extents = coords.max(axis=0) - coords.min(axis=0)
    order = np.argsort(-extents, kind="stable")
    extents, vt, coords = extents[order], vt[order], coords[:, order]
    dim = min(int(np.sum(extents >= voxel)), int(max_dimension))
    axes = tuple(tuple(float(x) for x in row) for row in vt)
    ext = (float(extents[0]), float(extents[1]), float(extents[2]))
    if dim == 1:
        return RegionDimension(1, ext, axes, length_m=max(ext[0], _curve_length(coords)), length_err_m=float(voxel))
    if dim == 2:
        area, err = _plane_area(coords[:, :2], voxel, closing)
        return RegionDimension(2, ext, axes, area_m2=area, area_err_m2=err)
    return RegionDimension(dim, ext, axes)


@dataclass(frozen=True)
class VolumeScale:
    """A region's volume at one nested sample size.

    Attributes
    ----------
    n_base : int
        Base samples at this size (n/4, n/2 or n).
    points : int
        Finite points counted at this size.
    voxel_m3, centre_m3 : float
        The outer estimate (occupied voxels) and the inner one (the boundary surface moved in by half a voxel)
        [m^3].
    estimate_m3 : float
        Their mean [m^3].
    """

    n_base: int
    points: int
    voxel_m3: float
    centre_m3: float
    estimate_m3: float

    def to_dict(self) -> JsonDict:
        """JSON-ready form (``workspace.json``'s ``scales`` entries)."""
        return {"n_base": self.n_base, "points": self.points, "voxel_m3": self.voxel_m3,
                "centre_m3": self.centre_m3, "estimate_m3": self.estimate_m3}

    @classmethod
    def from_dict(cls, d: JsonObject) -> VolumeScale:
        """The scale :meth:`to_dict` wrote; KeyError naming a missing key."""
        return cls(int(d["n_base"]), int(d["points"]), float(d["voxel_m3"]), float(d["centre_m3"]),
                   float(d["estimate_m3"]))


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
    scales : tuple of VolumeScale
        The volume at each size, n/4, n/2 and n.
    search_m3 : float
        The growth still expected of a boundary search stopped before it converged (its budget spent), added
        to the error [m^3]: its last round's growth continued geometrically (0 when it converged).
    dimension : RegionDimension or None
        The dimension of the region at n (:func:`region_dimension`). Below 3 the volume and its errors are 0 and
        ``scales`` is empty: the region's measure is its area or length there.
    """

    volume_m3: float
    error_m3: float
    discretisation_m3: float
    sampling_m3: float
    ratio: float
    scales: tuple[VolumeScale, ...]
    search_m3: float = 0.0
    dimension: RegionDimension | None = None

    @property
    def has_volume(self) -> bool:
        """Whether the region is 3-D, so that its volume is its measure."""
        return self.dimension is None or self.dimension.dimension == 3

    def with_search_tail(self, tail_m3: float) -> VolumeEstimate:
        """This estimate with ``tail_m3`` [m^3] of unfinished search growth added to its error (none to a region
        without volume)."""
        if not self.has_volume:
            return self
        return VolumeEstimate(self.volume_m3, self.error_m3 + tail_m3, self.discretisation_m3, self.sampling_m3,
                              self.ratio, self.scales, tail_m3, self.dimension)

    def to_dict(self) -> JsonDict:
        """JSON-ready form."""
        return {"volume_m3": self.volume_m3, "error_m3": self.error_m3, "discretisation_m3": self.discretisation_m3,
                "sampling_m3": self.sampling_m3, "search_m3": self.search_m3, "ratio": self.ratio,
                "scales": [x.to_dict() for x in self.scales],
                "dimension": None if self.dimension is None else self.dimension.to_dict()}

    @classmethod
    def from_dict(cls, d: JsonObject) -> VolumeEstimate:
        """The estimate :meth:`to_dict` wrote (``dimension`` None when absent); KeyError
        naming a missing key."""
        dim = d.get("dimension")
        return cls(d["volume_m3"], d["error_m3"], d["discretisation_m3"], d["sampling_m3"], d["ratio"],
                   tuple(VolumeScale.from_dict(x) for x in d["scales"]), d.get("search_m3", 0.0),
                   None if dim is None else RegionDimension.from_dict(dim))


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
                    closing: int = 1, max_dimension: int = 3) -> tuple[VolumeEstimate, Region]:
    """The volume of the region of ``points`` (K, 3) [m] and the region at n.

    ``stage`` (K,) says from which nested size each point counts (:func:`nested_stages`): the sizes are n/4,
    n/2 and n base samples (``n_base``), and a point of stage s counts at size s and above. A region of
    dimension below 3 at n (:func:`region_dimension`, at most ``max_dimension``) gets volume 0 (its voxels, a
    slab one voxel thick, are not a volume).
    """
    stage = np.asarray(stage)
    dimension = region_dimension(points, voxel, closing, max_dimension)
    if dimension.dimension < 3:
        return VolumeEstimate(0.0, 0.0, 0.0, 0.0, 1.0, (), 0.0, dimension), region_from_points(points, voxel, closing)
    scales: list[VolumeScale] = []
    region = None
    for k, n in enumerate((max(1, n_base // 4), max(1, n_base // 2), n_base)):
        keep = stage <= k
        region = region_from_points(points[keep], voxel, closing)
        v, m = _both(region)
        scales.append(VolumeScale(int(n), int(np.sum(keep & np.all(np.isfinite(points), axis=1))), v, m,
                                  0.5 * (v + m)))
    e = [s.estimate_m3 for s in scales]
    d1, d2 = e[1] - e[0], e[2] - e[1]
    ratio = float(np.clip(d2 / d1, 0.5, 1.5)) if d1 > 0 and d2 > 0 else 1.0
    sampling = abs(d2) * (ratio + ratio**2)
    disc = 0.5 * abs(scales[-1].voxel_m3 - scales[-1].centre_m3)
    est = VolumeEstimate(e[-1], disc + sampling, disc, sampling, ratio, tuple(scales), 0.0, dimension)
    assert region is not None
    return est, region

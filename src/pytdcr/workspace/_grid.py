"""The workspace as a region: an occupancy grid of tip positions, its closed boundary surface, its volume."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from scipy import ndimage

from ..records import JsonDict
from ..validate import SettingsError

if TYPE_CHECKING:
    from trimesh import Trimesh

__all__ = ["MESH_LEVEL", "MIN_MESH_POINTS", "Region", "inside", "region_from_points"]

#: the occupancy level of the boundary surface (see :meth:`Region.mesh`)
MESH_LEVEL = 0.499
#: fewer tip positions than this make no boundary worth writing: a few voxels' cubes, not a region's surface
MIN_MESH_POINTS = 10


@dataclass(frozen=True, eq=False)
class Region:
    """Voxels that hold the tip of at least one sample, closed over gaps of ``closing`` voxels.

    Attributes
    ----------
    origin : ndarray, shape (3,)
        The corner of voxel (0, 0, 0) in the base frame [m].
    voxel : float
        Edge of a voxel [m].
    occupied : ndarray of bool, shape (nx, ny, nz)
        The region's voxels.
    closing : int
        Iterations of the morphological closing (gaps up to about twice this many voxels are filled).
    points : int
        Tip positions it was made from.
    MIN_MESH_POINTS : int
        (class attribute) The fewest tip positions a boundary surface is made from.
    """

    MIN_MESH_POINTS: ClassVar[int] = MIN_MESH_POINTS
    origin: np.ndarray
    voxel: float
    occupied: np.ndarray
    closing: int
    points: int

    @property
    def voxel_volume(self) -> float:
        """The occupied voxels' volume [m^3]."""
        return float(self.occupied.sum()) * self.voxel**3

    def mesh(self) -> Trimesh:
        """The closed boundary surface (``trimesh.Trimesh``, base frame, metres): marching cubes of the
        occupancy, passing halfway between occupied and empty voxel centres. The level is a hair below 1/2
        (:data:`MESH_LEVEL`): voxels that touch only along an edge or at a corner are then joined, where at
        exactly 1/2 the ambiguous faces are undecided and the surface can pinch into non-manifold edges."""
        import trimesh
        from skimage.measure import marching_cubes

        padded = np.pad(self.occupied, 1).astype(np.float32)
        if not self.occupied.any():
            return trimesh.Trimesh()
        verts, faces, _, _ = marching_cubes(padded, level=MESH_LEVEL, spacing=(self.voxel,) * 3,
                                            allow_degenerate=False)
        verts += self.origin - 0.5 * self.voxel  # voxel centres, less the padding
        mesh = trimesh.Trimesh(verts, faces[:, ::-1], process=True)
        if mesh.volume < 0:
            mesh.invert()
        return mesh

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether each point (..., 3) [m] lies in an occupied voxel: "can the robot hold its tip here under
        this load?", to the region's resolution. Shape (...,) of bool; a non-finite point is outside."""
        return inside(self, points)

    def to_dict(self) -> JsonDict:
        """JSON-ready summary (not the voxels)."""
        return {"origin_m": self.origin.tolist(), "voxel_m": self.voxel, "shape": list(self.occupied.shape),
                "occupied_voxels": int(self.occupied.sum()), "closing": self.closing, "points": self.points}


def region_from_points(points: np.ndarray, voxel: float, closing: int = 1) -> Region:
    """The region of tip ``points`` (K, 3) [m] at voxel edge ``voxel`` [m]; NaN rows are left out."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if not (np.isfinite(voxel) and voxel > 0):
        raise SettingsError("voxel", f" must be a positive length [m], got {voxel!r}")
    pad = closing + 1
    if p.shape[0] == 0:
        return Region(np.zeros(3), float(voxel), np.zeros((1, 1, 1), dtype=bool), closing, 0)
    origin = np.floor(p.min(axis=0) / voxel) * voxel - pad * voxel
    idx = np.floor((p - origin) / voxel).astype(np.int64)
    shape = tuple(int(x) for x in idx.max(axis=0) + pad + 1)
    occ = np.zeros(shape, dtype=bool)
    occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    if closing:
        occ = ndimage.binary_closing(occ, structure=ndimage.generate_binary_structure(3, 1), iterations=closing)
    return Region(origin, float(voxel), occ, int(closing), int(p.shape[0]))


def inside(region: Region, points: np.ndarray) -> np.ndarray:
    """Whether each point (..., 3) [m] lies in an occupied voxel of ``region``: "can the robot hold its tip
    here under this load?", to the region's resolution. Shape (...,) of bool."""
    p = np.asarray(points, dtype=float)
    finite = np.all(np.isfinite(p), axis=-1)
    idx = np.floor((np.where(finite[..., None], p, 0.0) - region.origin) / region.voxel).astype(np.int64)
    ok = np.all((idx >= 0) & (idx < np.array(region.occupied.shape)), axis=-1) & finite
    out = np.zeros(ok.shape, dtype=bool)
    i = idx[ok]
    out[ok] = region.occupied[i[:, 0], i[:, 1], i[:, 2]]
    return out

"""Contact checks on a solved shape: does the backbone pass through itself, do disks touch or go below the base?

A static model of the backbone knows nothing of contact, so an equilibrium it
returns may have the rod pass through itself: a pose no real robot takes. The
solvers call :func:`backbone_contact` on every converged shape and report
such a pose as not converged (``path = "self-contact"``), never as a result.

The test: two points of the backbone at least two diameters apart along it
and less than one diameter apart in space. The centreline is resampled every
quarter of the backbone's radius, so a contact is found to within that. A
curve that turns by less than 120 degrees in all cannot come back that close
(every tangent is within 60 degrees of the middle one, so points s apart along
it are at least s/2 apart), and is passed without the search.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["Contact", "backbone_contact", "bending_curvature", "contact_failure", "disks_below_base", "disks_touch",
           "turning_angle"]

#: a curve that turns less than this in all cannot touch itself two diameters on [rad]
_SAFE_TURNING = 2.0 * np.pi / 3.0


class Contact(NamedTuple):
    """The closest approach of two parts of the backbone that touch.

    Attributes
    ----------
    distance : float
        Distance between their centrelines [m] (less than the backbone's diameter).
    arc_gap : float
        Their distance along the backbone [m].
    """

    distance: float
    arc_gap: float

    def describe(self, diameter: float) -> str:
        """One line for a message, e.g. ``the backbone passes through itself (...)``."""
        # %g: a small distance is never shown as 0 (a thin backbone's contact is a few micrometres)
        return (f"the backbone passes through itself: two points {self.arc_gap * 1e3:.3g} mm apart along it are "
                f"{self.distance * 1e3:.3g} mm apart, less than its diameter {diameter * 1e3:.3g} mm")


def turning_angle(points: np.ndarray) -> float:
    """Total turning of the polyline ``points`` (K, 3) [rad]: the sum of the angles between its pieces."""
    d = np.diff(points, axis=0)
    n = np.linalg.norm(d, axis=1)
    d = d[n > 0] / n[n > 0, None]
    if d.shape[0] < 2:
        return 0.0
    c = np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1.0, 1.0)
    return float(np.sum(np.arccos(c)))


def _resample(points: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along the polyline at most ``spacing`` apart, and their arc lengths."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    grid = np.linspace(0.0, s[-1], max(2, int(np.ceil(s[-1] / spacing)) + 1))
    pts = np.column_stack([np.interp(grid, s, points[:, k]) for k in range(3)])
    return pts, grid


def backbone_contact(points: np.ndarray, radius: float) -> Contact | None:
    """The closest self-contact of a backbone of ``radius`` [m] along ``points`` (K, 3) [m], or None.

    Two points touch when they are at least two diameters apart along the
    backbone and less than one diameter apart in space (see the module).
    """
    points = np.asarray(points, dtype=float)
    if points.shape[0] < 3 or not np.all(np.isfinite(points)) or turning_angle(points) < _SAFE_TURNING:
        return None
    diameter = 2.0 * radius
    pts, s = _resample(points, radius / 4.0)
    pairs = cKDTree(pts).query_pairs(diameter, output_type="ndarray")
    if pairs.size == 0:
        return None
    gap = np.abs(s[pairs[:, 1]] - s[pairs[:, 0]])
    pairs, gap = pairs[gap >= 2.0 * diameter], gap[gap >= 2.0 * diameter]
    if pairs.size == 0:
        return None
    dist = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1)
    k = int(np.argmin(dist))
    return Contact(float(dist[k]), float(gap[k]))


def contact_failure(points: np.ndarray, radius: float) -> str:
    """The reason to refuse a shape whose backbone of ``radius`` [m] passes through itself, or ``""``."""
    c = backbone_contact(points, radius)
    return "" if c is None else c.describe(2.0 * radius)


def bending_curvature(rotations: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The backbone's bending curvature on each subsegment [1/m]: the angle between the disks' z axes at its
    ends over its arc length (exact for a constant-curvature arc; the mean for a rod that bends unevenly).

    ``rotations`` (..., N+1, 3, 3) disk frames, ``lengths`` (N,) subsegment arc lengths [m]; returns (..., N).
    """
    z = rotations[..., :, 2]
    cos = np.clip(np.sum(z[..., 1:, :] * z[..., :-1, :], axis=-1), -1.0, 1.0)
    return np.arccos(cos) / lengths


def disks_below_base(positions: np.ndarray, rotations: np.ndarray, radius: float) -> np.ndarray:
    """Whether any disk reaches below the base plane z = 0, per configuration, shape (B,) of bool.

    ``positions`` (B, N+1, 3) [m] and ``rotations`` (B, N+1, 3, 3) of the disks, row 0 the base (not
    tested); a disk of ``radius`` [m] reaches its lowest at ``z - radius * sqrt(1 - n_z^2)`` with n its
    normal (the disk frame's z axis). NaN rows (not converged) give False.
    """
    z = positions[:, 1:, 2]
    nz = rotations[:, 1:, 2, 2]
    low = z - radius * np.sqrt(np.clip(1.0 - nz * nz, 0.0, 1.0))
    return np.any(low < 0.0, axis=1)


def disks_touch(positions: np.ndarray, rotations: np.ndarray, radius: float, min_gap: int = 2) -> np.ndarray:
    """Whether two disks at least ``min_gap`` apart in the stack intersect, per configuration, shape (B,).

    The disks are flat circles of ``radius`` [m] (no thickness) centred at ``positions`` (B, N+1, 3) [m] with
    normals the z axes of ``rotations`` (B, N+1, 3, 3); row 0 is the base disk. Two circles in planes that
    cross meet when their chords on the planes' common line overlap; parallel ones meet only in one plane.
    Neighbouring disks (``min_gap`` = 2 leaves them out) are joined by the backbone and never tested.
    """
    B, n1 = positions.shape[:2]
    i, j = np.triu_indices(n1, k=min_gap)
    if i.size == 0:
        return np.zeros(B, dtype=bool)
    c1, c2 = positions[:, i], positions[:, j]
    normals = rotations[..., 2]
    m1, m2 = normals[:, i], normals[:, j]
    u = np.cross(m1, m2)
    s2 = np.einsum("bpk,bpk->bp", u, u)
    with np.errstate(invalid="ignore", divide="ignore"):
        d1 = np.einsum("bpk,bpk->bp", m1, c1)
        d2 = np.einsum("bpk,bpk->bp", m2, c2)
        k = np.einsum("bpk,bpk->bp", m1, m2)
        p0 = ((d1 - d2 * k)[..., None] * m1 + (d2 - d1 * k)[..., None] * m2) / s2[..., None]
        e = u / np.sqrt(s2)[..., None]
        touch = np.ones(s2.shape, dtype=bool)
        half, mid = [], []
        for c in (c1, c2):
            t = np.einsum("bpk,bpk->bp", e, c - p0)
            off = c - p0 - t[..., None] * e
            d = np.einsum("bpk,bpk->bp", off, off)
            touch &= d < radius * radius
            half.append(np.sqrt(np.clip(radius * radius - d, 0.0, None)))
            mid.append(t)
        crossing = touch & (np.abs(mid[0] - mid[1]) < half[0] + half[1])
        gap = c2 - c1
        parallel = (s2 < 1e-18) & (np.abs(np.einsum("bpk,bpk->bp", m1, gap)) < 1e-12) & (
            np.einsum("bpk,bpk->bp", gap, gap) < 4.0 * radius * radius)
    hit = np.where(s2 < 1e-18, parallel, crossing)
    return np.any(hit & np.isfinite(s2), axis=1)

"""Regions of known volume as images of a parameter box: the boundary tracer's check against the truth.

A ball (the cube mapped onto it), a box turned off the grid's axes, and a torus (a square mapped onto the
tube's disk, swept round the axis). Used by the tests and ``bench/surface.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._follow import MappedPoint

__all__ = ["KNOWN_SHAPES", "KnownMap", "KnownShape"]


class KnownMap:
    """x = f(u) on the box [lower, upper], with its Jacobian by central differences (step 1e-6)."""

    def __init__(self, f: Callable[[np.ndarray], np.ndarray], lower: list[float], upper: list[float]) -> None:
        self.f, self.lower, self.upper = f, np.asarray(lower, float), np.asarray(upper, float)

    def evaluate(self, u: np.ndarray, start: MappedPoint | None) -> MappedPoint:
        eye = 1e-6 * np.eye(u.size)
        jac = np.column_stack([(self.f(u + e) - self.f(u - e)) / 2e-6 for e in eye])
        return MappedPoint(u=np.array(u, dtype=float), x=self.f(u), jac=jac)


@dataclass(frozen=True, eq=False)
class KnownShape:
    """A region of known ``volume``: the image of ``fmap``'s box, inside the ball of radius ``extent`` round the
    origin; ``spacing`` is a coarse grid spacing with at least two cells across its thinnest part."""

    fmap: KnownMap
    volume: float
    extent: float
    spacing: float

    def seeds(self) -> list[MappedPoint]:
        """Two points of the region, from parameters inside the box."""
        lo, hi = self.fmap.lower, self.fmap.upper
        return [self.fmap.evaluate((lo + hi) / 2 + 0.3 * (hi - lo) * np.array(o), None)
                for o in [(0, 0, 0), (0.2, -0.1, 0.3)]]


def _ball(u: np.ndarray) -> np.ndarray:
    """The cube [-1, 1]^3 onto the unit ball (each face onto a sixth of the sphere)."""
    x, y, z = u
    return np.array([x * np.sqrt(1 - y * y / 2 - z * z / 2 + y * y * z * z / 3),
                     y * np.sqrt(1 - z * z / 2 - x * x / 2 + z * z * x * x / 3),
                     z * np.sqrt(1 - x * x / 2 - y * y / 2 + x * x * y * y / 3)])


_SIDES = np.array([1.6, 1.0, 0.6])
_TURN = (np.array([[1, 0, 0], [0, np.cos(0.7), -np.sin(0.7)], [0, np.sin(0.7), np.cos(0.7)]])
         @ np.array([[np.cos(0.5), -np.sin(0.5), 0], [np.sin(0.5), np.cos(0.5), 0], [0, 0, 1]]))


def _turned_box(u: np.ndarray) -> np.ndarray:
    """A 1.6 x 1.0 x 0.6 box, centred near the origin and turned off the grid's axes."""
    return _TURN @ (u - _SIDES / 2) + 0.01


def _torus(u: np.ndarray) -> np.ndarray:
    """A torus of centre radius 1 and tube radius 0.4: the square [-1, 1]^2 onto the tube's disk, swept by the
    angle u[2] (twice round, so that every point is reached from either side)."""
    x, y, angle = u
    rho = 1.0 + 0.4 * x * np.sqrt(1 - y * y / 2)
    return np.array([rho * np.cos(angle), rho * np.sin(angle), 0.4 * y * np.sqrt(1 - x * x / 2)])


#: the shapes by name
KNOWN_SHAPES = {
    "ball": KnownShape(KnownMap(_ball, [-1] * 3, [1] * 3), 4 / 3 * np.pi, 1.0, 0.5),
    "turned box": KnownShape(KnownMap(_turned_box, [0] * 3, list(_SIDES)), float(np.prod(_SIDES)), 1.0, 0.25),
    "torus": KnownShape(KnownMap(_torus, [-1, -1, -2 * np.pi], [1, 1, 2 * np.pi]), 2 * np.pi**2 * 0.16, 1.4, 0.5),
}

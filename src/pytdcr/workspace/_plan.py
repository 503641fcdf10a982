"""Which tension vectors a workspace study solves: scrambled Sobol points, and the box's corners and edges."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from ..bounds import TensionBounds
from ..limits import check_memory
from ..validate import check_count

__all__ = ["SOURCES", "TensionPlan", "plan_tensions"]

#: where a sample comes from, by its code in :attr:`TensionPlan.source`
SOURCES = ("sobol", "corner", "edge", "search")


@dataclass(frozen=True, eq=False)
class TensionPlan:
    """Tension vectors to solve, in order, with where each comes from.

    Attributes
    ----------
    tensions : ndarray, shape (M, n_tendons)
        Actuator tensions [N], one row per vector to solve; the first ``n_base`` rows are the Sobol points, in
        the sequence's order (so any prefix of them is a Sobol sample of its own), then the corners, then the
        edge points.
    source : ndarray of int8, shape (M,)
        Index into :data:`SOURCES`.
    n_base : int
        Sobol points.
    edges_total : int
        Edge points of the whole box (``edges_kept`` of them are in the plan: at most ``n_base``).
    edges_kept : int
    bounds : TensionBounds
        The tension box the plan spans (every row lies in it).
    """

    tensions: np.ndarray
    source: np.ndarray
    n_base: int
    edges_total: int
    edges_kept: int
    bounds: TensionBounds

    def count(self, name: str) -> int:
        """Rows from the source ``name``."""
        return int(np.sum(self.source == SOURCES.index(name)))


def _sobol(n: int, dim: int, seed: int) -> np.ndarray:
    """The first ``n`` points of a scrambled Sobol sequence in [0, 1)^dim (drawn to the next power of 2)."""
    m = max(0, math.ceil(math.log2(max(n, 1))))
    return qmc.Sobol(dim, scramble=True, seed=seed).random_base2(m)[:n]


def _edges(free: int, per_edge: int) -> np.ndarray:
    """Points on every edge of [0, 1]^free, ``per_edge`` inside each, shape (free 2^(free-1) per_edge, free)."""
    fractions = np.arange(1, per_edge + 1) / (per_edge + 1)
    rows = []
    for k in range(free):
        for corner in itertools.product((0.0, 1.0), repeat=free - 1):
            base = np.insert(np.array(corner), k, 0.0)
            for f in fractions:
                p = base.copy()
                p[k] = f
                rows.append(p)
    return np.array(rows).reshape(-1, free)


def plan_tensions(bounds: TensionBounds, n: int, *, seed: int = 0, edge_points: int = 2,
                  corners: bool = True) -> TensionPlan:
    """``n`` scrambled Sobol tension vectors in ``bounds``, then the box's corners and ``edge_points`` points
    inside each of its edges.

    Only free tendons (upper > lower) span the box; fixed ones stay at their value. The corners and edges
    together are capped at ``n`` rows: beyond that, a random subset of the edge points (``seed``) is kept.
    """
    n = check_count(n, "n")
    edge_points = check_count(edge_points, "edge_points", lo=0, hi=16)
    free = np.flatnonzero(bounds.free)
    dim = free.size
    per_row = 8.0 * (2 * bounds.n + 2 * dim) + 1.0
    check_memory(f"a tension plan of {n:,} Sobol points (and as many corners and edges)", 2 * n * per_row,
                 f"{per_row:.0f} bytes per tension vector drawn, Sobol points drawn to the next power of 2")
    if dim == 0:
        raise ValueError("bounds: every tension is fixed (lower == upper); there is no workspace to sample")
    unit = [_sobol(n, dim, seed)]
    source = [np.zeros(n, dtype=np.int8)]
    n_corners = 2**dim if corners and 2**dim <= n else 0
    if n_corners:
        unit.append(np.array(list(itertools.product((0.0, 1.0), repeat=dim))))
        source.append(np.full(n_corners, SOURCES.index("corner"), dtype=np.int8))
    edges_total = dim * 2 ** (dim - 1) * edge_points if corners else 0
    kept = min(edges_total, max(0, n - n_corners))
    if kept:
        if kept == edges_total:
            e = _edges(dim, edge_points)
        else:  # too many edges for the budget: random points on random edges
            rng = np.random.default_rng(seed)
            e = rng.integers(0, 2, size=(kept, dim)).astype(float)
            e[np.arange(kept), rng.integers(0, dim, size=kept)] = rng.integers(1, edge_points + 1, kept) / (
                edge_points + 1)
        unit.append(e)
        source.append(np.full(e.shape[0], SOURCES.index("edge"), dtype=np.int8))
    u = np.concatenate(unit)
    tensions = np.broadcast_to(bounds.lower, (u.shape[0], bounds.n)).copy()
    tensions[:, free] = bounds.lower[free] + u * (bounds.upper[free] - bounds.lower[free])
    return TensionPlan(tensions=tensions, source=np.concatenate(source), n_base=n, edges_total=edges_total,
                       edges_kept=kept, bounds=bounds)

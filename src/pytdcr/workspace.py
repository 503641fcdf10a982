"""Random sampling of the feasible static workspace."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .bounds import TensionBounds
from .design import Robot
from .loads import Loads
from .results import BatchSolution
from .statics import Model, solve_batch

__all__ = ["WorkspaceSamples", "sample_workspace"]


@dataclass(frozen=True, eq=False)
class WorkspaceSamples:
    """Random tension vectors and the equilibria they reach.

    Attributes
    ----------
    tensions : ndarray, shape (n, n_tendons)
        Actuator tensions [N].
    tip_position : ndarray, shape (n, 3)
        Tip position [m]; NaN where the solve did not converge.
    converged : ndarray of bool, shape (n,)
    residual : ndarray, shape (n,)
        max |residual| [N m].
    q : ndarray
        Unknowns of every solve (meaningful only where converged): PCC (n, N, 3).
    seed : int
    seconds : float
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    q: np.ndarray
    seed: int
    seconds: float
    batch: BatchSolution | None = None

    @property
    def stable(self) -> np.ndarray:
        """Per sample: 1.0 stable, 0.0 unstable, NaN not converged or untested (computed on first use)."""
        if self.batch is None:
            return np.full(self.converged.shape, np.nan)
        return self.batch.stable

    @property
    def reach(self) -> np.ndarray:
        """||tip|| [m], shape (n,); NaN where not converged."""
        return np.linalg.norm(self.tip_position, axis=1)


def sample_workspace(
    robot: Robot,
    loads: Loads,
    bounds: TensionBounds,
    n: int = 100,
    *,
    seed: int = 0,
    model: str | Model = "pcc",
    options: Any = None,
    threads: int | None = None,
) -> WorkspaceSamples:
    """Solve ``n`` random tension vectors drawn uniformly within ``bounds``.

    ``loads`` supplies the external wrenches and friction direction (its
    tensions are ignored). Non-converged samples are kept and flagged.
    ``model`` and ``options`` as for :func:`pytdcr.solve`; ``threads`` as for
    :func:`pytdcr.solve_batch`.
    """
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    bounds.check_robot(robot)
    rng = np.random.default_rng(seed)
    T = bounds.sample(int(n), rng)
    t0 = time.perf_counter()
    batch = solve_batch(robot, T, loads, model=model, options=options, threads=threads)
    return WorkspaceSamples(
        tensions=T,
        tip_position=batch.tip_position,
        converged=batch.converged,
        residual=batch.residual,
        q=batch.q,
        seed=seed,
        seconds=time.perf_counter() - t0,
        batch=batch,
    )

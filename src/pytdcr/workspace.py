"""Tendon-force bounds and random sampling of the feasible static workspace."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .design import Robot
from .loads import Loads
from .statics import CosseratOptions, SolverOptions, solve_batch

__all__ = ["TensionBounds", "WorkspaceSamples", "sample_workspace"]


@dataclass(frozen=True)
class TensionBounds:
    """Per-tendon actuator tension bounds [N].

    Parameters
    ----------
    lower, upper : array-like, shape (n_tendons,)
        Finite, 0 <= lower <= upper.
    """

    lower: np.ndarray
    upper: np.ndarray

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, dtype=float).reshape(-1)
        hi = np.asarray(self.upper, dtype=float).reshape(-1)
        if lo.shape != hi.shape:
            raise ValueError(f"bounds: lower has {lo.size} entries, upper {hi.size}")
        for name, arr in (("lower", lo), ("upper", hi)):
            bad = ~np.isfinite(arr) | (arr < 0)
            if np.any(bad):
                k = int(np.argmax(bad))
                raise ValueError(f"bounds: {name}[{k}] must be finite and >= 0 N, got {arr[k]}")
        bad = lo > hi
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(f"bounds: tendon {k + 1} has lower {lo[k]} > upper {hi[k]} N")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def uniform(cls, n_tendons: int, lower: float, upper: float) -> TensionBounds:
        """The same bounds [lower, upper] N for every tendon."""
        return cls(np.full(n_tendons, float(lower)), np.full(n_tendons, float(upper)))

    @property
    def n(self) -> int:
        """Number of tendons."""
        return int(self.lower.size)

    def check_robot(self, robot: Robot) -> None:
        """Raise ValueError unless there is one bound pair per tendon of ``robot``."""
        if self.n != robot.n_tendons:
            raise ValueError(f"bounds: robot '{robot.name}' has {robot.n_tendons} tendons, got bounds for {self.n}")

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` uniform random tension vectors, shape (n, n_tendons) [N]."""
        return self.lower + (self.upper - self.lower) * rng.random((n, self.n))

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-ready form."""
        return {"lower": self.lower.tolist(), "upper": self.upper.tolist()}


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
    q : ndarray, shape (n, N, 3)
        Unknowns of every solve (meaningful only where converged).
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
    model: str = "pcc",
    options: SolverOptions | CosseratOptions | None = None,
) -> WorkspaceSamples:
    """Solve ``n`` random tension vectors drawn uniformly within ``bounds``.

    ``loads`` supplies the external wrenches and friction direction (its
    tensions are ignored). Non-converged samples are kept and flagged.
    ``model`` is ``"pcc"`` or ``"cosserat"`` (see :func:`pytdcr.solve`).
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    bounds.check_robot(robot)
    rng = np.random.default_rng(seed)
    T = bounds.sample(n, rng)
    t0 = time.perf_counter()
    batch = solve_batch(robot, T, loads, model=model, options=options)
    return WorkspaceSamples(
        tensions=T,
        tip_position=batch.tip_position,
        converged=batch.converged,
        residual=batch.residual,
        q=batch.q,
        seed=seed,
        seconds=time.perf_counter() - t0,
    )

"""Result types."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .design import Robot
from .kinematics import backbone_curve

__all__ = ["BatchSolution", "NotConvergedError", "StaticSolution"]


class NotConvergedError(RuntimeError):
    """Raised when a shape is asked of a solve that did not converge."""


@dataclass(frozen=True, eq=False)
class StaticSolution:
    """The outcome of one static solve.

    Attributes
    ----------
    converged : bool
        True when max |residual| <= atol and every value is finite.
    residual : float
        max |residual| [N m] at the returned unknowns.
    iterations : int
        Newton iterations in all (load steps included).
    load_steps : int
        Continuation steps taken (0 when the direct solve converged).
    path : str
        How the equilibrium was reached: ``"loading"`` (followed the loading
        path from the unloaded robot), ``"snap"`` (that path, relaxed through
        a fold), ``"direct"`` (Newton at full load from the start point) or
        ``"fallback"`` (the loading path failed; another equilibrium).
    q : ndarray
        The model's unknowns, a warm start for a nearby solve of the same
        model (its ``unknowns`` attribute says what they are). PCC: shape
        (N, 3), (beta [1/m], gamma [1/m], eps [rad]) per subsegment (MODEL.md);
        Cosserat: shape (3,), the total moment at the base [N m], base frame.
    tensions : ndarray, shape (n_tendons, N)
        Tension in each tendon piece i (between disk i-1 and i) [N]; 0 past the anchor.
    seconds : float
        Wall time of the solve [s].
    atol : float
        Convergence tolerance used [N m].
    model : str
        The registered name of the model that solved it (:data:`pytdcr.statics.MODELS`).
    """

    converged: bool
    residual: float
    iterations: int
    load_steps: int
    path: str
    q: np.ndarray
    tensions: np.ndarray
    seconds: float
    atol: float
    _positions: np.ndarray
    _rotations: np.ndarray
    model: str = "pcc"
    _curve: np.ndarray | None = None

    def _require(self) -> None:
        if not self.converged:
            raise NotConvergedError(
                f"the solve did not converge (max |residual| = {self.residual:.3e} N m > atol = "
                f"{self.atol:.1e}); it has no shape"
            )

    @property
    def disk_positions(self) -> np.ndarray:
        """Disk centres in the base frame, shape (N+1, 3) [m]; row 0 is the base."""
        self._require()
        return self._positions

    @property
    def disk_rotations(self) -> np.ndarray:
        """Disk frame orientations in the base frame, shape (N+1, 3, 3)."""
        self._require()
        return self._rotations

    @property
    def tip_position(self) -> np.ndarray:
        """Tip position ^0P_n, shape (3,) [m]."""
        return self.disk_positions[-1]

    @property
    def tip_rotation(self) -> np.ndarray:
        """Tip orientation ^0R_n, shape (3, 3)."""
        return self.disk_rotations[-1]

    def backbone_points(self, robot: Robot) -> np.ndarray:
        """Points along the backbone in the base frame, shape (K, 3) [m], base to tip."""
        self._require()
        if self._curve is not None:
            return self._curve
        return backbone_curve(self.q, robot.subsegment_lengths)

    @property
    def reach(self) -> float:
        """||^0P_n||_2 [m]."""
        return float(np.linalg.norm(self.tip_position))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary; shape fields are None when not converged."""
        ok = self.converged
        return {
            "converged": bool(ok),
            "residual": float(self.residual),
            "iterations": int(self.iterations),
            "load_steps": int(self.load_steps),
            "model": self.model,
            "path": self.path,
            "seconds": float(self.seconds),
            "tip_position": self.tip_position.tolist() if ok else None,
            "tip_rotation": self.tip_rotation.tolist() if ok else None,
            "disk_positions": self.disk_positions.tolist() if ok else None,
            "q": self.q.tolist(),
            "tensions": self.tensions.tolist(),
        }


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """Solutions of many tension vectors under the same external loads.

    Attributes
    ----------
    tensions : ndarray, shape (B, n_tendons)
    converged : ndarray of bool, shape (B,)
    residual : ndarray, shape (B,)
        max |residual| [N m].
    iterations : ndarray of int, shape (B,)
    q : ndarray
        The model's unknowns per case: PCC (B, N, 3), Cosserat (B, 3).
    tip_position : ndarray, shape (B, 3)
        [m]; NaN where not converged.
    seconds : float
        Wall time of the whole batch [s].
    path : ndarray of str, shape (B,)
        How each equilibrium was reached (see :class:`StaticSolution`).
    model : str
        The registered name of the model.
    """

    tensions: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    q: np.ndarray
    tip_position: np.ndarray
    seconds: float
    path: np.ndarray
    model: str

    @classmethod
    def from_solutions(cls, tensions: np.ndarray, solutions: Sequence[StaticSolution], seconds: float,
                       model: str) -> BatchSolution:
        """Gather single solutions, case by case."""
        ok = np.array([s.converged for s in solutions], dtype=bool)
        tips = np.full((len(solutions), 3), np.nan)
        for b in np.flatnonzero(ok):
            tips[b] = solutions[b].tip_position
        return cls(tensions=tensions, converged=ok, residual=np.array([s.residual for s in solutions]),
                   iterations=np.array([s.iterations for s in solutions], dtype=np.int64),
                   q=np.array([s.q for s in solutions]), tip_position=tips, seconds=seconds,
                   path=np.array([s.path for s in solutions], dtype=object), model=model)

    @property
    def reach(self) -> np.ndarray:
        """||tip|| [m], shape (B,); NaN where not converged."""
        return np.linalg.norm(self.tip_position, axis=1)

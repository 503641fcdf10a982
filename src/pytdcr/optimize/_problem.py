"""What is solved: the paper's Eq. 29, or the reach along a direction, as one problem object."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..records import JsonDict
from ..results import BatchSolution, StaticSolution
from ..robot import Robot
from ..statics import TIGHT_ATOL, Model, ModelOptions, configure, resolve
from ..validate import SettingsError, unit_vector

__all__ = ["INFEASIBLE_COST", "Evaluated", "ReachProblem"]

#: cost given to tension vectors whose solve did not converge (they are also flagged infeasible)
INFEASIBLE_COST = 1e3
#: the paper's cost 1/reach counts every reach below this [m] as this (a nanometre, a millionth of the shortest
#: robot's length): finite at a tip on the base (reach 0), and still never lower for a shorter reach
MIN_COST_REACH = 1e-9


class Evaluated(NamedTuple):
    """A batch of tension vectors, evaluated: the solves, which are feasible (converged, and stable when the problem
    asks for it), and the cost of each (INFEASIBLE_COST where not feasible)."""

    batch: BatchSolution
    feasible: np.ndarray
    cost: np.ndarray


@dataclass(frozen=True, eq=False)
class ReachProblem:
    """The reach search's problem: robot, loads, bounds and model, giving an objective and its gradient.

    Minimised cost: ``1 / ||tip||`` (the paper's Eq. 29: the tip as far from the
    base as possible), or ``-d . tip`` with ``direction`` d (the tip as far as
    possible along d: the workspace's support function). Build it with
    :meth:`create`, which checks the request against the model's capabilities.

    Attributes
    ----------
    robot : Robot
    loads : Loads
        External loads and friction direction (its tensions are ignored).
    bounds : TensionBounds
    model : Model
    options : the model's options type
    direction : ndarray, shape (3,), or None
        Unit vector in the base frame, or None for the paper's objective.
    stable_only : bool
        An equilibrium that fails the static stability test is infeasible
        (:mod:`pytdcr.statics.stability`; the model must have the test).
    anchor : StaticSolution or None
        A solved equilibrium (of this model, robot and loads) that every solve continues along its branch
        (:meth:`continued_from`); None: every solve from rest, along the loading path (or from ``q0``).
    """

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: Model
    options: ModelOptions
    direction: np.ndarray | None = None
    stable_only: bool = False
    anchor: StaticSolution | None = None

    @classmethod
    def create(cls, robot: Robot, loads: Loads, bounds: TensionBounds, *, model: str | Model = "pcc",
               options: ModelOptions | None = None, direction: np.ndarray | None = None,
               stable_only: bool = False) -> ReachProblem:
        """Check the inputs and resolve the model; ``direction`` is normalised (:func:`pytdcr.validate.unit_vector`;
        ValueError if zero, not finite or subnormal)."""
        if not isinstance(bounds, TensionBounds):
            raise TypeError(f"bounds must be a pytdcr.TensionBounds, got {type(bounds).__name__}")
        m, opts = resolve(model, robot, loads, options, gradient=True, stability=stable_only)
        bounds.check_robot(robot)
        if not np.any(bounds.free):
            raise ValueError("bounds: every tension is fixed (lower == upper); nothing to optimise")
        d = None
        if direction is not None:
            try:  # the one rule for directions: scale-free, so (1e200, 1e200, 0) is (1, 1, 0) / sqrt(2)
                d = unit_vector(direction, "direction")
            except SettingsError as err:
                raise ValueError(f"direction must be {err.text.removeprefix(': give ')}") from None
        return cls(robot=robot, loads=loads.with_tensions(np.zeros(robot.n_tendons)), bounds=bounds, model=m,
                   options=opts, direction=d, stable_only=bool(stable_only))

    def with_direction(self, direction: np.ndarray | None) -> ReachProblem:
        """The same problem along another direction (None: the paper's objective)."""
        p = ReachProblem.create(self.robot, self.loads, self.bounds, model=self.model, options=self.options,
                                direction=direction, stable_only=self.stable_only)
        return replace(p, anchor=self.anchor)

    def continued_from(self, anchor: StaticSolution | None) -> ReachProblem:
        """The same problem with every solve continued from the equilibrium ``anchor`` along the straight
        segment of tensions (following its branch, snapping where it folds), so that each cost is the
        equilibrium the robot reaches from there; None: from rest again. The model must continue states."""
        if anchor is not None and not self.model.capabilities.continuation:
            raise ValueError(f"model '{self.model.name}' cannot continue a solved state")
        return replace(self, anchor=anchor)

    @property
    def free(self) -> np.ndarray:
        """Tendons the search varies, shape (n_tendons,) of bool."""
        return self.bounds.free

    def full(self, x: np.ndarray) -> np.ndarray:
        """Tension vectors (..., n_tendons) [N] from the free variables (..., n_free): fixed ones at their bound."""
        x = np.asarray(x, dtype=float)
        t = np.broadcast_to(self.bounds.lower, (*x.shape[:-1], self.robot.n_tendons)).copy()
        t[..., self.free] = x
        return t

    def cost(self, tip: np.ndarray) -> np.ndarray:
        """The minimised cost of tip positions (..., 3) [m]: 1/||tip|| [1/m] or -d . tip [m].

        The paper's cost takes ``max(||tip||, MIN_COST_REACH)``: finite for a tip on the base (at most
        1/:data:`MIN_COST_REACH`), and it never decreases as the reach shrinks.
        """
        tip = np.asarray(tip, dtype=float)
        if self.direction is None:
            return 1.0 / np.maximum(np.linalg.norm(tip, axis=-1), MIN_COST_REACH)
        return -(tip @ self.direction)

    def value(self, tip: np.ndarray) -> np.ndarray:
        """What is maximised, for tips (..., 3): ||tip|| or d . tip [m]."""
        tip = np.asarray(tip, dtype=float)
        return np.linalg.norm(tip, axis=-1) if self.direction is None else tip @ self.direction

    def cost_gradient(self, tip: np.ndarray, dtip: np.ndarray) -> np.ndarray:
        """d cost / d tensions (n_tendons,) from the tip (3,) and its derivative (3, n_tendons); 0 for the paper's
        cost at a reach below :data:`MIN_COST_REACH`, where it is constant (:meth:`cost`)."""
        if self.direction is None:
            r = float(np.linalg.norm(tip))
            if r < MIN_COST_REACH:
                return np.zeros(np.shape(dtip)[-1])
            return -(tip @ dtip) / r**3
        return -(self.direction @ dtip)

    def evaluate(self, tensions: np.ndarray, q0: np.ndarray | None = None) -> Evaluated:
        """Solve every row of ``tensions`` (B, n_tendons) [N] from ``q0`` or from rest (never from
        :attr:`anchor`): the batch and each row's cost."""
        batch = self.model.solve_batch(self.robot, np.ascontiguousarray(tensions, dtype=float), self.loads, q0,
                                       self.options)
        ok = batch.converged.copy()
        if self.stable_only:
            ok &= batch.stable == 1.0
        cost = np.full(ok.shape, INFEASIBLE_COST)
        cost[ok] = self.cost(batch.tip_position[ok])
        return Evaluated(batch, ok, cost)

    def solve(self, tensions: np.ndarray, q0: np.ndarray | None = None, atol: float | None = None) -> StaticSolution:
        """One equilibrium at ``tensions`` (n_tendons,) [N], at the problem's tolerance or ``atol`` [N m]:
        continued from :attr:`anchor` when it is set (``q0`` is then ignored), else from ``q0`` or from rest."""
        opts = self.options if atol is None else configure(self.model, self.options, atol=atol)
        loads = self.loads.with_tensions(tensions)
        if self.anchor is not None:
            sol = self.model.solve_from(self.robot, loads, self.anchor, opts)
        else:
            sol = self.model.solve(self.robot, loads, q0, opts)
        if sol.converged:
            self.check_reach(sol.reach)
        return sol

    def cost_and_gradient(self, tensions: np.ndarray, q0: np.ndarray | None = None,
                          atol: float = TIGHT_ATOL) -> tuple[float, np.ndarray | None, StaticSolution]:
        """Cost and its gradient by the tensions (n_tendons,) at ``tensions``; (INFEASIBLE_COST, None, sol)
        when the solve does not converge. Solved at the tight tolerance ``atol`` so that the cost is smooth
        to a gradient search."""
        sol = self.solve(tensions, q0, atol)
        if not sol.converged or (self.stable_only and not sol.stable):
            return INFEASIBLE_COST, None, sol
        opts = configure(self.model, self.options, atol=atol)
        tip, dtip = self.model.tip_gradient(self.robot, self.loads.with_tensions(tensions), sol, opts)
        return float(self.cost(tip)), self.cost_gradient(tip, dtip), sol

    def check_reach(self, reach: float) -> None:
        """The backbone is inextensible: a reach beyond its length can only be a bug (RuntimeError)."""
        if reach > self.robot.length * (1.0 + 1e-12):
            raise RuntimeError(f"reach {reach} m exceeds the backbone length {self.robot.length} m")

    def describe(self) -> JsonDict:
        """JSON-ready settings of the problem."""
        return {"model": self.model.name, "bounds": self.bounds.to_dict(),
                "objective": "reach" if self.direction is None else "direction",
                "direction": None if self.direction is None else self.direction.tolist(),
                "stable_only": self.stable_only}

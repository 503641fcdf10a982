"""A robot as a map from its tension box to its tip: the region the boundary tracer follows.

Each evaluation continues a solved equilibrium along its branch to new tensions (the continued region's
definition of which equilibrium a tension vector holds: the one the robot reaches by a quasi-static path from
rest), tests its static stability, and differentiates the tip by the tensions exactly. An equilibrium that
does not converge, touches itself or is unstable has no image, and a branch that folds ends at its fold (the
solver's ``fold="stop"``): the region's boundary is met there.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..results import StaticSolution
from ..robot import Robot
from ..statics import Model, resolve
from ._follow import MappedPoint
from ._surface import SurfaceSettings, TracedSurface, trace_surface

__all__ = ["RobotMap", "trace_robot_region"]


class RobotMap:
    """The tip of ``robot`` under ``loads`` (their own tensions ignored) as a function of its tensions in ``bounds``.

    Parameters
    ----------
    robot : Robot
    loads : Loads
        External wrenches and friction direction shared by every evaluation.
    bounds : TensionBounds
        The tension box [N].
    model : Model
        A registered model (from :func:`pytdcr.statics.resolve`) that can continue and differentiate.

    Attributes
    ----------
    lower, upper : ndarray, shape (n_tendons,)
        The tension box [N].
    evaluations : int
        Evaluations so far; ``refused`` of them had no admissible equilibrium.
    reached : float or None
        After an evaluation whose continuation stopped at a fold: the share of the straight tension path from
        its start where the fold lies; otherwise None.
    solve_seconds : float
        Time spent solving, testing stability and differentiating [s].
    """

    def __init__(self, robot: Robot, loads: Loads, bounds: TensionBounds, model: Model) -> None:
        self.robot, self.loads = robot, loads
        self.model, options = resolve(model, robot, loads, None, continuation=True, gradient=True)
        # a branch that folds ends there: a snap-through is a jump of the tip, not a step of a follow
        self.options = replace(options, fold="stop") if hasattr(options, "fold") else options
        self.lower = np.asarray(bounds.lower, dtype=float)
        self.upper = np.asarray(bounds.upper, dtype=float)
        self.evaluations, self.refused, self.solve_seconds = 0, 0, 0.0
        self.reached: float | None = None

    def evaluate(self, u: np.ndarray, start: MappedPoint | None) -> MappedPoint | None:
        """The stable equilibrium at tensions ``u`` [N] reached from ``start``'s (from rest along the loading path
        when ``start`` is None), its tip [m] and the tip's derivative by the tensions [m/N]; None when there is
        none."""
        self.evaluations += 1
        self.reached = None
        t0 = time.perf_counter()
        loads = self.loads.with_tensions(np.asarray(u, dtype=float))
        try:
            if start is None:
                sol = self.model.solve(self.robot, loads, None, self.options)
            else:
                state = start.state
                assert isinstance(state, StaticSolution)
                sol = self.model.solve_from(self.robot, loads, state, self.options)
            point = self._point(loads, sol)
            if point is None and start is not None and str(sol.path) == "fold":
                self.reached = self._fold_share(start, loads, sol)
        finally:
            self.solve_seconds += time.perf_counter() - t0
        if point is None:
            self.refused += 1
        return point

    def _fold_share(self, start: MappedPoint, loads: Loads, sol: StaticSolution) -> float | None:
        """Where on the straight path from ``start``'s tensions to ``loads``' the continuation stopped at a fold:
        the share lam in [0, 1] whose tensions hold the last equilibrium it reached (``sol.q``) in balance. The
        residual is affine in the tensions at fixed unknowns, ``r(lam) = a + lam b``: lam = -a.b / b.b."""
        equations = getattr(self.model, "equations", None)
        if equations is None:
            return None
        eq = equations(self.robot, loads, self.options)
        q = np.asarray(sol.q, dtype=float).reshape(-1)
        a = eq.with_tensions(start.u).evaluate(q).residual
        b = eq.evaluate(q).residual - a
        bb = float(b @ b)
        return None if bb <= 0.0 else float(np.clip(-(a @ b) / bb, 0.0, 1.0))

    def _point(self, loads: Loads, sol: StaticSolution) -> MappedPoint | None:
        """The mapped point of a stable, converged equilibrium ``sol`` under ``loads``, or None."""
        if not sol.converged or sol.stable is False:
            return None
        tip, jac = self.model.tip_gradient(self.robot, loads, sol, self.options)
        if not (np.all(np.isfinite(tip)) and np.all(np.isfinite(jac))):
            return None
        return MappedPoint(u=np.array(loads.tensions, dtype=float), x=np.array(tip, dtype=float),
                           jac=np.array(jac, dtype=float), state=sol)


def trace_robot_region(robot: Robot, loads: Loads, bounds: TensionBounds, model: Model, settings: SurfaceSettings,
                       seeds: int = 8, seed: int = 0) -> tuple[TracedSurface, RobotMap]:
    """The continued region of ``robot``'s tip, traced from its boundary (:func:`~._surface.trace_surface`).

    Seeds: the loading path's equilibria at the box's lower corner and at ``seeds - 1`` uniform random tension
    vectors (generator ``seed``); the grid is the cube of half-width ``length + spacing`` round the base.

    Returns
    -------
    TracedSurface
        The surface [m] and each level's volume [m^3] and evaluations.
    RobotMap
        The map, with its evaluation count, refusals and solve time.
    """
    fmap = RobotMap(robot, loads, bounds, model)
    rng = np.random.default_rng(seed)
    starts = [fmap.lower] + [rng.uniform(fmap.lower, fmap.upper) for _ in range(max(seeds - 1, 0))]
    points = [p for p in (fmap.evaluate(u, None) for u in starts) if p is not None]
    half = np.full(3, robot.length + settings.spacing)
    return trace_surface(fmap, points, -half, half, settings), fmap

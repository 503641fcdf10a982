"""Solving for equilibria with any registered model: one solve, a batch, the tip's gradient.

Every call asks the registry (:mod:`pytdcr.statics.registry`) for the model,
which checks the request against the model's capabilities before any work.
"""

from __future__ import annotations

import time

import numpy as np

from ..loads import Loads, check_tensions
from ..results import BatchSolution, StaticSolution
from ..robot import Robot
from ..runtime import default_threads
from .base import Model
from .options import SAME_EQUILIBRIUM, ModelOptions
from .registry import MODELS, check_resources, resolve

__all__ = ["SAME_EQUILIBRIUM", "check_solution", "check_start", "solve", "solve_batch", "tip_gradient", "warmup"]


def solve(robot: Robot, loads: Loads, *, model: str | Model = "pcc", q0: np.ndarray | None = None,
          options: ModelOptions | None = None, start: StaticSolution | None = None) -> StaticSolution:
    """Static equilibrium of ``robot`` under ``loads``.

    Parameters
    ----------
    robot : Robot
    loads : Loads
    model : str or Model
        A registered model's name (:data:`pytdcr.statics.MODELS`: ``"pcc"``,
        the paper's model, by default) or a model object.
    q0 : array-like, optional
        Warm start: ``solution.q`` of a nearby solve of the same model.
        Default: the straight robot.
    options : the model's options type, optional
        ``SolverOptions`` for ``pcc``, ``CosseratOptions`` for ``cosserat``;
        default: the model's defaults.
    start : StaticSolution, optional
        Continuation: a converged equilibrium of this robot and model (under
        its own ``start.loads``), followed along its branch as the tensions
        and disk wrenches move on the straight path from ``start.loads`` to
        ``loads`` (gravity is the robot's), with the loading path's step
        control and fold handling. ``path`` is ``"continued"``, ``"snap"``
        where the branch folded and the robot snapped, or ``"fallback"``; a
        failed continuation keeps ``"continued"`` with ``converged`` False.
        Where the robot has several equilibria, this is the one it reaches
        from ``start``'s state (the loading path, without ``start``, is the
        one it reaches from rest). Not with ``q0``; the friction direction
        (``release``) must match and holds along the path (docs/models.md).

    Returns
    -------
    StaticSolution
        Check ``converged``: a non-converged solution carries its residual and
        refuses to give a shape.

    Raises
    ------
    UnsupportedFeatureError
        When the model does not model something the robot or loads need (or cannot continue).
    ValueError
        When ``start`` is not an equilibrium of this robot and model.
    """
    if not isinstance(loads, Loads):
        raise TypeError(f"loads must be a pytdcr.Loads (tensions and external wrenches), got {type(loads).__name__}")
    m, opts = resolve(model, robot, loads, options, continuation=start is not None)
    if start is None:
        return m.solve(robot, loads, q0, opts)
    if q0 is not None:
        raise ValueError("give q0 (a start point at full load) or start (a solved state to continue), not both")
    check_start(m, robot, loads, start, opts)
    return m.solve_from(robot, loads, start, opts)


def check_start(model: Model, robot: Robot, loads: Loads, start: StaticSolution, options: ModelOptions) -> None:
    """Refuse a ``start`` that cannot be continued to ``loads``: not a converged equilibrium of ``model`` for
    ``robot`` under its own loads (:func:`check_solution`), or with the other friction direction."""
    if not isinstance(start, StaticSolution):
        raise TypeError(f"start must be a pytdcr.StaticSolution, got {type(start).__name__}")
    if not start.converged:
        raise ValueError(f"start: the solve did not converge (max |residual| {start.residual:.3g} N m): there is no "
                         "state to continue from")
    if start.loads is None:
        raise ValueError("start: the solution does not carry the loads it was solved under")
    _check_release(start.loads, loads)
    check_solution(model, robot, start.loads, start, options, "start")


def solve_batch(robot: Robot, tensions: np.ndarray, loads: Loads | None = None, *, model: str | Model = "pcc",
                q0: np.ndarray | None = None, options: ModelOptions | None = None, threads: int | None = None,
                start: BatchSolution | None = None) -> BatchSolution:
    """Solve every row of ``tensions`` (B, n_tendons) [N], on all cores.

    ``loads`` gives the external wrenches and friction direction shared by all
    cases (its own tensions are ignored). ``q0`` is one warm start or one per
    case. ``threads`` (default: the cores this process may use) does not
    change the results, only the time. ``model`` and ``options`` as for
    :func:`solve`. ``start``: a batch of the same number of rows solved by
    this model for this robot; row b is continued from ``start``'s row b (its
    tensions and loads) to ``tensions[b]`` under ``loads``, as
    :func:`solve` continues one solution; rows whose start did not converge
    are not solved (``path`` ``"no start"``).
    """
    base = loads if loads is not None else Loads(tensions=np.zeros(robot.n_tendons))
    m, opts = resolve(model, robot, base, options, continuation=start is not None)
    T = check_tensions(tensions, robot.n_tendons)  # a fresh C-ordered copy
    if T.ndim != 2:
        raise ValueError(f"tensions must have shape (B, {robot.n_tendons}), got {T.shape}")
    workers = min(default_threads() if threads is None else max(1, int(threads)), max(1, T.shape[0]))
    per_case = 8.0 * (robot.n_disks * 8 + robot.n_tendons + 16) + 400.0  # q, tip, residual, path, stability
    check_resources(m, robot, opts, workers, T.shape[0] * per_case,
                    f"a batch of {T.shape[0]:,} '{m.name}' solves of robot '{robot.name}' ({robot.n_disks} disks, "
                    f"{workers} threads)")
    unloaded = base.with_tensions(np.zeros(robot.n_tendons))
    if start is not None:
        _check_batch_start(m, robot, base, T, start, q0)
    if T.shape[0] == 0:  # an empty batch with the model's shapes: those of one solve of the unloaded robot, no rows
        return m.solve_batch(robot, np.zeros((1, robot.n_tendons)), unloaded, None, opts, 1).rows(slice(0, 0))
    if start is not None:
        return m.solve_batch_from(robot, T, unloaded, start, opts, threads)
    return m.solve_batch(robot, T, unloaded, q0, opts, threads)


def _check_release(start_loads: Loads, loads: Loads) -> None:
    """Refuse a continuation that would change the friction direction (``Loads.release``)."""
    if start_loads.release != loads.release:
        raise ValueError(f"start: solved with release={start_loads.release}, loads have release={loads.release}: "
                         "the friction direction cannot change along a continuation; solve from rest instead")


def _check_batch_start(model: Model, robot: Robot, loads: Loads, tensions: np.ndarray, start: BatchSolution,
                       q0: np.ndarray | None) -> None:
    """Refuse a batch ``start`` that cannot be continued row by row to ``tensions`` (B, n_tendons) under ``loads``:
    another model, another number of rows or unknowns, no loads, or the other friction direction."""
    if not isinstance(start, BatchSolution):
        raise TypeError(f"start must be a pytdcr.BatchSolution, got {type(start).__name__}")
    if q0 is not None:
        raise ValueError("give q0 (start points at full load) or start (solved states to continue), not both")
    if start.model != model.name:
        raise ValueError(f"start: solved by model '{start.model}', not '{model.name}'")
    if start.tensions.shape != tensions.shape:
        raise ValueError(f"start: {start.tensions.shape[0]} rows of {start.tensions.shape[1]} tensions, tensions "
                         f"has shape {tensions.shape}: continue row by row from a batch of the same shape")
    if start.loads is None:
        raise ValueError("start: the batch does not carry the loads it was solved under")
    _check_release(start.loads, loads)
    per_row = int(np.prod(start.q.shape[1:]))
    if start.q.shape[0] != tensions.shape[0] or per_row != robot.n_disks * getattr(model, "unknowns_per_disk", 0):
        raise ValueError(f"start: its unknowns (shape {start.q.shape}) are not those of robot '{robot.name}'")


def tip_gradient(robot: Robot, loads: Loads, solution: StaticSolution, *, model: str | Model = "pcc",
                 options: ModelOptions | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The tip of a converged equilibrium and its derivative by the actuator tensions.

    Returns
    -------
    tip : ndarray, shape (3,)
        [m]
    dtip_dT : ndarray, shape (3, n_tendons)
        [m/N]; exact for models whose ``capabilities.gradient`` is ``"exact"``.
    """
    m, opts = resolve(model, robot, loads, options, gradient=True)
    check_solution(m, robot, loads, solution, opts)
    return m.tip_gradient(robot, loads, solution, opts)




def check_solution(model: Model, robot: Robot, loads: Loads, solution: StaticSolution, options: ModelOptions,
                   name: str = "solution") -> None:
    """Refuse a solution that is not an equilibrium of ``model`` for ``robot`` under ``loads``.

    Raises
    ------
    NotConvergedError
        When the solution has no equilibrium.
    ValueError
        When it was solved by another model, for a robot with other unknowns, or (its equations re-evaluated
        at its unknowns) for another robot or other loads: max |residual| beyond :data:`SAME_EQUILIBRIUM` times
        its own residual and tolerance.
    """
    if not isinstance(solution, StaticSolution):
        raise TypeError(f"solution must be a pytdcr.StaticSolution, got {type(solution).__name__}")
    solution.tip_position  # noqa: B018 - raises NotConvergedError when there is no equilibrium
    if solution.model != model.name:
        raise ValueError(f"{name}: solved by model '{solution.model}', not '{model.name}'; pass "
                         f"model='{solution.model}' or solve again with '{model.name}'")
    try:
        r = model.equilibrium_residual(robot, loads, solution.q, options)
    except ValueError as err:
        raise ValueError(f"{name}: not a solution of robot '{robot.name}' ({err})") from None
    limit = SAME_EQUILIBRIUM * max(solution.residual, solution.atol)
    if not r <= limit:
        raise ValueError(f"{name}: not an equilibrium of robot '{robot.name}' under these loads (max |residual| "
                         f"{r:.3g} N m there, {solution.residual:.3g} N m when it was solved): pass the robot and "
                         "loads it was solved with")


def warmup() -> float:
    """Run each model's calls once (solve, warm start, continuation, batch, stability, tip gradients), in a fixed
    order; returns the seconds. Every model runs in the compiled core, so nothing compiles: what remains is the
    first call's set-up (imports, allocations), and a benchmark calls this before it times anything."""
    from ..paper import rao_robot

    t0 = time.perf_counter()
    robot = rao_robot()
    loads = Loads(np.full(robot.n_tendons, 1.0), tip_force=np.array([0.0, 0.01, 0.0]))
    for name, model in MODELS.items():
        sol = solve(robot, loads, model=name)
        solve(robot, loads, model=name, q0=sol.q)  # the warm-start path
        if model.capabilities.continuation:
            solve(robot, loads.with_tensions(np.full(robot.n_tendons, 1.5)), model=name, start=sol)
            batch = solve_batch(robot, np.ones((2, robot.n_tendons)), loads, model=name, threads=1)
            solve_batch(robot, np.full((2, robot.n_tendons), 1.5), loads, model=name, threads=1, start=batch)
        _ = solve_batch(robot, np.ones((2, robot.n_tendons)), loads, model=name, threads=1).stability
        tip_gradient(robot, loads, sol, model=name)
        model.tip_gradients(robot, np.ones((1, robot.n_tendons)), loads, sol.q[None], model.options_type())
        if "shear_extension" in model.options_type.__dataclass_fields__:
            solve(robot, loads, model=name, options=model.options_type(shear_extension=True))
    return time.perf_counter() - t0

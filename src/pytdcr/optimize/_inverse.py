"""Inverse statics: tensions inside the bounds that put the tip at a target (and optionally its axis along a
direction), the best of the redundant ones by an objective.

Eight tendons for three (or five) constraints leave a family of solutions. The search is a trust-region
sequential programme on the tensions T, each step a small convex problem on the exact Jacobian ``G`` of the
tip by the tensions (implicit function theorem, as :func:`pytdcr.tip_gradient` and
:func:`pytdcr.equilibrium_jacobians`):

1. **Reach** (Gauss-Newton): the least step that cancels the linearised miss ``G dT + r`` inside the bounds
   and the trust region (bounded least squares). Its end says whether the target is reachable (a miss within
   ``tol``); if it is not, the nearest point found is the answer.
2. **Choose**: steps that lower the objective (the least sum of squared tensions ``"least-squares"``, the
   least largest tension ``"least-max"``, the least total ``"least-total"``) with the linearised miss held at
   zero (bounded least squares on a quadratic model whose Hessian is the Lagrangian's, by damped BFGS; a
   linear programme for the other two), each brought back onto the target by Gauss-Newton and kept when the
   objective fell. It stops where no step lowers it: a local optimum (a KKT point) of the objective on the
   tensions that reach the target. The set is not convex; another start may find a better one.

Starts: the equilibria of a pool of scrambled Sobol tension vectors without their co-contraction (solved from
rest once per robot, loads, bounds, model and seed, and kept), the :data:`NEAREST` whose tips lie nearest the
target ranked by the objective their linearised best step predicts. Steps are solved by Newton from the last
kept equilibrium (cheap, about 1 ms with the Jacobian on the paper robot). The answer is then solved again
from rest (the loading path): the tensions returned are ones that, applied from rest, put the tip at the
target (``path`` ``"loading path"``). Where the loading path reaches another equilibrium there, the search
goes on with every step solved from rest, then from the next starts; where none reaches the target that way,
the answer is the best equilibrium found on another branch, ``path`` ``"another branch"`` (a robot brought
there another way holds it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from enum import StrEnum
from functools import partial

import numpy as np
from numpy.typing import ArrayLike

from ..bounds import TensionBounds
from ..loads import Loads, check_tensions
from ..records import JsonDict, JsonObject, check_schema, part
from ..results import StaticSolution
from ..robot import Robot
from ..statics import Model, ModelOptions, resolve, solve
from ..statics.displacement import pulled_in
from ..validate import MAX_SEED, SettingsError, as_real_array, check_count, check_positions, unit_vector
from ._inverse_search import (
    NEAREST,
    Point,
    Pool,
    Search,
    Target,
    is_optimal,
    objective_value,
    ranked_starts,
    sample_pool,
)

__all__ = ["NEAREST", "OBJECTIVES", "SCHEMA_VERSION", "InversePath", "InverseResult", "InverseSearch", "TipTarget",
           "inverse_path", "inverse_statics", "objective_value"]

#: how a solution is chosen among the redundant ones
OBJECTIVES = ("least-squares", "least-max", "least-total")

#: the layout of an inverse answer's JSON (:meth:`InverseResult.to_json`, ``tdcr inverse --json``)
SCHEMA_VERSION = 1

#: the record errors name
_FILE = "inverse result"
_read = partial(part, _FILE)


class InversePath(StrEnum):
    """How the robot reaches an answer of inverse statics (``InverseResult.path``).

    A member is a ``str`` equal to its value (``InversePath.LOADING_PATH == "loading path"``) and prints and
    serialises as that value (JSON, CSV): the files written keep their text, and a path read back from one
    compares equal to its member. Not :class:`pytdcr.statics.SolvePath`: that says how one solve reached an
    equilibrium, this how a robot gets to the answer's.
    """

    #: applied from rest (the loading path), the answer's tensions give its equilibrium
    LOADING_PATH = "loading path"
    #: along a path of targets, reached from the previous target's equilibrium by moving the tensions straight
    #: there (:func:`inverse_path`)
    CONTINUED = "continued"
    #: only a robot brought there another way holds the answer's equilibrium (from rest, another one)
    ANOTHER_BRANCH = "another branch"


@dataclass(frozen=True, init=False)
class TipTarget:
    """Where the tip should be: a position and, optionally, the direction of its axis.

    Parameters
    ----------
    position : array-like, shape (3,)
        [m], base frame; each coordinate within +/- :data:`~pytdcr.validate.MAX_POSITION_M` (no robot reaches
        farther). Held as a float ndarray (3,).
    direction : array-like, shape (3,), optional
        The tip axis wanted (the last disk's normal), normalised here (:func:`pytdcr.validate.unit_vector`: its
        scale is free); its miss counts ``robot.length`` times the difference of the unit vectors, so that one
        tolerance [m] holds both. Held as a unit ndarray (3,), or None.
    """

    position: np.ndarray
    direction: np.ndarray | None

    def __init__(self, position: ArrayLike, direction: ArrayLike | None = None) -> None:
        object.__setattr__(self, "position", check_positions(position, "target", single=True))
        object.__setattr__(self, "direction", None if direction is None else unit_vector(direction, "direction"))

    @classmethod
    def of(cls, target: TipTarget | ArrayLike) -> TipTarget:
        """``target`` itself, or a position (3,) [m] as a target without a direction."""
        return target if isinstance(target, TipTarget) else cls(target)


@dataclass(frozen=True)
class InverseSearch:
    """How :func:`inverse_statics` searches.

    Attributes
    ----------
    tol : float
        The miss accepted as reaching the target [m], in (0, 0.01] (default 1e-6).
    starts : int
        How many ranked starts to try, in turn, until one reaches on the loading path (1 to 100; default 3).
    max_solves : int
        The solves one target may spend (default 200; at least 10).
    seed : int
        The start pool's Sobol scramble seed.
    options : ModelOptions, optional
        Solver options of the model's options type (default: the model's).
    pool : tuple of ndarray, optional
        Equilibria to start from instead of the built-in pool: tensions (K, n_tendons) [N] and their tips
        (K, 3) [m], e.g. a workspace run's samples.
    """

    tol: float = 1e-6
    starts: int = 3
    max_solves: int = 200
    seed: int = 0
    options: ModelOptions | None = None
    pool: tuple[np.ndarray, np.ndarray] | None = None

    def __post_init__(self) -> None:
        tol = float(as_real_array(self.tol, "tol"))
        if not (np.isfinite(tol) and 0.0 < tol <= 0.01):
            raise SettingsError("tol", f": must be in (0, 0.01] m, got {self.tol!r}")
        object.__setattr__(self, "tol", tol)
        for name, lo, hi in (("starts", 1, 100), ("max_solves", 10, None), ("seed", 0, MAX_SEED)):
            try:
                object.__setattr__(self, name, check_count(getattr(self, name), name, lo=lo, hi=hi))
            except ValueError as err:
                raise SettingsError.about(name, err) from None
        if self.pool is not None:
            try:
                t, p = (as_real_array(a, "pool") for a in self.pool)
            except (TypeError, ValueError):
                t = p = np.zeros((0, 0))
            if t.ndim != 2 or p.shape != (t.shape[0], 3) or t.shape[0] == 0 or not (
                    np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
                raise ValueError("pool: give finite tensions (K, n_tendons) [N] and tips (K, 3) [m], K >= 1")
            object.__setattr__(self, "pool", (check_tensions(t, name="pool: tensions"),
                                              check_positions(p, "pool: tips")))


@dataclass(frozen=True, eq=False)
class InverseResult:
    """What :func:`inverse_statics` found.

    JSON happens at one boundary: :meth:`to_json` (what ``tdcr inverse --json`` prints for one target, with
    ``schema_version``: :data:`SCHEMA_VERSION`) and :meth:`from_json`, which reads it back (``path`` as its
    :class:`InversePath`), a missing key raising :class:`~pytdcr.records.RecordKeyError` naming it.

    Attributes
    ----------
    target : ndarray, shape (3,)
        The position asked for [m].
    tensions : ndarray, shape (n_tendons,)
        Actuator tensions [N], inside the bounds.
    tip_position, tip_axis : ndarray, shape (3,)
        The equilibrium's tip [m] and axis (unit) at those tensions.
    distance_m : float
        How far the tip lies from the target [m].
    axis_error_rad : float or None
        The angle between the tip axis and the direction asked for [rad]; None when none was asked.
    reachable : bool
        The tip reaches the target within the tolerance (and the axis the direction, when one was asked).
    stable : bool or None
        The equilibrium's stability (None where the model has no test).
    converged : bool
        The equilibrium converged (False only when no start converged).
    path : InversePath
        ``"loading path"`` (applied from rest, the tensions give this equilibrium), ``"continued"`` (in a
        path, reached from the previous target's equilibrium by moving the tensions straight there) or
        ``"another branch"`` (only a robot brought there another way holds it).
    objective : str
        How the tensions were chosen (:data:`OBJECTIVES`).
    objective_value : float
        Its value at ``tensions`` [N^2 or N].
    optimal : bool
        A reaching answer where no small move of the tensions that keeps the tip at the target lowers the
        objective (first-order optimality, checked on the exact Jacobian); False where the search stopped at
        the edge of the tensions the loading path holds there, or did not reach.
    solution : StaticSolution or None
        The equilibrium; None in a result read back from JSON (:meth:`from_json`: a file holds the answer's
        numbers, not its equilibrium).
    evaluations : int
        Solves spent.
    seconds : float
        Wall time [s].
    pulled_in : ndarray, shape (n_tendons,), or None
        The answer in displacements: each tendon's pull-in at the equilibrium [m] (:func:`pytdcr.pulled_in`,
        with the robot's tendon stiffness), what a motor driven by displacement must set; None where the answer
        has no equilibrium or was read from a file written without it.
    """

    target: np.ndarray
    tensions: np.ndarray
    tip_position: np.ndarray
    tip_axis: np.ndarray
    distance_m: float
    axis_error_rad: float | None
    reachable: bool
    stable: bool | None
    converged: bool
    path: InversePath
    objective: str
    objective_value: float
    optimal: bool
    solution: StaticSolution | None
    evaluations: int
    seconds: float
    pulled_in: np.ndarray | None = None

    def to_dict(self) -> JsonDict:
        """JSON-ready form without ``schema_version`` (one point of ``tdcr inverse --targets --json``): the
        vectors as lists [m, N], ``path`` as its text, the numbers as they are."""
        return {"target": self.target.tolist(), "tensions": self.tensions.tolist(),
                "tip_position": self.tip_position.tolist(), "tip_axis": self.tip_axis.tolist(),
                "distance_m": self.distance_m, "axis_error_rad": self.axis_error_rad, "reachable": self.reachable,
                "stable": self.stable,
                "converged": self.converged, "path": self.path.value, "objective": self.objective,
                "objective_value": self.objective_value, "optimal": self.optimal, "evaluations": self.evaluations,
                "seconds": self.seconds, "pulled_in_m": None if self.pulled_in is None else self.pulled_in.tolist()}

    def to_json(self) -> JsonDict:
        """The answer's JSON: :meth:`to_dict`'s keys and ``schema_version`` (:data:`SCHEMA_VERSION`)."""
        return {"schema_version": SCHEMA_VERSION, **self.to_dict()}

    @classmethod
    def from_json(cls, d: JsonObject) -> InverseResult:
        """The answer :meth:`to_json` (or :meth:`to_dict`) wrote, ``solution`` None (a file holds no
        equilibrium); a null number (non-finite, as :func:`~pytdcr.runtime.dump_json` writes it) reads as NaN,
        an absent ``seconds`` as 0.

        Raises
        ------
        RecordKeyError
            A key is missing (named).
        ValueError
            Another ``schema_version``, or a ``path`` that is no :class:`InversePath`'s text.
        """
        return _read("", _result_from_json, d)


def _number(x: float | None) -> float:
    """A float of a JSON object: null (a non-finite number written as null) as NaN."""
    return float("nan") if x is None else float(x)


def _vector(x: list[float | None]) -> np.ndarray:
    """A JSON list of numbers as a float ndarray, null entries as NaN."""
    return np.array(x, dtype=float)


def _result_from_json(d: JsonObject) -> InverseResult:
    """:meth:`InverseResult.from_json` of an object ``d`` (its schema checked)."""
    check_schema(d, _FILE, SCHEMA_VERSION)
    try:
        path = InversePath(d["path"])
    except ValueError:
        raise ValueError(f"{_FILE}: path {d['path']!r}: not one of {', '.join(repr(p.value) for p in InversePath)}"
                         ) from None
    turn, stable = d["axis_error_rad"], d["stable"]
    return InverseResult(_vector(d["target"]), _vector(d["tensions"]), _vector(d["tip_position"]),
                         _vector(d["tip_axis"]), _number(d["distance_m"]), None if turn is None else _number(turn),
                         bool(d["reachable"]), None if stable is None else bool(stable), bool(d["converged"]), path,
                         str(d["objective"]), _number(d["objective_value"]), bool(d["optimal"]), None,
                         int(d["evaluations"]), _number(d.get("seconds", 0.0)),
                         None if d.get("pulled_in_m") is None else _vector(d["pulled_in_m"]))


def _setup(robot: Robot, loads: Loads, target: TipTarget | ArrayLike, bounds: TensionBounds, model: str | Model,
           objective: str, search: InverseSearch) -> Target:
    """Checked inputs as the search's :class:`Target` (ValueError or TypeError naming the bad argument)."""
    tt = TipTarget.of(target)
    if objective not in OBJECTIVES:
        raise SettingsError("objective", f": must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if not isinstance(bounds, TensionBounds):
        raise TypeError(f"bounds must be a pytdcr.TensionBounds, got {type(bounds).__name__}")
    bounds.check_robot(robot)
    m, opts = resolve(model, robot, loads, search.options, gradient=True)
    if search.pool is not None and search.pool[0].shape[1] != robot.n_tendons:
        raise ValueError(f"pool: robot '{robot.name}' has {robot.n_tendons} tendons, the pool's tensions "
                         f"{search.pool[0].shape[1]}")
    return Target(robot, loads, m, opts, tt.position, tt.direction, search.max_solves)


def _starts(tg: Target, bounds: TensionBounds, start: ArrayLike | None, objective: str,
            search: InverseSearch) -> list[Point]:
    """The points to start from: ``start`` (tensions [N], clipped into the bounds), or the ranked pool's."""
    if start is not None:
        t = as_real_array(start, "start").reshape(-1)
        if t.shape != (tg.robot.n_tendons,) or not np.all(np.isfinite(t)):
            raise ValueError(f"start: give {tg.robot.n_tendons} finite tensions [N], got {start!r}")
        return [Point(bounds.clip(t), None, np.zeros(3), np.zeros((3, t.size)))]
    pool = sample_pool(tg, bounds, seed=search.seed) if search.pool is None else Pool(*search.pool)
    return ranked_starts(tg, pool, bounds, objective, search.starts)


def inverse_statics(robot: Robot, loads: Loads, target: TipTarget | ArrayLike, *, bounds: TensionBounds,
                    model: str | Model = "pcc", objective: str = "least-squares", start: ArrayLike | None = None,
                    search: InverseSearch | None = None) -> InverseResult:
    """Tensions inside ``bounds`` that put the tip of ``robot`` under ``loads`` (its tensions ignored) at
    ``target``, the best of the redundant ones by ``objective`` (see the module).

    Parameters
    ----------
    robot : Robot
    loads : Loads
        External loads and friction direction; its tensions are ignored.
    target : array-like, shape (3,), or TipTarget
        The tip position wanted [m], base frame (a :class:`TipTarget` adds the axis's direction).
    bounds : TensionBounds
    model : str or Model
        A model with a tip gradient (its registry entry's ``capabilities.gradient``): exact for ``pcc``,
        ``pcc2`` and ``sscr``, by finite differences for ``cosserat`` (slower, less sure).
    objective : str
        ``"least-squares"`` (default), ``"least-max"`` or ``"least-total"``.
    start : array-like, shape (n_tendons,), optional
        Tensions [N] to start from, instead of the pool's equilibria nearest the target.
    search : InverseSearch, optional
        Tolerance, starts, solve budget, seed, solver options, a pool of one's own.

    Returns
    -------
    InverseResult
        Also for an unreachable target: ``reachable`` False, the nearest point found in ``tip_position`` and
        its distance in ``distance_m``.

    Raises
    ------
    ValueError
        A target that is not three finite numbers, a zero direction, an unknown objective, bounds or a start
        of another robot, a model without a tip gradient.
    """
    clock = time.perf_counter()
    search = InverseSearch() if search is None else search
    tg = _setup(robot, loads, target, bounds, model, objective, search)
    best: InverseResult | None = None
    cold = False
    for first in _starts(tg, bounds, start, objective, search):
        p = tg.evaluate(first.tensions, None) if first.solution is None else tg.measure(first.tensions,
                                                                                        first.solution)
        if p is None:
            continue
        # steps solved from the last equilibrium (cheap); where that reached the target off the loading path,
        # the next starts solve every step from rest
        s = Search(tg, bounds, objective, search.tol, cold=cold)
        p = s.reach(p)
        if p.distance <= search.tol:
            p = s.choose(p)
        out = _settle(tg, bounds, p, objective, search.tol, clock)
        if out.reachable and out.path is InversePath.LOADING_PATH:
            return out
        if best is None or _rank(out) < _rank(best):
            best = out
        cold = cold or out.reachable
        if tg.exhausted:
            break
    if best is None:
        raise ValueError("no start converged from rest: check the robot, loads and bounds")
    return replace(best, evaluations=tg.count, seconds=time.perf_counter() - clock)


def _rank(r: InverseResult) -> tuple[int, float]:
    """Reaching before missing; of those reaching, the loading path before another branch; of those missing,
    the nearer (every equilibrium found is one the robot holds, brought there one way or another)."""
    if r.reachable:
        return (0 if r.path is InversePath.LOADING_PATH else 1), r.objective_value
    return 2, r.distance_m


def _settle(tg: Target, bounds: TensionBounds, found: Point, objective: str, tol: float,
            clock: float) -> InverseResult:
    """The answer as the loading path holds it: ``found`` solved again from rest; where that is another
    equilibrium, the search again with every step solved from rest; else ``found``, on another branch."""
    rest = tg.evaluate(found.tensions, None)
    if rest is not None and float(np.linalg.norm(rest.miss - found.miss)) <= tol:
        return _result(rest, objective, InversePath.LOADING_PATH, tol, tg, clock, bounds)
    if rest is not None:
        cold = Search(tg, bounds, objective, tol, cold=True)
        again = cold.reach(rest, max_steps=20)
        if again.distance <= tol and found.distance <= tol:
            again = cold.choose(again, max_steps=20)
        if again.distance <= max(tol, found.distance):
            return _result(again, objective, InversePath.LOADING_PATH, tol, tg, clock, bounds)
    return _result(found, objective, InversePath.ANOTHER_BRANCH, tol, tg, clock, bounds)


def _result(p: Point, objective: str, path: InversePath, tol: float, tg: Target, clock: float,
            bounds: TensionBounds) -> InverseResult:
    """The :class:`InverseResult` at ``p``."""
    sol = p.solution
    assert sol is not None
    tip, axis = sol.tip_position, sol.disk_rotations[-1][:, 2]
    reached = p.distance <= tol
    # the angle by atan2 of the cross and dot products: exact for small angles, where arccos of the dot is not
    turn = None if tg.direction is None else float(np.arctan2(np.linalg.norm(np.cross(axis, tg.direction)),
                                                               axis @ tg.direction))
    return InverseResult(tg.target.copy(), p.tensions.copy(), tip, axis, float(np.linalg.norm(tip - tg.target)),
                         turn, reached, sol.stable, True, path, objective, objective_value(p.tensions, objective),
                         reached and is_optimal(p, bounds, objective), sol, tg.count, time.perf_counter() - clock,
                         pulled_in(tg.robot, sol))


def inverse_path(robot: Robot, loads: Loads, targets: ArrayLike, *, bounds: TensionBounds, model: str | Model = "pcc",
                 objective: str = "least-squares", direction: ArrayLike | None = None,
                 search: InverseSearch | None = None) -> list[InverseResult]:
    """Inverse statics along a path: the first of ``targets`` (K, 3) [m] as :func:`inverse_statics` solves it,
    each next one searched from the last one's tensions and equilibrium, its answer checked by continuation
    (``solve(..., start=last)``: the robot moved there by changing its tensions straight, ``path``
    ``"continued"``); where that search does not reach or the continuation ends elsewhere (a fold on the way),
    the target is solved afresh.
    Along a smooth path the tensions follow one optimum smoothly. ``direction`` (3,): the tip axis wanted at
    every target. One :class:`InverseResult` per target, ``evaluations`` and ``seconds`` its own."""
    search = InverseSearch() if search is None else search
    pts = check_positions(targets, "targets")
    out = [inverse_statics(robot, loads, TipTarget(pts[0], direction), bounds=bounds, model=model,
                           objective=objective, search=search)]
    tg = _setup(robot, loads, TipTarget(pts[0], direction), bounds, model, objective, search)
    for row in pts[1:]:
        clock = time.perf_counter()
        tg.aim(row, search.max_solves)
        counted = tg.count
        last = out[-1]
        assert last.solution is not None  # a search's answer holds its equilibrium (None only when read from JSON)
        p = tg.measure(last.tensions, last.solution)
        s = Search(tg, bounds, objective, search.tol, cold=False)
        p = s.reach(p)
        if p.distance <= search.tol:
            p = s.choose(p)
        assert p.solution is not None
        if p.distance <= search.tol:  # the robot moved there: the straight change of tensions, continued
            moved = solve(robot, loads.with_tensions(p.tensions), model=tg.m, options=tg.opts, start=last.solution)
            tg.count += 1
            if moved.converged and float(np.linalg.norm(moved.tip_position - p.solution.tip_position)) <= search.tol:
                res = _result(tg.measure(p.tensions, moved), objective, InversePath.CONTINUED, search.tol, tg, clock,
                              bounds)
                out.append(replace(res, evaluations=tg.count - counted))
                continue
        out.append(inverse_statics(robot, loads, TipTarget(row, direction), bounds=bounds, model=model,
                                   objective=objective, search=search))
    return out

"""The explorer's state, without the web framework: the robot and its variants, the controls turned into loads,
and each browser session's last equilibrium, continued on every change, and its target point (answered by
inverse statics, or by the nearest sample of a workspace run: :mod:`._target`).

Sessions live in the server's memory, keyed by an id each page load draws (the page keeps it in a
``dcc.Store``; a random 128-bit id, the only key to a session's state: the page's server refuses an id of
another form); each has its own lock, so two tabs solve independently and one tab's changes are solved in turn.
What requests can make the server keep is bounded: at most :data:`MAX_SESSIONS` sessions (the least recently used
forgotten), each one pose and one target, and one robot per gravity and friction choice (four at most).
"""

from __future__ import annotations

import enum
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..paper import STANDARD_GRAVITY, paper_bounds, paper_robot, payload_gravity
from ..results import StaticSolution
from ..robot import NoFriction, Robot
from ..runs import read_workspace_pool
from ..statics import MODELS, Model, UnsupportedFeatureError, get_model, solve
from ..statics.displacement import DisplacementSolution, pulled_in, solve_displacements
from ..validate import SettingsError
from ._target import (
    SAME_TIP_M,
    NearestSample,
    TargetAnswer,
    answer_by_inverse,
    answer_by_sample,
    can_inverse,
    nearest_sample,
)
from ._workspace import WorkspaceView, read_workspace

__all__ = ["FRICTIONS", "MAX_SESSIONS", "SAME_TIP_M", "SLOW_FACTOR", "Action", "Controls", "Explorer", "Outcome",
           "Session", "same_equilibrium"]

#: a model whose estimated solve time on the robot (``Model.resources``) is more than this many times the
#: fastest registered model's is labelled slow
SLOW_FACTOR = 10.0
#: sessions kept in memory (the oldest is forgotten beyond)
MAX_SESSIONS = 32
#: the friction choices: the robot's own law, or none
FRICTIONS = ("own", "none")


class Action(enum.Enum):
    """What asked for a solve: a control changed, Reset, "solve from rest", "Reach target" or clear the target."""

    CHANGE = "change"
    DRIVE = "drive"
    RESET = "reset"
    REST = "rest"
    TARGET = "target"
    CLEAR = "clear"


@dataclass(frozen=True)
class Controls:
    """The page's controls: tensions (n_tendons,) [N], tip force (3,) [N], tip moment (3,) [N m], payload [kg],
    gravity on or off, friction (one of :data:`FRICTIONS`) and the model's registered name; ``pulls``
    (n_tendons,) [m]: every tendon driven by this pull-in instead of its tension (None: by tension)."""

    tensions: np.ndarray
    tip_force: np.ndarray
    tip_moment: np.ndarray
    payload_kg: float
    gravity: bool
    friction: str
    model: str
    pulls: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Outcome:
    """One solve for the page: the equilibrium drawn (None when there is none), the loading path's answer
    (``Action.REST`` only), the robot solved, what went wrong (``error``), notes on how it was solved and the
    wall time [s]; the session's target [m] (None: none placed), and for ``Action.TARGET`` how it was answered
    (``answer``) and the tensions [N] the page's controls take (``tensions``); ``drive``: the displacement-driven
    solve, when the tendons were driven by their pull-ins."""

    robot: Robot
    loads: Loads | None = None
    solution: StaticSolution | None = None
    rest: StaticSolution | None = None
    error: str = ""
    note: str = ""
    seconds: float = 0.0
    target: np.ndarray | None = None
    answer: TargetAnswer | None = None
    tensions: np.ndarray | None = None
    drive: DisplacementSolution | None = None


@dataclass(eq=False)
class Session:
    """One browser session: its last converged equilibrium, with the robot and model that solved it, the target
    placed [m] (None: none) and whether the pose drawn reaches it (``reached``: set by a reaching answer, cleared
    by the next change)."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    last: StaticSolution | None = None
    robot: Robot | None = None
    model: Model | None = None
    target: np.ndarray | None = None
    reached: bool = False

    def start_for(self, robot: Robot, model: Model) -> tuple[StaticSolution | None, str]:
        """The equilibrium to continue for ``robot`` and ``model`` (None: solve from rest) and why not."""
        if self.last is None:
            return None, "solved from rest"
        if self.model is not model:
            return None, "model changed: solved from rest"
        if self.robot is not robot:
            return None, "gravity or friction changed: solved from rest"
        if not model.capabilities.continuation:
            return None, f"model '{model.name}' cannot continue a solved state: solved from rest"
        return self.last, ""


class Explorer:
    """The robot explored, its tension bounds, the models offered and the sessions.

    Parameters
    ----------
    robot : Robot, optional
        Default: the workspace run's robot with ``workspace``, else :func:`pytdcr.paper.paper_robot`.
    workspace : str or Path, optional
        A finished ``tdcr workspace`` output folder to draw.
    model : str or None
        The registered model selected first (:data:`pytdcr.statics.MODELS`); None: the workspace run's, else the
        registry's first (pcc).
    """

    def __init__(self, robot: Robot | None = None, *, workspace: str | Path | None = None,
                 model: str | None = "pcc") -> None:
        if isinstance(model, str) and model not in MODELS:
            raise SettingsError("model", f": {model!r} is not a model; choose from {', '.join(MODELS)}")
        self.workspace: WorkspaceView | None = None if workspace is None else read_workspace(workspace)
        if model is None:
            model = self.workspace.model if self.workspace is not None else next(iter(MODELS))
        self.model = get_model(model)
        own = robot is None and self.workspace is not None
        self.robot: Robot = self.workspace.robot if own else (robot if robot is not None else paper_robot())
        if not isinstance(self.robot, Robot):
            raise TypeError(f"robot must be a pytdcr.Robot, got {type(self.robot).__name__}")
        ws = self.workspace
        self.bounds: TensionBounds = (ws.bounds if ws is not None and ws.robot.n_tendons == self.robot.n_tendons
                                      else paper_bounds(self.robot.n_tendons))
        base = ws.loads if own else Loads(np.zeros(self.robot.n_tendons))
        # a first model without friction starts on the frictionless robot
        friction = FRICTIONS[0] if self.model.capabilities.friction else FRICTIONS[1]
        self.defaults = Controls(self.bounds.lower.copy(), np.array(base.tip_force), np.array(base.tip_moment), 0.0,
                                 bool(np.any(self.robot.gravity)), friction, self.model.name)
        self.point_loads = base.point_loads if own else ()
        self.samples = self._samples()
        self._robots: dict[tuple[bool, str], Robot] = {}
        self._sessions: OrderedDict[str, Session] = OrderedDict()
        self._lock = threading.Lock()

    def _samples(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The workspace run's converged, stable samples' tensions (K, n_tendons) [N] and tips (K, 3) [m]; None
        without a run, or for a run of another robot than the one explored."""
        ws = self.workspace
        if ws is None or ws.robot != self.robot:
            return None
        try:
            pool = read_workspace_pool(ws.folder)
        except SettingsError:  # no converged, stable sample
            return None
        return pool.tensions, pool.tips

    # ------------------------------------------------------------------ what the page offers
    def slow_models(self) -> set[str]:
        """The registered models whose estimated solve time on this robot (``Model.resources``) exceeds
        :data:`SLOW_FACTOR` times the fastest's."""
        cost = {}
        for name, m in MODELS.items():
            estimate = getattr(m, "resources", None)
            cost[name] = estimate(self.robot, m.default_options()).seconds if estimate is not None else np.inf
        fastest = min(cost.values())
        return {name for name, c in cost.items() if c > SLOW_FACTOR * fastest}

    def model_choices(self) -> list[tuple[str, str, str]]:
        """(name, label, description) of every registered model; the :meth:`slow_models` labelled ``(slow)``."""
        slow = self.slow_models()
        return [(name, f"{name} (slow)" if name in slow else name, m.description) for name, m in MODELS.items()]

    def nearest_sample(self, target: np.ndarray) -> NearestSample | None:
        """The workspace run's converged, stable sample whose tip lies nearest ``target`` (3,) [m]; None without
        a run's samples (:meth:`_samples`)."""
        return None if self.samples is None else nearest_sample(*self.samples, target)

    def robot_for(self, gravity: bool, friction: str) -> Robot:
        """The robot with gravity on or off (on: its own, or -9.81 m/s^2 along base z if it has none) and
        ``friction`` (:data:`FRICTIONS`); one object per combination, so a session sees when it changed."""
        if friction not in FRICTIONS:
            raise ValueError(f"friction must be one of {', '.join(FRICTIONS)}, got {friction!r}")
        key = (bool(gravity), friction)
        with self._lock:
            robot = self._robots.get(key)
            if robot is None:
                robot = self.robot
                has = bool(np.any(robot.gravity))
                if has != key[0]:
                    robot = robot.with_gravity(STANDARD_GRAVITY if key[0] else None)
                if friction == FRICTIONS[1] and not robot.friction.is_frictionless:
                    robot = robot.with_friction(NoFriction())
                self._robots[key] = robot
        return robot

    def loads_for(self, robot: Robot, c: Controls) -> Loads:
        """The loads of the controls: the tensions, the tip force plus the payload's weight ``payload_kg`` g
        along :func:`pytdcr.paper.payload_gravity` [N], the tip moment [N m] (and the run's disk loads)."""
        force = np.asarray(c.tip_force, dtype=float) + float(c.payload_kg) * payload_gravity(robot)
        return Loads(np.asarray(c.tensions, dtype=float), tip_force=force, tip_moment=c.tip_moment,
                     point_loads=self.point_loads)

    def session(self, sid: str) -> Session:
        """The session of id ``sid`` (a new one for an id not seen, or forgotten)."""
        with self._lock:
            s = self._sessions.get(sid)
            if s is None:
                s = self._sessions[sid] = Session()
                while len(self._sessions) > MAX_SESSIONS:
                    self._sessions.popitem(last=False)
            self._sessions.move_to_end(sid)
        return s

    def forget(self, sid: str) -> None:
        """Forget the session of id ``sid``."""
        with self._lock:
            self._sessions.pop(sid, None)

    # ------------------------------------------------------------------ solving
    def step(self, sid: str, controls: Controls, action: Action = Action.CHANGE) -> Outcome:
        """Solve the controls for session ``sid``: continued from its last equilibrium where the robot and model
        are the same and the model can (``pytdcr.solve(..., start=last)``), else from rest; with
        ``Action.REST`` also from rest along the loading path, to compare. A failed solve keeps the last
        equilibrium for the next change."""
        session = self.session(sid)
        with session.lock:
            if action is Action.RESET:
                session.last = None
            try:
                robot, model, loads = self._inputs(controls)
            except ValueError as err:
                return Outcome(self.robot, error=str(err), target=session.target)
            if controls.pulls is not None:
                return self._driven(session, robot, model, loads, controls.pulls)
            start, note = session.start_for(robot, model)
            t0 = time.perf_counter()
            try:
                sol = solve(robot, loads, model=model, start=start)
            except UnsupportedFeatureError as err:
                return Outcome(robot, loads, error=str(err), target=session.target)
            except ValueError as err:  # the last state cannot be continued to these loads
                note = f"cannot continue the last state ({err}): solved from rest"
                sol = solve(robot, loads, model=model)
            rest = solve(robot, loads, model=model) if action is Action.REST else None
            seconds = time.perf_counter() - t0
            if sol.converged:
                session.last, session.robot, session.model = sol, robot, model
                session.reached = False
            return Outcome(robot, loads, sol, rest, note=note, seconds=seconds, target=session.target)

    def _driven(self, session: Session, robot: Robot, model: Model, loads: Loads, pulls: np.ndarray) -> Outcome:
        """Every tendon driven by its pull-in ``pulls`` [m] (:func:`pytdcr.solve_displacements`, the motors moved
        from the session's last equilibrium where it can be continued, else from rest with the loads; the robot's
        tendon stiffness): the equilibrium with the tensions found."""
        t0 = time.perf_counter()
        start, _ = session.start_for(robot, model)
        try:
            d = solve_displacements(robot, loads.with_tensions(np.zeros(robot.n_tendons)),
                                    [float(v) for v in pulls], model=model, start=start)
        except ValueError as err:
            return Outcome(robot, loads, error=str(err), target=session.target)
        seconds = time.perf_counter() - t0
        if not d.converged:
            hint = ("; two taut opposite tendons that cannot stretch lock their segment: pay one out, or give the "
                    "tendons a stiffness in the robot file") if np.all(np.isinf(d.stiffness)) else ""
            return Outcome(robot, loads, error=f"the pull-ins are not met: {d.message}{hint}",
                           target=session.target, seconds=seconds)
        session.last, session.robot, session.model = d.solution, robot, model
        session.reached = False
        note = ("driven by the pull-ins, continued from the last equilibrium" if start is not None else
                "driven by the pull-ins from rest")
        return Outcome(robot, loads.with_tensions(d.tensions), d.solution, note=note, seconds=seconds,
                       target=session.target, drive=d)

    def _inputs(self, controls: Controls) -> tuple[Robot, Model, Loads]:
        """The robot, model and loads of the controls (ValueError naming what is wrong)."""
        robot = self.robot_for(controls.gravity, controls.friction)
        return robot, get_model(controls.model), self.loads_for(robot, controls)

    def reach(self, sid: str, controls: Controls, target: np.ndarray) -> Outcome:
        """Answer ``target`` (3,) [m] for session ``sid`` under the controls' robot, loads and model (their
        tensions ignored): by :func:`pytdcr.inverse_statics` where the model has a tip gradient (its registered
        capabilities), with the nearest workspace sample named beside it; else by the nearest workspace sample.
        A converged answer becomes the last equilibrium, continued by the next change; ``session.reached`` says
        whether its tip lies within the search's tolerance of the target."""
        session = self.session(sid)
        with session.lock:
            point = np.asarray(target, dtype=float).reshape(-1)
            if point.shape != (3,) or not np.all(np.isfinite(point)):
                return Outcome(self.robot, error="target: give x, y, z as finite numbers", target=session.target)
            session.target, session.reached = point, False
            try:
                robot, model, loads = self._inputs(controls)
            except ValueError as err:
                return Outcome(self.robot, error=str(err), target=point)
            sample = self.nearest_sample(point)
            start, _ = session.start_for(robot, model)
            t0 = time.perf_counter()
            try:
                if can_inverse(model):
                    answer, sol, tensions = answer_by_inverse(robot, loads, model, self.bounds, point, start, sample)
                elif sample is not None:
                    answer, sol, tensions = answer_by_sample(robot, loads, model, self.bounds, point, sample)
                else:
                    return Outcome(robot, loads, error=f"model '{model.name}' has no tip gradient, so no inverse "
                                   "statics; with a workspace run (--workspace) its nearest sample is offered",
                                   target=point)
            except ValueError as err:
                return Outcome(robot, loads, error=str(err), target=point)
            seconds = time.perf_counter() - t0
            if sol.converged:
                session.last, session.robot, session.model = sol, robot, model
                session.reached = answer.reached
            return Outcome(robot, loads.with_tensions(tensions), sol, seconds=seconds, target=point, answer=answer,
                           tensions=tensions)

    def pose_inputs(self, sid: str) -> tuple[np.ndarray, np.ndarray] | None:
        """Session ``sid``'s last equilibrium as inputs of either drive: its tensions [N] and its pull-ins [m]
        (:func:`pytdcr.pulled_in`, with the robot's tendon stiffness); None before any equilibrium."""
        session = self.session(sid)
        with session.lock:
            last, robot = session.last, session.robot
            if last is None or robot is None or last.loads is None:
                return None
            return last.loads.tensions_for(robot.n_tendons).astype(float), pulled_in(robot, last)

    def clear_target(self, sid: str) -> None:
        """Forget session ``sid``'s target."""
        session = self.session(sid)
        with session.lock:
            session.target, session.reached = None, False


def same_equilibrium(a: StaticSolution, b: StaticSolution) -> tuple[bool, float]:
    """Whether two converged equilibria are the same (tips within :data:`SAME_TIP_M`) and their tips' distance
    [m]."""
    gap = float(np.linalg.norm(a.tip_position - b.tip_position))
    return gap <= SAME_TIP_M, gap

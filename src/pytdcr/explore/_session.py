"""The explorer's state, without the web framework: the robot and its variants, the controls turned into loads,
and each browser session's last equilibrium, continued on every change.

Sessions live in the server's memory, keyed by an id each page load draws (the page keeps it in a
``dcc.Store``); each has its own lock, so two tabs solve independently and one tab's changes are solved in turn.
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
from ..design import NoFriction, Robot
from ..loads import Loads
from ..paper import STANDARD_GRAVITY, paper_bounds, paper_robot, payload_gravity
from ..results import StaticSolution
from ..statics import MODELS, Model, UnsupportedFeatureError, get_model, solve
from ..validate import SettingsError
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
#: two tips closer than this are the same equilibrium [m]
SAME_TIP_M = 1e-6


class Action(enum.Enum):
    """What asked for a solve: a control changed, Reset, or "solve from rest"."""

    CHANGE = "change"
    RESET = "reset"
    REST = "rest"


@dataclass(frozen=True)
class Controls:
    """The page's controls: tensions (n_tendons,) [N], tip force (3,) [N], tip moment (3,) [N m], payload [kg],
    gravity on or off, friction (one of :data:`FRICTIONS`) and the model's registered name."""

    tensions: np.ndarray
    tip_force: np.ndarray
    tip_moment: np.ndarray
    payload_kg: float
    gravity: bool
    friction: str
    model: str


@dataclass(frozen=True, eq=False)
class Outcome:
    """One solve for the page: the equilibrium drawn (None when there is none), the loading path's answer
    (``Action.REST`` only), the robot solved, what went wrong (``error``) and notes on how it was solved."""

    robot: Robot
    loads: Loads | None = None
    solution: StaticSolution | None = None
    rest: StaticSolution | None = None
    error: str = ""
    note: str = ""
    seconds: float = 0.0


@dataclass(eq=False)
class Session:
    """One browser session: its last converged equilibrium, with the robot and model that solved it."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    last: StaticSolution | None = None
    robot: Robot | None = None
    model: Model | None = None

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
        self._robots: dict[tuple[bool, str], Robot] = {}
        self._sessions: OrderedDict[str, Session] = OrderedDict()
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ what the page offers
    def model_choices(self) -> list[tuple[str, str, str]]:
        """(name, label, description) of every registered model; those whose estimated solve time on this robot
        exceeds :data:`SLOW_FACTOR` times the fastest's are labelled ``(slow)``."""
        cost = {}
        for name, m in MODELS.items():
            estimate = getattr(m, "resources", None)
            cost[name] = estimate(self.robot, m.default_options()).seconds if estimate is not None else np.inf
        fastest = min(cost.values())
        return [(name, f"{name} (slow)" if cost[name] > SLOW_FACTOR * fastest else name, m.description)
                for name, m in MODELS.items()]

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
                robot = self.robot_for(controls.gravity, controls.friction)
                model = get_model(controls.model)
                loads = self.loads_for(robot, controls)
            except ValueError as err:
                return Outcome(self.robot, error=str(err))
            start, note = session.start_for(robot, model)
            t0 = time.perf_counter()
            try:
                sol = solve(robot, loads, model=model, start=start)
            except UnsupportedFeatureError as err:
                return Outcome(robot, loads, error=str(err))
            except ValueError as err:  # the last state cannot be continued to these loads
                note = f"cannot continue the last state ({err}): solved from rest"
                sol = solve(robot, loads, model=model)
            rest = solve(robot, loads, model=model) if action is Action.REST else None
            seconds = time.perf_counter() - t0
            if sol.converged:
                session.last, session.robot, session.model = sol, robot, model
            return Outcome(robot, loads, sol, rest, note=note, seconds=seconds)


def same_equilibrium(a: StaticSolution, b: StaticSolution) -> tuple[bool, float]:
    """Whether two converged equilibria are the same (tips within :data:`SAME_TIP_M`) and their tips' distance
    [m]."""
    gap = float(np.linalg.norm(a.tip_position - b.tip_position))
    return gap <= SAME_TIP_M, gap

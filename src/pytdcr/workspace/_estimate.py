"""How long a run will take, said before it starts: the work it plans, in solves, times the time of one solve of
its robot, loads and model measured on this machine."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import qmc

from ..bounds import TensionBounds
from ..loads import Loads
from ..robot import Robot
from ..runtime import default_threads, duration
from ..statics import Model, resolve, solve
from ._compute import planned_work
from ._settings import WorkspaceSettings

if TYPE_CHECKING:
    from ..statics.options import ModelOptions

__all__ = ["SOLVES_PER_DIRECTION", "STEP_SOLVES", "Estimate", "solve_seconds", "workspace_estimate"]

#: a sample's or a boundary step's solve (continued, its state kept, its stability checked) in solves from rest,
#: and one direction of the support function h(d) (its searches' evaluations, gradients and exchanges), without
#: and with a load at the tip or on the disks: measured by ``tdcr workspace`` on the paper robot, pcc, 2 cores.
#: Without: 106,504 solves in 131 s and 200 directions in 26.7 s beside a 2.0 ms solve (default settings, 2 min
#: 50 s in all). With (``--tip-force 0.2,-0.2,0 --n 2000``): 54,200 solves in 104 s and 200 directions in 235 s
#: beside a 2.8 ms solve (5 min 55 s in all). h(d) is where a load costs most: its searches end on folds.
STEP_SOLVES = {False: 1.25, True: 1.4}
SOLVES_PER_DIRECTION = {False: 133.0, True: 840.0}
#: the seconds of writing a workspace case's files (meshes, figures, the page)
FILES_SECONDS = 8.0


@dataclass(frozen=True)
class Estimate:
    """A run's expected length.

    Attributes
    ----------
    seconds : float
        The expected wall time [s] when the searches spend their budgets (they may stop sooner), from the
        costs measured on the paper robot (:data:`STEP_SOLVES`, :data:`SOLVES_PER_DIRECTION`); another robot
        or load may cost more or less a solve.
    solves : int
        The solves (and solve-equivalents of the searches) planned.
    solve_seconds : float
        One solve from rest on this machine [s] (the median of a few).
    threads : int
        The threads the run uses.
    """

    seconds: float
    solves: int
    solve_seconds: float
    threads: int

    def text(self) -> str:
        """``estimated time: about 3 min 10 s (120,000 solves at 3.1 ms on 2 threads; ...)``."""
        return (f"estimated time: about {duration(self.seconds)} ({self.solves:,} solves at "
                f"{self.solve_seconds * 1e3:.1f} ms on {self.threads} thread{'s' if self.threads > 1 else ''}; "
                f"the searches may stop sooner)")


def solve_seconds(robot: Robot, loads: Loads, bounds: TensionBounds, *, model: str | Model = "pcc",
                  options: ModelOptions | None = None, k: int = 16, seed: int = 0) -> float:
    """The median wall time of one solve from rest [s] of ``robot`` under ``loads`` and ``model``, at ``k``
    scrambled Sobol tension vectors in ``bounds`` (the first not counted: it may compile)."""
    m, opts = resolve(model, robot, loads, options)
    u = qmc.Sobol(robot.n_tendons, scramble=True, seed=seed).random(k) if robot.n_tendons else np.zeros((k, 0))
    T = bounds.lower + (bounds.upper - bounds.lower) * u
    times = []
    for i, t in enumerate(T):
        t0 = time.perf_counter()
        solve(robot, loads.with_tensions(t), model=m, options=opts)
        if i:
            times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _loaded(loads: Loads) -> bool:
    """A force or moment at the tip or on a disk (gravity alone does not count)."""
    return bool(np.any(loads.tip_force) or np.any(loads.tip_moment)
                or any(np.any(p.force) or np.any(p.moment) for p in loads.point_loads))


def workspace_estimate(cases: Sequence[tuple[Robot, Loads, WorkspaceSettings, str | Model, ModelOptions | None]],
                       bounds: TensionBounds) -> Estimate:
    """The expected length of workspace studies of ``cases`` (robot, loads, settings, model, options each, run
    one after the other) with tensions in ``bounds``: each case's planned work in solves
    (:data:`STEP_SOLVES`, :data:`SOLVES_PER_DIRECTION`, by whether the case has a load) at the time of one of
    its solves (:func:`solve_seconds`), over its threads, plus the files."""
    seconds, solves, per, threads = 0.0, 0, [], 1
    for robot, loads, settings, model, options in cases:
        work = planned_work(robot, loads, bounds, settings, model=model, options=options)
        one = solve_seconds(robot, loads, bounds, model=model, options=options, seed=settings.seed)
        loaded = _loaded(loads)
        steps = (work["sampling"] + work["boundary search"] + work["multistability"]) * STEP_SOLVES[loaded]
        n = steps + work["support function h(d)"] * SOLVES_PER_DIRECTION[loaded]
        threads = settings.threads or default_threads()
        seconds += n * one / threads + FILES_SECONDS
        solves += round(n)
        per.append(one)
    return Estimate(seconds, solves, float(np.median(per)), threads)

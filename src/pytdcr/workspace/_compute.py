"""The whole workspace computation, without files: sample, seek the boundary, measure both regions."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..robot import Robot
from ..runtime import end_stage
from ..statics import Model, UnsupportedFeatureError, check_resources, resolve
from ._frontier import BoundarySearch, GrowthSettings, SearchRound, SearchState, grow_region
from ._grid import Region
from ._history import Multistability, measure_multistability
from ._plan import TensionPlan, plan_tensions
from ._settings import VOXELS_PER_LENGTH, WorkspaceHooks, WorkspaceSettings, search_budget
from ._solve import (
    EQUILIBRIA,
    RegionSamples,
    WarmStarts,
    _Solver,
    continue_plan,
    equilibria_for,
    solve_plan,
    solves_needed,
)
from ._volume import VolumeEstimate, estimate_volume

if TYPE_CHECKING:
    from ..statics.options import ModelOptions

__all__ = ["VOXELS_PER_LENGTH", "WorkspaceRegion", "check_workspace", "planned_work", "search_budget",
           "workspace_region"]


@dataclass(frozen=True, eq=False)
class WorkspaceRegion:
    """The feasible static workspace of one robot under one load, as regions.

    Attributes
    ----------
    samples : RegionSamples
        Every solved tension vector: the plan's, then the boundary search's.
    voxel : float
        Voxel edge [m] (the settings' :meth:`~pytdcr.workspace.WorkspaceSettings.voxel_for` the robot).
    fsw, realisable : VolumeEstimate
        The volume of the paper's FSW (converged, stable) and of its realisable part, with errors.
    fsw_region, realisable_region : Region
        The regions at n (occupancy grids; ``.mesh()`` for the boundary).
    search : BoundarySearch or None
        What the boundary search did (None when it was off).
    equilibria : str
        Which equilibria the region holds (:data:`~pytdcr.workspace.EQUILIBRIA`).
    multistability : Multistability or None
        Samples solved along the other history and compared (None when not measured).
    """

    samples: RegionSamples
    voxel: float
    fsw: VolumeEstimate
    realisable: VolumeEstimate
    fsw_region: Region
    realisable_region: Region
    search: BoundarySearch | None
    equilibria: str = EQUILIBRIA[1]
    multistability: Multistability | None = None


def _tail(rounds: list[SearchRound], key: str, voxel: float) -> float:
    """The growth [m^3] a search stopped by its budget would still add: its last round's growth (scaled up to
    the whole round when the budget cut it short), continued geometrically at the ratio to the round before
    (ten more rounds of it when the ratio is 1 or more)."""
    v = [getattr(r, key) for r in rounds]
    g = np.diff(v).astype(float)
    if g.size == 0:
        return 0.0
    last_round = rounds[-1]
    last = g[-1] * (last_round.planned / max(last_round.steps, 1))
    prev = float(g[-2]) if g.size > 1 else last
    ratio = last / prev if prev > 0 else 1.0
    tail = last * ratio / (1.0 - ratio) if ratio < 1.0 else 10.0 * last
    return max(tail, 0.0) * voxel**3


def _search(solver: _Solver, samples: RegionSamples, bounds: TensionBounds, voxel: float, growth: GrowthSettings,
            hooks: WorkspaceHooks) -> tuple[RegionSamples, BoundarySearch]:
    """The boundary search at each nested size in turn (n/4, n/2, n), sharing ``growth.budget``."""
    rounds: list[SearchRound] = []
    state, spent, stop = SearchState(), 0, "converged"
    for stage in range(3):
        left = growth.budget - spent
        solver.progress = hooks.progress(f"boundary search {stage + 1}/3 (budget)", left) if hooks.progress else None
        samples, got, state, stop = grow_region(solver, samples, bounds, voxel, stage,
                                                settings=replace(growth, budget=left), state=state,
                                                on_round=hooks.on_round)
        end_stage(solver.progress)
        rounds += got
        spent += sum(r.steps for r in got)
        if hooks.checkpoint is not None:
            hooks.checkpoint(samples)
        if stop == "budget":
            break
    return samples, BoundarySearch(tuple(rounds), spent, stop, growth.tol, growth.budget)


def _sampling(m: Model, bounds: TensionBounds, s: WorkspaceSettings) -> tuple[TensionPlan, str, WarmStarts | bool]:
    """The sampling of a workspace study: its plan, which equilibria it holds and its warm starts (False: none)."""
    plan = plan_tensions(bounds, s.n, seed=s.seed)
    kind = equilibria_for(m, s.equilibria)
    return plan, kind, WarmStarts(seed=s.seed) if s.warm and kind == EQUILIBRIA[1] else False


def check_workspace(robot: Robot, loads: Loads, settings: WorkspaceSettings | None = None, *,
                    model: str | Model = "pcc",
                    options: ModelOptions | None = None) -> tuple[Model, ModelOptions, WorkspaceSettings]:
    """Every capability a workspace study of these inputs asks of ``model``, checked before any solve: the one
    check of :func:`workspace_region` (and of every command that plans several studies, before the first).

    The request itself (:func:`pytdcr.statics.resolve`: the robot's friction law, wrenches at inner disks, the
    memory of one solve), the equilibria asked for (:func:`equilibria_for`: ``"continuation"`` needs a model
    that continues a solved state), and the multistability check of a loading-path region, which continues its
    samples from the root (the same capability). Returns the model, its options and the settings (checked
    against ``robot``).

    Raises
    ------
    UnsupportedFeatureError
        Naming the model and the capability it lacks (and the setting that asks for it).
    ValueError
        For settings that do not suit ``robot``, or equilibria the model cannot hold.
    """
    s = (settings if settings is not None else WorkspaceSettings()).check(robot)
    m, opts = resolve(model, robot, loads, options)
    kind = equilibria_for(m, s.equilibria)
    if kind == EQUILIBRIA[0]:
        m, opts = resolve(m, robot, loads, opts, continuation=True)
    elif s.multistability and not m.capabilities.continuation:
        raise UnsupportedFeatureError(m.name, "continuation from a solved state, which the multistability check "
                                      "of its loading-path region needs (its samples continued from the root)",
                                      "set multistability 0 (--multistability 0)", setting="multistability")
    return m, opts, s


def planned_work(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings | None = None, *,
                 model: str | Model = "pcc", options: ModelOptions | None = None) -> dict[str, int]:
    """The most work a workspace study (:func:`pytdcr.workspace.workspace_study`) of these inputs plans, by stage,
    before it starts: ``"sampling"`` and ``"boundary search"`` (the budget; the search may converge sooner) and
    ``"multistability"`` in solves, ``"support function h(d)"`` in directions, ``"largest reach search"`` 1
    when it runs (the model must have a tip gradient for h(d) and the search). Nothing is solved."""
    m, _, s = check_workspace(robot, loads, settings, model=model, options=options)
    plan, _, warm = _sampling(m, bounds, s)
    rows = plan.tensions.shape[0]
    searched = m.capabilities.gradient is not None
    directions = s.direction_vectors()
    return {"sampling": solves_needed(plan, warm), "boundary search": s.search_budget if s.search else 0,
            "multistability": min(s.multistability, rows + (s.search_budget if s.search else 0)),
            "support function h(d)": 0 if directions is None or not searched else int(directions.shape[0]),
            "largest reach search": int(searched and s.reach in ("search", "farthest"))}


def workspace_region(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings | None = None,
                     *, model: str | Model = "pcc", options: ModelOptions | None = None,
                     hooks: WorkspaceHooks | None = None) -> WorkspaceRegion:
    """The feasible static workspace of ``robot`` under ``loads`` with tensions in ``bounds``, as regions: the
    first stage of :func:`pytdcr.workspace.workspace_study` (``settings.directions`` and ``settings.reach`` are not
    used here).

    ``settings.n`` scrambled Sobol tension vectors (``settings.seed``) and the box's corners and edges are
    solved: by default each continued from a solved parent (:func:`continue_plan`; ``settings.equilibria``,
    :func:`~pytdcr.workspace.equilibria_for`), or from rest along the loading path (:func:`solve_plan`, with
    checked warm starts when ``settings.warm``); with ``settings.search``, the boundary search
    (:func:`grow_region`) then grows the region at n/4, n/2 and n base samples in turn, within
    ``settings.search_budget`` solves (default 25 n), until a round adds less than ``settings.tol`` of the
    voxels. Each search step is continued from the sample
    it steps from in a continued region; in a loading-path region it follows the loading path (warm starts
    from the equilibria they step from agree with it on only about 91 % of a checked subset on the paper's
    case: the boundary lies near folds). ``settings.multistability`` of the region's samples are then solved
    along the other history (``measure_multistability``). The volume at each size by
    two estimators gives the error (:func:`estimate_volume`), widened by the growth still expected when the
    budget stopped the search.

    The voxel is ``settings.voxel_for(robot)`` (default the robot's length / 32), checked against the robot
    (:meth:`~pytdcr.workspace.WorkspaceSettings.check`). ``hooks`` (:class:`~pytdcr.workspace.WorkspaceHooks`) see the
    progress, each search round and the samples solved so far after the sampling and after each stage of the
    search.
    """
    m, opts, s = check_workspace(robot, loads, settings, model=model, options=options)
    hooks = hooks if hooks is not None else WorkspaceHooks()
    voxel = s.voxel_for(robot)
    plan, kind, warm = _sampling(m, bounds, s)
    step = hooks.progress("sampling", solves_needed(plan, warm)) if hooks.progress else None
    if kind == EQUILIBRIA[0]:
        samples = continue_plan(robot, loads, plan, model=m, options=opts, threads=s.threads, progress=step)
    else:
        samples = solve_plan(robot, loads, plan, model=m, options=opts, threads=s.threads, warm=warm, progress=step)
    if hooks.checkpoint is not None:
        hooks.checkpoint(samples)
    record, history = None, None
    solver = _Solver(robot, loads.with_tensions(np.zeros(robot.n_tendons)), m, opts, s.threads, None,
                     bool(m.capabilities.stability))
    if s.search:
        check_resources(m, robot, opts)
        growth = GrowthSettings(tol=s.tol, budget=s.search_budget, warm=False, seed=s.seed, folds=s.folds)
        samples, record = _search(solver, samples, bounds, voxel, growth, hooks)
    if s.multistability:
        total = min(s.multistability, int(samples.feasible.sum()))
        solver.progress = hooks.progress("multistability", total) if hooks.progress else None
        history = measure_multistability(solver, samples, s.multistability, seed=s.seed)
    # the tip is a smooth function of the tensions: k free tensions span at most k dimensions
    free = min(3, int(np.sum(bounds.upper > bounds.lower)))
    estimates = []
    for mask, key in ((samples.feasible, "voxels"), (samples.realisable, "voxels_realisable")):
        est, region = estimate_volume(np.where(mask[:, None], samples.tip_position, np.nan), samples.stage, s.n,
                                      voxel, max_dimension=free)
        if record is not None and record.stop != "converged" and record.rounds:
            est = est.with_search_tail(_tail(list(record.rounds), key, voxel))
        estimates.append((est, region))
    (fsw, fsw_region), (real, real_region) = estimates
    return WorkspaceRegion(samples, voxel, fsw, real, fsw_region, real_region, record, kind, history)

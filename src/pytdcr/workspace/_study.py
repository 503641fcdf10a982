"""One workspace study, without files: the region, then h(d), then the largest reach by an explicit rule, and
the numbers ``tdcr workspace``, ``tdcr reproduce`` and ``tdcr designs`` report."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import ReachProblem
from ..records import JsonDict
from ..robot import Robot
from ..runtime import end_stage
from ..statics import Model, stability_test
from ._compute import WorkspaceRegion, check_workspace, workspace_region
from ._settings import WorkspaceHooks, WorkspaceSettings
from ._solve import RegionSamples
from ._summary import WorkspaceSummary, summarise
from ._support import LargestReach, SampleStates, SupportFunction, largest_reach, support_function

if TYPE_CHECKING:
    from ..statics.options import ModelOptions

__all__ = ["Reach", "WorkspaceStudy", "workspace_study"]


@dataclass(frozen=True, eq=False)
class Reach:
    """The largest reach of a workspace study, by its settings' rule (:attr:`WorkspaceSettings.reach`).

    Attributes
    ----------
    reach : float or None
        ``||tip||`` [m]; None when no sample is feasible.
    tensions : ndarray, shape (n_tendons,), or None
        Actuator tensions that attain it [N].
    tip_position : ndarray, shape (3,), or None
        The tip there [m].
    source : str
        Where it comes from: ``"search"`` (the reach search), ``"support"`` (a tip of the support function),
        ``"samples"`` (the farthest feasible sample) or ``"none"``.
    """

    reach: float | None
    tensions: np.ndarray | None
    tip_position: np.ndarray | None
    source: str


def _farthest_sample(samples: RegionSamples, mask: np.ndarray) -> Reach:
    """The farthest of the ``mask`` samples from the base (the first of equals), or none."""
    if not np.any(mask):
        return Reach(None, None, None, "none")
    tips = samples.tip_position[mask]
    r = np.linalg.norm(tips, axis=1)
    k = int(r.argmax())
    return Reach(float(r.max()), samples.tensions[mask][k], tips[k], "samples")


def _by_rule(rule: str, far: Reach, support: SupportFunction | None, search: LargestReach | None) -> Reach:
    """The largest reach by ``rule`` from the farthest sample, the support function's tips and the search."""
    if search is not None and rule == "search":
        return Reach(float(search.reach), search.tensions, search.tip_position, "search")
    best = far
    if support is not None and rule in ("farthest", "support"):
        r = np.linalg.norm(support.tip_position, axis=1)
        if r.max() > best.reach:  # the tips that attain h are feasible: the largest reach is at least theirs
            k = int(r.argmax())
            best = Reach(float(r.max()), support.tensions[k], support.tip_position[k], "support")
    if search is not None and rule == "farthest" and search.reach >= best.reach:
        best = Reach(float(search.reach), search.tensions, search.tip_position, "search")
    return best


@dataclass(frozen=True, eq=False)
class WorkspaceStudy:
    """What :func:`workspace_study` found: the regions, h(d), the largest reach, and their numbers.

    Attributes
    ----------
    settings : WorkspaceSettings
        As given.
    model : Model
        The model that solved it, and ``options`` its options (resolved).
    options : SolverOptions, CosseratOptions or SSCROptions
    region : WorkspaceRegion
        The samples, both regions and their volumes, the boundary search.
    support : SupportFunction or None
        h(d) over the settings' directions (None without directions, a feasible sample or the model's gradient).
    reach_search : LargestReach or None
        The reach search, when the rule ran it (``"search"``, ``"farthest"``) and the model has a gradient.
    largest_reach : Reach
        The largest reach by the settings' rule.
    realisable_reach : float or None
        The farthest realisable sample's reach [m] (None when none is realisable): never searched, so it can be
        below a searched FSW optimum that is itself realisable.
    """

    settings: WorkspaceSettings
    model: Model
    options: ModelOptions
    region: WorkspaceRegion
    support: SupportFunction | None
    reach_search: LargestReach | None
    largest_reach: Reach
    realisable_reach: float | None

    @property
    def samples(self) -> RegionSamples:
        """Every solved tension vector (``region.samples``)."""
        return self.region.samples

    @cached_property
    def summary(self) -> WorkspaceSummary:
        """The numbers (:class:`WorkspaceSummary`), assembled once: the FSW's volume, error, largest reach and
        what it is, points and estimate, the realisable region's (its largest reach is the farthest realisable
        sample, not searched); the voxel, the samples' counts, the warm starts, the boundary voxels' sources,
        the boundary search, h(d), the reach search, the sampling time, which equilibria the region holds and
        its multistability."""
        return summarise(self.region, self.support, self.reach_search,
                         (self.largest_reach.reach, self.largest_reach.source), self.realisable_reach,
                         stability_test(self.model))

    def to_dict(self) -> JsonDict:
        """The numbers, JSON-ready (:meth:`WorkspaceSummary.to_json` of :attr:`summary`)."""
        return self.summary.to_json()


def _parents_as_rows(support: SupportFunction | None, search: LargestReach | None,
                     rows: np.ndarray) -> tuple[SupportFunction | None, LargestReach | None]:
    """The searches' parents (indices into the feasible samples ``rows`` they were given) as sample rows."""
    if support is not None and support.parent is not None:
        support = replace(support, parent=np.where(support.parent >= 0, rows[np.maximum(support.parent, 0)], -1))
    if search is not None and search.parent >= 0:
        search = replace(search, parent=int(rows[search.parent]))
    return support, search


def workspace_study(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings | None = None,
                    *, model: str | Model = "pcc", options: ModelOptions | None = None,
                    hooks: WorkspaceHooks | None = None) -> WorkspaceStudy:
    """The feasible static workspace of ``robot`` under ``loads`` with tensions in ``bounds``: the one pipeline
    of ``tdcr workspace``, ``tdcr reproduce`` and ``tdcr designs``.

    1. The regions (:func:`workspace_region`): samples, boundary search, volumes with errors.
    2. h(d) over ``settings.directions`` (:func:`support_function`, from the feasible samples).
    3. The largest reach by ``settings.reach`` (:class:`WorkspaceSettings` says each rule): the reach search
       (:func:`largest_reach`, seeded by the support function's tips), the farthest of it, the support function's
       tips and the samples, the farther of the tips and the samples, or the farthest sample.

    Steps 2 and 3 need a feasible sample and the model's tip gradient; without them there is no h(d), and the
    largest reach is the farthest feasible sample (none when none is). ``hooks`` see the progress (the sampling,
    the search's stages and the directions of h(d)), each search round and the samples solved so far.
    """
    m, opts, s = check_workspace(robot, loads, settings, model=model, options=options)  # before any solve
    hooks = hooks if hooks is not None else WorkspaceHooks()
    wr = workspace_region(robot, loads, bounds, s, model=m, options=opts, hooks=hooks)
    samples = wr.samples
    far = _farthest_sample(samples, samples.feasible)
    support, search = None, None
    if far.reach is not None and m.capabilities.gradient is not None:
        # h(d) and the largest reach from stable equilibria only, as the region (where the model can tell)
        problem = ReachProblem.create(robot, loads, bounds, model=m, options=opts,
                                      stable_only=bool(m.capabilities.stability))
        T, tips = samples.tensions[samples.feasible], samples.tip_position[samples.feasible]
        # searches start warm from the samples' equilibria; their ends are solved by the region's definition
        states = None if samples.q is None else SampleStates(samples.q[samples.feasible], samples.parent is not None)
        D = s.direction_vectors()
        if D is not None:
            step = hooks.progress("support function h(d)", D.shape[0]) if hooks.progress else None
            support = support_function(problem, T, tips, D, threads=s.threads, progress=step, states=states)
            end_stage(step)
        if s.reach in ("search", "farthest"):
            step = hooks.progress("largest reach search", None) if hooks.progress else None
            if step is not None:
                step(0)  # shown from its start: its length is not known
            search = largest_reach(problem, T, tips, support=support, threads=s.threads, states=states)
            end_stage(step)
        support, search = _parents_as_rows(support, search, np.flatnonzero(samples.feasible))
    real = _farthest_sample(samples, samples.realisable)
    return WorkspaceStudy(s, m, opts, wr, support, search, _by_rule(s.reach, far, support, search), real.reach)

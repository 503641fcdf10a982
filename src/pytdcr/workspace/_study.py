"""One workspace study, without files: the region, then h(d), then the largest reach by an explicit rule, and
the numbers ``tdcr workspace``, ``tdcr reproduce`` and ``tdcr designs`` report."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy import ndimage

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import ReachProblem
from ..robot import Robot
from ..runtime import end_stage
from ..statics import Model, stability_counts, stability_test
from ._compute import WorkspaceRegion, check_workspace, workspace_region
from ._grid import Region
from ._plan import SOURCES
from ._settings import WorkspaceHooks, WorkspaceSettings
from ._solve import RegionSamples
from ._support import LargestReach, SampleStates, SupportFunction, largest_reach, support_function
from ._volume import VolumeEstimate

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


def _counts(samples: RegionSamples, test: str) -> dict[str, Any]:
    """How many samples were solved, converged, and of the converged unstable, untested and stable
    (:func:`stability_counts`: None for stable and unstable when the stability ``test`` is ``"untested"``),
    below the base, touching, realisable, by source."""
    ok = samples.converged
    n_ok = max(int(ok.sum()), 1)
    states = stability_counts(ok, samples.stable, test)
    return {"solved": int(ok.size), "converged": int(ok.sum()), "not_converged": int((~ok).sum()),
            "unstable": states["unstable"], "stability_untested": states["untested"], "stable": states["stable"],
            "below_base": int(samples.below_base.sum()), "disks_touch": int(samples.disks_touch.sum()),
            "fraction_below_base": float(samples.below_base.sum() / n_ok),
            "fraction_disks_touch": float(samples.disks_touch.sum() / n_ok),
            "fraction_realisable": float(samples.realisable.sum() / n_ok),
            "by_source": {name: int(np.sum(samples.source == k)) for k, name in enumerate(SOURCES)}}


def _boundary_sources(region: Region, samples: RegionSamples, mask: np.ndarray) -> dict[str, float]:
    """Of the region's boundary voxels (occupied, with an empty face neighbour), the share holding a sample
    from each source (a voxel can hold several)."""
    occ = region.occupied
    boundary = occ & ~ndimage.binary_erosion(occ, structure=ndimage.generate_binary_structure(3, 1))
    total = int(boundary.sum())
    idx = np.floor((samples.tip_position[mask] - region.origin) / region.voxel).astype(np.int64)
    src = samples.source[mask]
    shares = {}
    for k, name in enumerate(SOURCES):
        hit = np.zeros_like(occ)
        i = idx[src == k]
        hit[i[:, 0], i[:, 1], i[:, 2]] = True
        shares[name] = float((hit & boundary).sum() / total) if total else 0.0
    return shares


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


def _reach_rule(source: str, searched: bool, region: str = "feasible") -> str:
    """What a region's largest reach is, in words (``workspace.json``'s ``reach_rule``): from its
    :attr:`Reach.source`, whether the reach search ran (``searched``) and the samples it is taken from
    (``region``: ``"feasible"`` or ``"realisable"``). Only ``"search"`` is a searched optimum."""
    if source == "none":
        return f"none: no {region} sample"
    if source == "search":
        return "the reach search's optimum"
    what = "the farthest tip attaining h(d)" if source == "support" else f"the farthest {region} sample"
    return what + (", farther than the reach search's optimum" if searched else " (not searched)")


def _region_numbers(est: VolumeEstimate, mask: np.ndarray, reach: float | None, rule: str) -> dict[str, Any]:
    """A region's numbers: its volume (0 below three dimensions), the dimension and the measure that applies
    (with its value: ``area_m2`` or ``length_m`` and their errors, for a 2- or 1-D region), largest reach and
    what it is (``rule``: :func:`_reach_rule`), points and the whole estimate."""
    dim = est.dimension
    out: dict[str, Any] = {"volume_m3": est.volume_m3, "volume_err_m3": est.error_m3,
                           "dimension": 3 if dim is None else dim.dimension,
                           "measure": "volume" if dim is None else dim.measure}
    if dim is not None and dim.dimension == 2:
        out.update(area_m2=dim.area_m2, area_err_m2=dim.area_err_m2)
    if dim is not None and dim.dimension == 1:
        out.update(length_m=dim.length_m, length_err_m=dim.length_err_m)
    return {**out, "largest_reach_m": reach, "reach_rule": rule, "points": int(mask.sum()),
            "volume": est.to_dict()}


@dataclass(frozen=True, eq=False)
class WorkspaceStudy:
    """What :func:`workspace_study` found: the regions, h(d), the largest reach, and their numbers.

    Attributes
    ----------
    settings : WorkspaceSettings
        As given.
    model : Model
        The model that solved it, and ``options`` its options (resolved).
    options : object
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
    options: Any
    region: WorkspaceRegion
    support: SupportFunction | None
    reach_search: LargestReach | None
    largest_reach: Reach
    realisable_reach: float | None

    @property
    def samples(self) -> RegionSamples:
        """Every solved tension vector (``region.samples``)."""
        return self.region.samples

    def to_dict(self) -> dict[str, Any]:
        """The numbers, JSON-ready: the FSW's volume, error, largest reach and what it is (``reach_rule``),
        points and estimate at the top level, the realisable region's under ``realisable`` (its largest reach is
        the farthest realisable sample, not searched); the voxel, the samples' counts, the warm starts, the
        boundary voxels' sources, the boundary search, h(d), the reach search, the sampling time, which
        equilibria the region holds and its multistability."""
        wr, s = self.region, self.region.samples
        searched = self.reach_search is not None
        real = "none" if self.realisable_reach is None else "samples"
        return {**_region_numbers(wr.fsw, s.feasible, self.largest_reach.reach,
                                  _reach_rule(self.largest_reach.source, searched)),
                "realisable": _region_numbers(wr.realisable, s.realisable, self.realisable_reach,
                                              _reach_rule(real, False, "realisable")),
                "voxel_m": wr.voxel, "counts": _counts(s, stability_test(self.model)), "warm_start": s.warm.to_dict(),
                "boundary_sources": _boundary_sources(wr.fsw_region, s, s.feasible) if np.any(s.feasible) else {},
                "boundary_search": wr.search.to_dict() if wr.search is not None else None,
                "support": self.support.to_dict() if self.support is not None else None,
                "largest_reach": self.reach_search.to_dict() if self.reach_search is not None else None,
                "seconds_sampling": s.seconds, "equilibria": wr.equilibria, "root": s.root,
                "stability_test": stability_test(self.model),
                "multistability": wr.multistability.to_dict() if wr.multistability is not None else None}


def _parents_as_rows(support: SupportFunction | None, search: LargestReach | None,
                     rows: np.ndarray) -> tuple[SupportFunction | None, LargestReach | None]:
    """The searches' parents (indices into the feasible samples ``rows`` they were given) as sample rows."""
    if support is not None and support.parent is not None:
        support = replace(support, parent=np.where(support.parent >= 0, rows[np.maximum(support.parent, 0)], -1))
    if search is not None and search.parent >= 0:
        search = replace(search, parent=int(rows[search.parent]))
    return support, search


def workspace_study(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings | None = None,
                    *, model: str | Model = "pcc", options: Any = None,
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

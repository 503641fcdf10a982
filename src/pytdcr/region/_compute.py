"""The whole workspace computation, without files: sample, seek the boundary, measure both regions."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..design import Robot
from ..loads import Loads
from ..statics import Model, check_resources, resolve
from ..validate import check_count
from ._frontier import BoundarySearch, SearchRound, grow_region
from ._grid import Region
from ._plan import plan_tensions
from ._solve import RegionSamples, _Solver, solve_plan, solves_needed
from ._volume import VolumeEstimate, estimate_volume

__all__ = ["VOXELS_PER_LENGTH", "WorkspaceRegion", "search_budget", "workspace_region"]

#: voxels per robot length by default (12.5 mm for the paper robot's 0.4 m)
VOXELS_PER_LENGTH = 32
#: the boundary search's default budget of solves, per base sample
SEARCH_SOLVES_PER_SAMPLE = 25

#: ``progress(stage, total)`` returns a callable advanced by the solves done (total None: unknown)
Progress = Callable[[str, "int | None"], Callable[[int], None]]


@dataclass(frozen=True, eq=False)
class WorkspaceRegion:
    """The feasible static workspace of one robot under one load, as regions.

    Attributes
    ----------
    samples : RegionSamples
        Every solved tension vector: the plan's, then the boundary search's.
    voxel : float
        Voxel edge [m].
    fsw, realisable : VolumeEstimate
        The volume of the paper's FSW (converged, stable) and of its realisable part, with errors.
    fsw_region, realisable_region : Region
        The regions at n (occupancy grids; ``.mesh()`` for the boundary).
    search : BoundarySearch or None
        What the boundary search did (None when it was off).
    """

    samples: RegionSamples
    voxel: float
    fsw: VolumeEstimate
    realisable: VolumeEstimate
    fsw_region: Region
    realisable_region: Region
    search: BoundarySearch | None


def search_budget(n: int) -> int:
    """The boundary search's default budget of solves for ``n`` base samples."""
    return SEARCH_SOLVES_PER_SAMPLE * int(n)


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


def _search(solver: _Solver, samples: RegionSamples, bounds: TensionBounds, voxel: float, budget: int, tol: float,
            seed: int, progress: Progress | None, on_round: Callable[[SearchRound], None] | None,
            checkpoint: Callable[[RegionSamples], None] | None = None) -> tuple[RegionSamples, BoundarySearch]:
    """The boundary search at each nested size in turn (n/4, n/2, n), sharing the budget."""
    rounds: list[SearchRound] = []
    tried, counts, spent, stop = None, ({}, {}), 0, "converged"
    for stage in range(3):
        solver.progress = progress(f"boundary search {stage + 1}/3", None) if progress else None
        samples, got, tried, stop = grow_region(solver, samples, bounds, voxel, stage, tol=tol,
                                                budget=budget - spent, warm=False, seed=seed, tried=tried,
                                                counts=counts, on_round=on_round)
        rounds += got
        spent += sum(r.steps for r in got)
        if checkpoint is not None:
            checkpoint(samples)
        if stop == "budget":
            break
    return samples, BoundarySearch(tuple(rounds), spent, stop, tol, budget)


def workspace_region(robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, *,
                     model: str | Model = "pcc", options: Any = None, voxel: float | None = None, warm: bool = True,
                     search: bool = True, budget: int | None = None, tol: float = 0.002, threads: int | None = None,
                     progress: Progress | None = None, on_round: Callable[[SearchRound], None] | None = None,
                     checkpoint: Callable[[RegionSamples], None] | None = None) -> WorkspaceRegion:
    """The feasible static workspace of ``robot`` under ``loads`` with tensions in ``bounds``.

    ``n`` scrambled Sobol tension vectors (``seed``) and the box's corners and edges are solved
    (:func:`solve_plan`); with ``search``, the boundary search (:func:`grow_region`) then grows the region at
    n/4, n/2 and n base samples in turn, within ``budget`` solves (default 25 n), until a round adds less
    than ``tol`` of the voxels. The search's steps follow the loading path: warm starts from the equilibria
    they step from agree with it on only about 91 % of a checked subset on the paper's case (the boundary
    lies near folds), so checking them costs more than it saves (``grow_region(warm=True)`` to try). The
    volume at each size by two estimators gives the error
    (:func:`estimate_volume`), widened by the growth still expected when the budget stopped the search.

    ``voxel`` [m] defaults to the robot's length / 32. ``progress(stage, total)`` returns a callable that is
    advanced by the solves done; ``on_round`` sees each search round; ``checkpoint`` sees the samples solved
    so far after the sampling and after each stage of the search (to save them: an interrupted study keeps them).
    """
    n = check_count(n, "n", lo=1)
    m, opts = resolve(model, robot, loads, options)
    voxel = float(voxel) if voxel is not None else robot.length / VOXELS_PER_LENGTH
    if not (np.isfinite(voxel) and voxel > 0):
        raise ValueError(f"voxel = {voxel!r}: must be a positive length [m]")
    plan = plan_tensions(bounds, n, seed)
    step = progress("sampling", solves_needed(plan, warm)) if progress else None
    samples = solve_plan(robot, loads, bounds, plan, model=m, options=opts, threads=threads, warm=warm, seed=seed,
                         progress=step)
    if checkpoint is not None:
        checkpoint(samples)
    record = None
    if search:
        check_resources(m, robot, opts)
        budget = search_budget(n) if budget is None else check_count(budget, "budget", lo=0)
        stability = bool(m.capabilities.stability)
        solver = _Solver(robot, loads.with_tensions(np.zeros(robot.n_tendons)), m, opts, threads, None, stability)
        samples, record = _search(solver, samples, bounds, voxel, budget, tol, seed, progress, on_round, checkpoint)
    estimates = []
    for mask, key in ((samples.feasible, "voxels"), (samples.realisable, "voxels_realisable")):
        est, region = estimate_volume(np.where(mask[:, None], samples.tip, np.nan), samples.stage, n, voxel)
        if record is not None and record.stop != "converged" and record.rounds:
            est = est.with_search_tail(_tail(list(record.rounds), key, voxel))
        estimates.append((est, region))
    (fsw, fsw_region), (real, real_region) = estimates
    return WorkspaceRegion(samples, voxel, fsw, real, fsw_region, real_region, record)

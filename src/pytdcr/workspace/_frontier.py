"""Seeking the boundary: grow the sampled region voxel by voxel until it stops growing.

Sampling alone leaves the outer parts of the workspace empty: the tension-to-tip map is far from uniform, and
the tips of random tension vectors crowd its middle. The search takes every occupied voxel with an empty face
neighbour, one sample in it, and the tip's exact derivative by the tensions (implicit function theorem), and
asks for the tension step, inside the bounds, that moves the tip 1.5 voxels across that face (least squares,
smallest step, tendons at a bound held there). The step is solved along the loading path like every sample.
Where it lands in an empty voxel the region grows; where the bounds forbid the move (to first order) it is
not tried. Each sample tries each face once. Rounds repeat until a round adds less than ``tol`` of the
region's voxels, or the budget of solves is spent.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import MISSING, asdict, dataclass, field, fields, replace

import numpy as np

from .. import _core
from ..bounds import TensionBounds
from ..records import JsonDict, JsonObject
from ..validate import SettingsError, check_count
from ._grid import region_from_points
from ._plan import SOURCES
from ._solve import RegionSamples, WarmStartCheck, _checked, _Solver

__all__ = ["FOLD_RULES", "BoundarySearch", "GrowthSettings", "SearchRound", "SearchState", "grow_region"]

#: the six face directions of a voxel
FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
#: source code of the search's rows
SEARCH = SOURCES.index("search")
#: what a search step does where its path meets a fold: ``"snap"`` through to the equilibrium past it (kept as a
#: sample), or ``"stop"`` there (the step adds nothing; no snap-through is sought, which is most of a search's cost)
FOLD_RULES = ("snap", "stop")


@dataclass(frozen=True)
class SearchRound:
    """One round of the boundary search.

    Attributes
    ----------
    stage : int
        The nested sample size it grew (0: n/4, 1: n/2, 2: n).
    round : int
    faces : int
        Boundary faces tried (a sample and the empty neighbour across one of its voxel's faces).
    steps : int
        Tension steps solved (faces whose step the bounds allow, up to the budget).
    planned : int
        Steps the bounds allowed; more than ``steps`` when the budget cut the round short.
    voxels : int
        The FSW's occupied voxels after the round.
    voxels_realisable : int
        The realisable region's, likewise.
    seconds : float
    warm : str
        How the steps were solved: ``"continuation"`` (continued from the sample they step from, in a region of
        continued samples), ``"warm"`` (from the sample they step from, kept because a checked subset agreed with
        the loading path) or ``"loading path"``.
    checked, agreed : int
        The round's checked subset (solved both ways) and how many reached the same equilibrium.
    at_fold : int
        Steps that stopped at a fold (``folds="stop"``; counted in ``steps``, not kept as samples).
    """

    stage: int
    round: int
    faces: int
    steps: int
    planned: int
    voxels: int
    voxels_realisable: int
    seconds: float
    warm: str = "loading path"
    checked: int = 0
    agreed: int = 0
    at_fold: int = 0


@dataclass(frozen=True)
class GrowthSettings:
    """How :func:`grow_region` searches.

    Attributes
    ----------
    tol : float
        Stop when a round adds less than this share of the voxels.
    max_rounds : int
        Rounds at most, >= 1.
    budget : int
        Solves at most, >= 0.
    step : float
        The tip's asked move across a face [voxels].
    tries : int
        Times a boundary face of a voxel may be tried (by different samples), >= 1.
    warm : bool
        Start each round's steps from the equilibria they step from, if a checked subset agrees with the
        loading path; otherwise they follow the loading path.
    check : int
        The checked subset's size, >= 0.
    seed : int
        Seed of the checked subsets (with the stage and the round), >= 0.
    folds : str
        Where a step's continuation meets a fold (:data:`FOLD_RULES`): ``"snap"`` through it and keep the
        equilibrium past it, or ``"stop"`` there and keep nothing (models without the choice snap).
    """

    tol: float = 0.002
    max_rounds: int = 40
    budget: int = 100_000
    step: float = 1.5
    tries: int = 2
    warm: bool = True
    check: int = 200
    seed: int = 0
    folds: str = FOLD_RULES[0]

    def __post_init__(self) -> None:
        for name, lo in (("max_rounds", 1), ("budget", 0), ("tries", 1), ("check", 0), ("seed", 0)):
            object.__setattr__(self, name, check_count(getattr(self, name), name, lo=lo))
        if not (np.isfinite(self.step) and self.step > 0):
            raise SettingsError("step", f" = {self.step!r}: must be a positive number of voxels")
        if self.folds not in FOLD_RULES:
            raise SettingsError("folds", f" = {self.folds!r}: must be one of {', '.join(FOLD_RULES)}")


@dataclass
class SearchState:
    """What the boundary search has tried, carried from one stage to the next: per sample, face and region
    (FSW, realisable) whether it was tried (``tried``, (M, 6, 2) of bool, None before the first stage), per
    region how often each voxel's face was tried (``counts``), and the tip's derivative by the tensions at
    each sample where it was computed (``gradients``, sample row -> (3, n_tendons) [m/N]: a sample steps
    across several faces, in several rounds, from one equilibrium)."""

    tried: np.ndarray | None = None
    counts: tuple[dict, dict] = field(default_factory=lambda: ({}, {}))
    gradients: dict[int, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class BoundarySearch:
    """What the boundary search did: its rounds, its solves, why it stopped."""

    rounds: tuple[SearchRound, ...]
    solves: int
    stop: str
    tol: float
    budget: int

    @property
    def warm_agreement(self) -> float | None:
        """Agreed over checked warm starts, all rounds (None when none were checked)."""
        checked = sum(r.checked for r in self.rounds)
        return sum(r.agreed for r in self.rounds) / checked if checked else None

    def to_dict(self) -> JsonDict:
        """JSON-ready form."""
        return {"solves": self.solves, "stop": self.stop, "tol": self.tol, "budget": self.budget,
                "warm_rounds": sum(r.warm == "warm" for r in self.rounds),
                "warm_checked": sum(r.checked for r in self.rounds), "warm_agreement": self.warm_agreement,
                "at_fold": sum(r.at_fold for r in self.rounds),
                "rounds": [asdict(r) for r in self.rounds]}

    @classmethod
    def from_dict(cls, d: JsonObject) -> BoundarySearch:
        """The search :meth:`to_dict` wrote (its totals over the rounds are derived from them); KeyError naming a
        missing key. A round's keys with defaults may be absent (older files), and its ``seconds`` (a record
        with its times dropped: read 0)."""
        def one(r: JsonObject) -> SearchRound:
            kw = {f.name: r[f.name] for f in fields(SearchRound)
                  if f.name in r or (f.default is MISSING and f.name != "seconds")}
            return SearchRound(**{"seconds": 0.0, **kw})

        return cls(tuple(one(r) for r in d["rounds"]), d["solves"], d["stop"], d["tol"], d["budget"])


def _voxel_keys(tip: np.ndarray, voxel: float) -> np.ndarray:
    return np.floor(tip / voxel).astype(np.int64)


def _faces(tip: np.ndarray, rows: np.ndarray, tried: np.ndarray, voxel: float, counts: dict[tuple[int, ...], int],
           tries: int) -> tuple[np.ndarray, np.ndarray]:
    """The round's steps for the region of ``tip[rows]`` (closed as the final region is): per empty voxel next
    to it, one boundary face leading there that has been tried fewer than ``tries`` times (``counts``,
    updated), with a sample in the occupied voxel that has not tried this face. Returns the samples' rows and
    the faces' indices into :data:`FACES` (deterministic: the lowest face, then the lowest row, wins)."""
    region = region_from_points(tip[rows], voxel)
    occ = np.pad(region.occupied, 1)
    idx = np.floor((tip[rows] - region.origin) / voxel).astype(np.int64) + 1
    lin = np.ravel_multi_index(idx.T, occ.shape)
    key0 = np.round(region.origin / voxel).astype(np.int64) - 1
    cand_rows, cand_faces, cand_target = [], [], []
    for f, e in enumerate(FACES):
        n = idx + e
        empty = ~occ[n[:, 0], n[:, 1], n[:, 2]] & ~tried[rows, f]
        if not np.any(empty):
            continue
        _, first = np.unique(lin[empty], return_index=True)
        vox = idx[empty][first]
        keep = np.array([counts.get((*v, f), 0) < tries for v in map(tuple, vox + key0)], dtype=bool)
        cand_rows.append(rows[empty][first][keep])
        cand_faces.append(np.full(int(keep.sum()), f))
        target = vox[keep] + e
        cand_target.append(np.ravel_multi_index(target.T, occ.shape) if target.size else np.zeros(0, np.int64))
    if not cand_rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    r, f, t = np.concatenate(cand_rows), np.concatenate(cand_faces), np.concatenate(cand_target)
    _, first = np.unique(t, return_index=True)  # one step per empty voxel and round
    first = np.sort(first)
    r, f = r[first], f[first]
    for v, face in zip(map(tuple, idx[np.searchsorted(rows, r)] + key0), f, strict=True):
        counts[(*v, int(face))] = counts.get((*v, int(face)), 0) + 1
    return r, f



def tension_step(J: np.ndarray, t: np.ndarray, lower: np.ndarray, upper: np.ndarray, dp: np.ndarray) -> np.ndarray:
    """The tension step ``dt`` (n,) [N] with ``J dt`` closest to ``dp`` (3,) [m] and ``t + dt`` in the bounds,
    the smallest such: the least-norm solution when it stays inside, else bounded least squares with a small
    damping of the step (``J`` (3, n) [m/N] scaled by its largest entry times 1e-3;
    the compiled core's ``box_least_squares``, src/cpp/box_lsq.hpp)."""
    free = upper > lower
    dt = np.zeros(t.size)
    A = J[:, free]
    if A.shape[1] == 0:
        return dt
    G = A @ A.T
    G[np.diag_indices(3)] += 1e-12 * max(np.trace(G), 1e-300)
    dt[free] = A.T @ np.linalg.solve(G, dp)
    if np.all(t + dt >= lower) and np.all(t + dt <= upper):
        return dt
    damp = 1e-3 * float(np.abs(A).max())
    lo, hi = np.minimum((lower - t)[free], 0.0), np.maximum((upper - t)[free], 0.0)
    x = _core.box_least_squares(np.ascontiguousarray(A), np.ascontiguousarray(dp, dtype=float), damp, lo, hi)
    dt[free] = np.clip(x, (lower - t)[free], (upper - t)[free])
    return dt


def _gradients(solver: _Solver, samples: RegionSamples, rows: np.ndarray, cache: dict[int, np.ndarray]) -> np.ndarray:
    """The tip's derivative by the tensions at the samples ``rows`` (K, 3, n_tendons) [m/N]: from ``cache``
    where a sample's is there, else computed once per distinct sample and added to it."""
    assert samples.q is not None
    new = np.array(sorted({int(b) for b in rows} - cache.keys()), dtype=np.int64)
    if new.size:
        got = solver.model.tip_gradients(solver.robot, samples.tensions[new], solver.loads, samples.q[new],
                                         solver.options, solver.threads)
        cache.update(zip(new.tolist(), got, strict=True))
    if rows.size == 0:
        return np.zeros((0, 3, samples.tensions.shape[1]))
    return np.stack([cache[int(b)] for b in rows])


def _steps(solver: _Solver, samples: RegionSamples, rows: np.ndarray, faces: np.ndarray, bounds: TensionBounds,
           length: float, cache: dict[int, np.ndarray]) -> np.ndarray:
    """The tension vectors the faces ask for; rows whose step the bounds forbid (the tip moves less than a
    third of the asked length across the face, to first order) are NaN. ``cache``: the samples' tip
    derivatives computed so far (:func:`_gradients`)."""
    T = samples.tensions[rows]
    J = _gradients(solver, samples, rows, cache)
    out = np.full(T.shape, np.nan)
    for k in range(rows.size):
        if not np.all(np.isfinite(J[k])):
            continue
        e = FACES[faces[k]].astype(float)
        dt = tension_step(J[k], T[k], bounds.lower, bounds.upper, length * e)
        if (J[k] @ dt) @ e >= length / 3.0:
            out[k] = np.clip(T[k] + dt, bounds.lower, bounds.upper)
    return out


def _solved(solver: _Solver, samples: RegionSamples, T: np.ndarray, parents: np.ndarray, warm: bool, stage: int,
            check: int, seed: int) -> tuple[RegionSamples, WarmStartCheck]:
    """Solve the search's tension vectors ``T``, each a step from the sample ``parents[k]``: continued from it
    where ``samples`` are continued samples (they have parents); otherwise warm from it (``warm``) when a
    random subset of ``check`` of them, solved both ways, agrees with the loading path (:func:`solve_plan`'s
    rule), else along the loading path."""
    t0 = time.perf_counter()
    parent = None
    if samples.parent is not None:
        got = solver.solve(T, start=samples.start_batch(parents, solver.loads, solver.model.name))
        report, parent = WarmStartCheck("continuation"), parents.astype(np.int64)
    elif not warm or check == 0:
        got, report = solver.solve(T), WarmStartCheck("loading path")
    else:
        assert samples.q is not None
        got, report = _checked(solver, T, samples.q[parents], check, seed, 0)
    if np.any(got.at_fold):  # steps that stopped at a fold reached nothing new
        keep = ~got.at_fold
        got, T = got.take(keep), T[keep]
        parent = None if parent is None else parent[keep]
    found = RegionSamples.of(T, np.full(T.shape[0], SEARCH, dtype=np.int8), got, 0,
                             np.full(T.shape[0], stage, dtype=np.int8), warm=WarmStartCheck("loading path"),
                             seconds=time.perf_counter() - t0)
    return replace(found, parent=parent, root=samples.root), report


def _stopping_at_folds(solver: _Solver, folds: str) -> _Solver:
    """``solver`` with its model's fold handling set to stop at a fold for ``folds="stop"`` (where the model's
    options have the choice), else ``solver`` itself."""
    if folds != "stop" or "fold" not in getattr(type(solver.options), "__dataclass_fields__", {}):
        return solver
    return replace(solver, options=replace(solver.options, fold="stop"))


def _voxels(samples: RegionSamples, mask: np.ndarray, voxel: float) -> int:
    return int(region_from_points(samples.tip_position[mask], voxel).occupied.sum()) if np.any(mask) else 0


def grow_region(solver: _Solver, samples: RegionSamples, bounds: TensionBounds, voxel: float, stage: int, *,
                settings: GrowthSettings | None = None, state: SearchState | None = None,
                on_round: Callable[[SearchRound], None] | None = None
                ) -> tuple[RegionSamples, list[SearchRound], SearchState, str]:
    """Grow the FSW and the realisable region of ``samples`` rows with ``stage <= stage`` (see the module).

    With ``settings.warm``, each round's steps start from the equilibria they step from, if a random subset of
    ``settings.check`` (``settings.seed``, the stage and the round) solved both ways agrees with the loading path
    as :func:`solve_plan` requires; otherwise they follow the loading path. ``state`` is what an earlier stage
    tried (updated in place; a new one when None); ``on_round`` sees each round.

    Returns the samples with the search's rows appended (source ``"search"``, this ``stage``), the rounds,
    the state (pass it to the next stage) and why the search stopped: ``"converged"`` (a round added less than
    ``settings.tol`` of the voxels), ``"no boundary left"``, ``"budget"`` (``settings.budget`` solves spent)
    or ``"rounds"`` (``settings.max_rounds``).
    """
    assert samples.stage is not None
    g = settings if settings is not None else GrowthSettings()
    state = state if state is not None else SearchState()
    if state.tried is None:
        state.tried = np.zeros((samples.source.size, FACES.shape[0], 2), dtype=bool)
    tried, counts = state.tried, state.counts
    rounds: list[SearchRound] = []
    spent, stop = 0, "rounds"
    stepper = _stopping_at_folds(solver, g.folds)
    active = samples.stage <= stage
    before = (_voxels(samples, samples.feasible & active, voxel), _voxels(samples, samples.realisable & active, voxel))
    for k in range(g.max_rounds):
        t0 = time.perf_counter()
        picks = [_faces(samples.tip_position, np.flatnonzero(m & active), tried[:, :, j], voxel, counts[j], g.tries)
                 for j, m in enumerate((samples.feasible, samples.realisable))]
        for j, (rows, faces) in enumerate(picks):
            tried[rows, faces, j] = True
        rows = np.concatenate([p[0] for p in picks])
        faces = np.concatenate([p[1] for p in picks])
        if rows.size == 0:
            stop = "no boundary left"
            break
        T = _steps(solver, samples, rows, faces, bounds, g.step * voxel, state.gradients)
        ok = np.all(np.isfinite(T), axis=1)
        parents, T = rows[ok][: max(0, g.budget - spent)], T[ok][: max(0, g.budget - spent)]
        new, report = _solved(stepper, samples, T, parents, g.warm, stage, g.check,
                              int(np.random.SeedSequence([g.seed, stage, k]).generate_state(1)[0]))
        spent += T.shape[0]
        samples = samples.joined(new)
        tried = np.concatenate([tried, np.zeros((new.source.size, *tried.shape[1:]), dtype=bool)])
        active = samples.stage <= stage
        now = (_voxels(samples, samples.feasible & active, voxel),
               _voxels(samples, samples.realisable & active, voxel))
        rounds.append(SearchRound(stage, k, int(rows.size), int(T.shape[0]), int(ok.sum()), now[0], now[1],
                                  time.perf_counter() - t0, report.mode, report.checked, report.agreed,
                                  int(T.shape[0] - new.source.size)))
        if on_round is not None:
            on_round(rounds[-1])
        grown = max((a - b) / max(b, 1) for a, b in zip(now, before, strict=True))
        before = now
        if spent >= g.budget:
            stop = "budget"
            break
        if grown < g.tol:
            stop = "converged"
            break
    state.tried = tried
    return samples, rounds, state, stop

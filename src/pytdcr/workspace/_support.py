"""The workspace's support function h(d) and its largest reach, by gradient search from the best samples.

For a unit direction d, ``h(d) = max d . tip`` over the feasible tension vectors: how far the workspace
reaches along d. The samples give a lower bound (the best sample's ``d . tip``); the reach search's local
optimiser (:func:`pytdcr.optimize.polish_reach`: L-BFGS-B with the exact gradient of the tip through the
implicit function theorem, every cost a cold solve along the loading path at a tight tolerance) climbs from
the samples with the largest ``d . tip``. The objective has many local optima (folds of the loading path,
friction regimes, the edge of convergence), and another direction's optimum is often a better start than any
sample: rounds of searches from the other directions' tips follow, until none beats a direction's h. The
largest reach ``max ||tip||`` (the paper's Eq. 29) is found by the same optimiser, from the samples farthest
from the base and from the tensions that attain h(d).

Which equilibrium a tip is: without the samples' states (:class:`SampleStates`) every cost is a cold solve
along the loading path, and every reported tip is the cold solve of the reported tensions. With them, each
search starts from its sample's equilibrium and solves every cost warm from the last (five times cheaper than
cold solves under a load), and only the end is solved by the region's own definition: along the loading path,
or continued from the sample's equilibrium along the straight segment of tensions (``parent``: the sample), so
that the reported tip is the equilibrium the robot reaches there, replayable from rest through its parent. Where
the warm search's end lies on another branch than the definition reaches (it crossed a fold on the way), the best
of the definition's equilibria at the end and at 3/4, 1/2 and 1/4 of the way to it is climbed by a short search
(:data:`STRICT_ITER` iterations) solving every cost by the definition. A search whose end, so solved, lies lower
than the sample does not count. Either way h(d) is never below the
best sample's ``d . tip``. Searches run in
parallel threads (the compiled solvers release the GIL); which searches run, and from where, does not depend
on the number of threads, and neither do the results.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import as_completed
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..optimize import ReachProblem, SearchFailed, polish_reach
from ..records import JsonDict, JsonObject
from ..results import StaticSolution
from ..runtime import default_threads, worker_pool
from ..statics import TIGHT_ATOL
from ..validate import SettingsError, check_count, unit_vectors

__all__ = ["DEFAULT_DIRECTIONS", "LargestReach", "SampleStates", "SupportFunction", "SupportSettings",
           "fibonacci_directions", "largest_reach", "support_function"]

#: directions of the support function by default (a Fibonacci sphere)
DEFAULT_DIRECTIONS = 200
#: a direction is searched again from another direction's tip when that tip beats its h by more than this [m]
EXCHANGE_TOL = 1e-7
#: rounding allowed in ``h[k] = max_j d_k . tip_j`` [m]
TAKE_TOL = 1e-12
#: a warm search's end and the samples' definition's solve of its tensions are one equilibrium within this [m]
SAME_END = 1e-6
#: two starts are distinct when they differ by more than this fraction of the bounds' span in some tension
_DISTINCT = 0.05
#: where a warm search ended on another branch: the fractions of the way from its start to its end at which the
#: definition's equilibria are tried, and the iterations of the climb from the best of them (every cost solved by
#: the definition: a continuation from the sample, several times a warm solve's cost). Measured on 60 directions
#: under the paper's load: 8.4 to 13.9 s against 37.2 s for a full search so solved, h lower by 0.07 mm on average
#: (at most 1.1 mm)
SEGMENT = (1.0, 0.75, 0.5, 0.25)
STRICT_ITER = 15


def fibonacci_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread near-uniformly over the sphere (the golden-angle spiral), deterministic.

    Row ``i`` has ``z = 1 - (2 i + 1) / n`` and azimuth ``i`` times the golden angle ``pi (3 - sqrt 5)``: each
    covers an equal area ``4 pi / n`` of the sphere, and none lies at a pole.

    Parameters
    ----------
    n : int
        Number of directions, >= 1.

    Returns
    -------
    ndarray, shape (n, 3)
        Unit vectors in the base frame.
    """
    n = check_count(n, "n", lo=1)
    i = np.arange(n, dtype=float)
    z = 1.0 - (2.0 * i + 1.0) / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return d / np.linalg.norm(d, axis=1)[:, None]


@dataclass(frozen=True, eq=False)
class SupportFunction:
    """The support function of a workspace on a set of directions, and the tensions that attain it.

    Attributes
    ----------
    directions : ndarray, shape (K, 3)
        Unit vectors in the base frame.
    h : ndarray, shape (K,)
        ``max d . tip`` found along each direction [m]; never below ``sample_h``.
    tensions : ndarray, shape (K, n_tendons)
        Actuator tensions that attain it [N].
    tip_position : ndarray, shape (K, 3)
        Their tips [m] (``h = tip_position . directions`` row by row).
    sample_h : ndarray, shape (K,)
        The best sample's ``d . tip`` [m]: the lower bound the search started from.
    from_sample : ndarray of bool, shape (K,)
        No search beat the best sample (they failed, or ended lower): tensions and tip are the sample's, as
        given (the cold solve of its tensions when the samples followed the loading path).
    exchanged : ndarray of bool, shape (K,)
        Another direction's tip beat the first search: the row is the search from it, or that tip itself.
    evaluations : ndarray of int, shape (K,)
        Model solves (most with the tip's gradient) of the searches on each direction that ended.
    starts : ndarray of int, shape (K,)
        Searches run on each direction (from samples, then from other directions' tips).
    seconds : float
        Wall time [s].
    settings : dict
        The problem's and the search's settings.
    stable : ndarray, shape (K,), or None
        1.0 where the equilibrium attaining h is known stable: the search ran with ``problem.stable_only``
        (unstable equilibria refused) from stable samples; NaN where that was not asked (untested).
    parent : ndarray of int, shape (K,), or None
        With the samples' states: the sample (index into the samples given) whose equilibrium each row's was
        continued from, or which the row is; -1 where the row was solved from rest. None without states.
    """

    directions: np.ndarray
    h: np.ndarray
    tensions: np.ndarray
    tip_position: np.ndarray
    sample_h: np.ndarray
    from_sample: np.ndarray
    exchanged: np.ndarray
    evaluations: np.ndarray
    starts: np.ndarray
    seconds: float
    settings: dict[str, Any] = field(default_factory=dict)
    stable: np.ndarray | None = None
    parent: np.ndarray | None = None

    @property
    def gain(self) -> np.ndarray:
        """What the search added to the best sample, ``h - sample_h`` [m], shape (K,)."""
        return self.h - self.sample_h

    def table(self) -> list[JsonDict]:
        """One row per direction: direction, h and the best sample's [m], the search's gain, tensions, tip."""
        return [{"direction": self.directions[k].tolist(), "h_m": float(self.h[k]),
                 "sample_h_m": float(self.sample_h[k]), "gain_m": float(self.gain[k]),
                 "from_sample": bool(self.from_sample[k]), "exchanged": bool(self.exchanged[k]),
                 "evaluations": int(self.evaluations[k]), "stable": self._stable(k),
                 "tensions": self.tensions[k].tolist(), "tip": self.tip_position[k].tolist()}
                for k in range(self.h.size)]

    def _stable(self, k: int) -> bool | None:
        """Row k's stability: True (known stable) or None (untested)."""
        return None if self.stable is None or not np.isfinite(self.stable[k]) else bool(self.stable[k])

    def to_dict(self) -> JsonDict:
        """JSON-ready form: the arrays as lists, and a summary."""
        gain = self.gain
        return {"directions": self.directions.tolist(), "h": self.h.tolist(), "tensions": self.tensions.tolist(),
                "tips": self.tip_position.tolist(), "sample_h": self.sample_h.tolist(),
                "from_sample": self.from_sample.tolist(), "exchanged": self.exchanged.tolist(),
                "evaluations": self.evaluations.tolist(), "stable": [self._stable(k) for k in range(self.h.size)],
                "starts": self.starts.tolist(), "seconds": self.seconds, "settings": self.settings,
                "parent": None if self.parent is None else self.parent.tolist(),
                "summary": {"directions": int(self.h.size), "improved": int(np.sum(gain > 0)),
                            "exchanged": int(np.sum(self.exchanged)),
                            "gain_median_m": float(np.median(gain)) if gain.size else 0.0,
                            "gain_max_m": float(np.max(gain)) if gain.size else 0.0,
                            "evaluations_median": float(np.median(self.evaluations)) if gain.size else 0.0,
                            "evaluations_total": int(np.sum(self.evaluations))}}

    @classmethod
    def from_dict(cls, d: JsonObject) -> SupportFunction:
        """The support function :meth:`to_dict` wrote (its ``summary`` is derived; ``stable``'s None read as NaN,
        untested; ``settings`` kept as the record it is; a time absent from a record with its times dropped reads
        0); KeyError naming a missing key."""
        h = np.asarray(d["h"], dtype=float).reshape(-1)
        k = h.size

        def rows(key: str) -> np.ndarray:
            a = np.asarray(d[key], dtype=float)
            return a.reshape(k, -1) if k else a.reshape(0, 0)

        stable = np.array([np.nan if x is None else float(x) for x in d["stable"]], dtype=float)
        parent = d["parent"]
        return cls(rows("directions"), h, rows("tensions"), rows("tips"), np.asarray(d["sample_h"], dtype=float),
                   np.asarray(d["from_sample"], dtype=bool), np.asarray(d["exchanged"], dtype=bool),
                   np.asarray(d["evaluations"], dtype=np.int64), np.asarray(d["starts"], dtype=np.int64),
                   d.get("seconds", 0.0), dict(d["settings"]), stable,
                   None if parent is None else np.asarray(parent, dtype=np.int64))


@dataclass(frozen=True, eq=False)
class LargestReach:
    """The largest reach ``max ||tip||`` found, and the tensions that attain it.

    Attributes
    ----------
    tensions : ndarray, shape (n_tendons,)
        Actuator tensions [N].
    tip_position : ndarray, shape (3,)
        [m].
    reach : float
        ``||tip||`` [m]; never below ``sample_reach``.
    sample_reach : float
        The farthest sample's reach [m].
    from_sample : bool
        No search beat the farthest sample: tensions and tip are that sample's.
    evaluations : int
        Model solves (most with the tip's gradient) of the searches that ended.
    starts : int
        Searches run (distinct starts: samples, and tensions of the support function).
    seconds : float
        Wall time [s].
    parent : int
        With the samples' states: the sample whose equilibrium the reported one was continued from, or which it
        is (-1: solved from rest).
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    reach: float
    sample_reach: float
    from_sample: bool
    evaluations: int
    starts: int
    seconds: float
    parent: int = -1

    def to_dict(self) -> JsonDict:
        """JSON-ready form."""
        return {"tensions": self.tensions.tolist(), "tip": self.tip_position.tolist(), "reach": self.reach,
                "sample_reach": self.sample_reach, "from_sample": self.from_sample,
                "evaluations": self.evaluations, "starts": self.starts, "seconds": self.seconds,
                "parent": self.parent}

    @classmethod
    def from_dict(cls, d: JsonObject) -> LargestReach:
        """The reach :meth:`to_dict` wrote (a time absent from a record with its times dropped reads 0); KeyError
        naming a missing key."""
        return cls(np.asarray(d["tensions"], dtype=float), np.asarray(d["tip"], dtype=float), d["reach"],
                   d["sample_reach"], d["from_sample"], d["evaluations"], d["starts"], d.get("seconds", 0.0),
                   d["parent"])


@dataclass(frozen=True)
class SupportSettings:
    """How :func:`support_function` searches each direction.

    Attributes
    ----------
    starts : int
        First searches per direction, from the samples, >= 1.
    max_iter, restarts : int
        L-BFGS-B iterations per search and per restart (>= 1), and restarts after a failed line search (>= 0)
        (:func:`pytdcr.optimize.polish_reach`).
    exchange_rounds : int
        Rounds of searches from other directions' tips, >= 0 (they end at the first round with nothing to do).
    """

    starts: int = 1
    max_iter: int = 30
    restarts: int = 1
    exchange_rounds: int = 4

    def __post_init__(self) -> None:
        for name, lo in (("starts", 1), ("max_iter", 1), ("restarts", 0), ("exchange_rounds", 0)):
            object.__setattr__(self, name, check_count(getattr(self, name), name, lo=lo))


@dataclass(frozen=True, eq=False)
class SampleStates:
    """The samples' equilibria, for searches that start from them (see the module).

    Attributes
    ----------
    q : ndarray, shape (M, ...)
        Each sample's state, in the order of the samples given (``RegionSamples.q`` rows).
    continued : bool
        The samples' equilibria were continued from parents: a search's end is continued from its sample's
        equilibrium. Otherwise it is solved from rest, along the loading path.
    """

    q: np.ndarray
    continued: bool


class _Start(NamedTuple):
    """Where a search starts: tensions [N], the sample it starts from (-1: none), the state its first solve
    starts from (None: cold) and the sample's equilibrium it is continued from (None: solved from rest)."""

    tensions: np.ndarray
    parent: int = -1
    q: np.ndarray | None = None
    anchor: StaticSolution | None = None


class _Best(NamedTuple):
    """The outcome on one objective: tensions, tip, value, whether the sample was kept, solves, searches; the
    sample it continues from or is (-1: none), its equilibrium where a search solved it, and the sample's
    equilibrium it was continued from."""

    tensions: np.ndarray
    tip_position: np.ndarray
    value: float
    from_sample: bool
    evaluations: int
    starts: int
    parent: int = -1
    state: StaticSolution | None = None
    anchor: StaticSolution | None = None

    def restart(self) -> _Start:
        """A search from this outcome: its tensions, from its equilibrium, continued from its sample's."""
        q = self.state.q if self.state is not None else (self.anchor.q if self.anchor is not None else None)
        return _Start(self.tensions, self.parent, q, self.anchor)


def _start(problem: ReachProblem, T: np.ndarray, states: SampleStates | None, k: int) -> _Start:
    """A search from sample ``k``: cold without states; else warm from the sample's equilibrium, tightened
    (Newton from its own state: the same equilibrium), which the search's end is continued from."""
    if states is None:
        return _Start(T[k], k)
    sol = problem.solve(T[k], states.q[k], atol=TIGHT_ATOL)
    if not sol.converged or (problem.stable_only and not sol.stable):
        return _Start(T[k], k, states.q[k], None)
    return _Start(T[k], k, sol.q, sol)


def _definition(problem: ReachProblem, states: SampleStates, start: _Start) -> ReachProblem | None:
    """``problem`` solving as the samples were: from rest, or continued from the search's sample's equilibrium
    (None when it has none to continue)."""
    if not states.continued:
        return problem
    return None if start.anchor is None else problem.continued_from(start.anchor)


def _check_samples(problem: ReachProblem, tensions: np.ndarray,
                   tip_position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples as float arrays (M, n_tendons) [N] and (M, 3) [m]: finite, at least one (ValueError)."""
    t = np.asarray(tensions, dtype=float)
    p = np.asarray(tip_position, dtype=float)
    nt = problem.robot.n_tendons
    if t.ndim != 2 or t.shape[1] != nt or p.shape != (t.shape[0], 3):
        raise ValueError(f"samples: tensions must have shape (M, {nt}) and tip positions (M, 3), got {t.shape} and "
                         f"{p.shape}")
    if t.shape[0] == 0:
        raise ValueError("samples: at least one feasible sample is needed")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
        raise SettingsError("samples", " must be finite: pass the feasible ones (samples.tensions[samples.feasible], "
                         "samples.tip_position[samples.feasible])")
    return t, p


def _check_directions(directions: np.ndarray | None) -> np.ndarray:
    """Unit directions (K, 3), K >= 1: the default Fibonacci sphere, or the rows given, normalised
    (:func:`~pytdcr.validate.unit_vectors`: ordinary rows as ``d / np.linalg.norm(d, axis=1)`` always was, any
    scale a direction, all-subnormal rows refused naming ``directions``)."""
    if directions is None:
        return fibonacci_directions(DEFAULT_DIRECTIONS)
    d = np.asarray(directions, dtype=float)
    d = d.reshape(1, 3) if d.shape == (3,) else d
    if d.ndim != 2 or d.shape[1] != 3 or d.shape[0] == 0:
        raise SettingsError("directions", f" must have shape (K, 3), K >= 1, got {np.shape(directions)}")
    if not (np.all(np.isfinite(d)) and np.all(np.any(d, axis=1))):
        raise SettingsError("directions", " must be finite and nonzero")
    return unit_vectors(d, "directions")


def _dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (K, 3) arrays, in one fixed order (equal rows give equal values)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _top_distinct(values: np.ndarray, tensions: np.ndarray, count: int, scale: np.ndarray) -> list[int]:
    """Indices of the ``count`` largest ``values`` whose tensions are pairwise distinct (they differ by more
    than 5 % of the bounds' span in some tension), largest first; ties go to the lower index."""
    picked: list[int] = []
    for k in np.argsort(-values, kind="stable"):
        if len(picked) >= count:
            break
        if all(np.max(np.abs(tensions[k] - tensions[j]) / scale) > _DISTINCT for j in picked):
            picked.append(int(k))
    return picked


def _polish(problem: ReachProblem, st: _Start, max_iter: int, restarts: int,
            states: SampleStates | None) -> tuple[np.ndarray, np.ndarray, StaticSolution | None, int] | None:
    """One search from ``st``: its tensions, tip, reported equilibrium (None without states) and solves; None
    when it failed. With ``states`` it runs warm (each cost from the last equilibrium) and its end is solved by
    the samples' definition; where that equilibrium is not the warm search's (another branch), the search runs
    again with every cost so solved."""
    if states is None:
        r = polish_reach(problem, st.tensions, max_iter=max_iter, restarts=restarts)
        return r.tensions, r.tip_position, None, r.evaluations
    strict = _definition(problem, states, st)
    if strict is None:
        return None
    r = polish_reach(problem, st.tensions, q0=st.q, warm=st.q is not None, max_iter=max_iter, restarts=restarts)
    end = strict.solve(r.tensions, atol=TIGHT_ATOL)
    if end.converged and np.linalg.norm(end.tip_position - r.tip_position) <= SAME_END:
        return _held(problem, r.tensions, end, r.evaluations + 1)
    t, end, n = _across_a_fold(problem, strict, st.tensions, r.tensions, end)
    return _held(problem, t, end, r.evaluations + 1 + n)


def _held(problem: ReachProblem, t: np.ndarray, end: StaticSolution | None,
          n: int) -> tuple[np.ndarray, np.ndarray, StaticSolution, int] | None:
    """``_polish``'s outcome for the tensions ``t`` [N] and their equilibrium ``end`` by the definition: None
    where it is missing, did not converge or (``problem.stable_only``) is unstable."""
    if end is None or not end.converged or (problem.stable_only and not end.stable):
        return None
    return t, end.tip_position, end, n


def _across_a_fold(problem: ReachProblem, strict: ReachProblem, start: np.ndarray, warm_end: np.ndarray,
                   end: StaticSolution) -> tuple[np.ndarray, StaticSolution | None, int]:
    """A warm search from ``start`` ended at ``warm_end`` (tensions [N]) on another branch than ``strict`` (the
    definition) reaches there (``end``): the best of ``strict``'s equilibria at :data:`SEGMENT` of the way, then
    a climb of :data:`STRICT_ITER` iterations from it on ``strict``. Returns the tensions, their equilibrium by the
    definition (None when none held) and the solves spent."""

    def held(sol: StaticSolution) -> bool:
        return sol.converged and (not problem.stable_only or bool(sol.stable))

    best_t, best, n = start, None, 0
    for frac in SEGMENT:
        t = start + frac * (warm_end - start)
        sol = end if frac == 1.0 else strict.solve(t, atol=TIGHT_ATOL)
        n += frac != 1.0
        if held(sol) and (best is None or problem.value(sol.tip_position) > problem.value(best.tip_position)):
            best_t, best = t, sol
    try:
        r = polish_reach(strict, best_t, max_iter=STRICT_ITER, restarts=0)
    except SearchFailed:
        return best_t, best, n
    sol = strict.solve(r.tensions, atol=TIGHT_ATOL)
    n += r.evaluations + 1
    if held(sol) and (best is None or problem.value(sol.tip_position) > problem.value(best.tip_position)):
        best_t, best = r.tensions, sol
    return best_t, best, n


def _climb(problem: ReachProblem, starts: list[_Start], sample: tuple[_Start, np.ndarray], max_iter: int,
           restarts: int = 3, states: SampleStates | None = None) -> _Best:
    """Polish every start on ``problem``'s objective and keep the best; the ``sample`` (its start, its tip) is
    kept when no search ends above it. With ``states``, each search runs warm and its end is the samples'
    definition's equilibrium (:func:`_polish`)."""
    first, tip0 = sample
    best = _Best(first.tensions, tip0, float(problem.value(tip0)), True, 0, len(starts), first.parent,
                 None, first.anchor)
    evaluations = 0
    for st in starts:
        try:
            got = _polish(problem, st, max_iter, restarts, states)
        except SearchFailed:
            continue
        if got is None:
            continue
        t, tip, end, n = got
        evaluations += n
        value = float(problem.value(tip))
        if value > best.value:
            best = _Best(t, tip, value, False, 0, len(starts), st.parent, end, st.anchor)
    return best._replace(evaluations=evaluations)


def _run(jobs: list[Callable[[], _Best]], threads: int | None,
         progress: Callable[[int], None] | None) -> list[_Best]:
    """Run the jobs in parallel threads, in any order; the results in the jobs' order."""
    workers = min(len(jobs), default_threads() if threads is None else check_count(threads, "threads", lo=1))
    out: list[_Best | None] = [None] * len(jobs)
    with worker_pool(workers) as submit:
        futures = {submit(job): k for k, job in enumerate(jobs)}
        for fut in as_completed(futures):
            out[futures[fut]] = fut.result()
            if progress is not None:
                progress(1)
    return [r for r in out if r is not None]


def _exchange(problem: ReachProblem, D: np.ndarray, found: list[_Best], max_iter: int, restarts: int,
              threads: int | None, search: bool = True, states: SampleStates | None = None) -> list[int]:
    """One exchange round, in place on ``found``: each direction whose h another direction's tip beats (by more
    than :data:`EXCHANGE_TOL`) is searched again from that tip's tensions, keeping at least that tip; without
    ``search``, each that a tip beats by more than :data:`TAKE_TOL` takes it as it is (no solve). Returns the
    directions changed."""
    tips = np.array([b.tip_position for b in found])
    h = np.array([b.value for b in found])
    values = tips @ D.T  # values[j, k] = d_k . tip_j
    donor = np.argmax(values, axis=0)
    tol = EXCHANGE_TOL if search else TAKE_TOL
    todo = [k for k in range(D.shape[0]) if values[donor[k], k] > h[k] + tol]

    def job(k: int) -> Callable[[], _Best]:
        j = int(donor[k])
        if not search:
            return lambda: found[j]._replace(value=float(values[j, k]), from_sample=False, evaluations=0, starts=0)
        start = found[j].restart()
        return lambda: _climb(problem.with_direction(D[k]), [start], (start, found[j].tip_position), max_iter,
                              restarts, states)

    again = _run([job(k) for k in todo], threads if search else 1, None)
    for k, b in zip(todo, again, strict=True):
        found[k] = b._replace(from_sample=False, evaluations=found[k].evaluations + b.evaluations,
                              starts=found[k].starts + b.starts)
    return todo


def support_function(problem: ReachProblem, samples_tensions: np.ndarray, samples_tip_position: np.ndarray,
                     directions: np.ndarray | None = None, *, settings: SupportSettings | None = None,
                     threads: int | None = None, progress: Callable[[int], None] | None = None,
                     states: SampleStates | None = None) -> SupportFunction:
    """The support function ``h(d) = max d . tip`` over the feasible tensions, along each direction.

    First, for each direction d, the ``settings.starts`` samples with the largest ``d . tip`` (with distinct
    tensions) are polished by :func:`pytdcr.optimize.polish_reach` on ``problem.with_direction(d)``; the best
    result is kept, or the best sample itself when no search ends above it (``from_sample``). The objective has
    many local optima, and another direction's optimum is often a better start than any sample: in up to
    ``settings.exchange_rounds`` rounds, every direction whose h another direction's tip beats is searched again
    from that tip's tensions (``exchanged``). A last pass takes, without a solve, any tip that still beats a
    direction's h, so that h is the support function of the reported tips themselves:
    ``h[k] = max_j directions[k] . tip_position[j]`` (to 1e-12 m). Without ``states`` every reported tip is the
    cold solve of its tensions (or a sample's, as given); with them, the equilibrium the samples' definition
    gives there (see the module), and ``parent`` names the sample it continues. With ``problem.stable_only``
    the search refuses unstable equilibria (pass stable samples).

    Parameters
    ----------
    problem : ReachProblem
        Robot, loads, bounds, model (its own direction is ignored).
    samples_tensions : ndarray, shape (M, n_tendons)
        Feasible samples' actuator tensions [N] (e.g. ``samples.tensions[samples.feasible]``).
    samples_tip_position : ndarray, shape (M, 3)
        Their tips [m] (``samples.tip_position[samples.feasible]``).
    directions : ndarray, shape (K, 3), optional
        Directions (normalised here); default :func:`fibonacci_directions` (200).
    settings : SupportSettings, optional
        The searches: starts, iterations, restarts, exchange rounds (default :class:`SupportSettings`).
    threads : int, optional
        Searches run at once (default: the cores this process may use); the results do not depend on it.
    progress : callable, optional
        Called as ``progress(1)`` after each direction's first search (an increment, as for a tqdm bar); the
        exchange rounds that follow are not counted.
    states : SampleStates, optional
        The samples' equilibria: searches start warm from them (see the module).

    Returns
    -------
    SupportFunction
    """
    t0 = time.perf_counter()
    T, P = _check_samples(problem, samples_tensions, samples_tip_position)
    D = _check_directions(directions)
    cfg = settings if settings is not None else SupportSettings()
    starts, max_iter, restarts, exchange_rounds = cfg.starts, cfg.max_iter, cfg.restarts, cfg.exchange_rounds
    scale = problem.bounds.span

    def job(d: np.ndarray) -> Callable[[], _Best]:
        def run() -> _Best:
            pr = problem.with_direction(d)
            picked = [_start(pr, T, states, k) for k in _top_distinct(P @ d, T, starts, scale)]
            return _climb(pr, picked, (picked[0], P[picked[0].parent]), max_iter, restarts, states)
        return run

    found = _run([job(d) for d in D], threads, progress)
    exchanged = np.zeros(D.shape[0], dtype=bool)
    log = [{"searches": D.shape[0], "evaluations": sum(b.evaluations for b in found),
            "seconds": time.perf_counter() - t0}]
    while len(log) <= exchange_rounds:
        t1, before = time.perf_counter(), sum(b.evaluations for b in found)
        todo = _exchange(problem, D, found, max_iter, restarts, threads, states=states)
        if not todo:
            break
        exchanged[todo] = True
        log.append({"searches": len(todo), "evaluations": sum(b.evaluations for b in found) - before,
                    "seconds": time.perf_counter() - t1})
    taken = _exchange(problem, D, found, max_iter, restarts, threads, search=False)
    exchanged[taken] = True
    record = {**problem.describe(), "objective": "support", "direction": None, "starts": starts,
              "equilibria": "cold" if states is None else ("continued" if states.continued else "loading path"),
              "max_iter": max_iter, "restarts": restarts, "exchange_rounds": exchange_rounds, "rounds": log,
              "taken_without_search": len(taken), "samples": int(T.shape[0])}
    tips = np.array([b.tip_position for b in found])
    best = np.argmax(P @ D.T, axis=0)
    return SupportFunction(
        directions=D, h=_dots(tips, D), tensions=np.array([b.tensions for b in found]), tip_position=tips,
        sample_h=_dots(P[best], D),
        from_sample=np.array([b.from_sample for b in found], dtype=bool), exchanged=exchanged,
        evaluations=np.array([b.evaluations for b in found], dtype=int),
        starts=np.array([b.starts for b in found], dtype=int), seconds=time.perf_counter() - t0, settings=record,
        stable=np.full(D.shape[0], 1.0 if problem.stable_only else np.nan),
        parent=None if states is None else np.array([b.parent for b in found], dtype=np.int64))


def largest_reach(problem: ReachProblem, samples_tensions: np.ndarray, samples_tip_position: np.ndarray,
                  support: SupportFunction | None = None, *, starts: int = 4, max_iter: int = 200,
                  threads: int | None = None, states: SampleStates | None = None) -> LargestReach:
    """The largest reach ``max ||tip||`` over the feasible tensions (the paper's Eq. 29), by the same search.

    Polished by :func:`pytdcr.optimize.polish_reach` on ``problem.with_direction(None)`` from the ``starts``
    samples farthest from the base (distinct tensions) and, given ``support``, from the ``starts`` tensions of
    the support function whose tips are farthest from the base (its far tips lie on the workspace's boundary).
    The searches run in parallel threads; the farthest sample is kept when none ends beyond it.

    Parameters
    ----------
    problem : ReachProblem
    samples_tensions : ndarray, shape (M, n_tendons)
        Feasible samples' actuator tensions [N].
    samples_tip_position : ndarray, shape (M, 3)
        Their tips [m].
    support : SupportFunction, optional
        Of the same problem: more starts.
    starts : int
        Starts taken from the samples, and as many from ``support``, >= 1.
    max_iter : int
        L-BFGS-B iterations per search (and per restart).
    threads : int, optional
        Searches run at once (default: the cores); the result does not depend on it.
    states : SampleStates, optional
        The samples' equilibria: searches start warm from them, as :func:`support_function`'s (pass the
        support function computed with the same states).

    Returns
    -------
    LargestReach
    """
    t0 = time.perf_counter()
    T, P = _check_samples(problem, samples_tensions, samples_tip_position)
    starts = check_count(starts, "starts", lo=1)
    max_iter = check_count(max_iter, "max_iter", lo=1)
    reach_problem = problem.with_direction(None)
    scale = problem.bounds.span
    reach = np.linalg.norm(P, axis=1)
    first = _top_distinct(reach, T, starts, scale)
    begin = [_start(reach_problem, T, states, k) for k in first]
    if support is not None:
        far = np.linalg.norm(support.tip_position, axis=1)
        for k in _top_distinct(far, support.tensions, starts, scale):
            t = support.tensions[k]
            if any(np.max(np.abs(t - b.tensions) / scale) <= _DISTINCT for b in begin):
                continue
            parent = -1 if support.parent is None else int(support.parent[k])
            anchor = _start(reach_problem, T, states, parent) if states is not None and parent >= 0 else None
            begin.append(_Start(t, parent, None if anchor is None else anchor.q,
                                None if anchor is None else anchor.anchor))
    sample = (begin[0], P[first[0]])
    jobs = [lambda st=st: _climb(reach_problem, [st], sample, max_iter, states=states) for st in begin]
    found = _run(jobs, threads, None)
    best = max(found, key=lambda b: (b.value, not b.from_sample))
    return LargestReach(tensions=np.array(best.tensions), tip_position=np.array(best.tip_position),
                        reach=float(best.value), sample_reach=float(reach[first[0]]), from_sample=best.from_sample,
                        evaluations=int(sum(b.evaluations for b in found)), starts=len(begin),
                        seconds=time.perf_counter() - t0, parent=int(best.parent) if states is not None else -1)

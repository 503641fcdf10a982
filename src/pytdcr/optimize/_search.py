"""How it is solved and when to stop: a memetic GA (pymoo), a gradient polish, a termination rule.

The pieces follow pymoo's shape: the problem (:class:`ReachProblem`, what is
solved), the algorithm (:class:`MemeticGA`, how) and the termination
(:class:`Termination`, when to stop) are separate objects joined by one call,
:func:`maximize_reach`, which returns one :class:`ReachResult`.

The GA is pymoo's (SBX crossover, polynomial mutation, tournament selection),
driven by ask/tell with each population solved as one parallel batch. A
tension vector whose solve does not converge is infeasible (a constraint
violation): pymoo ranks every feasible individual above it, so it can never
be the optimum; such evaluations are counted. Memetic: whenever a generation
produces a new leader, a short gradient search (:func:`polish_reach`) replaces
it by its local optimum (Lamarckian learning), so the GA explores basins and
the local search settles them. At the end, a multi-start L-BFGS-B polish whose
gradient is the implicit-function-theorem one (exact for the PCC model).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.population import Population
from pymoo.core.problem import Problem
from scipy.optimize import minimize as sp_minimize
from scipy.spatial import cKDTree

from ..limits import check_memory
from ..records import JsonDict
from ..runtime import default_threads, single_threaded_blas, worker_pool
from ..statics import TIGHT_ATOL, check_resources
from ..validate import SettingsError
from ._problem import INFEASIBLE_COST, ReachProblem
from ._result import Optimum, ReachResult, SearchFailed

__all__ = ["MemeticGA", "Termination", "maximize_reach", "polish_reach"]

#: distinct starts differ by more than this fraction of the bounds' span in some tension
_DISTINCT = 0.05


def _check_int(name: str, value: object, lowest: int) -> None:
    if isinstance(value, bool) or int(value) != value or value < lowest:
        raise ValueError(f"{name} = {value!r}: must be an integer >= {lowest}")


@dataclass(frozen=True)
class Termination:
    """When the GA stops: the best cost improved by less than ``tol`` over ``window`` generations, or ``max_gen``.

    Parameters
    ----------
    tol : float
        [1/m] for the paper's cost 1/reach, [m] along a direction.
    window : int
    max_gen : int
    """

    tol: float = 1e-6
    window: int = 5
    max_gen: int = 100

    def __post_init__(self) -> None:
        if not (np.isfinite(self.tol) and self.tol > 0):
            raise SettingsError("tol", f" must be finite and > 0, got {self.tol}")
        _check_int("window", self.window, 1)
        _check_int("max_gen", self.max_gen, 1)

    def reason(self, best: Sequence[float]) -> str | None:
        """``"tolerance"``, ``"generation cap"`` or None (go on), given the best cost of each generation so far."""
        g = len(best)
        if g > self.window and np.isfinite(best[-1]) and best[g - 1 - self.window] - best[-1] < self.tol:
            return "tolerance"
        return "generation cap" if g >= self.max_gen else None


@dataclass(frozen=True)
class MemeticGA:
    """The GA of the paper's Eq. 29 with a gradient search on each new leader.

    Parameters
    ----------
    pop_size : int
        Population (the paper tried 50, 100 and 200).
    local_search : bool
        Memetic (default): each new leader is replaced by its local optimum
        (``ls_max_iter`` L-BFGS-B iterations); the first generation searches
        from its ``ls_starts`` best distinct individuals. False: the paper's plain GA.
    polish : bool
        Refine the GA's best at the end, from it and up to ``n_polish - 1``
        other distinct individuals of the final population (keep the best),
        plus ``extra_starts`` (clipped into the bounds).
    warm_start : bool
        Start each evaluation from the equilibrium of the nearest tension
        vector already solved (faster). Off by default: where a tension vector
        has several equilibria this makes the cost depend on the search
        history; cold evaluations (the solver's loading path) make it a
        function of the tensions alone.
    """

    pop_size: int = 50
    local_search: bool = True
    ls_max_iter: int = 100
    ls_starts: int = 1
    polish: bool = True
    n_polish: int = 3
    warm_start: bool = False
    extra_starts: tuple[np.ndarray, ...] = ()

    def __post_init__(self) -> None:
        _check_int("pop_size", self.pop_size, 2)
        _check_int("ls_max_iter", self.ls_max_iter, 1)
        _check_int("ls_starts", self.ls_starts, 1)
        _check_int("n_polish", self.n_polish, 1)

    def describe(self) -> JsonDict:
        """JSON-ready settings."""
        d = asdict(self)
        d["extra_starts"] = [np.asarray(x).tolist() for x in self.extra_starts]
        return d


# ------------------------------------------------------------------------------------------ the local search
def polish_reach(problem: ReachProblem, tensions: np.ndarray, *, q0: np.ndarray | None = None, warm: bool = False,
                 max_iter: int = 200, ftol: float = 1e-12, gtol: float = 1e-8, restarts: int = 3) -> ReachResult:
    """Refine a tension vector by L-BFGS-B on the problem's cost, with its gradient.

    ``ftol`` and ``gtol`` are L-BFGS-B's stopping tolerances (relative change
    of the cost, and projected gradient); with the exact gradient of the PCC
    model tighter ones only creep along kinks. The cost has
    kinks (friction regimes, folds of the loading path) where L-BFGS-B's line
    search can give up; it is then restarted from its best point, up to
    ``restarts`` times, while that still lowers the cost. Every cost is a
    static solve at a tight tolerance, cold (from the straight robot) unless
    ``warm``, in which case it starts from ``q0`` and then the last equilibrium.
    The answer is the best point evaluated (each restart from it, and a warm
    final solve from its equilibrium), not L-BFGS-B's last iterate: warm, the
    cost is not a function of the tensions alone (a solve may change branch).

    Raises
    ------
    SearchFailed
        When the final tension vector's solve does not converge.
    """
    t0 = time.perf_counter()
    free = problem.free
    start = problem.bounds.clip(tensions)
    state: dict[str, Any] = {"q": None if q0 is None else np.asarray(q0, dtype=float), "n": 0,
                             "best": (np.inf, None, None)}
    lo, hi = problem.bounds.lower[free], problem.bounds.upper[free]

    def full(x: np.ndarray) -> np.ndarray:
        t = start.copy()
        t[free] = np.clip(x, lo, hi)
        return t

    def fun(x: np.ndarray) -> tuple[float, np.ndarray]:
        cost, grad, sol = problem.cost_and_gradient(full(x), state["q"] if warm else None)
        state["n"] += 1
        if grad is None:
            return INFEASIBLE_COST, np.zeros_like(x)
        state["q"] = sol.q
        if cost < state["best"][0]:  # the best point evaluated, with its equilibrium
            state["best"] = (cost, np.array(x, dtype=float), sol.q)
        return cost, grad[free]

    x, best = start[free], fun(start[free])[0]
    q_best = state["q"]
    c0, message, success = best, "no free tension", True
    if np.any(free):
        for _ in range(1 + max(0, int(restarts))):
            res = sp_minimize(fun, x, jac=True, method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True)),
                              options={"maxiter": max_iter, "ftol": ftol, "gtol": gtol})
            # the best point evaluated, not L-BFGS-B's last iterate: with warm solves the cost is not a
            # function of the tensions alone (a solve may change branch), and the last iterate may lie below it
            gain = best - float(state["best"][0])
            if gain > 0:
                best, x, q_best = state["best"]
            state["q"] = q_best
            if res.success or gain <= 1e-12:
                break
        message, success = str(res.message), bool(res.success)
    t = full(x)
    final = problem.solve(t, q_best if warm else None, atol=TIGHT_ATOL)
    state["n"] += 1
    if not final.converged:  # pragma: no cover - the optimiser only accepts converged points
        raise SearchFailed("polish ended on a tension vector whose solve does not converge")
    tip = final.tip_position
    cost = float(problem.cost(tip))
    if problem.stable_only and not final.stable:  # pragma: no cover - the optimiser only accepts stable points
        raise SearchFailed("polish ended on an unstable equilibrium")
    begin = Optimum(start, np.full(3, np.nan), float("nan"), c0)
    return ReachResult(tensions=t, tip_position=tip, reach=final.reach, cost=cost, value=float(problem.value(tip)),
                       stable=final.stable, converged=success, stop_reason=message, generations=0,
                       evaluations=state["n"], nonconverged=0, seconds=time.perf_counter() - t0, seed=None,
                       history={}, ga=begin, polish_gain=c0 - cost, polish_evaluations=state["n"],
                       polish_message=message, settings=problem.describe())


# ------------------------------------------------------------------------------------------ the GA
@dataclass
class _Stats:
    evals: int = 0
    nonconv: int = 0
    rejected_unstable: int = 0  # converged but refused as unstable (stable_only)
    ls: int = 0
    ls_runs: int = 0
    history: dict[str, list] = field(default_factory=lambda: {
        "best": [], "mean": [], "evaluations": [], "nonconverged": [], "local_search_evaluations": []})


class _Evaluator(Problem):
    """pymoo's view of a :class:`ReachProblem`: the free tensions in, cost and feasibility out."""

    def __init__(self, problem: ReachProblem, warm_start: bool, stats: _Stats) -> None:
        free = problem.free
        super().__init__(n_var=int(free.sum()), n_obj=1, n_ieq_constr=1, xl=problem.bounds.lower[free],
                         xu=problem.bounds.upper[free])
        self.reach = problem
        self.warm_start = warm_start
        self.stats = stats
        self.archive_T: list[np.ndarray] = []
        self.archive_q: list[np.ndarray] = []

    def _evaluate(self, x: np.ndarray, out: dict, *args: object, **kwargs: object) -> None:
        T = self.reach.full(x)
        q0 = None
        if self.warm_start and self.archive_T:
            # warm start from the nearest tension vector already solved (offspring lie near parents)
            scale = self.reach.bounds.span
            nearest = cKDTree(np.vstack(self.archive_T) / scale).query(T / scale)[1]
            q0 = np.vstack(self.archive_q)[nearest]
        ev = self.reach.evaluate(T, q0)
        conv = ev.batch.converged
        self.archive_T.append(T[conv])
        self.archive_q.append(ev.batch.q[conv])
        self.stats.evals += x.shape[0]
        self.stats.nonconv += int((~conv).sum())
        self.stats.rejected_unstable += int((conv & ~ev.feasible).sum())
        out["F"] = ev.cost[:, None]
        out["G"] = np.where(ev.feasible, -1.0, 1.0)[:, None]


def _distinct(x: np.ndarray, picked: Sequence[np.ndarray], scale: np.ndarray) -> bool:
    return all(np.max(np.abs((x - y) / scale)) > _DISTINCT for y in picked)


class _GARun:
    """One run of the memetic GA: pymoo's GA stepped by ask/tell, with the local search between ask and tell."""

    def __init__(self, problem: ReachProblem, algo: MemeticGA, termination: Termination, seed: int,
                 on_generation: Callable[[int, float, float], None] | None) -> None:
        self.problem = problem
        self.algo = algo
        self.termination = termination
        self.on_generation = on_generation
        self.stats = _Stats()
        self.evaluator = _Evaluator(problem, algo.warm_start, self.stats)
        self.ga = GA(pop_size=int(algo.pop_size), eliminate_duplicates=True)
        self.ga.setup(self.evaluator, termination=("n_gen", int(termination.max_gen)), seed=int(seed), verbose=False)

    def learn(self, infills: Population) -> Population:
        """Lamarckian step: a new leader (better than the incumbent) is replaced by its local optimum.

        In the first generation the best ``ls_starts`` distinct individuals are searched.
        """
        best_hist = self.stats.history["best"]
        F = infills.get("F")[:, 0]
        feas = infills.get("feas")
        incumbent = best_hist[-1] if best_hist else np.inf
        tol = self.termination.tol
        order = [int(k) for k in np.argsort(F) if feas[k] and F[k] < incumbent - tol]
        scale = self.problem.bounds.span[self.problem.free]
        picked: list[np.ndarray] = []
        for k in order:
            if len(picked) >= (self.algo.ls_starts if not best_hist else 1):
                break
            x = infills[k].get("X")
            if _distinct(x, picked, scale):
                picked.append(x)
        found = []
        for x in picked:
            try:
                pr = polish_reach(self.problem, self.problem.full(x), max_iter=self.algo.ls_max_iter)
            except SearchFailed:
                continue
            self.stats.ls += pr.evaluations
            self.stats.ls_runs += 1
            found.append(pr.tensions[self.problem.free])
        if not found:
            return infills
        extra = Population.new("X", np.array(found))
        self.ga.evaluator.eval(self.evaluator, extra, algorithm=self.ga)
        return Population.merge(infills, extra)

    def generation(self) -> None:
        """One generation: ask, evaluate, learn, tell, record."""
        before = self.stats.nonconv
        infills = self.ga.infill()
        self.ga.evaluator.eval(self.evaluator, infills, algorithm=self.ga)
        if self.algo.local_search:
            infills = self.learn(infills)
        self.ga.advance(infills=infills)
        F = self.ga.pop.get("F")[:, 0]
        feas = self.ga.pop.get("feas")
        opt_f = self.ga.opt.get("F")[:, 0]
        opt_feas = self.ga.opt.get("feas")
        best = float(opt_f[opt_feas].min()) if np.any(opt_feas) else float("inf")
        mean = float(F[feas].mean()) if np.any(feas) else float("inf")
        h = self.stats.history
        h["best"].append(best)
        h["mean"].append(mean)
        h["evaluations"].append(self.stats.evals + self.stats.ls)
        h["nonconverged"].append(self.stats.nonconv - before)
        h["local_search_evaluations"].append(self.stats.ls)
        if self.on_generation is not None:
            self.on_generation(len(h["best"]), best, mean)

    def run(self) -> str:
        """Generations until the termination rule; returns its reason."""
        while True:
            self.generation()
            reason = self.termination.reason(self.stats.history["best"])
            if reason is not None:
                return reason

    def best(self) -> tuple[Optimum, np.ndarray]:
        """The GA's best, re-solved cold (independent of any warm-start history), and its unknowns."""
        opt = self.ga.opt[0]
        if not opt.get("feas"):
            what = "converged and stable" if self.problem.stable_only else "converged"
            raise SearchFailed(f"no tension vector within the bounds gave a {what} static solve "
                               f"({self.stats.evals} tried)")
        T = self.problem.full(opt.get("X"))
        sol = self.problem.solve(T)
        if not sol.converged:
            raise SearchFailed("the GA's best does not converge when solved cold from the straight robot")
        return Optimum(T, sol.tip_position, sol.reach, float(self.problem.cost(sol.tip_position)), sol.stable), sol.q

    def polish_starts(self, best: np.ndarray) -> list[np.ndarray]:
        """The GA's best, the best few distinct feasible individuals of the last population, the extra starts."""
        pop = self.ga.pop
        scale = self.problem.bounds.span
        starts: list[np.ndarray] = [best]
        for k in np.argsort(pop.get("F")[:, 0]):
            if len(starts) >= self.algo.n_polish:
                break
            if pop[k].get("feas"):
                cand = self.problem.full(pop[k].get("X"))
                if _distinct(cand, starts, scale):
                    starts.append(cand)
        return starts + [self.problem.bounds.clip(x) for x in self.algo.extra_starts]


def _polish_many(problem: ReachProblem, starts: list[np.ndarray], q0: np.ndarray,
                 warm: bool) -> ReachResult | None:
    """Polish every start in parallel threads (the compiled solvers release the GIL); the best."""

    def one(k: int) -> ReachResult | None:
        try:
            return polish_reach(problem, starts[k], q0=q0 if k == 0 else None, warm=warm)
        except SearchFailed:
            return None

    # BLAS on one thread for the whole pool: the gradients' LAPACK calls run outside the solvers' own limit, and
    # whether another thread's solve held that limit at the time changed their last bits from run to run
    with single_threaded_blas(), worker_pool(min(len(starts), default_threads())) as submit:
        futures = [submit(one, k) for k in range(len(starts))]
        results = [r for r in (f.result() for f in futures) if r is not None]
    if not results:
        return None
    best = min(results, key=lambda r: r.cost)
    evaluations = sum(r.evaluations for r in results)
    return ReachResult(**{**best.__dict__, "evaluations": evaluations, "polish_evaluations": evaluations,
                          "polish_message": f"best of {len(results)} starts: {best.polish_message}"})


def _check_population(problem: ReachProblem, algo: MemeticGA) -> None:
    """Refuse a population whose individuals (pymoo keeps parents and offspring, about 3 kB each with their
    solves' unknowns) and solves would not fit in the memory budget."""
    robot = problem.robot
    res = check_resources(problem.model, robot, problem.options, default_threads())
    per = 3000.0 + 16.0 * ((res.unknowns if res else 3 * robot.n_disks) + robot.n_tendons)
    check_memory(f"a GA population of {algo.pop_size:,} on robot '{robot.name}'",
                 2 * algo.pop_size * per + default_threads() * (res.bytes if res else 0.0))


def maximize_reach(problem: ReachProblem, algorithm: MemeticGA | None = None, termination: Termination | None = None,
                   *, seed: int = 0, on_generation: Callable[[int, float, float], None] | None = None) -> ReachResult:
    """Maximise the reach (the paper's Eq. 29), or the reach along a direction, over the tensions.

    Parameters
    ----------
    problem : ReachProblem
        What is solved (:meth:`ReachProblem.create`).
    algorithm : MemeticGA, optional
        How (default: population 50, memetic, with the final polish).
    termination : Termination, optional
        When to stop (default: 1e-6 over 5 generations, at most 100).
    seed : int
        Seed of the GA: same seed, same result.
    on_generation : callable, optional
        Called as ``on_generation(generation, best_cost, mean_cost)``.

    Returns
    -------
    ReachResult
        The final optimum; ``ga`` keeps the GA's best before the polish.
    """
    algo = algorithm or MemeticGA()
    term = termination or Termination()
    _check_int("seed", seed, 0)
    _check_population(problem, algo)
    t0 = time.perf_counter()
    run = _GARun(problem, algo, term, seed, on_generation)
    reason = run.run()
    ga, q = run.best()
    final: ReachResult | None = None
    if algo.polish:
        final = _polish_many(problem, run.polish_starts(ga.tensions), q, algo.warm_start)
    top = final.optimum if final is not None else ga
    stats = run.stats
    return ReachResult(
        tensions=top.tensions, tip_position=top.tip_position, reach=top.reach, cost=top.cost,
        value=float(problem.value(top.tip_position)), stable=top.stable, converged=reason == "tolerance",
        stop_reason=reason, generations=len(stats.history["best"]), evaluations=stats.evals + stats.ls,
        nonconverged=stats.nonconv, rejected_unstable=stats.rejected_unstable,
        seconds=time.perf_counter() - t0, seed=int(seed), history=stats.history, ga=ga,
        polish_gain=ga.cost - top.cost if final is not None else 0.0,
        polish_evaluations=final.polish_evaluations if final is not None else 0,
        polish_message=final.polish_message if final is not None else "",
        settings={**problem.describe(), **algo.describe(), **asdict(term), "local_search_runs": stats.ls_runs},
    )

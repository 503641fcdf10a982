"""The feasible static workspace problem of the paper (Eq. 29) and its solution.

What is solved: minimise ``1 / ||^0P_n||`` over the actuator tensions within
bounds, subject to static equilibrium, under given external loads. How: the
genetic algorithm of pymoo (the population evaluated as one parallel batch of
static solves), stopped when its best cost changes by less than ``tol`` over
``window`` generations or at ``max_gen``; then a gradient polish (L-BFGS-B)
whose gradient comes exactly from the implicit function theorem.

A tension vector whose static solve does not converge is infeasible (a
constraint violation): pymoo ranks every feasible individual above it, so it
can never be the optimum; such evaluations are counted.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize as sp_minimize
from scipy.spatial import cKDTree

from .design import Robot
from .kinematics import forward_kinematics, tip_jacobian
from .loads import Loads
from .statics import CosseratModel, CosseratOptions, SolverOptions, StaticModel, options_for, solve, solve_batch
from .workspace import TensionBounds

__all__ = ["PolishResult", "ReachResult", "maximize_reach", "polish_reach", "reach_gradient"]

#: cost given to non-converged individuals (they are also flagged infeasible)
_INFEASIBLE_COST = 1e3


@dataclass(frozen=True, eq=False)
class PolishResult:
    """Local refinement of an optimum.

    Attributes
    ----------
    tensions : ndarray, shape (n_tendons,)
    cost : float
        1 / reach [1/m].
    reach : float
        [m]
    cost_change : float
        Start cost minus polished cost (>= 0 when the polish improved it).
    evaluations : int
        Static solves used.
    message : str
        The local optimiser's own report.
    """

    tensions: np.ndarray
    cost: float
    reach: float
    tip_position: np.ndarray
    cost_change: float
    evaluations: int
    message: str


@dataclass(frozen=True, eq=False)
class ReachResult:
    """Outcome of :func:`maximize_reach`.

    Attributes
    ----------
    tensions : ndarray, shape (n_tendons,)
        The GA's best actuator tensions [N].
    tip_position : ndarray, shape (3,)
        [m]
    reach : float
        ||tip|| [m].
    cost : float
        1 / reach [1/m].
    generations : int
    evaluations : int
        Static solves made by the GA and its local searches.
    nonconverged : int
        GA evaluations whose static solve did not converge (made infeasible).
    converged : bool
        True when the stopping rule (not the generation cap) ended the run.
    seconds : float
    seed : int
    history : dict
        ``best`` and ``mean`` feasible cost per generation, ``evaluations``
        (cumulative) and ``nonconverged`` per generation.
    polish : PolishResult or None
    settings : dict
        pop_size, tol, window, max_gen, bounds.
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    reach: float
    cost: float
    generations: int
    evaluations: int
    nonconverged: int
    converged: bool
    seconds: float
    seed: int
    history: dict[str, list[float]]
    polish: PolishResult | None
    settings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the keys of ``tdcr optimize --json``)."""
        out = {
            "tensions": self.tensions.tolist(),
            "tip_position": self.tip_position.tolist(),
            "reach": self.reach,
            "cost": self.cost,
            "generations": self.generations,
            "evaluations": self.evaluations,
            "nonconverged": self.nonconverged,
            "converged": self.converged,
            "seconds": self.seconds,
            "seed": self.seed,
            "history": self.history,
            "settings": self.settings,
        }
        if self.polish is not None:
            p = self.polish
            out["polish"] = {
                "tensions": p.tensions.tolist(),
                "tip_position": p.tip_position.tolist(),
                "reach": p.reach,
                "cost": p.cost,
                "cost_change": p.cost_change,
                "evaluations": p.evaluations,
                "message": p.message,
            }
        return out


def _check_reach(reach: float, robot: Robot) -> None:
    # the backbone is inextensible: a longer reach can only be a bug
    if reach > robot.length * (1.0 + 1e-12):
        raise RuntimeError(f"reach {reach} m exceeds the backbone length {robot.length} m")


def reach_gradient(robot: Robot, loads: Loads, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tip position and its exact derivative with respect to the actuator tensions.

    At an equilibrium ``q`` (N, 3) of ``robot`` under ``loads``, the implicit
    function theorem gives ``dq/dT = -J^-1 dr/dT``; the residual is affine in
    the tensions at fixed ``q``, so ``dr/dT_c`` is a difference of residuals.

    Returns
    -------
    tip : ndarray, shape (3,)
        [m]
    dtip_dT : ndarray, shape (3, n_tendons)
        [m/N]
    """
    q = np.ascontiguousarray(q, dtype=float).reshape(-1)
    model = StaticModel.build(robot, loads)
    J = model.jacobian(q)
    r0 = model.residual(q).reshape(-1)
    nt = robot.n_tendons
    dr = np.empty((q.size, nt))
    for c in range(nt):
        t = model.tension.copy()
        t[c] += 1.0
        dr[:, c] = replace(model, tension=t).residual(q).reshape(-1) - r0
    dq = -np.linalg.solve(J, dr)
    tip = forward_kinematics(q, robot.subsegment_lengths)[0][-1]
    return tip, tip_jacobian(q, model.sub, 1e-7) @ dq


def polish_reach(
    robot: Robot,
    loads: Loads,
    bounds: TensionBounds,
    tensions: np.ndarray,
    *,
    q0: np.ndarray | None = None,
    max_iter: int = 200,
    warm: bool = False,
    model: str = "pcc",
    options: SolverOptions | CosseratOptions | None = None,
    ftol: float = 1e-15,
    gtol: float = 1e-12,
    restarts: int = 3,
) -> PolishResult:
    """Refine a tension vector by L-BFGS-B on 1/reach with exact gradients.

    ``ftol`` and ``gtol`` are L-BFGS-B's stopping tolerances. The cost has
    kinks (friction regimes, folds of the loading path) where L-BFGS-B's line
    search can give up; it is then restarted from its best point, up to
    ``restarts`` times, while that still lowers the cost.

    Every cost is a static solve at a tight tolerance (1e-12 N m), so the cost
    is smooth to the optimiser; cold (from the straight robot) unless ``warm``,
    in which case it starts from ``q0`` and then the last equilibrium. The
    gradient is the implicit-function-theorem one: exact for the PCC model
    (:func:`reach_gradient`), from central differences of the shooting map
    for the Cosserat model.
    """
    bounds.check_robot(robot)
    opts = replace(options_for(model, options), atol=1e-12)
    state = {"q": None if q0 is None else np.asarray(q0, dtype=float), "n": 0}
    free = bounds.upper > bounds.lower
    x_fixed = np.array(tensions, dtype=float)

    def full(x: np.ndarray) -> np.ndarray:
        t = x_fixed.copy()
        t[free] = x
        return t

    def fun(x: np.ndarray) -> tuple[float, np.ndarray]:
        t = full(np.clip(x, bounds.lower[free], bounds.upper[free]))
        lds = loads.with_tensions(t)
        sol = solve(robot, lds, model=model, q0=state["q"] if warm else None, options=opts)
        state["n"] += 1
        if not sol.converged:
            return _INFEASIBLE_COST, np.zeros_like(x)
        state["q"] = sol.q
        if model == "cosserat":
            tip, dtip = CosseratModel.build(robot, lds, opts).tip_and_gradient(sol.q)
        else:
            tip, dtip = reach_gradient(robot, lds, sol.q)
        r = float(np.linalg.norm(tip))
        grad = -(tip @ dtip) / r**3
        return 1.0 / r, grad[free]

    x0 = np.array(tensions, dtype=float)[free]
    c0, _ = fun(x0)
    if not np.any(free):
        res_x, msg = x0, "no free tension"
    else:
        box = list(zip(bounds.lower[free], bounds.upper[free], strict=True))
        x, best = x0, c0
        for _ in range(1 + max(0, int(restarts))):
            res = sp_minimize(fun, x, jac=True, method="L-BFGS-B", bounds=box,
                              options={"maxiter": max_iter, "ftol": ftol, "gtol": gtol})
            gain = best - float(res.fun)
            if gain > 0:
                x, best = res.x, float(res.fun)
            if res.success or gain <= 1e-12:
                break
        res_x, msg = x, str(res.message)
    t = full(np.clip(res_x, bounds.lower[free], bounds.upper[free]))
    final = solve(robot, loads.with_tensions(t), model=model,
                  q0=state["q"] if warm else None, options=opts)
    state["n"] += 1
    if not final.converged:  # pragma: no cover - the optimiser only accepts converged points
        raise RuntimeError("polish ended on a tension vector whose solve does not converge")
    _check_reach(final.reach, robot)
    cost = 1.0 / final.reach
    return PolishResult(tensions=t, cost=cost, reach=final.reach, tip_position=final.tip_position,
                        cost_change=c0 - cost, evaluations=state["n"], message=msg)


def maximize_reach(
    robot: Robot,
    loads: Loads,
    bounds: TensionBounds,
    *,
    pop_size: int = 50,
    tol: float = 1e-6,
    window: int = 5,
    max_gen: int = 100,
    seed: int = 0,
    polish: bool = True,
    n_polish: int = 3,
    warm_start: bool = False,
    extra_starts: Sequence[np.ndarray] = (),
    local_search: bool = True,
    ls_max_iter: int = 100,
    ls_starts: int = 1,
    model: str = "pcc",
    options: SolverOptions | CosseratOptions | None = None,
    on_generation: Callable[[int, float, float], None] | None = None,
) -> ReachResult:
    """Maximise the tip's distance from the base over the tensions (the paper's Eq. 29).

    Parameters
    ----------
    robot, loads
        The robot and the external loads (the tensions of ``loads`` are ignored).
    bounds : TensionBounds
    pop_size : int
        GA population (the paper tried 50, 100 and 200).
    tol, window : float, int
        Stop once the best cost has improved by less than ``tol`` [1/m] over
        the last ``window`` generations.
    max_gen : int
        Generation cap.
    seed : int
        Seed of the GA (same seed, same result).
    polish : bool
        Refine the GA's best with :func:`polish_reach`.
    n_polish : int
        Polish the GA's best and up to ``n_polish - 1`` other distinct
        individuals of the final population; keep the best result.
    warm_start : bool
        Start each evaluation from the equilibrium of the nearest tension
        vector already solved (faster). Off by default: where a tension vector
        has several equilibria this makes the cost depend on the search
        history. Cold evaluations (from the straight robot, the solver's
        default path) make the cost a function of the tensions alone.
    extra_starts : sequence of array-like, shape (n_tendons,)
        Further polish starts (clipped into the bounds), e.g. a known optimum
        of tighter bounds.
    local_search : bool
        Memetic GA (default): whenever a generation produces a new leader, a
        short gradient search (:func:`polish_reach`, ``ls_max_iter``
        iterations) replaces it by its local optimum (Lamarckian learning), so
        the GA explores basins and the local search settles them; the first
        generation searches from its ``ls_starts`` best distinct individuals.
        Its solves are counted in ``evaluations``. False: the plain GA of the paper.
    model : {'pcc', 'cosserat'}
        The static model (see :func:`pytdcr.solve`); ``options`` must suit it.
    on_generation : callable, optional
        Called as ``on_generation(generation, best_cost, mean_cost)``.
    """
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.population import Population
    from pymoo.core.problem import Problem

    bounds.check_robot(robot)
    for name, val, lo in (("pop_size", pop_size, 2), ("window", window, 1), ("max_gen", max_gen, 1)):
        if int(val) != val or val < lo:
            raise ValueError(f"{name} must be an integer >= {lo}, got {val}")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be finite and > 0, got {tol}")
    free = bounds.upper > bounds.lower
    if not np.any(free):
        raise ValueError("bounds: every tension is fixed (lower == upper); nothing to optimise")
    base = np.array(bounds.lower, dtype=float)
    counters = {"evals": 0, "nonconv": 0}
    opts = options_for(model, options)
    archive_T: list[np.ndarray] = []
    archive_q: list[np.ndarray] = []
    scale = np.maximum(bounds.upper - bounds.lower, 1e-12)

    class _Reach(Problem):
        def __init__(self) -> None:
            super().__init__(n_var=int(free.sum()), n_obj=1, n_ieq_constr=1,
                             xl=bounds.lower[free], xu=bounds.upper[free])

        def _evaluate(self, x: np.ndarray, out: dict, *args: Any, **kwargs: Any) -> None:
            T = np.repeat(base[None, :], x.shape[0], axis=0)
            T[:, free] = x
            q0 = None
            if warm_start and archive_T:
                # warm start from the nearest tension vector already solved (offspring lie near parents)
                AT = np.vstack(archive_T)
                nearest = cKDTree(AT / scale).query(T / scale)[1]
                q0 = np.vstack(archive_q)[nearest]
            batch = solve_batch(robot, T, loads, model=model, q0=q0, options=opts)
            ok = batch.converged
            archive_T.append(T[ok])
            archive_q.append(batch.q[ok])
            counters["evals"] += x.shape[0]
            counters["nonconv"] += int((~ok).sum())
            reach = batch.reach
            f = np.full(x.shape[0], _INFEASIBLE_COST)
            f[ok] = 1.0 / reach[ok]
            out["F"] = f[:, None]
            out["G"] = np.where(ok, -1.0, 1.0)[:, None]

    t0 = time.perf_counter()
    problem = _Reach()
    algorithm = GA(pop_size=int(pop_size), eliminate_duplicates=True)
    algorithm.setup(problem, termination=("n_gen", int(max_gen)), seed=int(seed), verbose=False)
    best_hist: list[float] = []
    mean_hist: list[float] = []
    evals_hist: list[int] = []
    nonconv_hist: list[int] = []
    ls_hist: list[int] = []
    stopped = False
    counters["ls"] = 0
    counters["ls_runs"] = 0

    def learn(infills: Population) -> Population:
        """Lamarckian step: a new leader (better than the incumbent) is replaced by its local optimum.

        In the first generation the best ``ls_starts`` distinct individuals are searched.
        """
        F = infills.get("F")[:, 0]
        feas = infills.get("feas")
        incumbent = best_hist[-1] if best_hist else np.inf
        order = [int(k) for k in np.argsort(F) if feas[k] and F[k] < incumbent - tol]
        picked: list[np.ndarray] = []
        for k in order:
            if len(picked) >= (ls_starts if not best_hist else 1):
                break
            x = infills[k].get("X")
            if all(np.max(np.abs((x - y) / scale[free])) > 0.05 for y in picked):
                picked.append(x)
        found = []
        for x in picked:
            start = base.copy()
            start[free] = x
            try:
                pr = polish_reach(robot, loads, bounds, start, max_iter=ls_max_iter, model=model, options=opts,
                              ftol=1e-12, gtol=1e-8)
            except RuntimeError:
                continue
            counters["ls"] += pr.evaluations
            counters["ls_runs"] += 1
            found.append(pr.tensions[free])
        if not found:
            return infills
        extra = Population.new("X", np.array(found))
        algorithm.evaluator.eval(problem, extra, algorithm=algorithm)
        return Population.merge(infills, extra)

    while algorithm.has_next():
        before = counters["nonconv"]
        infills = algorithm.infill()
        algorithm.evaluator.eval(problem, infills, algorithm=algorithm)
        if local_search:
            infills = learn(infills)
        algorithm.advance(infills=infills)
        pop = algorithm.pop
        F = pop.get("F")[:, 0]
        feas = pop.get("feas")
        opt_f = algorithm.opt.get("F")[:, 0]
        opt_feas = algorithm.opt.get("feas")
        best = float(opt_f[opt_feas].min()) if np.any(opt_feas) else float("inf")
        mean = float(F[feas].mean()) if np.any(feas) else float("inf")
        best_hist.append(best)
        mean_hist.append(mean)
        evals_hist.append(counters["evals"] + counters["ls"])
        nonconv_hist.append(counters["nonconv"] - before)
        ls_hist.append(counters["ls"])
        if on_generation is not None:
            on_generation(len(best_hist), best, mean)
        g = len(best_hist)
        if g > window and np.isfinite(best) and best_hist[g - 1 - window] - best < tol:
            stopped = True
            break
    seconds = time.perf_counter() - t0
    opt = algorithm.opt[0]
    if not opt.get("feas"):
        raise RuntimeError("no tension vector within the bounds gave a converged static solve")
    T = base.copy()
    T[free] = opt.get("X")
    # the optimum is re-solved cold, from the straight robot, independent of the warm-start history
    sol = solve(robot, loads.with_tensions(T), model=model, options=opts)
    if not sol.converged:
        raise RuntimeError("the GA's best does not converge when solved cold from the straight robot")
    _check_reach(sol.reach, robot)
    pol = None
    if polish:
        # polish the best few distinct individuals (the landscape has several local optima)
        pop = algorithm.pop
        order = np.argsort(pop.get("F")[:, 0])
        starts: list[np.ndarray] = [T]
        for k in order:
            if len(starts) >= n_polish:
                break
            if not pop[k].get("feas"):
                continue
            cand = base.copy()
            cand[free] = pop[k].get("X")
            if all(np.max(np.abs((cand - s_) / scale)) > 0.05 for s_ in starts):
                starts.append(cand)
        starts += [np.clip(np.asarray(x, dtype=float), bounds.lower, bounds.upper) for x in extra_starts]
        def one(k: int) -> PolishResult | None:
            try:
                return polish_reach(robot, loads, bounds, starts[k], q0=sol.q if k == 0 else None, warm=warm_start,
                                    model=model, options=opts, ftol=1e-12, gtol=1e-8)
            except RuntimeError:
                return None

        # the starts are independent: run them on all cores (the compiled solver releases the GIL)
        with ThreadPoolExecutor(max_workers=min(len(starts), os.cpu_count() or 1)) as pool:
            results = [r_ for r_ in pool.map(one, range(len(starts))) if r_ is not None]
        if results:
            best_pol = min(results, key=lambda p_: p_.cost)
            try:  # the winner once more at the tightest tolerances
                tight = polish_reach(robot, loads, bounds, best_pol.tensions, warm=warm_start, model=model,
                                     options=opts)
                if tight.cost <= best_pol.cost:
                    results.append(tight)
                    best_pol = tight
            except RuntimeError:
                pass
            pol = PolishResult(tensions=best_pol.tensions, cost=best_pol.cost, reach=best_pol.reach,
                               tip_position=best_pol.tip_position, cost_change=1.0 / sol.reach - best_pol.cost,
                               evaluations=sum(p_.evaluations for p_ in results),
                               message=f"best of {len(results)} starts: {best_pol.message}")
    return ReachResult(
        tensions=T,
        tip_position=sol.tip_position,
        reach=sol.reach,
        cost=1.0 / sol.reach,
        generations=len(best_hist),
        evaluations=counters["evals"] + counters["ls"],
        nonconverged=counters["nonconv"],
        converged=stopped,
        seconds=seconds,
        seed=int(seed),
        history={"best": best_hist, "mean": mean_hist, "evaluations": evals_hist, "nonconverged": nonconv_hist,
                 "local_search_evaluations": ls_hist},
        polish=pol,
        settings={"model": model, "local_search": bool(local_search), "ls_max_iter": int(ls_max_iter),
                  "ls_starts": int(ls_starts),
                  "local_search_runs": counters["ls_runs"], "pop_size": int(pop_size), "tol": float(tol),
                  "window": int(window), "max_gen": int(max_gen), "bounds": bounds.to_dict()},
    )

"""Where a solve's time goes, phase by phase, in the compiled core (pytdcr._core): issue 46's profile.

Cases: random tension vectors, uniform in [0, 20] N, on the paper robot under the paper's load (its friction
law, gravity, tip force (0.1, 0.1, -0.1) N and moment (-0.1, 0.1, 0.1) N m), each model with its default
options, one thread (the core's ``_profile_range_<model>``: ``solve_range`` with each case's work counted and
timed). Two kinds of solve per model:

- cold: from the straight robot along the loading path (``solve(robot, loads)``);
- continued: from a cold solve's equilibrium to tensions 2 N away (Euclidean in tension space, clipped to
  [0, 20] N), as ``solve(..., start=solution)`` does.

Per model and kind: the time per solve (median, mean); per solve, the median count of residual-only evaluations,
Jacobian evaluations (residual with its exact Jacobian), dense LU factorisations (of the Jacobian, its bordered
and damped forms) and load steps; the share of all the solves' time in each phase (residuals, Jacobians,
factorisations, the rest: Broyden updates, predictors, bookkeeping) and each phase's median unit cost [us].
The timers cost about 0.05 us a call; ``--untimed`` runs without them for the totals alone.

Prints a table, writes ``bench/results/solve_phases.json`` (``--out`` elsewhere) and, with ``--json``, prints
one JSON object as the last line.

Usage: python bench/solve_phases.py [--model pcc|pcc2|sscr|all] [--cases 200] [--seed 0] [--json] [--out F]
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from _common import add_out_argument, write_result

#: the models profiled by --model all, and each one's default case count (an sscr solve costs ~15 pcc solves)
MODELS = {"pcc": 400, "pcc2": 300, "sscr": 60}
#: how far a continuation's end tensions are from its start's [N] (Euclidean)
CONTINUATION_STEP = 2.0
MAX_TENSION = 20.0
PHASES = ("residual", "jacobian", "factorisation")


def setup(name: str) -> tuple[Any, Any, Any, Any]:
    """The paper robot and paper load, the registry's model ``name``, its equations and solver settings."""
    from pytdcr import Loads, paper_robot
    from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
    from pytdcr.statics.compiled import kernel_settings
    from pytdcr.statics.registry import get_model

    robot = paper_robot()
    loads = Loads(np.zeros(8), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)
    model = get_model(name)
    options = model.default_options()
    eq = model.equations(robot, loads, options)
    return robot, loads, eq, kernel_settings(options)


def summarise(res: np.ndarray, counts: np.ndarray, seconds: np.ndarray) -> dict[str, Any]:
    """One kind's figures from the core's per-case outputs (see ``_profile_range_*``)."""
    total = seconds[:, 3]
    ms = 1e3 * total
    spent = seconds[:, :3].sum(axis=0)
    out: dict[str, Any] = {
        "n": int(res.size), "converged": int(np.sum(res >= 0.0)),
        "median_ms": float(np.median(ms)), "mean_ms": float(np.mean(ms)), "max_ms": float(np.max(ms)),
        "median_count": {k: float(np.median(counts[:, c])) for c, k in
                         enumerate(("residuals", "jacobians", "factorisations", "load_steps"))},
        "mean_count": {k: float(np.mean(counts[:, c])) for c, k in
                       enumerate(("residuals", "jacobians", "factorisations", "load_steps"))},
        "share": {}, "unit_us": {},
    }
    if total.sum() > 0.0:
        for c, phase in enumerate(PHASES):
            out["share"][phase] = float(spent[c] / total.sum())
            calls = counts[:, c].sum()
            out["unit_us"][phase] = float(1e6 * spent[c] / calls) if calls else None
        out["share"]["other"] = float(1.0 - spent.sum() / total.sum())
    return out


def profile(name: str, cases: int, seed: int, timed: bool) -> dict[str, Any]:
    """Cold and continued solves of model ``name`` on ``cases`` random tension vectors."""
    from pytdcr import _core
    from pytdcr.statics.compiled import case_tolerances
    from pytdcr.statics.options import STEP_CONTINUE

    robot, loads, eq, settings = setup(name)
    run = getattr(_core, "_profile_range_pcc" if name in ("pcc", "pcc2") else "_profile_range_sscr")
    rng = np.random.default_rng(seed)
    T = rng.uniform(0.0, MAX_TENSION, (cases, robot.n_tendons))
    tols = case_tolerances(robot, loads, T, settings.atol)
    km = eq.kernel_model
    q0 = np.zeros((cases, eq.n_unknowns))
    run(q0[:2], km, km, T[:2], T[:2], settings, tols[:2], timed)  # first call: allocation, page faults
    q, res, counts, seconds = run(q0, km, km, T, T, settings, tols, timed)
    cold = summarise(res, counts, seconds)
    ok = res >= 0.0
    step = rng.normal(size=T.shape)
    step *= CONTINUATION_STEP / np.linalg.norm(step, axis=1, keepdims=True)
    T1 = np.clip(T + step, 0.0, MAX_TENSION)[ok]
    tols1 = case_tolerances(robot, loads, T1, settings.atol)
    _, res1, counts1, seconds1 = run(np.ascontiguousarray(q[ok]), km, km, np.ascontiguousarray(T[ok]), T1,
                                     settings._replace(stepping=STEP_CONTINUE), tols1, timed)
    return {"cold": cold, "continued": summarise(res1, counts1, seconds1)}


def table(results: dict[str, Any]) -> str:
    """The printed summary, one row per model and kind."""
    head = (f"{'model':6} {'kind':10} {'median':>8} {'mean':>8}  {'res':>5} {'jac':>5} {'fact':>5} {'steps':>5}"
            f"   share res/jac/fact/other        unit us res/jac/fact")
    lines = [head]
    for name, kinds in results.items():
        for kind, r in kinds.items():
            c, s, u = r["median_count"], r["share"], r["unit_us"]
            share = "/".join(f"{100 * s[k]:.0f}%" for k in (*PHASES, "other")) if s else "untimed"
            unit = "/".join(f"{u[k]:.1f}" if u.get(k) else "-" for k in PHASES) if u else ""
            lines.append(f"{name:6} {kind:10} {r['median_ms']:7.2f}ms {r['mean_ms']:7.2f}ms  {c['residuals']:5.0f} "
                         f"{c['jacobians']:5.0f} {c['factorisations']:5.0f} {c['load_steps']:5.0f}   {share:28} {unit}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default="all", choices=[*MODELS, "all"])
    ap.add_argument("--cases", type=int, default=None, help="tension vectors per model (default: per model)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--untimed", action="store_true", help="count without the phase timers")
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "solve_phases")
    args = ap.parse_args()
    names = list(MODELS) if args.model == "all" else [args.model]
    results = {n: profile(n, args.cases or MODELS[n], args.seed, not args.untimed) for n in names}
    print(table(results))
    write_result("solve_phases", {"models": results, "cases": {n: args.cases or MODELS[n] for n in names},
                                  "seed": args.seed, "timed": not args.untimed}, args.json, args.out)


if __name__ == "__main__":
    main()

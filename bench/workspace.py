"""The workspace study's speed on the paper robot under the paper's load, tensions in [0, 20] N.

Three measurements (their tables are in docs/validation.md):
- sampling: ``solve_plan`` on ``--samples`` Sobol points (with the box's corners and edges, and the checked
  warm starts), solves per second; the issue's target is 20,000 samples in 10 s (2,000 solves/s);
- support: h(d) on ``--directions`` Fibonacci directions from ``--n`` samples continued from the root, stable
  equilibria only, as ``tdcr workspace`` computes it: each search warm from its sample's equilibrium, its end
  continued from it (target 200 in 30 s); with ``--cold``, every cost a cold solve from rest as before;
- region: ``workspace_region`` at ``--n`` base samples with the boundary search (its default budget, or
  ``--budget`` solves; ``--folds stop``: its steps stop at folds instead of snapping through): the seconds, the
  solves, the steps stopped at a fold, the FSW's volume and error.
Each is repeated ``--repeat`` times; medians are printed and written to ``bench/results/workspace.json``.

Usage: python bench/workspace.py [--samples 20000] [--n 4000] [--budget N] [--directions 200] [--repeat 1]
       [--cold] [--folds snap|stop] [--skip region]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr.optimize import ReachProblem
from pytdcr.paper import paper_bounds, paper_loads, paper_robot
from pytdcr.statics import warmup
from pytdcr.workspace import WorkspaceSettings
from pytdcr.workspace._compute import workspace_region
from pytdcr.workspace._plan import plan_tensions
from pytdcr.workspace._solve import WarmStarts, continue_plan, solve_plan
from pytdcr.workspace._support import SampleStates, fibonacci_directions, support_function


def sampling(n: int, seed: int) -> dict[str, float]:
    robot, loads, b = paper_robot(), paper_loads(), paper_bounds()
    t0 = time.perf_counter()
    s = solve_plan(robot, loads, plan_tensions(b, n, seed=seed), warm=WarmStarts(seed=seed))
    sec = time.perf_counter() - t0
    solves = s.source.size + s.warm.checked
    return {"samples": int(s.source.size), "solves": int(solves), "seconds": sec, "solves_per_s": solves / sec,
            "warm_mode": s.warm.mode, "agreement": s.warm.agreement or 0.0}


def support(n: int, k: int, seed: int, cold: bool = False) -> dict[str, float]:
    robot, loads, b = paper_robot(), paper_loads(), paper_bounds()
    s = continue_plan(robot, loads, plan_tensions(b, n, seed=seed))
    problem = ReachProblem.create(robot, loads, b, stable_only=True)
    ok = s.feasible
    states = None if cold else SampleStates(s.q[ok], continued=True)
    t0 = time.perf_counter()
    sf = support_function(problem, s.tensions[ok], s.tip_position[ok], fibonacci_directions(k), states=states)
    sec = time.perf_counter() - t0
    return {"directions": k, "seconds": sec, "evaluations_median": float(np.median(sf.evaluations)),
            "improved": int(np.sum(sf.gain > 0)), "gain_median_m": float(np.median(sf.gain)),
            "h_mean_m": float(np.mean(sf.h)), "searches": "cold" if cold else "warm, continued ends"}


def region(n: int, seed: int, budget: int | None = None, folds: str = "snap") -> dict[str, float]:
    robot, loads, b = paper_robot(), paper_loads(), paper_bounds()
    t0 = time.perf_counter()
    wr = workspace_region(robot, loads, b, WorkspaceSettings(n=n, seed=seed, budget=budget, folds=folds))
    sec = time.perf_counter() - t0
    assert wr.search is not None
    return {"n": n, "folds": folds, "seconds": sec, "solves": int(wr.samples.source.size + wr.samples.warm.checked),
            "search_solves": wr.search.solves, "search_at_fold": wr.search.to_dict()["at_fold"],
            "search_stop": wr.search.stop,
            "volume_cm3": wr.fsw.volume_m3 * 1e6, "error_cm3": wr.fsw.error_m3 * 1e6,
            "realisable_cm3": wr.realisable.volume_m3 * 1e6, "realisable_error_cm3": wr.realisable.error_m3 * 1e6}


def _median(rows: list[dict[str, float]]) -> dict[str, float]:
    return {k: (statistics.median(r[k] for r in rows) if isinstance(rows[0][k], float) else rows[0][k])
            for k in rows[0]}


def main() -> None:
    """Run the measurements and print their medians."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20_000)
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--directions", type=int, default=200)
    ap.add_argument("--budget", type=int, default=None, help="the boundary search's solves (default 25 n)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--cold", action="store_true", help="h(d) with every cost solved from rest (the old way)")
    ap.add_argument("--folds", choices=("snap", "stop"), default="snap",
                    help="what a boundary-search step does at a fold (region)")
    ap.add_argument("--skip", default="", help="comma-separated: sampling, support, region")
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "workspace")
    args = ap.parse_args()
    warmup()
    skip = set(filter(None, args.skip.split(",")))
    out = {}
    jobs = {"sampling": lambda: sampling(args.samples, args.seed),
            "support": lambda: support(args.n, args.directions, args.seed, args.cold),
            "region": lambda: region(args.n, args.seed, args.budget, args.folds)}
    for name, job in jobs.items():
        if name in skip:
            continue
        out[name] = _median([job() for _ in range(args.repeat)])
        print(f"{name}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                      for k, v in out[name].items()), flush=True)
    write_result("workspace", {"robot": "paper", "load": "paper wrench", "bounds_N": [0, 20],
                               "repeat": args.repeat, **out}, args.json, out=args.out)


if __name__ == "__main__":
    main()

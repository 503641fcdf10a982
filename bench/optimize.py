"""The optimiser on the paper's study: does the population-50 GA converge, and to what?

For each seed: the memetic GA of Eq. 29 (pymoo GA + gradient search on each new leader) on the paper
robot under the paper's tip load (force (0.1, 0.1, -0.1) N, moment (-0.1, 0.1, 0.1) N m), bounds
[0, 20] N, population 50, tolerance 1e-6 over 5 generations, cap 30; then the multi-start polish.
Reports generations, model solves (local searches included), how much the polish moved the cost, the
reach before and after, and the time. Also the plain GA (no local search) for one seed, for contrast.
Prints a table, writes ``bench/results/optimize.json``; ``--json`` prints it as the last line.

Usage: python bench/optimize.py [--seeds 8] [--json]
"""

from __future__ import annotations

import argparse
import time

from _common import add_out_argument, write_result

from pytdcr import paper_loads, paper_robot
from pytdcr.optimize import MemeticGA, ReachProblem, Termination, maximize_reach
from pytdcr.paper import paper_bounds
from pytdcr.statics import warmup


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=8, help="seeds 0..N-1")
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "optimize")
    args = ap.parse_args()
    warmup()
    problem = ReachProblem.create(paper_robot(), paper_loads(), paper_bounds())
    rows = []
    print("seed  generations  solves  polish change [1/m]  GA reach [m]  polished reach [m]  seconds")
    for seed in range(args.seeds):
        t0 = time.perf_counter()
        r = maximize_reach(problem, MemeticGA(pop_size=50), Termination(1e-6, 5, 30), seed=seed)
        row = {"seed": seed, "generations": r.generations, "tol_met": r.stop_reason == "tolerance",
               "evaluations": r.evaluations, "local_search_evaluations": r.history["local_search_evaluations"][-1],
               "polish_cost_change": r.polish_gain, "reach": r.ga.reach, "polished_reach": r.reach,
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"{seed:4d}  {r.generations:11d}  {r.evaluations:6d}  {r.polish_gain:19.2e}  "
              f"{r.ga.reach:12.7f}  {r.reach:18.7f}  {row['seconds']:7.1f}")
    t0 = time.perf_counter()
    plain = maximize_reach(problem, MemeticGA(pop_size=50, local_search=False), Termination(1e-6, 5, 100), seed=0)
    plain_row = {"generations": plain.generations, "tol_met": plain.stop_reason == "tolerance",
                 "evaluations": plain.evaluations, "polish_cost_change": plain.polish_gain, "reach": plain.ga.reach,
                 "polished_reach": plain.reach, "seconds": time.perf_counter() - t0}
    print(f"plain GA, seed 0: {plain.generations} generations ({plain.stop_reason}), "
          f"{plain.evaluations} solves, polish change {plain.polish_gain:.2e}, reach {plain.ga.reach:.7f} -> "
          f"{plain.reach:.7f} m, {plain_row['seconds']:.1f} s")
    ok = [r_ for r_ in rows if r_["generations"] <= 10 and r_["evaluations"] <= 500
          and abs(r_["polish_cost_change"]) < 1e-6]
    print(f"seeds meeting <= 10 generations, <= 500 solves and polish change < 1e-6: {len(ok)} of {len(rows)}")
    write_result("optimize", {"memetic": rows, "plain_seed0": plain_row, "meeting_target": len(ok)},
                 args.json, out=args.out)


if __name__ == "__main__":
    main()

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

import numpy as np
from _common import write_result

from pytdcr import Loads, paper_robot
from pytdcr.optimize import maximize_reach
from pytdcr.statics import warmup
from pytdcr.workspace import TensionBounds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=8, help="seeds 0..N-1")
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    args = ap.parse_args()
    warmup()
    robot = paper_robot()
    loads = Loads(np.zeros(8), tip_force=[0.1, 0.1, -0.1], tip_moment=[-0.1, 0.1, 0.1])
    bounds = TensionBounds.uniform(8, 0.0, 20.0)
    rows = []
    print("seed  generations  solves  polish change [1/m]  GA reach [m]  polished reach [m]  seconds")
    for seed in range(args.seeds):
        t0 = time.perf_counter()
        r = maximize_reach(robot, loads, bounds, pop_size=50, tol=1e-6, window=5, max_gen=30, seed=seed)
        row = {"seed": seed, "generations": r.generations, "tol_met": r.converged, "evaluations": r.evaluations,
               "local_search_evaluations": r.history["local_search_evaluations"][-1],
               "polish_cost_change": r.polish.cost_change, "reach": r.reach, "polished_reach": r.polish.reach,
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"{seed:4d}  {r.generations:11d}  {r.evaluations:6d}  {r.polish.cost_change:19.2e}  "
              f"{r.reach:12.7f}  {r.polish.reach:18.7f}  {row['seconds']:7.1f}")
    t0 = time.perf_counter()
    plain = maximize_reach(robot, loads, bounds, pop_size=50, tol=1e-6, window=5, max_gen=100, seed=0,
                           local_search=False)
    plain_row = {"generations": plain.generations, "tol_met": plain.converged, "evaluations": plain.evaluations,
                 "polish_cost_change": plain.polish.cost_change, "reach": plain.reach,
                 "polished_reach": plain.polish.reach, "seconds": time.perf_counter() - t0}
    print(f"plain GA, seed 0: {plain.generations} generations ({'tol met' if plain.converged else 'cap'}), "
          f"{plain.evaluations} solves, polish change {plain.polish.cost_change:.2e}, reach {plain.reach:.7f} -> "
          f"{plain.polish.reach:.7f} m, {plain_row['seconds']:.1f} s")
    ok = [r_ for r_ in rows if r_["generations"] <= 10 and r_["evaluations"] <= 500
          and abs(r_["polish_cost_change"]) < 1e-6]
    print(f"seeds meeting <= 10 generations, <= 500 solves and polish change < 1e-6: {len(ok)} of {len(rows)}")
    write_result("optimize", {"memetic": rows, "plain_seed0": plain_row, "meeting_target": len(ok)}, args.json)


if __name__ == "__main__":
    main()

"""Displacement-driven solves: round trips from tensions to pull-ins and back (paper robot).

For each case (a model, the tendons' stiffness and the external loads), ``--n`` random tension vectors (each
tendon uniform in [0, 10] N, or 0 N with probability 1/2) are solved by tension; their pull-ins
(:func:`pytdcr.pulled_in`) are then given to :func:`pytdcr.solve_displacements` for all eight tendons, the
0-N tendons paid out 0.5 mm more than they take up (so that they are clearly slack). Reports per case how many
round trips converge, how many of those reach the tension-driven equilibrium (tip within 0.1 mm; elsewhere the
robot has another equilibrium for the same displacements), the largest tension error of those, and the
equilibria solved and the wall time per round trip (medians, one thread).

Usage: python bench/displacement.py [--n 30] [--seed 1] [--out FILE] [--json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import Loads, paper_robot, pulled_in, solve, solve_displacements
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT

#: the cases: label, model, stiffness [N/m] (None: inextensible), tip force [N], tip moment [N m]
CASES = [
    ("gravity, paper friction", "pcc2", 3.5e4, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ("+ the paper's tip force", "pcc2", 3.5e4, PAPER_TIP_FORCE, (0.0, 0.0, 0.0)),
    ("+ the paper's tip force", "pcc", 3.5e4, PAPER_TIP_FORCE, (0.0, 0.0, 0.0)),
    ("+ the paper's tip force", "sscr", 3.5e4, PAPER_TIP_FORCE, (0.0, 0.0, 0.0)),
    ("the paper's tip force and moment", "pcc2", 3.5e4, PAPER_TIP_FORCE, PAPER_TIP_MOMENT),
    ("gravity, paper friction, inextensible", "pcc2", None, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
]


def round_trips(model: str, stiffness: float | None, force, moment, n: int, seed: int) -> dict:
    """``n`` round trips of one case; see the module docstring."""
    robot = paper_robot()
    loads = Loads(np.zeros(8), tip_force=force, tip_moment=moment)
    rng = np.random.default_rng(seed)
    solved = converged = same = 0
    errors, solves, seconds = [], [], []
    while solved < n:
        T = rng.uniform(0, 10, 8) * (rng.random(8) < 0.5)
        ref = solve(robot, loads.with_tensions(T), model=model)
        if not ref.converged:
            continue
        solved += 1
        asked = pulled_in(robot, ref, stiffness) - 5e-4 * (T == 0)
        t0 = time.perf_counter()
        got = solve_displacements(robot, loads, list(asked), stiffness=stiffness, model=model)
        seconds.append(time.perf_counter() - t0)
        solves.append(got.solves)
        if got.converged:
            converged += 1
            if np.abs(got.solution.tip_position - ref.tip_position).max() <= 1e-4:
                same += 1
                errors.append(float(np.abs(got.tensions - T).max()))
    return {"round_trips": n, "converged": converged, "same_equilibrium": same,
            "max_tension_error_n": max(errors) if errors else None,
            "median_solves": float(np.median(solves)), "median_seconds": float(np.median(seconds))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=30, help="round trips per case")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "displacement")
    args = ap.parse_args()
    rows, cases = [], []
    for label, model, k, force, moment in CASES:
        r = round_trips(model, k, force, moment, args.n, args.seed)
        cases.append({"loads": label, "model": model, "stiffness_n_per_m": k, **r})
        err = r["max_tension_error_n"]
        rows.append([label, f"`{model}`", "inextensible" if k is None else f"{k:,.0f}",
                     f"{r['converged']} of {r['round_trips']}", f"{r['same_equilibrium']}",
                     "\u2013" if err is None else f"{err * 1e3:.2g}", r["median_solves"], r["median_seconds"] * 1e3])
        print(f"{label:40s} {model:5s} {rows[-1][2]:>12s}: {rows[-1][3]} converged, {r['same_equilibrium']} same, "
              f"T error {rows[-1][5]} mN, {r['median_solves']:.0f} equilibria, {r['median_seconds'] * 1e3:.0f} ms")
    table = {"columns": ["loads (paper robot, all 8 tendons driven)", "model", "stiffness N/m", "converged",
                         "same equilibrium as the tension solve", "largest tension error mN",
                         "median equilibria solved", "median ms"], "rows": rows}
    write_result("displacement", {"n": args.n, "seed": args.seed, "cases": cases, "table": table}, args.json,
                 args.out)


if __name__ == "__main__":
    main()

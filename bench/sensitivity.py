"""What the exact derivatives of an equilibrium cost beside its solve, and how stiff the paper robot's tip is.

On the paper robot under the paper's load, ``--n`` random tension vectors in [0, 20] N (seed ``--seed``),
each solved by ``--model``: the median time of the solve, of the tip's compliance
(:func:`pytdcr.tip_compliance`, the issue's target: 2 ms beside its solve) and of the Jacobians by the
tensions (:func:`pytdcr.equilibrium_jacobians`); and over the stable ones, the smallest and largest stiffness
of the tip to a force [N/m] (the inverse singular values of ``C[:3, :3]``: a force along the softest direction
moves the tip farthest).

Prints a table and writes ``bench/results/sensitivity.json``.

Usage: python bench/sensitivity.py [--n 200] [--model pcc] [--seed 0] [--json]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import equilibrium_jacobians, solve, tip_compliance
from pytdcr.paper import paper_loads, paper_robot
from pytdcr.statics import warmup


def main() -> None:
    """Time the solves and their derivatives; print the medians and the stiffness range."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--model", default="pcc")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "sensitivity")
    args = ap.parse_args()
    warmup()
    robot = paper_robot()
    rng = np.random.default_rng(args.seed)
    times: dict[str, list[float]] = {"solve": [], "compliance": [], "jacobians": []}
    stiff_lo, stiff_hi, unstable = [], [], 0
    for t in rng.uniform(0.0, 20.0, (args.n, robot.n_tendons)):
        loads = paper_loads(t)
        t0 = time.perf_counter()
        sol = solve(robot, loads, model=args.model)
        t1 = time.perf_counter()
        if not sol.converged:
            continue
        c = tip_compliance(robot, loads, sol, model=args.model)
        t2 = time.perf_counter()
        equilibrium_jacobians(robot, loads, sol, model=args.model)
        t3 = time.perf_counter()
        times["solve"].append(t1 - t0)
        times["compliance"].append(t2 - t1)
        times["jacobians"].append(t3 - t2)
        if sol.stability is not None and not sol.stability.stable:
            unstable += 1
            continue
        lo, hi, _, _ = c.stiffness_range()
        stiff_lo.append(lo)
        stiff_hi.append(hi)
    med = {k: statistics.median(v) * 1e3 for k, v in times.items()}
    out = {"model": args.model, "n": args.n, "seed": args.seed, "converged": len(times["solve"]),
           "unstable_left_out": unstable, "median_ms": med,
           "stiffness_N_per_m": {"smallest": min(stiff_lo), "largest": max(stiff_hi),
                                 "median_smallest": statistics.median(stiff_lo),
                                 "median_largest": statistics.median(stiff_hi)}}
    print(f"{args.model}, {out['converged']} of {args.n} converged: solve {med['solve']:.2f} ms, compliance "
          f"{med['compliance']:.2f} ms, jacobians {med['jacobians']:.2f} ms (medians)")
    s = out["stiffness_N_per_m"]
    print(f"tip translational stiffness over the {len(stiff_lo)} stable ones: {s['smallest']:.3g} to "
          f"{s['largest']:.3g} N/m (medians of each pose's softest and stiffest direction "
          f"{s['median_smallest']:.3g} and {s['median_largest']:.3g})")
    write_result("sensitivity", out, args.json, out=args.out)


if __name__ == "__main__":
    main()

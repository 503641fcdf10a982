"""Convergence of the compiled models under the paper's load, for every friction law (issue 26, item 2).

Random tension vectors uniform in [0, 20] N (``numpy.random.default_rng(seed)``, seed 0 by default; the first
``--n`` rows for ``pcc`` and ``pcc2``, the first ``--n-sscr`` rows for ``sscr``) on the paper robot with the
paper's friction law (exponential), without friction and with a constant mu = 0.1, under the paper's load
(gravity, tip force (0.1, 0.1, -0.1) N, tip moment (-0.1, 0.1, 0.1) N m). Each row is solved on its own
through ``solve_batch(..., threads=1)`` (kernels compiled and
cached): the count converged, how each was reached (``path``), the median and mean time per solve [ms] and the
mean Newton iterations. Every row reported converged is checked to be within its tolerance. A row whose solver
converged to an equilibrium through which the backbone passes through itself (``path`` "self-contact": the
models have no contact, so the library refuses it) is counted apart: the solver found the equilibrium, the robot
cannot take it.

Prints a table, writes ``bench/results/convergence.json`` and, with ``--json``, prints it as the last line.
Times are noisy on a shared machine; the counts are not.

Usage: python bench/convergence.py [--n 200] [--n-sscr 60] [--seed 0] [--models pcc,pcc2,sscr] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
from collections import Counter

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import ConstantFriction, NoFriction, paper_loads, paper_robot, solve_batch
from pytdcr.statics import warmup

#: friction law by name: the paper robot's friction
LAWS = {"paper": None, "none": NoFriction(), "constant 0.1": ConstantFriction(mu=0.1)}
#: the laws each model is measured with
MODEL_LAWS = {"pcc": ("paper", "none", "constant 0.1"), "pcc2": ("paper", "none", "constant 0.1"),
              "sscr": ("paper", "none", "constant 0.1")}


def run_case(robot, T: np.ndarray, model: str) -> dict:
    """Every row of ``T`` solved alone on one thread: counts, paths, times, failing rows."""
    loads = paper_loads()
    ms, its, paths, failed, contact, bad = [], [], Counter(), [], [], 0
    for i, t in enumerate(T):
        b = solve_batch(robot, t[None, :], loads, model=model, threads=1)
        ms.append(b.seconds * 1e3)
        its.append(int(b.iterations[0]))
        paths[str(b.path[0])] += 1
        if b.converged[0]:
            bad += not (b.residual[0] <= b.atol[0])
        elif str(b.path[0]) == "self-contact":
            contact.append(i)
        else:
            failed.append(i)
    a = np.asarray(ms)
    return {"cases": len(T), "converged": len(T) - len(failed) - len(contact), "paths": dict(paths),
            "failed_rows": failed, "self_contact_rows": contact,
            "converged_out_of_tolerance": bad, "median_ms": float(np.median(a)), "mean_ms": float(a.mean()),
            "mean_iterations": float(np.mean(its))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=200, help="tension vectors for pcc and pcc2")
    ap.add_argument("--n-sscr", type=int, default=60, help="tension vectors for sscr")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--models", default=",".join(MODEL_LAWS), help="comma-separated, of " + ",".join(MODEL_LAWS))
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "convergence")
    args = ap.parse_args()
    warmup()
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (max(args.n, args.n_sscr), 8))
    result: dict = {"config": {"n": args.n, "n_sscr": args.n_sscr, "seed": args.seed, "cpus": os.cpu_count(),
                               "python": platform.python_version()}}
    print(f"paper robot, paper load, random tensions in [0, 20] N (seed {args.seed}), one thread, one row a call")
    print(f"  {'model':6s} {'friction':13s} {'converged':>10s} {'contact':>8s} {'median ms':>10s} {'mean ms':>8s} "
          f"{'mean it':>8s}  paths")
    for model in args.models.split(","):
        rows = T[: args.n_sscr if model == "sscr" else args.n]
        result[model] = {}
        for law in MODEL_LAWS[model]:
            r = run_case(paper_robot(LAWS[law]), rows, model)
            result[model][law] = r
            print(f"  {model:6s} {law:13s} {r['converged']:5d}/{r['cases']:<4d} {len(r['self_contact_rows']):8d} "
                  f"{r['median_ms']:10.2f} "
                  f"{r['mean_ms']:8.2f} {r['mean_iterations']:8.1f}  {r['paths']}"
                  + (f"  ({r['converged_out_of_tolerance']} converged out of tolerance!)"
                     if r["converged_out_of_tolerance"] else ""))
    write_result("convergence", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

"""Speed and convergence of every registered model on the paper's case (not part of the tests).

For each model: cold solves (no warm start, kernels compiled and cached) of the same random tension vectors,
uniform in [0, 20] N (seed 0), on the paper robot under the paper's tip load with gravity, one after the other
on one core (median and mean time of the public call ``pytdcr.solve``, validation, packing and result included;
convergence; how each equilibrium was reached); then the same vectors as one batch on all cores (solves per
second). Case "friction": the paper's friction law (the smeared Cosserat rod has none: it
is skipped there); case "no friction": every model.

Prints a table, writes ``bench/results/models.json`` and, with ``--json``, prints one JSON object as the last
line. Medians are quoted: these machines are noisy.

Usage: python bench/models.py [--n 200] [--models pcc,sscr] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections import Counter

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import MODELS, NoFriction, paper_loads, paper_robot, solve, solve_batch
from pytdcr.statics import UnsupportedFeatureError, resolve, warmup


def run_case(robot, T: np.ndarray, name: str) -> dict:
    loads = paper_loads()
    try:
        resolve(name, robot, loads)
    except UnsupportedFeatureError as err:
        return {"unsupported": str(err)}
    ms, ok, paths = [], 0, Counter()
    for t in T:
        case = loads.with_tensions(t)
        t0 = time.perf_counter()
        s = solve(robot, case, model=name)
        ms.append((time.perf_counter() - t0) * 1e3)
        ok += s.converged
        paths[s.path] += 1
    t0 = time.perf_counter()
    batch = solve_batch(robot, T, loads, model=name)
    wall = time.perf_counter() - t0
    a = np.asarray(ms)
    return {"median_ms": float(np.median(a)), "mean_ms": float(a.mean()), "p90_ms": float(np.percentile(a, 90)),
            "max_ms": float(a.max()), "converged": int(ok), "cases": len(T), "paths": dict(paths),
            "batch_per_s": len(T) / wall, "batch_converged": int(batch.converged.sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=200, help="tension vectors")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--models", default=",".join(MODELS), help="comma-separated registered models")
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "models")
    args = ap.parse_args()
    warmup()
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (args.n, 8))
    result: dict = {"config": {"n": args.n, "seed": args.seed, "cpus": os.cpu_count(),
                               "python": platform.python_version()}}
    for case, robot in (("friction", paper_robot()), ("no friction", paper_robot(NoFriction()))):
        result[case] = {}
        print(f"{case}: paper robot, paper tip load, gravity, {args.n} random tension vectors in [0, 20] N")
        for name in args.models.split(","):
            r = run_case(robot, T, name)
            result[case][name] = r
            if "unsupported" in r:
                print(f"  {name:9s} unsupported ({r['unsupported'].split(';')[0]})")
                continue
            print(f"  {name:9s} cold solve median {r['median_ms']:7.2f} ms (mean {r['mean_ms']:7.2f}, p90 "
                  f"{r['p90_ms']:7.2f}, max {r['max_ms']:8.1f}); converged {r['converged']}/{r['cases']} "
                  f"{r['paths']}; batch {r['batch_per_s']:7.1f} solves/s")
    write_result("models", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

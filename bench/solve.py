"""Speed of the static solver on the paper robot (not part of the tests).

Cases
-----
a  cold solve, tendons only (no gravity, no friction, no external load)
b  cold solve with the paper's friction law, gravity and the paper's tip load
   (force (0.1, 0.1, -0.1) N, moment (-0.1, 0.1, 0.1) N m), load stepping included
c  warm-started solve: tensions moved by 2 % from a solved neighbour (case b's model)
d  throughput: many random tension vectors in [0, 20] N solved in parallel on all
   cores, with friction and gravity (d), also under the paper's tip load (d_load), and
   with ``load_stepping="auto"`` (Newton at full load first; faster, branch not guaranteed)

Prints a table, writes ``bench/results/solve.json`` and, with ``--json``, prints one
JSON object as the last line. Medians are quoted: these machines are noisy.

Usage: python bench/solve.py [--runs 200] [--batch 4000] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys

import numpy as np
from _common import add_out_argument, write_result


def startup_seconds() -> float:
    """Import and kernel load/compile in a fresh interpreter (uses the on-disk cache)."""
    code = "import time; t=time.perf_counter(); import pytdcr.statics as s; s.warmup(); print(time.perf_counter()-t)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return float(out.strip().splitlines()[-1])


def stats(xs: list[float]) -> dict[str, float]:
    a = np.asarray(xs)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()), "n": int(a.size)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200, help="solves per timed case")
    ap.add_argument("--batch", type=int, default=4000, help="tension vectors in the throughput case")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "solve")
    args = ap.parse_args()

    startup = [startup_seconds() for _ in range(3)]
    import pytdcr
    from pytdcr import Loads, NoFriction, SolverOptions, paper_robot, solve, solve_batch
    from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT

    pytdcr.statics.warmup()
    rng = np.random.default_rng(args.seed)
    paper = paper_robot()
    bare = paper.with_gravity(None).with_friction(NoFriction())
    tip = {"tip_force": PAPER_TIP_FORCE, "tip_moment": PAPER_TIP_MOMENT}

    def timed(robot, make_loads, q0=None):
        ms, conv, steps = [], 0, 0
        for _ in range(args.runs):
            loads, start = make_loads()
            sol = solve(robot, loads, q0=start if q0 is None else q0)
            ms.append(sol.seconds * 1e3)
            conv += sol.converged
            steps += sol.load_steps > 0
        return ms, conv / args.runs, steps / args.runs

    a_ms, a_conv, _ = timed(bare, lambda: (Loads(rng.uniform(0, 20, 8)), None))
    b_ms, b_conv, b_step = timed(paper, lambda: (Loads(rng.uniform(0, 20, 8), **tip), None))

    def neighbour():
        t = rng.uniform(0, 20, 8)
        first = solve(paper, Loads(t, **tip))
        while not first.converged:
            t = rng.uniform(0, 20, 8)
            first = solve(paper, Loads(t, **tip))
        return Loads(np.clip(t * rng.uniform(0.98, 1.02, 8), 0, None), **tip), first.q

    c_ms, c_conv, _ = timed(paper, neighbour)

    T = rng.uniform(0, 20, (args.batch, 8))
    thr, thr_load, thr_auto, conv_d, conv_dl = [], [], [], [], []
    for _ in range(3):
        res = solve_batch(paper, T)
        thr.append(args.batch / res.seconds)
        conv_d.append(res.converged.mean())
        res = solve_batch(paper, T, options=SolverOptions(load_stepping="auto"))
        thr_auto.append(args.batch / res.seconds)
        res = solve_batch(paper, T, Loads(np.zeros(8), **tip))
        thr_load.append(args.batch / res.seconds)
        conv_dl.append(res.converged.mean())

    result = {
        "startup_s": float(np.median(startup)),
        "cold_tendons_ms": float(np.median(a_ms)),
        "cold_full_ms": float(np.median(b_ms)),
        "warm_ms": float(np.median(c_ms)),
        "throughput_per_s": float(np.median(thr)),
        "throughput_paper_load_per_s": float(np.median(thr_load)),
        "throughput_auto_per_s": float(np.median(thr_auto)),
        "converged_fraction": {"a": a_conv, "b": b_conv, "c": c_conv, "d": float(np.median(conv_d)),
                               "d_load": float(np.median(conv_dl))},
        "load_stepped_fraction_b": b_step,
        "detail": {"startup_s": stats(startup), "cold_tendons_ms": stats(a_ms), "cold_full_ms": stats(b_ms),
                   "warm_ms": stats(c_ms), "throughput_per_s": stats(thr),
                   "throughput_paper_load_per_s": stats(thr_load), "throughput_auto_per_s": stats(thr_auto)},
        "config": {"runs": args.runs, "batch": args.batch, "seed": args.seed, "cpus": os.cpu_count(),
                   "python": platform.python_version(), "numpy": np.__version__, "pytdcr": pytdcr.__version__},
    }
    print(f"start-up (import + cached kernels)  {result['startup_s']:.2f} s")
    for key, label in (("cold_tendons_ms", "a cold, tendons only"), ("cold_full_ms", "b cold, friction+gravity+tip"),
                       ("warm_ms", "c warm start")):
        d = result["detail"][key]
        print(f"{label:34s}  median {d['median']:.3f} ms  (min {d['min']:.3f}, max {d['max']:.3f})")
    print(f"d throughput (friction+gravity)     {result['throughput_per_s']:.0f} solves/s")
    print(f"d throughput under the paper load   {result['throughput_paper_load_per_s']:.0f} solves/s")
    print(f"d throughput, load_stepping='auto'  {result['throughput_auto_per_s']:.0f} solves/s")
    print(f"converged: {result['converged_fraction']}")
    write_result("solve", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

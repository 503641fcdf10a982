"""Continuation from a solved state against a cold solve (paper robot, paper load).

``--samples`` tension vectors uniform in [0, 20] N are solved cold (the loading path from rest); each is then
moved ``--step`` N (Euclidean, a random direction, kept in the bounds) and solved twice through the public
call on one thread: continued from its solved state (``solve(..., start=solution)``) and cold. Reports the
medians and means of both, the ratio of the medians, how many continuations converged, how many snapped, and
how often the continued tip equals the cold one (within 1 um: where it does not, the tension vector has
another equilibrium on the start's branch). Then the same steps as one ``solve_batch(..., start=batch)`` on
all cores, against a cold batch: solves per second.

Prints a summary, writes ``bench/results/continuation.json``; ``--json`` also prints it as the last line.

Usage: python bench/continuation.py [--samples 300] [--step 2.0] [--model pcc] [--seed 0] [--json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr.paper import paper_loads, paper_robot
from pytdcr.runtime import default_threads
from pytdcr.statics import MODELS, solve, solve_batch, warmup


def _moved(rng: np.random.Generator, T: np.ndarray, step: float) -> np.ndarray:
    d = rng.normal(size=T.shape)
    return np.clip(T + step * d / np.linalg.norm(d, axis=1, keepdims=True), 0.0, 20.0)


def singles(robot, starts, T2: np.ndarray, model: str) -> dict:
    """Each row of ``T2`` continued from its start and solved cold, one by one (the public call)."""
    rows = []
    for start, t in zip(starts, T2, strict=True):
        loads = paper_loads(t)
        t0 = time.perf_counter()
        c = solve(robot, loads, model=model, start=start)
        t1 = time.perf_counter()
        k = solve(robot, loads, model=model)
        t2 = time.perf_counter()
        same = c.converged and k.converged and np.linalg.norm(c.tip_position - k.tip_position) < 1e-6
        rows.append((t1 - t0, t2 - t1, c.converged, c.path == "snap", same, k.converged))
    a = np.array(rows, dtype=float)
    return {"continued_median_ms": float(np.median(a[:, 0]) * 1e3), "continued_mean_ms": float(a[:, 0].mean() * 1e3),
            "cold_median_ms": float(np.median(a[:, 1]) * 1e3), "cold_mean_ms": float(a[:, 1].mean() * 1e3),
            "median_ratio": float(np.median(a[:, 0]) / np.median(a[:, 1])), "steps": len(rows),
            "continued_converged": int(a[:, 2].sum()), "snapped": int(a[:, 3].sum()),
            "cold_converged": int(a[:, 5].sum()), "same_as_cold": int(a[:, 4].sum())}


def batches(robot, start_batch, T2: np.ndarray, model: str) -> dict:
    """``T2`` as one continued batch and one cold batch on all cores: solves per second."""
    loads = paper_loads()
    t0 = time.perf_counter()
    c = solve_batch(robot, T2, loads, model=model, start=start_batch)
    t1 = time.perf_counter()
    solve_batch(robot, T2, loads, model=model)
    t2 = time.perf_counter()
    return {"threads": default_threads(), "continued_per_s": len(T2) / (t1 - t0), "cold_per_s": len(T2) / (t2 - t1),
            "continued_converged": int(c.converged.sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--step", type=float, default=2.0)
    ap.add_argument("--model", choices=[m for m, v in MODELS.items() if v.capabilities.continuation], default="pcc")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "continuation")
    args = ap.parse_args()
    if not 10 <= args.samples <= 100_000:
        ap.error(f"--samples must be in [10, 100000], got {args.samples}")
    if not 0.0 < args.step <= 20.0:
        ap.error(f"--step must be in (0, 20] N, got {args.step}")
    warmup()
    robot = paper_robot()
    rng = np.random.default_rng(args.seed)
    T = rng.uniform(0.0, 20.0, (args.samples, robot.n_tendons))
    start_batch = solve_batch(robot, T, paper_loads(), model=args.model)
    keep = np.flatnonzero(start_batch.converged)
    start_batch = start_batch.rows(keep)
    T2 = _moved(rng, start_batch.tensions, args.step)
    starts = [solve(robot, paper_loads(t), model=args.model) for t in start_batch.tensions]
    result = {"model": args.model, "samples": args.samples, "step_N": args.step, "seed": args.seed,
              "single": singles(robot, starts, T2, args.model), "batch": batches(robot, start_batch, T2, args.model)}
    s, b = result["single"], result["batch"]
    print(f"{args.model}, {s['steps']} steps of {args.step:g} N from solved states (one thread, public call):")
    print(f"  continued: median {s['continued_median_ms']:.2f} ms, mean {s['continued_mean_ms']:.2f} ms; "
          f"converged {s['continued_converged']}/{s['steps']}, snapped {s['snapped']}")
    print(f"  cold:      median {s['cold_median_ms']:.2f} ms, mean {s['cold_mean_ms']:.2f} ms; "
          f"converged {s['cold_converged']}/{s['steps']}")
    print(f"  continued / cold (medians): {s['median_ratio']:.2f}; same tip as cold: {s['same_as_cold']}")
    print(f"  batch on {b['threads']} threads: continued {b['continued_per_s']:.0f} /s, cold {b['cold_per_s']:.0f} /s")
    write_result("continuation", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

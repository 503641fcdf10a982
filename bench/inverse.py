"""What inverse statics costs: one target, and a path of targets.

On the paper robot under the paper's tip wrench with ``--model`` (default ``pcc``): ``--n`` targets made by the
forward model (the tips of tension vectors uniform in [0, 20] N, solved from rest; seed ``--seed``), each solved
by :func:`pytdcr.inverse_statics` with each objective asked for: the median, 90th percentile and largest time,
the median solves, how many were reached and by which path (the issue's target: 50 ms to a reachable target),
after the start pool is built (its one-off time is printed too); then a smooth path of ``--path`` targets (the
tips along a smooth change of tensions, continued) solved by :func:`pytdcr.inverse_path` (the issue's target:
2 s for 100 points), with the largest tension change between neighbours; and ``--far`` targets beyond reach
(random directions, 0.45 m from the base), with the distance to the nearest point found.

Prints a table and writes ``bench/results/inverse.json``.

Usage: python bench/inverse.py [--n 100] [--path 100] [--far 5] [--objectives least-squares] [--seed 0]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import TensionBounds, inverse_path, inverse_statics, solve
from pytdcr.paper import paper_loads, paper_robot
from pytdcr.statics import warmup


def _targets(robot, loads, n: int, seed: int) -> np.ndarray:
    """The tips of ``n`` converged solves from rest at tensions uniform in [0, 20] N, (n, 3) [m]."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        sol = solve(robot, loads.with_tensions(rng.uniform(0.0, 20.0, robot.n_tendons)))
        if sol.converged:
            out.append(sol.tip_position)
    return np.array(out)


def _one_objective(robot, loads, bounds, targets: np.ndarray, objective: str, model: str) -> dict:
    """Every target by one objective: times [ms], solves, how many reached and by which path."""
    rs = [inverse_statics(robot, loads, p, bounds=bounds, model=model, objective=objective) for p in targets]
    ms = np.array([r.seconds for r in rs]) * 1e3
    paths = {p: sum(r.path == p for r in rs) for p in ("loading path", "another branch")}
    return {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)), "max_ms": float(ms.max()),
            "median_solves": float(statistics.median(r.evaluations for r in rs)),
            "reached": sum(r.reachable for r in rs), "optimal": sum(r.optimal for r in rs), "paths": paths}


def _path(robot, loads, bounds, k: int, model: str) -> dict:
    """A smooth path of ``k`` targets: the continued tips along a smooth change of tensions."""
    s = np.linspace(0.0, 1.0, k)
    tens = np.stack([6 * s, 3 * np.sin(np.pi * s), 0 * s, 2 * s**2, 1 + 0 * s, 4 * s, 0 * s, 3 * (1 - s)], axis=1)
    pts, last = [], None
    for t in tens:
        last = solve(robot, loads.with_tensions(t), start=last)
        pts.append(last.tip_position)
    t0 = time.perf_counter()
    rs = inverse_path(robot, loads, np.array(pts), bounds=bounds, model=model)
    seconds = time.perf_counter() - t0
    jumps = np.abs(np.diff([r.tensions for r in rs], axis=0)).max()
    return {"points": k, "seconds": seconds, "length_m": float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))),
            "reached": sum(r.reachable for r in rs), "continued": sum(r.path == "continued" for r in rs),
            "largest_tension_change_N": float(jumps)}


def main() -> None:
    """Time the inverse solves; print the medians and write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--path", type=int, default=100)
    ap.add_argument("--far", type=int, default=5)
    ap.add_argument("--objectives", default="least-squares", help="comma-separated")
    ap.add_argument("--model", default="pcc")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "inverse")
    args = ap.parse_args()
    warmup()
    robot, loads = paper_robot(), paper_loads()
    bounds = TensionBounds.uniform(robot.n_tendons, 0.0, 20.0)
    t0 = time.perf_counter()
    inverse_statics(robot, loads, [0.0, 0.1, 0.3], bounds=bounds, model=args.model)  # builds the start pool
    out: dict = {"model": args.model, "n": args.n, "seed": args.seed, "first_call_s": time.perf_counter() - t0}
    targets = _targets(robot, loads, args.n, args.seed)
    out["objectives"] = {}
    for obj in args.objectives.split(","):
        r = out["objectives"][obj] = _one_objective(robot, loads, bounds, targets, obj, args.model)
        print(f"{obj}: {r['reached']} of {args.n} reached ({r['paths']['loading path']} on the loading path, "
              f"{r['optimal']} first-order optimal); median {r['median_ms']:.1f} ms, p90 {r['p90_ms']:.0f} ms, "
              f"largest {r['max_ms']:.0f} ms; median {r['median_solves']:.0f} solves")
    if args.path:
        p = out["path"] = _path(robot, loads, bounds, args.path, args.model)
        print(f"path of {p['points']} targets ({p['length_m'] * 1e3:.0f} mm): {p['seconds']:.2f} s, {p['reached']} "
              f"reached, {p['continued']} continued, largest tension change {p['largest_tension_change_N']:.3f} N")
    if args.far:
        d = np.random.default_rng(args.seed).normal(size=(args.far, 3))
        far = 0.45 * d / np.linalg.norm(d, axis=1, keepdims=True)
        rs = [inverse_statics(robot, loads, p, bounds=bounds, model=args.model) for p in far]
        out["far"] = {"n": args.far, "reached": sum(r.reachable for r in rs),
                      "median_s": statistics.median(r.seconds for r in rs),
                      "distances_m": [r.distance_m for r in rs]}
        print(f"{args.far} targets 0.45 m out: {out['far']['reached']} reached; nearest points found "
              f"{', '.join(f'{x:.3f}' for x in out['far']['distances_m'])} m away; "
              f"median {out['far']['median_s']:.2f} s")
    print(f"first call (builds the start pool): {out['first_call_s']:.2f} s")
    write_result("inverse", out, args.json, out=args.out)


if __name__ == "__main__":
    main()

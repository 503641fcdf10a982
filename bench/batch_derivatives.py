"""What a batch's stability test and tip gradients cost, compiled against the per-row Python reference.

On the paper robot under the paper's load, ``--n`` random tension vectors in [0, 20] N (seed ``--seed``) are
solved once by ``--model``; then, ``--repeat`` times each, the median wall time [ms a row] of: the batch's
stability test (``BatchSolution.stability``: the tangent stiffness compiled, the eigenvalues one stacked LAPACK
call a chunk) and the tip's derivatives by the tensions (``Model.tip_gradients``, compiled),
on 1 and 2 threads; beside them the per-row Python reference each replaced (``stability_at`` and
``_tip_derivative`` row by row, on one thread).

Prints a table and writes ``bench/results/batch_derivatives.json``.

Usage: python bench/batch_derivatives.py [--n 1000] [--model pcc] [--repeat 3] [--seed 0] [--json]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from _common import add_out_argument, write_result

from pytdcr.paper import paper_loads, paper_robot
from pytdcr.statics import solve_batch, warmup
from pytdcr.statics.compiled import _tip_derivative
from pytdcr.statics.registry import resolve


def _median_ms(fn: Callable[[], object], rows: int, repeat: int) -> float:
    """Median wall time of ``fn()`` over ``repeat`` runs [ms a row]."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3 / max(rows, 1)


def main() -> None:
    """Solve the batch once; time each way of testing and differentiating it."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--model", default="pcc")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "batch_derivatives")
    args = ap.parse_args()
    warmup()
    robot, loads = paper_robot(), paper_loads()
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (args.n, robot.n_tendons))
    m, opts = resolve(args.model, robot, loads, None)
    eq = m.equations(robot, loads, opts)
    batches = {k: solve_batch(robot, T, loads, model=m, options=opts, threads=k) for k in (1, 2)}
    ok = batches[1].converged
    rows = int(ok.sum())
    Tk, qk = T[ok], batches[1].q[ok].reshape(rows, -1)
    out: dict = {"model": args.model, "n": args.n, "seed": args.seed, "repeat": args.repeat, "rows": rows,
                 "ms_per_row": {}}
    ms = out["ms_per_row"]
    for k, batch in batches.items():  # the solves themselves, for scale
        ms[f"solve_{k}_threads"] = batch.seconds * 1e3 / args.n
    for k, batch in batches.items():
        # a copy computes its stability afresh (each batch keeps its own once computed), on the batch's threads
        ms[f"stability_{k}_threads"] = _median_ms(lambda b=batch: replace(b).stability, rows, args.repeat)
        ms[f"gradients_{k}_threads"] = _median_ms(
            lambda k=k: m.tip_gradients(robot, Tk, loads, qk, opts, threads=k), rows, args.repeat)
    ms["stability_python_reference"] = _median_ms(
        lambda: [m.stability_at(eq.with_tensions(t), q) for t, q in zip(Tk, qk, strict=True)], rows, args.repeat)
    ms["gradients_python_reference"] = _median_ms(
        lambda: [_tip_derivative(eq.with_tensions(t), q) for t, q in zip(Tk, qk, strict=True)], rows, args.repeat)
    print(f"{args.model}, {rows} of {args.n} rows converged; ms a row (medians of {args.repeat}):")
    for k, v in ms.items():
        print(f"  {k:28s} {v:.3f}")
    write_result("batch_derivatives", out, args.json, out=args.out)


if __name__ == "__main__":
    main()

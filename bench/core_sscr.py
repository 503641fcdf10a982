"""Speed of one evaluation of the subsegment Cosserat rod (``sscr``): the compiled core against numba.

The paper robot (two segments, 20 disks, 8 tendons, 120 unknowns) under the paper's load: gravity, the paper's
friction law, tip force (0.1, 0.1, -0.1) N and moment (-0.1, 0.1, 0.1) N m, tensions pulling one tendon of each
segment, at its solved equilibrium. One ``evaluate`` (residual only, and residual with the exact Jacobian) is
timed three ways:

- ``cpp``: inside C++, a loop of ``repeats`` calls timed with std::chrono (``pytdcr._core._bench_evaluate_sscr``);
- ``cpp_python``: ``SscrModel.evaluate`` called from Python (allocates the outputs, copies the tensions);
- ``numba``: ``pytdcr.statics.kernels.sscr.evaluate`` called from Python into preallocated arrays.

Medians of ``--runs`` samples of ``--repeats`` calls each [s per call]. Writes ``bench/results/core_sscr.json``
and, with ``--json``, prints one JSON object as the last line.

Usage: python bench/core_sscr.py [--runs 15] [--repeats 50] [--json]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial

import numpy as np
from _common import add_out_argument, write_result


def stats(xs: list[float]) -> dict[str, float]:
    """Median, min and max of the samples [s per call] and their count."""
    a = np.asarray(xs)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()), "n": int(a.size)}


def per_call(fn: Callable[[], object], repeats: int) -> float:
    """Seconds per call of ``fn``, timed over ``repeats`` calls from Python."""
    t0 = time.perf_counter()
    for _ in range(repeats):
        fn()
    return (time.perf_counter() - t0) / repeats


def main() -> None:
    """Time the cases and write the result."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=15, help="samples per timed case")
    ap.add_argument("--repeats", type=int, default=50, help="calls per sample")
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "core_sscr")
    args = ap.parse_args()

    import pytdcr
    from pytdcr import _core
    from pytdcr.statics.kernels import sscr as SK
    from pytdcr.statics.sscr import SSCREquations

    robot = pytdcr.paper_robot()
    loads = pytdcr.paper_loads(np.array([2.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0]))
    eq = SSCREquations.build(robot, loads)
    t0 = time.perf_counter()
    sol = pytdcr.solve(robot, loads, model="sscr")  # numba: compiles on first use, else loads the cache
    first_solve = time.perf_counter() - t0
    q = np.ascontiguousarray(sol.q, dtype=float).reshape(-1)
    p = eq.packed
    m = q.size
    t0 = time.perf_counter()
    model = _core.SscrModel.from_packed(p)
    build_model = time.perf_counter() - t0

    r = np.empty(m)
    J = np.empty((m, m))
    J1 = np.empty((1, 1))
    work = SK.make_model_work(p)
    result: dict = {"robot": "paper", "n_disks": eq.n_disks, "n_unknowns": m, "runs": args.runs,
                    "repeats": args.repeats, "first_solve_seconds": first_solve,
                    "build_model_seconds": build_model, "cases": {}}
    # agreement at the timed point (the tests check it everywhere)
    SK.evaluate(q, 1.0, p, True, r, J, work)
    rc, Jc, _ = model.evaluate(q, 1.0, True)
    result["bit_identical"] = bool(np.array_equal(rc, r) and np.array_equal(Jc, J))
    rows = []
    for want_jac in (False, True):
        numba_fn = partial(SK.evaluate, q, 1.0, p, want_jac, r, J if want_jac else J1, work)
        cpp_fn = partial(model.evaluate, q, 1.0, want_jac)
        numba_fn()
        cpp_fn()
        samples: dict[str, list[float]] = {"cpp": [], "cpp_python": [], "numba": []}
        for _ in range(args.runs):  # interleaved, so that a change of the machine's load hits all three alike
            samples["cpp"].append(_core._bench_evaluate_sscr(model, q, 1.0, want_jac, args.repeats))
            samples["cpp_python"].append(per_call(cpp_fn, args.repeats))
            samples["numba"].append(per_call(numba_fn, args.repeats))
        case = {k: stats(v) for k, v in samples.items()}
        case["numba_over_cpp"] = case["numba"]["median"] / case["cpp"]["median"]
        name = "jacobian" if want_jac else "residual"
        result["cases"][name] = case
        rows.append((name, case))

    print(f"sscr evaluate, paper robot ({m} unknowns), {args.runs} samples of {args.repeats} calls: median (min) "
          f"[ms per call]")
    print(f"{'':10s} {'C++ (in C++)':>19s} {'C++ (Python)':>19s} {'numba':>19s} {'numba / C++':>12s}")
    for name, case in rows:
        cells = [f"{1e3 * case[k]['median']:.4f} ({1e3 * case[k]['min']:.4f})" for k in ("cpp", "cpp_python", "numba")]
        print(f"{name:10s} {cells[0]:>19s} {cells[1]:>19s} {cells[2]:>19s} {case['numba_over_cpp']:12.2f}")
    print(f"bit-identical at this point: {result['bit_identical']}")
    write_result("core_sscr", result, args.json, args.out)


if __name__ == "__main__":
    main()

"""Speed of one evaluation of the PCC model's equations: the compiled C++ kernel (pytdcr._core) against the numba
kernel it twins (pytdcr.statics.kernels.pcc); not part of the tests.

The paper robot under the paper's loads: gravity, the paper's friction law, tip force (0.1, 0.1, -0.1) N and
moment (-0.1, 0.1, 0.1) N m, tensions uniform random in [0, 20] N; q an equilibrium solved at full load (or, with
``--state random``, random moderate bends). One core (the process is pinned to one CPU where it can be).

Timed (residual alone, and residual with the exact Jacobian), each the median over rounds that take one sample of
every kind in turn, so that all see the same load on a shared machine:

python   a call from Python: ``PccModel.evaluate(q, lam, want_jac)`` (new r, J, T arrays each call) against
         ``K.evaluate(q, lam, packed, want_jac, r, J, work)`` (preallocated; unboxing the Packed and Work
         namedtuples each call). Both carry the call's overhead.
kernel   the kernel's own cost: a loop of calls timed inside C++ (``pytdcr._core._bench_evaluate``, std::chrono),
         and a loop of calls timed inside numba (a jitted loop calling the kernel; compiled on first use). Many
         short loops (``--loop-seconds``), their median: a long loop on a shared machine also times the other
         processes that preempt it. numba's loop is less the cost of calling it (an empty loop's median).

Also records how the two agree at the timed state (max |difference| of residual, Jacobian and tensions).

Prints a table, writes ``bench/results/core_pcc.json`` and, with ``--json``, prints one JSON object as the last
line. Medians are quoted: these machines are noisy.

Usage: python bench/core_pcc.py [--rounds 2001] [--state solved|random] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numba
import numpy as np
from _common import add_out_argument, write_result

import pytdcr
from pytdcr import Loads, _core, paper_robot
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
from pytdcr.statics.kernels import pcc as K
from pytdcr.statics.pcc import PCCEquations


@numba.njit(cache=True)
def numba_loop(q, lam, packed, want_jac, r, J, work, repeats):  # pragma: no cover - compiled
    """``repeats`` calls of the numba kernel, in numba (no Python between them)."""
    for _ in range(repeats):
        K.evaluate(q, lam, packed, want_jac, r, J, work)


def stats(xs: list[float]) -> dict[str, float]:
    """Median, min, max and count of ``xs``."""
    a = np.asarray(xs)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()), "n": int(a.size)}


def pin_one_core() -> int | None:
    """Pin this process to one of the CPUs it may run on (the last); returns it, or None where not possible."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    cpu = max(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})
    return cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2001,
                    help="rounds per case, each timing one call of each kind and one loop of each kind")
    ap.add_argument("--loop-seconds", type=float, default=0.0003,
                    help="about how long each timed loop runs [s] (shorter than a scheduler time slice)")
    ap.add_argument("--state", choices=("solved", "random"), default="solved",
                    help="q: an equilibrium under the loads (default), or random moderate bends")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "core_pcc")
    args = ap.parse_args()

    cpu = pin_one_core()
    rng = np.random.default_rng(args.seed)
    robot = paper_robot()  # gravity and the paper's exponential friction law
    tensions = rng.uniform(0.0, 20.0, 8)
    loads = Loads(tensions, tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)
    packed = PCCEquations.build(robot, loads).packed
    model = _core.PccModel.from_packed(packed)
    n = packed.sub.shape[0]
    m = 3 * n
    state = args.state
    if state == "solved":
        sol = pytdcr.solve(robot, loads)
        if sol.converged:
            q = np.ascontiguousarray(sol.q, dtype=float).reshape(-1)
        else:  # pragma: no cover - the paper's loads converge
            state = "random (the solve did not converge)"
    if state != "solved":
        q = rng.normal(size=m) * 3.0  # moderate bends: |kappa| ~ 3 /m, about 0.06 rad per subsegment
    lam = 1.0

    r = np.empty(m)
    J = np.empty((m, m))
    J1 = np.empty((1, 1))
    work = K.make_model_work(packed)

    # agreement at the timed state
    K.evaluate(q, lam, packed, True, r, J, work)
    rc, Jc, Tc = model.evaluate(q, lam, True)
    agreement = {"residual": float(np.abs(rc - r).max()), "jacobian": float(np.abs(Jc - J).max()),
                 "tensions": float(np.abs(Tc - work.T).max()), "max_abs_residual": float(np.abs(r).max()),
                 "max_abs_jacobian": float(np.abs(J).max())}

    def numba_seconds(want_jac: bool, repeats: int, overhead: float = 0.0) -> float:
        """Seconds per call of a loop of ``repeats`` calls in numba, less ``overhead`` (the loop's own call)."""
        t0 = time.perf_counter_ns()
        numba_loop(q, lam, packed, want_jac, r, J if want_jac else J1, work, repeats)
        return ((time.perf_counter_ns() - t0) * 1e-9 - overhead) / max(repeats, 1)

    t0 = time.perf_counter()
    numba_seconds(False, 1)
    numba_seconds(True, 1)
    loop_compile_s = time.perf_counter() - t0

    detail: dict[str, dict[str, float]] = {}
    result_us: dict[str, dict[str, float]] = {}
    for want_jac, case in ((False, "residual"), (True, "jacobian")):
        Jn = J if want_jac else J1

        def py_cpp(w: bool = want_jac) -> object:
            return model.evaluate(q, lam, w)

        def py_numba(w: bool = want_jac, Jn: np.ndarray = Jn) -> object:
            return K.evaluate(q, lam, packed, w, r, Jn, work)

        # the call into numba (unboxing the Packed and Work namedtuples): the median of empty loops
        overhead = float(np.median([numba_seconds(want_jac, 0) for _ in range(201)]))
        # loops of about --loop-seconds each
        one = max(_core._bench_evaluate(model, q, lam, want_jac, 50), 1e-9)
        reps_cpp = max(3, int(args.loop_seconds / one))
        one = max(numba_seconds(want_jac, 50, overhead), 1e-9)
        reps_numba = max(3, int(args.loop_seconds / one))
        for _ in range(20):  # warm up
            py_cpp()
            py_numba()
        # round robin: one sample of each per round, so that all four see the same (changing) load
        samples: dict[str, list[float]] = {"python_cpp": [], "python_numba": [], "kernel_cpp": [],
                                           "kernel_numba": []}
        clock = time.perf_counter_ns
        for _ in range(args.rounds):
            t0 = clock()
            py_cpp()
            samples["python_cpp"].append((clock() - t0) * 1e-3)
            t0 = clock()
            py_numba()
            samples["python_numba"].append((clock() - t0) * 1e-3)
            samples["kernel_cpp"].append(_core._bench_evaluate(model, q, lam, want_jac, reps_cpp) * 1e6)
            samples["kernel_numba"].append(numba_seconds(want_jac, reps_numba, overhead) * 1e6)
        py_cpp_us, py_numba_us = samples["python_cpp"], samples["python_numba"]
        loop_cpp, loop_numba = samples["kernel_cpp"], samples["kernel_numba"]
        detail[f"{case}_numba_loop_call_overhead_us"] = {"median": overhead * 1e6}
        detail[f"{case}_loop_repeats"] = {"cpp": reps_cpp, "numba": reps_numba}
        for key, xs in (("python_cpp", py_cpp_us), ("python_numba", py_numba_us), ("kernel_cpp", loop_cpp),
                        ("kernel_numba", loop_numba)):
            detail[f"{case}_{key}_us"] = stats(xs)
        result_us[case] = {key: detail[f"{case}_{key}_us"]["median"]
                           for key in ("python_cpp", "python_numba", "kernel_cpp", "kernel_numba")}
        result_us[case]["kernel_speedup"] = result_us[case]["kernel_numba"] / result_us[case]["kernel_cpp"]
        result_us[case]["python_speedup"] = result_us[case]["python_numba"] / result_us[case]["python_cpp"]

    result = {
        "evaluate_us": result_us,
        "agreement": agreement,
        "numba_loop_compile_s": loop_compile_s,
        "detail": detail,
        "config": {"state": state, "lam": lam, "n_disks": n, "n_unknowns": m, "tensions_N": tensions.tolist(),
                   "rounds": args.rounds, "seed": args.seed, "pinned_cpu": cpu,
                   "cpus": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
                   "numba": numba.__version__, "pytdcr": pytdcr.__version__},
    }
    print(f"paper robot, N = {n} ({m} unknowns), q {state}, one core (cpu {cpu}); medians [us]")
    print(f"{'':10s} {'python C++':>11s} {'python numba':>13s} {'kernel C++':>11s} {'kernel numba':>13s} "
          f"{'speed-up (kernel)':>18s}")
    for case in ("residual", "jacobian"):
        d = result_us[case]
        print(f"{case:10s} {d['python_cpp']:11.2f} {d['python_numba']:13.2f} {d['kernel_cpp']:11.2f} "
              f"{d['kernel_numba']:13.2f} {d['kernel_speedup']:17.2f}x")
    print(f"agreement (max |C++ - numba|): residual {agreement['residual']:.3g}, Jacobian {agreement['jacobian']:.3g},"
          f" tensions {agreement['tensions']:.3g}")
    write_result("core_pcc", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

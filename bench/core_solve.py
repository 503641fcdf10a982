"""Cold-solve time per case of the PCC model: the compiled core (pytdcr._core.solve_range_pcc, C++) against the
numba solver (pytdcr.statics.kernels.loading_path.solve_range), on one core (not part of the tests).

Each case is one random tension vector, uniform in [0, 20] N, on the paper robot with the paper's friction law,
gravity and tip load (force (0.1, 0.1, -0.1) N, moment (-0.1, 0.1, 0.1) N m), solved from the straight robot
with the library's default options (the loading path). Both solvers solve the same cases one by one, one call
per case, BLAS on one thread, the kernels already compiled (numba's loaded from its cache and run once first).
Also reports how often the two agree (converged flags, path codes) and the largest q difference [rad] where
both converged on the same path.

Prints a table, writes ``bench/results/core_solve.json`` and, with ``--json``, prints one JSON object as the
last line. Medians are quoted: these machines are noisy.

Usage: python bench/core_solve.py [--cases 200] [--repeats 3] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
from _common import add_out_argument, write_result


def stats(ms: np.ndarray) -> dict[str, float]:
    """Median, mean, min and max [ms] and the count of the per-case times ``ms``."""
    return {"median_ms": float(np.median(ms)), "mean_ms": float(np.mean(ms)), "min_ms": float(np.min(ms)),
            "max_ms": float(np.max(ms)), "n": int(ms.size)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=200, help="random tension vectors")
    ap.add_argument("--repeats", type=int, default=3, help="times each case is solved by each solver (best kept)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "core_solve")
    args = ap.parse_args()

    import pytdcr
    from pytdcr import Loads, SolverOptions, paper_robot
    from pytdcr import _core as core
    from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
    from pytdcr.runtime import single_threaded_blas
    from pytdcr.statics.compiled import case_tolerances, kernel_settings
    from pytdcr.statics.kernels import loading_path as SV
    from pytdcr.statics.pcc import PCC

    robot = paper_robot()
    loads = Loads(np.zeros(8), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)
    options = SolverOptions()
    packed = PCC.equations(robot, loads, options).packed
    model = core.PccModel.from_packed(packed)
    settings = kernel_settings(options)
    rng = np.random.default_rng(args.seed)
    T = rng.uniform(0.0, 20.0, (args.cases, 8))
    tols = case_tolerances(robot, loads, T, settings.atol)
    m = model.n_unknowns
    Q0 = np.zeros((args.cases, m))

    def outputs() -> tuple[np.ndarray, ...]:
        nb = args.cases
        return (np.empty((nb, m)), np.empty(nb, dtype=np.bool_), np.empty(nb), np.empty(nb, dtype=np.int64),
                np.empty(nb, dtype=np.int64), np.empty(nb, dtype=np.int64))

    def numba_range(out: tuple[np.ndarray, ...], b: int) -> None:
        SV.solve_range(Q0, packed, packed, T, T, settings, tols, b, b + 1, *out)

    def core_range(out: tuple[np.ndarray, ...], b: int) -> None:
        core.solve_range_pcc(Q0, model, model, T, T, settings, tols, b, b + 1, *out)

    solvers = {"numba": numba_range, "core": core_range}
    outs = {name: outputs() for name in solvers}
    times = {name: np.full(args.cases, np.inf) for name in solvers}
    with single_threaded_blas():
        for name, run in solvers.items():
            run(outs[name], 0)  # numba: load the compiled solver from its cache
        for _ in range(args.repeats):
            for b in range(args.cases):
                for name, run in solvers.items():  # alternate, so that both see the same load on the machine
                    t0 = time.perf_counter()
                    run(outs[name], b)
                    times[name][b] = min(times[name][b], time.perf_counter() - t0)

    ref, got = outs["numba"], outs["core"]
    same_path = ref[5] == got[5]
    both = ref[1] & got[1] & same_path
    d = (ref[0] - got[0]).reshape(args.cases, -1, 3)
    dq = np.max(np.maximum(np.hypot(d[..., 0], d[..., 1]) * packed.sub[:, 0], np.abs(d[..., 2])), axis=1)
    result = {
        "numba": stats(times["numba"] * 1e3),
        "core": stats(times["core"] * 1e3),
        "speedup_median": float(np.median(times["numba"]) / np.median(times["core"])),
        "speedup_mean": float(np.mean(times["numba"]) / np.mean(times["core"])),
        "converged_fraction": {"numba": float(ref[1].mean()), "core": float(got[1].mean())},
        "agreement": {"flags_differ": int((ref[1] != got[1]).sum()), "paths_differ": int((~same_path).sum()),
                      "max_dq_rad": float(dq[both].max()) if both.any() else None},
        "config": {"cases": args.cases, "repeats": args.repeats, "seed": args.seed, "cpus": os.cpu_count(),
                   "threads": 1, "python": platform.python_version(), "numpy": np.__version__,
                   "pytdcr": pytdcr.__version__},
    }
    for name in solvers:
        s = result[name]
        print(f"{name:6s} cold solve per case: median {s['median_ms']:.3f} ms, mean {s['mean_ms']:.3f} ms "
              f"(min {s['min_ms']:.3f}, max {s['max_ms']:.3f}; {s['n']} cases, best of {args.repeats})")
    print(f"numba / core: median {result['speedup_median']:.2f}x, mean {result['speedup_mean']:.2f}x; "
          f"agreement {result['agreement']}")
    write_result("core_solve", result, args.json, args.out)


if __name__ == "__main__":
    main()

"""Cold-solve time per case of the PCC model and the subsegment Cosserat rod (sscr): the compiled core
(pytdcr._core.solve_range_pcc, solve_range_sscr, C++) against the numba solver
(pytdcr.statics.kernels.loading_path.solve_range), on one core (not part of the tests).

Each case is one random tension vector, uniform in [0, 20] N, on the paper robot with the paper's friction law,
gravity and tip load (force (0.1, 0.1, -0.1) N, moment (-0.1, 0.1, 0.1) N m), solved from the straight robot
with the model's default options (the loading path; sscr's default rod and fold handling, arclength). Both
solvers solve the same cases one by one, one call per case, BLAS on one thread, the kernels already compiled
(numba's loaded from its cache and run once first). Also reports how often the two agree (converged flags, path
codes) and the largest q difference where both converged on the same path: pcc [rad] (a subsegment's bend or
twist), sscr [N m] (a base wrench).

Prints a table, writes ``bench/results/core_solve.json`` (one entry per model under ``models``) and, with
``--json``, prints one JSON object as the last line. Medians are quoted: these machines are noisy.

Usage: python bench/core_solve.py [--model pcc|sscr|all] [--cases 200] [--repeats 3] [--json]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from _common import add_out_argument, write_result

#: the default case count per model (an sscr solve takes ~10x a pcc solve)
DEFAULT_CASES = {"pcc": 200, "sscr": 60}


def stats(ms: np.ndarray) -> dict[str, float]:
    """Median, mean, min and max [ms] and the count of the per-case times ``ms``."""
    return {"median_ms": float(np.median(ms)), "mean_ms": float(np.mean(ms)), "min_ms": float(np.min(ms)),
            "max_ms": float(np.max(ms)), "n": int(ms.size)}


class Setup(NamedTuple):
    """One model's cases: the numba packed model, the core's, its solve_range, the settings and the q metric."""

    packed: Any
    model: Any
    core_range: Callable[..., None]
    settings: Any
    tols: np.ndarray
    dq: Callable[[np.ndarray, np.ndarray], np.ndarray]  # per case, the q difference of two (B, m) arrays
    dq_unit: str


def setup(name: str, T: np.ndarray) -> Setup:
    """The paper robot under the paper's load for model ``name`` ("pcc" or "sscr"), the cases' tensions T."""
    from pytdcr import Loads, paper_robot
    from pytdcr import _core as core
    from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
    from pytdcr.statics.compiled import case_tolerances, kernel_settings
    from pytdcr.statics.registry import MODELS

    robot = paper_robot()
    loads = Loads(np.zeros(8), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)
    entry = MODELS[name]
    options = entry.default_options()
    eq = entry.equations(robot, loads, options)
    settings = kernel_settings(options)
    tols = case_tolerances(robot, loads, T, settings.atol)
    if name == "pcc":
        sub = eq.packed.sub

        def dq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            d = (a - b).reshape(a.shape[0], -1, 3)
            return np.max(np.maximum(np.hypot(d[..., 0], d[..., 1]) * sub[:, 0], np.abs(d[..., 2])), axis=1)

        return Setup(eq.packed, core.PccModel.from_packed(eq.packed), core.solve_range_pcc, settings, tols, dq,
                     "rad")
    return Setup(eq.packed, core.SscrModel.from_packed(eq.packed), core.solve_range_sscr, settings, tols,
                 lambda a, b: np.max(np.abs(a - b), axis=1), "Nm")


def bench_model(name: str, cases: int, repeats: int, seed: int) -> dict:
    """Time both solvers on ``cases`` random cases of model ``name``, each the best of ``repeats``."""
    from pytdcr.runtime import single_threaded_blas
    from pytdcr.statics.kernels import loading_path as SV

    T = np.random.default_rng(seed).uniform(0.0, 20.0, (cases, 8))
    s = setup(name, T)
    m = s.model.n_unknowns
    Q0 = np.zeros((cases, m))

    def outputs() -> tuple[np.ndarray, ...]:
        return (np.empty((cases, m)), np.empty(cases, dtype=np.bool_), np.empty(cases),
                np.empty(cases, dtype=np.int64), np.empty(cases, dtype=np.int64), np.empty(cases, dtype=np.int64))

    def numba_range(out: tuple[np.ndarray, ...], b: int) -> None:
        SV.solve_range(Q0, s.packed, s.packed, T, T, s.settings, s.tols, b, b + 1, *out)

    def core_range(out: tuple[np.ndarray, ...], b: int) -> None:
        s.core_range(Q0, s.model, s.model, T, T, s.settings, s.tols, b, b + 1, *out)

    solvers = {"numba": numba_range, "core": core_range}
    outs = {key: outputs() for key in solvers}
    times = {key: np.full(cases, np.inf) for key in solvers}
    with single_threaded_blas():
        for key, run in solvers.items():
            run(outs[key], 0)  # numba: load the compiled solver from its cache
        for _ in range(repeats):
            for b in range(cases):
                for key, run in solvers.items():  # alternate, so that both see the same load on the machine
                    t0 = time.perf_counter()
                    run(outs[key], b)
                    times[key][b] = min(times[key][b], time.perf_counter() - t0)

    ref, got = outs["numba"], outs["core"]
    same_path = ref[5] == got[5]
    both = ref[1] & got[1] & same_path
    dq = s.dq(ref[0], got[0])
    return {
        "numba": stats(times["numba"] * 1e3),
        "core": stats(times["core"] * 1e3),
        "speedup_median": float(np.median(times["numba"]) / np.median(times["core"])),
        "speedup_mean": float(np.mean(times["numba"]) / np.mean(times["core"])),
        "converged_fraction": {"numba": float(ref[1].mean()), "core": float(got[1].mean())},
        "agreement": {"flags_differ": int((ref[1] != got[1]).sum()), "paths_differ": int((~same_path).sum()),
                      f"max_dq_{s.dq_unit}": float(dq[both].max()) if both.any() else None},
        "cases": cases,
        "unknowns": int(m),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", choices=("pcc", "sscr", "all"), default="all")
    ap.add_argument("--cases", type=int, default=None,
                    help=f"random tension vectors per model (default {DEFAULT_CASES})")
    ap.add_argument("--repeats", type=int, default=3, help="times each case is solved by each solver (best kept)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "core_solve")
    args = ap.parse_args()

    import pytdcr

    names = ("pcc", "sscr") if args.model == "all" else (args.model,)
    models = {}
    for name in names:
        cases = args.cases if args.cases is not None else DEFAULT_CASES[name]
        r = models[name] = bench_model(name, cases, args.repeats, args.seed)
        for key in ("numba", "core"):
            st = r[key]
            print(f"{name:4s} {key:6s} cold solve per case: median {st['median_ms']:.3f} ms, mean "
                  f"{st['mean_ms']:.3f} ms (min {st['min_ms']:.3f}, max {st['max_ms']:.3f}; {st['n']} cases, best "
                  f"of {args.repeats})")
        print(f"{name:4s} numba / core: median {r['speedup_median']:.2f}x, mean {r['speedup_mean']:.2f}x; "
              f"agreement {r['agreement']}")
    result = {
        "models": models,
        "config": {"models": list(names), "repeats": args.repeats, "seed": args.seed, "cpus": os.cpu_count(),
                   "threads": 1, "python": platform.python_version(), "numpy": np.__version__,
                   "pytdcr": pytdcr.__version__},
    }
    write_result("core_solve", result, args.json, args.out)


if __name__ == "__main__":
    main()

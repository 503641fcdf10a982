"""Where a cold solve's time goes, and whether warm starts could replace it (paper robot, paper load).

``--model``: ``pcc`` (default), ``pcc2`` or ``sscr``. The workspace's sampling speed is bound by the
loading-path solve under the paper's load (docs/validation.md).
This script measures what a faster solver would have to attack:

- kernel: one residual, one exact Jacobian and one inverse of it (the quasi-Newton's pieces) [us, medians];
  for ``sscr`` also the Jacobian's phases: the rod integrated with and without its tangents, the chained
  sensitivities, the tendons with and without their pose lanes, and the disks' loads with their derivatives;
- cold: ``--samples`` uniform tension vectors in [0, 20] N solved one by one on one thread along the loading
  path: the time per solve (median, mean), the share of the total time taken by each path (loading,
  snap-through, fallback, not converged) and by the slowest tenth, with their iterations and Jacobians;
- warm: the second half solved from the nearest solved loading-path equilibrium of the first half (Newton at
  full load, no load steps), on all cores: solves per second, agreement with the cold solves (tips within
  1 um), and the agreement left after keeping only the warm solves below a quantile of the Newton iterations,
  of the change of the unknowns and of the neighbour's distance (is there a filter that finds the
  disagreeing ones?).

Prints a summary, writes ``bench/results/solve_profile_<model>.json``; ``--json`` also prints it as the last line.

Usage: python bench/solve_profile.py [--samples 1500] [--seed 0] [--model pcc] [--json]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from _common import add_out_argument, write_result
from numba import njit
from scipy.spatial import cKDTree

from pytdcr.paper import paper_loads, paper_robot
from pytdcr.statics import SolvePath, solve_batch, warmup
from pytdcr.statics.compiled import case_tolerances, kernel_settings
from pytdcr.statics.kernels import loading_path as SV
from pytdcr.statics.registry import get_model

#: the models solved by the compiled solver (their kernels are timed here)
COMPILED = ("pcc", "pcc2", "sscr")


@njit(cache=False)
def _invert(J, reps):  # pragma: no cover - timing only
    H = np.linalg.inv(J)
    for _ in range(reps - 1):
        H = np.linalg.inv(J)
    return H


def _per_call(fn, reps: int = 2000, rounds: int = 5) -> float:
    """Median over ``rounds`` of the time per call of ``fn(reps)`` [us]."""
    ts = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn(reps)
        ts.append((time.perf_counter() - t0) / reps * 1e6)
    return float(np.median(ts))


def kernel_costs(eq, q: np.ndarray) -> dict[str, float]:
    """One residual, one Jacobian, one inverse [us] at ``q``."""
    n = q.size
    r, J, J1 = np.empty(n), np.empty((n, n)), np.empty((1, 1))
    K = SV.KERNELS[type(eq.packed)]
    work = K.make_model_work(eq.packed)

    def residuals(reps: int) -> None:
        for _ in range(reps):
            K.evaluate(q, 1.0, eq.packed, False, r, J1, work)

    def jacobians(reps: int) -> None:
        for _ in range(reps):
            K.evaluate(q, 1.0, eq.packed, True, r, J, work)

    jacobians(1)
    _invert(J, 1)
    out = {"residual_us": _per_call(residuals), "jacobian_us": _per_call(jacobians, 500),
           "inverse_us": _per_call(lambda reps: _invert(J, reps), 500), "unknowns": n}
    if K.__name__.endswith(".sscr"):
        out["jacobian_phases_us"] = sscr_phases(K, eq.packed, q, work)
    return out


def sscr_phases(K, packed, q: np.ndarray, work) -> dict[str, float]:
    """The pieces of one ``sscr`` Jacobian [us, medians], called one by one from Python (each call's overhead,
    about a microsecond, included); ``work`` holds an evaluation with the Jacobian at ``q``."""
    load, A = np.empty(6), np.zeros((6, 18))
    n = packed.sub.shape[0]

    def loop(fn):
        return lambda reps: [fn() for _ in range(reps)]

    def disk_loads() -> None:
        for i in range(1, n + 1):
            K._disk_load(i, 1.0, packed, True, work, load, A)

    return {"rod_with_tangents": _per_call(loop(lambda: K._chain(q, 1.0, packed, True, work)), 300),
            "rod_alone": _per_call(loop(lambda: K._chain(q, 1.0, packed, False, work)), 300),
            "sensitivities": _per_call(loop(lambda: K._sensitivities(packed, work)), 300),
            "tendons_with_lanes": _per_call(loop(lambda: K._tendons(1.0, packed, True, work)), 300),
            "tendons_alone": _per_call(loop(lambda: K._tendons(1.0, packed, False, work)), 300),
            "disk_loads_with_derivatives": _per_call(loop(disk_loads), 300)}


def cold(eq, T: np.ndarray, tols: np.ndarray, options) -> tuple[dict, np.ndarray]:
    """Solve every row of ``T`` on one thread, each to its tolerances ``tols`` (B, 2) [N m] as the library would
    with ``options``; returns the summary and the per-solve table."""
    base = kernel_settings(options)
    K = SV.KERNELS[type(eq.packed)]
    work = K.make_model_work(eq.packed)
    q0 = np.zeros(eq.n_unknowns)
    rows = []
    for t, (tol, step) in zip(T, tols, strict=True):
        m = K.with_tension(eq.packed, t)
        settings = base._replace(atol=float(tol), step_atol=float(step))
        t0 = time.perf_counter()
        o = SV.solve_one(q0, SV.Homotopy(m, m, True), settings, work)
        rows.append((time.perf_counter() - t0, o.path if o.converged else -1, o.iterations, o.jacobians))
    a = np.array(rows)
    total = a[:, 0].sum()
    out: dict = {"solves": len(T), "median_ms": float(np.median(a[:, 0]) * 1e3),
                 "mean_ms": float(a[:, 0].mean() * 1e3), "by_path": {}}
    for code, name in [(-1, "not converged"), *((m.code, m.value) for m in SolvePath if m.code >= 0)]:
        s = a[:, 1] == code
        if s.any():
            out["by_path"][name] = {"fraction": float(s.mean()), "time_share": float(a[s, 0].sum() / total),
                                    "mean_ms": float(a[s, 0].mean() * 1e3), "iterations": float(a[s, 2].mean()),
                                    "jacobians": float(a[s, 3].mean())}
    slow = a[:, 0] > np.quantile(a[:, 0], 0.9)
    out["slowest_tenth_time_share"] = float(a[slow, 0].sum() / total)
    return out, a


def warm(robot, loads, T: np.ndarray, q: np.ndarray, tip: np.ndarray, ok: np.ndarray, model: str) -> dict:
    """Warm starts of the second half of ``T`` from the nearest solved loading-path case of the first half."""
    half = len(T) // 2
    anchors = np.flatnonzero(ok[:half])
    targets = np.arange(half, len(T))
    dist, idx = cKDTree(T[anchors]).query(T[targets])
    nb = anchors[idx]
    opts = replace(get_model(model).default_options(), load_stepping="never")
    t0 = time.perf_counter()
    w = solve_batch(robot, T[targets], loads, q0=q[nb].reshape(len(targets), -1, q.shape[1] // robot.n_disks),
                    options=opts, model=model)
    sec = time.perf_counter() - t0
    both = w.converged & ok[targets]
    agree = np.linalg.norm(w.tip_position - tip[targets], axis=1) < 1e-6
    change = np.abs(w.q.reshape(len(targets), -1) - q[nb]).max(axis=1)
    filters = {}
    for name, feat in [("iterations", w.iterations.astype(float)), ("change", change), ("distance_N", dist)]:
        rows = []
        for level in (0.25, 0.5, 0.75):
            keep = both & (feat <= np.quantile(feat[both], level))
            rows.append({"quantile": level, "kept": float(keep.sum() / len(targets)),
                         "agreement": float(agree[keep].mean())})
        filters[name] = rows
    return {"targets": len(targets), "solves_per_s": len(targets) / sec, "converged": float(w.converged.mean()),
            "neighbour_distance_median_N": float(np.median(dist)), "agreement": float(agree[both].mean()),
            "filters": filters}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--model", default="pcc", choices=COMPILED)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "solve_profile_<model>")
    args = ap.parse_args()
    if not 20 <= args.samples <= 1_000_000:
        ap.error(f"--samples must be in [20, 1000000], got {args.samples}")
    warmup()
    robot, loads = paper_robot(), paper_loads()
    model = get_model(args.model)
    options = model.default_options()
    eq = model.equations(robot, loads, options)
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (args.samples, robot.n_tendons))
    summary, table = cold(eq, T, case_tolerances(robot, loads, T, options.atol), options)
    ok = table[:, 1] == SolvePath.LOADING.code
    cases = solve_batch(robot, T, loads, model=args.model)  # the same cold solves, for the unknowns and tips
    q_mid = cases.q[int(np.flatnonzero(ok)[0])].ravel()
    result = {"samples": args.samples, "seed": args.seed, "model": args.model, "kernel": kernel_costs(eq, q_mid),
              "cold": summary,
              "warm": warm(robot, loads, T, cases.q.reshape(len(T), -1), cases.tip_position,
                           ok & cases.converged, args.model)}
    k, c, w = result["kernel"], result["cold"], result["warm"]
    print(f"kernel ({k['unknowns']} unknowns): residual {k['residual_us']:.1f} us, Jacobian {k['jacobian_us']:.1f} "
          f"us, inverse {k['inverse_us']:.1f} us")
    for name, us in k.get("jacobian_phases_us", {}).items():
        print(f"  Jacobian phase {name:28s} {us:7.1f} us")
    print(f"cold, one thread: median {c['median_ms']:.2f} ms, mean {c['mean_ms']:.2f} ms; the slowest tenth takes "
          f"{100 * c['slowest_tenth_time_share']:.0f} % of the time")
    for name, p in c["by_path"].items():
        print(f"  {name:14s} {100 * p['fraction']:5.1f} % of solves, {100 * p['time_share']:5.1f} % of the time, "
              f"{p['mean_ms']:6.2f} ms, {p['iterations']:.0f} iterations, {p['jacobians']:.0f} Jacobians")
    print(f"warm from the nearest of {len(T) // 2} (median {w['neighbour_distance_median_N']:.1f} N away): "
          f"{w['solves_per_s']:.0f} solves/s, converged {100 * w['converged']:.1f} %, agree "
          f"{100 * w['agreement']:.1f} %")
    for name, rows in w["filters"].items():
        print(f"  kept by {name}: " + ", ".join(f"{100 * r['kept']:.0f} % kept -> {100 * r['agreement']:.1f} %"
                                                for r in rows))
    write_result(f"solve_profile_{args.model}", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

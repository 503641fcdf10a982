"""Benchmark of the Cosserat-rod model and of ``tdcr compare``.

Cases (paper robot without friction, which the Cosserat model does not have;
random tensions in [0, 20] N, 10 disks per segment):

(a) tendons and gravity, cold start, default options (loading path);
(b) (a) plus the paper's tip force (0.1, 0.1, -0.1) N and moment (-0.1, 0.1, 0.1) N m;
(c) (a) with ``load_stepping="auto"`` (Newton at full load first);
(d) warm start from the solution of a neighbouring tension vector;
(e) the comparison table of ``tdcr compare`` for 100 random cases (0-20 N, gravity), both models.

Medians over the runs; convergence counted on every case. Prints a table,
writes ``bench/results/cosserat.json`` and, with ``--json``, prints one JSON
object as the last line.

Usage: python bench/cosserat.py [--runs 200] [--json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import CosseratOptions, Loads, NoFriction, paper_robot, solve
from pytdcr.compare import compare_models
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
from pytdcr.statics import warmup


def stats(xs: list[float]) -> dict[str, float]:
    a = np.asarray(xs) * 1e3
    return {"median_ms": float(np.median(a)), "p90_ms": float(np.percentile(a, 90)), "max_ms": float(a.max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200, help="solves per timed case")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "cosserat")
    args = ap.parse_args()
    t0 = time.perf_counter()
    warmup()
    compile_s = time.perf_counter() - t0
    robot = paper_robot(NoFriction())
    rng = np.random.default_rng(args.seed)
    T = rng.uniform(0.0, 20.0, size=(args.runs, robot.n_tendons))
    paper_load = {"tip_force": PAPER_TIP_FORCE, "tip_moment": PAPER_TIP_MOMENT}
    result: dict = {"runs": args.runs, "seed": args.seed, "warmup_s": compile_s}

    def timed(name: str, opts: CosseratOptions, load: dict, warm: bool = False) -> None:
        times, ok = [], 0
        for t in T:
            q0 = None
            if warm:
                near = solve(robot, Loads(t * 0.98, **load), model="cosserat", options=opts)
                q0 = near.q if near.converged else None
            s = solve(robot, Loads(t, **load), model="cosserat", q0=q0, options=opts)
            times.append(s.seconds)
            ok += s.converged
        result[name] = {**stats(times), "converged": ok, "cases": len(T)}
        r = result[name]
        print(f"{name:32s} median {r['median_ms']:7.2f} ms  p90 {r['p90_ms']:7.2f}  max {r['max_ms']:7.1f}  "
              f"converged {ok}/{len(T)}")

    timed("a_tendons_gravity", CosseratOptions(), {})
    timed("b_paper_tip_load", CosseratOptions(), paper_load)
    timed("c_auto_stepping", CosseratOptions(load_stepping="auto"), {})
    timed("d_warm_start", CosseratOptions(), {}, warm=True)
    Tc = np.random.default_rng(args.seed + 1).uniform(0.0, 20.0, size=(100, robot.n_tendons))
    t1 = time.perf_counter()
    cmp = compare_models(robot, Loads(np.zeros(robot.n_tendons)), Tc)
    result["e_compare_100"] = {"seconds": time.perf_counter() - t1, **cmp.summary().to_json()}
    e = result["e_compare_100"]
    print(f"{'e_compare_100':32s} {e['seconds']:.2f} s; both converged {e['all_converged']}/100; tip difference "
          f"median {e['cosserat_difference_median_mm']:.3f} mm, max {e['cosserat_difference_max_mm']:.3f} mm")
    write_result("cosserat", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

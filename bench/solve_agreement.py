"""Which equilibrium the loading path reaches, against a reference with load steps four times finer.

Random tension vectors uniform in [0, 20] N under the paper's load (gravity, the paper's friction law, tip force
(0.1, 0.1, -0.1) N and moment (-0.1, 0.1, 0.1) N m), each solved along the loading path twice: with the default
load steps and with ``SolverOptions(step_scale=0.25)`` (the step target and the largest step four times smaller).
Reports how many converged each way, on how many both reached the same equilibrium (tips within 1 um), and
for the others: whether both are equilibria, the distance between their tips, whether the solver's answer is
unstable where the reference's is stable, and how each was reached. Also the median and mean time per solve
of both (one thread, through the public call).

Prints a summary, writes ``bench/results/solve_agreement.json``; ``--json`` also prints it as the last line.

Usage: python bench/solve_agreement.py [--samples 3000] [--seed 0] [--model pcc] [--json]
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import paper_loads, paper_robot, solve_batch
from pytdcr.statics import MODELS, configure, warmup

#: the same equilibrium: tips closer than this [m]
SAME_TIP = 1e-6


def solve_all(robot, T: np.ndarray, loads, model: str, options) -> tuple:
    """Every row of ``T`` one by one on one thread (the batch call, one thread): the batch and the time per row."""
    batch = solve_batch(robot, T, loads, model=model, options=options, threads=1)
    return batch, batch.seconds / len(T)


def compare(fast, ref) -> dict:
    """Agreement of two batches of the same rows."""
    both = fast.converged & ref.converged
    dist = np.linalg.norm(fast.tip_position - ref.tip_position, axis=1)
    same = both & (dist <= SAME_TIP)
    differ = both & ~same
    fast_stable, ref_stable = fast.stable, ref.stable
    worse = differ & (ref_stable == 1.0) & (fast_stable == 0.0)
    paths = Counter(f"{a} / {b}" for a, b in zip(fast.path[differ], ref.path[differ], strict=True))
    return {"converged": int(fast.converged.sum()), "reference_converged": int(ref.converged.sum()),
            "both": int(both.sum()), "agree": int(same.sum()), "agreement": float(same.sum() / max(both.sum(), 1)),
            "differ": int(differ.sum()),
            "differ_within_tolerance": int(np.sum(differ & (fast.residual <= fast.atol) & (ref.residual <= ref.atol))),
            "unstable_where_reference_stable": int(worse.sum()),
            "differ_tip_distance_m": sorted(float(d) for d in dist[differ]),
            "differ_paths_solver_reference": dict(paths)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--model", default="pcc", choices=sorted(MODELS))
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "solve_agreement_<model>")
    args = ap.parse_args()
    if not 10 <= args.samples <= 1_000_000:
        ap.error(f"--samples must be in [10, 1000000], got {args.samples}")
    warmup()
    robot, loads = paper_robot(), paper_loads()
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (args.samples, robot.n_tendons))
    base = configure(args.model, None)
    fast, t_fast = solve_all(robot, T, loads, args.model, base)
    ref, t_ref = solve_all(robot, T, loads, args.model, configure(args.model, None, step_scale=0.25))
    result = {"samples": args.samples, "seed": args.seed, "model": args.model, "same_tip_m": SAME_TIP,
              "seconds_per_solve": t_fast, "reference_seconds_per_solve": t_ref, **compare(fast, ref)}
    r = result
    print(f"{args.model}, {args.samples} random vectors: converged {r['converged']} "
          f"(reference {r['reference_converged']}); of {r['both']} converged both ways, {r['agree']} agree "
          f"({100 * r['agreement']:.2f} %)")
    print(f"  {r['differ']} differ ({r['differ_within_tolerance']} both within tolerance), "
          f"{r['unstable_where_reference_stable']} unstable where the reference is stable; "
          f"paths (solver / reference): {r['differ_paths_solver_reference']}")
    print(f"  mean time per solve, one thread: {t_fast * 1e3:.2f} ms (reference {t_ref * 1e3:.2f} ms)")
    write_result(f"solve_agreement_{args.model}", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

"""A lever for issue 46, measured: the subsegment rod (sscr) solved by Newton at full load from the PCC model's
equilibrium, instead of along its own loading path. Not part of the tests.

For each random tension vector (uniform in [0, 20] N, paper robot, paper load, one thread): ``pcc``'s cold solve
(the compiled core), its disk poses turned into the rod's base wrenches (``SscrModel.wrenches_from_poses``), then
the core's sscr solver with load stepping "auto" from there (Newton at full load; the loading path where Newton
fails). Against the reference, sscr's own cold solve along its loading path, it reports:

- how often both reach the same equilibrium (tips within 1 mm), and for the others whether each is stable (the
  tangent stiffness's real eigenvalues all positive, the library's static test);
- the time per solve, the seeded route's as pcc's solve + the mapping + sscr's Newton (median, mean) [ms].

The issue's bar for a lever that changes which equilibrium is reached: the same branch on at least 99 % of
1,000 vectors, and where the two differ both stable or both unstable.

Prints a summary, writes ``bench/results/sscr_seeded.json`` (``--out`` elsewhere); ``--json`` prints it too.

Usage: python bench/sscr_seeded.py [--cases 1000] [--seed 0] [--json] [--out F]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
from _common import add_out_argument, write_result
from solve_phases import setup

#: two tips closer than this are the same equilibrium [m]
SAME_TIP = 1e-3


def stable(model: Any, q: np.ndarray) -> bool:
    """The library's static test on the rod's tangent stiffness at q: no real eigenvalue <= 0."""
    ev = np.linalg.eigvals(model.tangent_stiffness(q))
    real = ev[np.abs(ev.imag) <= 1e-9 * np.abs(ev).max()].real
    return bool(real.size == 0 or real.min() > 0.0)


def run(cases: int, seed: int) -> dict[str, Any]:
    """The comparison on ``cases`` random tension vectors."""
    from pytdcr import _core
    from pytdcr.statics.compiled import case_tolerances

    robot, loads, eqs, set_s = setup("sscr")
    _, _, eqp, set_p = setup("pcc")
    T = np.random.default_rng(seed).uniform(0.0, 20.0, (cases, robot.n_tendons))
    tols = case_tolerances(robot, loads, T, set_s.atol)
    ks, kp = eqs.kernel_model, eqp.kernel_model
    q_ref, r_ref, _, s_ref = _core._profile_range_sscr(np.zeros((cases, eqs.n_unknowns)), ks, ks, T, T, set_s,
                                                       tols, True)
    q_pcc, _, _, s_pcc = _core._profile_range_pcc(np.zeros((cases, eqp.n_unknowns)), kp, kp, T, T, set_p, tols, True)
    x0 = np.empty((cases, eqs.n_unknowns))
    t_map = np.empty(cases)
    for b in range(cases):
        t0 = time.perf_counter()
        pos, rot, _ = eqp.with_tensions(T[b]).shape(q_pcc[b])
        x0[b] = ks.with_tension(T[b]).wrenches_from_poses(pos, rot)
        t_map[b] = time.perf_counter() - t0
    q_new, r_new, c_new, s_new = _core._profile_range_sscr(x0, ks, ks, T, T, set_s._replace(stepping=1), tols, True)
    tip = np.array([[ks.record_shape(q)[0][-1] for q in qq] for qq in (q_ref, q_new)])
    both = (r_ref >= 0.0) & (r_new >= 0.0)
    d = np.linalg.norm(tip[0] - tip[1], axis=1)
    differ = np.flatnonzero(both & (d >= SAME_TIP))
    verdicts = [(stable(ks.with_tension(T[b]), q_ref[b]), stable(ks.with_tension(T[b]), q_new[b])) for b in differ]
    seeded_ms = 1e3 * (s_pcc[:, 3] + t_map + s_new[:, 3])
    return {
        "cases": cases, "converged_reference": int(np.sum(r_ref >= 0.0)), "converged_seeded": int(np.sum(r_new >= 0)),
        "same_equilibrium": int(np.sum(both & (d < SAME_TIP))), "both_converged": int(both.sum()),
        "seeded_paths": np.bincount(c_new[:, 4].astype(int), minlength=6).tolist(),
        "differ": [{"row": int(b), "tip_distance_mm": float(1e3 * d[b]), "reference_stable": v[0],
                    "seeded_stable": v[1]} for b, v in zip(differ, verdicts, strict=True)],
        "differ_one_stable_one_not": int(sum(v[0] != v[1] for v in verdicts)),
        "reference_ms": {"median": float(np.median(1e3 * s_ref[:, 3])), "mean": float(np.mean(1e3 * s_ref[:, 3]))},
        "seeded_ms": {"median": float(np.median(seeded_ms)), "mean": float(np.mean(seeded_ms)),
                      "pcc_median": float(np.median(1e3 * s_pcc[:, 3])),
                      "newton_median": float(np.median(1e3 * s_new[:, 3]))},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "sscr_seeded")
    args = ap.parse_args()
    r = run(args.cases, args.seed)
    share = r["same_equilibrium"] / max(r["both_converged"], 1)
    print(f"same equilibrium (tips within 1 mm): {r['same_equilibrium']}/{r['both_converged']} = {100 * share:.1f} %; "
          f"differing with one stable and one not: {r['differ_one_stable_one_not']} of {len(r['differ'])}")
    print(f"seeded paths (direct, loading, snap, fallback): {r['seeded_paths'][:4]}")
    print(f"time per solve [ms]: loading path median {r['reference_ms']['median']:.2f}, mean "
          f"{r['reference_ms']['mean']:.2f}; seeded median {r['seeded_ms']['median']:.2f} (pcc "
          f"{r['seeded_ms']['pcc_median']:.2f} + Newton {r['seeded_ms']['newton_median']:.2f}), mean "
          f"{r['seeded_ms']['mean']:.2f}")
    write_result("sscr_seeded", {**r, "seed": args.seed}, args.json, args.out)


if __name__ == "__main__":
    main()

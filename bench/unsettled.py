"""Why ``pcc2`` misses some tension vectors under the paper's load without friction or with a constant mu.

For every random tension vector (seed and draw as ``bench/convergence.py``) that ``pcc2`` does not converge on
with the given friction laws, this script:

1. follows the loading path's branch in small steps (the solver's own follower, compiled) to each fold;
2. past the last fold (1/128 in the load factor, as the solver) runs the snap-through's pseudo-time flow
   dq/dt = -J0^-1 r (implicit Euler, ``J0`` the unloaded robot's Jacobian: a stiffness-proportional damping)
   for ``--flow-steps`` steps, ten times the solver's cap, and reports whether it settles (max |r| within the
   load step's tolerance) and the least max |r| it met;
3. solves the same rows with the tip moment removed and with half of it, everything else unchanged.

The paper's tip moment is fixed in space: for finite rotations in three dimensions such a moment has no
potential (it is not conservative), the only load of the paper's that is not. Prints a table, writes
``bench/results/unsettled.json``; ``--json`` also prints it as the last line.

Usage: python bench/unsettled.py [--n 200] [--seed 0] [--flow-steps 3000] [--json]
"""

from __future__ import annotations

import argparse

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import ConstantFriction, Loads, NoFriction, paper_robot, solve_batch
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
from pytdcr.statics import warmup
from pytdcr.statics.compiled import case_tolerances
from pytdcr.statics.kernels import pcc as K
from pytdcr.statics.kernels import solver as SV
from pytdcr.statics.pcc2 import PCC2

#: friction law by name (the ones ``pcc2`` misses rows with)
LAWS = {"none": NoFriction(), "constant 0.1": ConstantFriction(mu=0.1)}


def _loads(moment_scale: float) -> Loads:
    """The paper's load with its tip moment scaled by ``moment_scale``."""
    return Loads(np.zeros(8), tip_force=PAPER_TIP_FORCE, tip_moment=moment_scale * np.asarray(PAPER_TIP_MOMENT))


def diagnose(robot, tensions: np.ndarray, flow_steps: int) -> dict:
    """The folds of the loading path of ``tensions`` (8,) [N] and whether the flow past the last one settles."""
    loads = _loads(1.0).with_tensions(tensions)
    eq = PCC2.equations(robot, loads)
    m = eq.packed
    tol, step_tol = case_tolerances(robot, loads, tensions[None, :], 1e-9)[0]
    work = K.make_work(eq.n_disks, tensions.size)
    r, J = np.empty(eq.n_unknowns), np.empty((eq.n_unknowns, eq.n_unknowns))

    def evaluate(q: np.ndarray, lam: float) -> None:
        K.evaluate(q, lam, m, True, r, J, work)

    q, lam, folds = np.zeros(eq.n_unknowns), 0.0, []
    evaluate(q, 0.0)
    J0 = J.copy()
    tol = max(tol, step_tol)
    for _ in range(8):
        reached, lam, *_ = SV._follow(q, lam, m, tol, step_tol, 200, 0.5, work, 0.05)
        if reached:
            return {"folds": folds, "settled": True, "reached_full_load": True}
        folds.append(float(lam))
        lam = min(1.0, lam + 1.0 / 128.0)
        settled, least, dt = False, np.inf, 1.0
        for k in range(flow_steps):
            evaluate(q, lam)
            least = min(least, float(np.abs(r).max()))
            if least <= tol:
                settled = True
                break
            dx = -np.linalg.solve(J + J0 / dt, r)
            step = K.largest_angle(dx, m)
            if step > 0.2:  # the solver's rule: a shorter pseudo-time step where one moves too far
                dt *= 0.05 / step
                continue
            q += dx
            dt = min(1e12, dt * min(4.0, 0.1 / max(step, 1e-300)), 1.0 if k < 100 else 1e12)
        if not settled:
            return {"folds": folds, "settled": False, "least_max_residual": least, "tolerance": float(tol)}
    return {"folds": folds, "settled": False, "least_max_residual": float("nan"), "tolerance": float(tol)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--flow-steps", type=int, default=3000)
    ap.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    add_out_argument(ap, "unsettled")
    args = ap.parse_args()
    warmup()
    T = np.random.default_rng(args.seed).uniform(0.0, 20.0, (args.n, 8))
    result: dict = {"config": vars(args) | {"json": None}}
    for name, law in LAWS.items():
        robot = paper_robot(law)
        b = solve_batch(robot, T, _loads(1.0), model="pcc2", threads=2)
        rows = np.flatnonzero(~b.converged)
        case: dict = {"cases": args.n, "converged": int(b.converged.sum()), "failed_rows": rows.tolist(), "rows": {}}
        print(f"pcc2, friction {name}: converged {case['converged']}/{args.n}; not: {rows.tolist()}")
        for i in rows:
            d = diagnose(robot, T[i], args.flow_steps)
            case["rows"][int(i)] = d
            print(f"  row {i:3d}: folds at lambda {[round(f, 4) for f in d['folds']]}; the flow past the last "
                  + ("settles" if d["settled"] else f"does not settle in {args.flow_steps} steps (least max |r| "
                     f"{d['least_max_residual']:.1e} N m, tolerance {d['tolerance']:.1e})"))
        for scale in (0.0, 0.5):
            if rows.size:
                c = solve_batch(robot, T[rows], _loads(scale), model="pcc2", threads=2)
                case[f"converged_with_moment_x{scale}"] = int(c.converged.sum())
                print(f"  the same rows with the tip moment x {scale}: converged {int(c.converged.sum())}/{rows.size}")
        result[name] = case
    write_result("unsettled", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

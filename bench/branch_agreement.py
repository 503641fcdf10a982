"""Does a change of the solver keep its equilibria? A solver's answers recorded, then compared with another build's.

Issue 46's bar for a change of the solver that may change which equilibrium is reached: on random tension
vectors (uniform in [0, 20] N, paper robot, paper load, one thread, the core's ``_profile_range_<model>``), the
same equilibrium as the recorded solver (tips within 1 um for ``pcc`` and ``pcc2`` on 3,000 vectors, within
1 mm for ``sscr`` on 1,000) on at least 99 % of them, and where the two differ, both equilibria and neither
unstable where the other is stable (the tangent stiffness's real eigenvalues, the library's static test).

``--record F`` writes the answers (unknowns, residuals, tips, work counts, times) of this checkout's build to
``F`` (``.npz``); ``--against F`` solves the same cases and compares: same equilibrium, both converged, the
differing pairs' stability, and the time per solve (median, mean) and work per solve of both.

Prints a summary, writes ``bench/results/branch_agreement.json`` (``--out`` elsewhere) with ``--against``;
``--json`` prints it too.

Usage: python bench/branch_agreement.py [--models pcc,sscr] --record '/tmp/before_{model}.npz'
       (then, with the changed build) python bench/branch_agreement.py --against '/tmp/before_{model}.npz'
                                          [--change "what changed"] [--set step_scale=2 ...]
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
from _common import add_out_argument, write_result
from solve_phases import setup

#: per model: the default number of vectors and the tip distance below which two answers are one equilibrium [m]
BAR = {"pcc": (3000, 1e-6), "pcc2": (3000, 1e-6), "sscr": (1000, 1e-3)}
#: share of the vectors that must reach the same equilibrium
SAME_SHARE = 0.99


def stable(name: str, eq: Any, q: np.ndarray) -> bool:
    """The library's static test (``Model.stability_at``) at the equilibrium q of the equations eq."""
    from pytdcr.statics.registry import get_model

    return bool(get_model(name).stability_at(eq, q).stable)


def solve(name: str, cases: int, seed: int, overrides: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """Cold solves of ``cases`` random vectors by this build's core: unknowns, residuals, tips, work, seconds.
    ``overrides``: solver settings (fields of the core's ``Settings``) in place of the model's defaults."""
    from pytdcr import _core
    from pytdcr.statics.compiled import case_tolerances
    from pytdcr.statics.tolerance import moment_scale

    robot, loads, eq, settings = setup(name)
    overrides = dict(overrides or {})
    step_relative = overrides.pop("step_relative", None)
    settings = settings._replace(**overrides)
    T = np.random.default_rng(seed).uniform(0.0, 20.0, (cases, robot.n_tendons))
    tols = case_tolerances(robot, loads, T, settings.atol)
    if step_relative is not None:  # the load steps' tolerance relative to the moment scale (tolerance.py)
        tols[:, 1] = np.maximum(tols[:, 0], step_relative * moment_scale(robot, loads, T))
    km = eq.kernel_model
    profile = getattr(_core, f"_profile_range_{name}")
    q, res, counts, seconds = profile(np.zeros((cases, eq.n_unknowns)), km, km, T, T, settings, tols, True)
    tips = np.array([eq.with_tensions(T[b]).shape(q[b])[0][-1] for b in range(cases)])
    return {"tensions": T, "q": q, "res": res, "counts": counts, "seconds": seconds[:, 3], "tip": tips}


def compare(name: str, ref: dict[str, np.ndarray], new: dict[str, np.ndarray]) -> dict[str, Any]:
    """The agreement of two solvers' answers to the same cases."""
    _, _, eq, _ = setup(name)
    same_tip = BAR[name][1]
    both = (ref["res"] >= 0.0) & (new["res"] >= 0.0)
    d = np.linalg.norm(ref["tip"] - new["tip"], axis=1)
    differ = np.flatnonzero(both & (d >= same_tip))
    verdicts = []
    for b in differ:
        at = eq.with_tensions(ref["tensions"][b])
        verdicts.append((stable(name, at, ref["q"][b]), stable(name, at, new["q"][b])))
    cases = len(ref["res"])

    def timing(s: dict[str, np.ndarray]) -> dict[str, float]:
        ms = 1e3 * s["seconds"]
        med = np.median(s["counts"], axis=0)
        return {"median_ms": float(np.median(ms)), "mean_ms": float(np.mean(ms)), "residuals": float(med[0]),
                "jacobians": float(med[1]), "factorisations": float(med[2]), "load_steps": float(med[3])}

    return {
        "model": name, "cases": cases, "same_tip_m": same_tip,
        "converged_before": int(np.sum(ref["res"] >= 0.0)), "converged_after": int(np.sum(new["res"] >= 0.0)),
        "both_converged": int(both.sum()), "same_equilibrium": int(np.sum(both & (d < same_tip))),
        "same_share": float(np.sum(both & (d < same_tip)) / cases),
        "largest_same_tip_distance_m": float(d[both & (d < same_tip)].max(initial=0.0)),
        "differ": [{"row": int(b), "tip_distance_mm": float(1e3 * d[b]), "before_stable": v[0], "after_stable": v[1]}
                   for b, v in zip(differ, verdicts, strict=True)],
        "differ_one_stable_one_not": int(sum(v[0] != v[1] for v in verdicts)),
        "before": timing(ref), "after": timing(new),
    }


def record(models: list[str], path: str, cases: int | None, seed: int) -> None:
    """Write each model's answers to ``path`` (``{model}`` replaced by the model's name)."""
    for name in models:
        out = solve(name, cases or BAR[name][0], seed)
        np.savez(path.format(model=name), seed=seed, **out)
        print(f"recorded {len(out['res'])} {name} solves to {path.format(model=name)}: median "
              f"{1e3 * np.median(out['seconds']):.2f} ms, converged {int(np.sum(out['res'] >= 0))}")


def against(name: str, path: str, overrides: dict[str, float]) -> dict[str, Any]:
    """Solve the cases recorded in ``path`` with this build and compare; prints a summary."""
    try:
        with np.load(path) as f:
            ref = {k: f[k] for k in f.files}
    except OSError as e:
        print(f"branch_agreement.py: --against: cannot read {path}: {e.strerror or e}", file=sys.stderr)
        raise SystemExit(2) from None
    new = solve(name, len(ref["res"]), int(ref["seed"]), overrides)
    if not np.array_equal(new["tensions"], ref["tensions"]):
        raise SystemExit(f"{path}: the recorded cases are not this seed's")
    r = compare(name, ref, new)
    print(f"{name}: same equilibrium on {r['same_equilibrium']}/{r['cases']} = {100 * r['same_share']:.2f} % "
          f"(bar {100 * SAME_SHARE:.0f} %); converged {r['converged_before']} -> {r['converged_after']}; "
          f"differing with one stable and one not: {r['differ_one_stable_one_not']} of {len(r['differ'])}")
    for k in ("before", "after"):
        t = r[k]
        print(f"  {k}: median {t['median_ms']:.2f} ms, mean {t['mean_ms']:.2f} ms; per solve {t['residuals']:.0f} "
              f"residuals, {t['jacobians']:.0f} Jacobians, {t['factorisations']:.0f} factorisations, "
              f"{t['load_steps']:.0f} load steps")
    return {**r, "seed": int(ref["seed"])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", default="pcc,sscr", help="comma-separated, of " + ",".join(BAR))
    ap.add_argument("--cases", type=int, default=None, help="with --record: vectors (default per model)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--record", default=None, metavar="NPZ", help="file of the answers; {model} is the model's name")
    ap.add_argument("--against", default=None, metavar="NPZ", help="as --record, of the build to compare with")
    ap.add_argument("--change", default="", help="with --against: what changed since the recorded build (words)")
    ap.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                    help="with --against: solver settings to change (a lever to measure): fields of the core's "
                         "Settings (e.g. step_scale=2) or step_relative (the load steps' tolerance, tolerance.py)")
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "branch_agreement")
    args = ap.parse_args()
    models = args.models.split(",")
    if (args.record is None) == (args.against is None) or any(m not in BAR for m in models):
        ap.error("give one of --record and --against, and models of " + ",".join(BAR))
    if args.record is not None:
        record(models, args.record, args.cases, args.seed)
        return
    overrides = {k: float(v) for k, v in (item.split("=", 1) for item in args.set)}
    out = {name: against(name, args.against.format(model=name), overrides) for name in models}
    write_result("branch_agreement", {"models": out, "change": args.change, "settings_changed": overrides},
                 args.json, args.out)


if __name__ == "__main__":
    main()

"""Calibration (:mod:`pytdcr.calibrate`): recovery of known parameters, and how much of sscr's shape pcc absorbs.

Recovery: data are made with the ``sscr`` model from a robot whose parameters are known (two sets, below) at
``--n`` random tension vectors (each tendon uniform in [0, 6] N with probability 0.4, else 0 N) plus 0.5 mm
Gaussian noise on each axis of the tip, then fitted with ``sscr`` starting from the paper robot's values
(no cross-validation). Reported per parameter: the true and fitted values, the standard error, |fitted - true| /
SE and whether the truth is within 2 SE; the whole is repeated ``--replicates`` times (new tensions and noise)
to count how often the truth lies within 2 SE (about 95 % if the standard errors are right).

pcc absorbs: data are made with ``sscr`` from the paper robot itself, without noise (0.5 mm is the stated
uncertainty), at ``--n-absorb`` tension vectors over the paper's range (each tendon uniform in [0, 20] N with
probability 0.4, else 0 N), without and with the paper's tip force and moment. ``pcc`` is fitted to them
(E, G, the friction law's mu0 and decay, the tendons' radius; also with ``base_z``, and with plain least
squares) with 5-fold cross-validation. Reported: the RMS tip error of pcc against the sscr data before and
after the fit (on the training rows, on the same rows re-solved cold at the fitted values, and held out), the
fitted values and the fit's warnings. A row that either model cannot solve at the paper robot's values is
dropped and counted.

Identifiability: whether the data determine a parameter set, from sscr data (0.5 mm noise, ``--n`` rows) fitted
with sscr: the smallest normalised singular value of the whitened Jacobian (the fit warns below 0.01), the
largest correlation, each parameter's standard error relative to its value, for friction from one tendon pulled
at a time and from random tensions, and for E with the routing radius with and without gravity and friction.

Usage: python bench/calibration.py [--n 24] [--n-absorb 48] [--replicates 5] [--seed 0] [--out FILE] [--json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_result

from pytdcr import Loads, paper_robot, solve
from pytdcr.calibrate import CalibrationOptions, Measurements, calibrate
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
from pytdcr.robot import NoFriction, Robot

NA = "\u2013"
#: the noise of the synthetic tips, per axis [m], and the uncertainty the data state
SIGMA = 0.5e-3
#: the recovery's parameter sets: label -> {parameter: true value}
SETS = {
    "A": {"youngs_modulus": 60e9, "friction.mu0": 0.5, "base_z": 1.5e-3},
    "B": {"youngs_modulus": 48e9, "tendon_radius": 0.0105, "pretension": 0.3},
}
#: the pcc fit's parameters
ABSORB = ["youngs_modulus", "shear_modulus", "friction.mu0", "friction.decay_per_deg", "tendon_radius"]
#: the pcc fits: label, extra parameters, loss
VARIANTS = [("E, G, mu0, decay, r", [], "soft_l1"), ("+ base_z", ["base_z"], "soft_l1"),
            ("E, G, mu0, decay, r; plain least squares", [], "linear")]
#: how each parameter is shown: factor from its SI unit, unit shown
SHOWN = {"youngs_modulus": (1e-9, "GPa"), "shear_modulus": (1e-9, "GPa"), "friction.mu0": (1.0, "-"),
         "friction.decay_per_deg": (1.0, "1/deg"), "tendon_radius": (1e3, "mm"), "pretension": (1.0, "N"),
         "base_z": (1e3, "mm")}


def shown(name: str, value: float | None) -> str:
    """``value`` of parameter ``name`` in its shown unit, 4 significant digits."""
    if value is None or not np.isfinite(value):
        return NA
    return f"{value * SHOWN[name][0]:.4g}"


def true_robot(robot: Robot, truth: dict[str, float]) -> Robot:
    """``robot`` with the true values of its own quantities (moduli, friction, every tendon's radius); written out
    here rather than through the package's parameter map, so that a slip there shows as a failed recovery."""
    update: dict[str, object] = {}
    if "youngs_modulus" in truth:
        update["backbone"] = robot.backbone.model_copy(update={"youngs_modulus": truth["youngs_modulus"]})
    if "friction.mu0" in truth:
        update["friction"] = robot.friction.model_copy(update={"mu0": truth["friction.mu0"]})
    if "tendon_radius" in truth:
        update["tendons"] = tuple(t.model_copy(update={"radius": truth["tendon_radius"]}) for t in robot.tendons)
    return robot.model_copy(update=update)


def tensions(rng: np.random.Generator, b: int, top: float) -> np.ndarray:
    """``b`` tension vectors: each tendon uniform in [0, top] N with probability 0.4, else 0 N."""
    return rng.uniform(0.0, top, (b, 8)) * (rng.random((b, 8)) < 0.4)


def recovery(label: str, truth: dict[str, float], n: int, replicate: int, seed: int) -> dict:
    """One synthetic recovery of parameter set ``label`` (module docstring)."""
    rng = np.random.default_rng([seed, ord(label), replicate])
    robot = paper_robot()
    true = true_robot(robot, truth)
    t_in = tensions(rng, n, 6.0)
    kept, tips = [], []
    for t in t_in:
        sol = solve(true, Loads(t + truth.get("pretension", 0.0)), model="sscr")
        if sol.converged:
            kept.append(t)
            tips.append(sol.tip_position)
    tips = np.array(tips) + np.array([0.0, 0.0, truth.get("base_z", 0.0)])
    tips = tips + rng.normal(0.0, SIGMA, tips.shape)
    data = Measurements.from_arrays(robot, np.array(kept), tips, sigma=SIGMA)
    res = calibrate(robot, data, list(truth), model="sscr", options=CalibrationOptions(folds=0, seed=seed))
    params = []
    for p in res.parameters:
        z = abs(p.value - truth[p.name]) / p.standard_error if np.isfinite(p.standard_error) else None
        params.append({"name": p.name, "unit": p.unit, "true": truth[p.name], "initial": p.initial,
                       "fitted": p.value, "standard_error": p.standard_error if np.isfinite(p.standard_error) else None,
                       "z": z, "within_2se": bool(z is not None and z <= 2.0), "at_bound": p.at_bound})
    return {"set": label, "replicate": replicate, "rows": len(kept), "dropped": n - len(kept),
            "converged": res.converged, "message": res.message, "warnings": list(res.warnings),
            "rms_before_mm": res.rms_before_m * 1e3, "rms_after_mm": res.rms_after_m * 1e3,
            "evaluations": res.evaluations, "solves": res.solves, "seconds": res.seconds,
            "correlation": [[round(float(c), 3) if np.isfinite(c) else None for c in row] for row in res.correlation],
            "parameters": params}


def absorb_data(n: int, seed: int, loaded: bool) -> tuple[Measurements, dict]:
    """sscr tips of the paper robot (no noise) at ``n`` tension vectors in [0, 20] N; rows either model cannot
    solve at the paper robot's values dropped and counted."""
    rng = np.random.default_rng([seed, 20, int(loaded)])
    robot = paper_robot()
    force, moment = (PAPER_TIP_FORCE, PAPER_TIP_MOMENT) if loaded else ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    kept, tips = [], []
    sscr_failed = pcc_failed = 0
    for t in tensions(rng, n, 20.0):
        loads = Loads(t, tip_force=force, tip_moment=moment)
        ref = solve(robot, loads, model="sscr")
        if not ref.converged:
            sscr_failed += 1
            continue
        if not solve(robot, loads, model="pcc").converged:
            pcc_failed += 1
            continue
        kept.append(t)
        tips.append(ref.tip_position)
    data = Measurements.from_arrays(robot, np.array(kept), np.array(tips), sigma=SIGMA,
                                    tip_force=np.array(force), tip_moment=np.array(moment))
    return data, {"rows": len(kept), "asked": n, "sscr_failed": sscr_failed, "pcc_failed": pcc_failed}


def absorb_fit(data: Measurements, loaded: bool, names: list[str], loss: str, seed: int) -> dict:
    """pcc fitted to ``data`` with 5-fold cross-validation; the training rows also re-solved here through the
    public ``solve`` at the fitted robot, a check that the fit's errors belong to the fitted parameters alone."""
    robot = paper_robot()
    res = calibrate(robot, data, names, model="pcc", options=CalibrationOptions(folds=5, seed=seed, loss=loss))
    force, moment = (PAPER_TIP_FORCE, PAPER_TIP_MOMENT) if loaded else ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    cold = [solve(res.robot, Loads(t, tip_force=force, tip_moment=moment), model="pcc") for t in data.tensions]
    ok = np.array([s.converged for s in cold])
    base_z = next((p.value for p in res.parameters if p.name == "base_z"), 0.0)
    err = np.array([np.linalg.norm(s.tip_position + np.array([0.0, 0.0, base_z]) - p)
                    for s, p in zip(cold, data.tip_position, strict=True)])
    cv = res.cross_validation
    return {"parameters_fitted": names, "loss": loss, "converged": res.converged, "message": res.message,
            "warnings": list(res.warnings), "rms_before_mm": res.rms_before_m * 1e3,
            "rms_after_mm": res.rms_after_m * 1e3,
            "rms_after_cold_mm": float(np.sqrt(np.mean(err[ok] ** 2))) * 1e3 if ok.any() else None,
            "cold_converged": int(ok.sum()),
            "rows_cold_differ_1mm": int(np.sum(np.abs(err - res.errors_after_m) > 1e-3)),
            "max_error_after_mm": float(res.errors_after_m.max()) * 1e3,
            "cv_rms_mm": cv.rms_m * 1e3 if cv and np.isfinite(cv.rms_m) else None,
            "cv_rms_before_mm": cv.rms_before_m * 1e3 if cv else None,
            "cv_failed_folds": cv.failed_folds if cv else None, "chi2": res.chi2, "dof": res.dof,
            "evaluations": res.evaluations, "solves": res.solves, "seconds": res.seconds,
            "fitted": [{"name": p.name, "unit": p.unit, "initial": p.initial, "value": p.value,
                        "standard_error": p.standard_error if np.isfinite(p.standard_error) else None,
                        "at_bound": p.at_bound} for p in res.parameters]}


#: the identifiability cases: label, robot change, tension design, fitted parameters
IDENTIFY = [
    ("one tendon at a time, paper robot", "paper", "one", ["youngs_modulus", "friction.mu0", "friction.decay_per_deg"]),
    ("random tensions, paper robot", "paper", "random", ["youngs_modulus", "friction.mu0", "friction.decay_per_deg"]),
    ("random tensions, no gravity, no friction", "bare", "random", ["youngs_modulus", "tendon_radius"]),
    ("random tensions, paper robot", "paper", "random", ["youngs_modulus", "tendon_radius"]),
]


def identifiability(label: str, kind: str, design: str, names: list[str], n: int, seed: int) -> dict:
    """Whether ``names`` are determined by sscr data (0.5 mm noise) of ``design``: each tendon alone at
    0.5 to 8 N ("one"; ``n`` rows cycling over the tendons) or the recovery's random tensions; fitted with sscr
    from the paper robot's values."""
    rng = np.random.default_rng([seed, 30, len(label)])
    robot = paper_robot()
    if kind == "bare":
        robot = robot.model_copy(update={"gravity": (0.0, 0.0, 0.0), "friction": NoFriction()})
    if design == "one":
        t = np.zeros((n, 8))
        t[np.arange(n), np.arange(n) % 8] = rng.uniform(0.5, 8.0, n)
    else:
        t = tensions(rng, n, 6.0)
    tips = np.array([solve(robot, Loads(x), model="sscr").tip_position for x in t])
    data = Measurements.from_arrays(robot, t, tips + rng.normal(0.0, SIGMA, tips.shape), sigma=SIGMA)
    res = calibrate(robot, data, names, model="sscr", options=CalibrationOptions(folds=0, seed=seed))
    corr = res.correlation
    off = [abs(corr[i, j]) for i in range(len(names)) for j in range(i + 1, len(names)) if np.isfinite(corr[i, j])]
    return {"case": label, "parameters": names, "rows": data.n_rows, "converged": res.converged,
            "smallest_singular_value": float(res.singular_values[-1]),
            "largest_correlation": max(off) if off else None, "warnings": list(res.warnings),
            "relative_se": {p.name: p.standard_error / abs(p.value) if p.value else None for p in res.parameters}}


def crashed(err: Exception) -> str:
    """A crash in one line: the exception's type and the start of its text."""
    return f"{type(err).__name__}: {' '.join(str(err).split())[:240]}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=24, help="rows of each recovery fit")
    ap.add_argument("--n-absorb", type=int, default=48, help="rows of each pcc-absorbs case")
    ap.add_argument("--replicates", type=int, default=5, help="recovery fits of each set (new tensions and noise)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "calibration")
    args = ap.parse_args()
    start = time.perf_counter()

    fits = []
    for label, truth in SETS.items():
        for r in range(args.replicates):
            try:
                f = recovery(label, truth, args.n, r, args.seed)
            except Exception as err:  # a crash of the package is a finding: record it, go on
                fits.append({"set": label, "replicate": r, "crashed": crashed(err)})
                print(f"set {label} replicate {r + 1}: CRASHED {fits[-1]['crashed']}", flush=True)
                continue
            fits.append(f)
            print(f"set {label} replicate {r + 1}: {f['rows']} rows, RMS {f['rms_before_mm']:.3g} -> "
                  f"{f['rms_after_mm']:.3g} mm, {f['evaluations']} evaluations, {f['seconds']:.1f} s, "
                  + ", ".join(f"{p['name']} {shown(p['name'], p['fitted'])} (z {p['z']:.2f})"
                              if p["z"] is not None else f"{p['name']} SE inf" for p in f["parameters"]),
                  flush=True)
    rec_rows = []
    for label, truth in SETS.items():
        mine = [f for f in fits if f["set"] == label and "crashed" not in f]
        lost = sum(f["set"] == label and "crashed" in f for f in fits)
        if not mine:
            rec_rows.append([label, f"all {lost} fits crashed", *[NA] * 8])
            continue
        first = mine[0]
        for i, name in enumerate(truth):
            p = first["parameters"][i]
            zs = [f["parameters"][i]["z"] for f in mine]
            within = sum(f["parameters"][i]["within_2se"] for f in mine)
            rec_rows.append([label, f"`{name}` [{SHOWN[name][1]}]", shown(name, p["true"]), shown(name, p["initial"]),
                             shown(name, p["fitted"]), shown(name, p["standard_error"]),
                             NA if p["z"] is None else f"{p['z']:.2f}", "yes" if p["within_2se"] else "no",
                             f"{within} of {len(mine)}",
                             NA if None in zs else f"{float(np.median(zs)):.2f}"])
        rec_rows.append([label, "tip RMS before \u2192 after, mm", NA, f"{first['rms_before_mm']:.3g}",
                         f"{first['rms_after_mm']:.3g}", NA, NA, "converged" if first["converged"] else "NOT converged",
                         f"{sum(f['converged'] for f in mine)} of {len(mine)} converged"
                         + (f", {lost} crashed" if lost else ""),
                         f"{float(np.median([f['seconds'] for f in mine])):.1f} s a fit (median)"])
    recovery_table = {"columns": [f"set (sscr data, {args.n} rows, 0.5 mm noise)", "parameter", "true",
                                  "initial (paper)", "fitted (replicate 1)", "SE", "abs(fitted \u2212 true) / SE",
                                  "within 2 SE", f"within 2 SE, {args.replicates} replicates",
                                  "median abs(fitted \u2212 true) / SE"], "rows": rec_rows}

    cases, abs_rows, val_rows = [], [], []
    for loaded in (False, True):
        data, info = absorb_data(args.n_absorb, args.seed, loaded)
        load_label = "paper's tip force and moment" if loaded else "gravity only"
        print(f"pcc absorbs, {load_label}: {info}", flush=True)
        for label, extra, loss in VARIANTS:
            try:
                fit = absorb_fit(data, loaded, ABSORB + extra, loss, args.seed)
            except Exception as err:  # a crash of the package is a finding: record it, go on
                crash = crashed(err)
                cases.append({"loads": load_label, "variant": label, **info, "parameters_fitted": ABSORB + extra,
                              "loss": loss, "crashed": crash})
                print(f"  {label}: CRASHED {crash}", flush=True)
                abs_rows.append([load_label, label, f"{info['rows']} of {info['asked']}", f"crashed ({crash.strip()})",
                                 NA, NA, NA, "no", NA, NA])
                val_rows.append([load_label, label] + [NA] * (len(ABSORB) + 1))
                continue
            cases.append({"loads": load_label, "variant": label, **info, **fit})
            print(f"  {label}: RMS {fit['rms_before_mm']:.3g} -> {fit['rms_after_mm']:.3g} mm (cold "
                  f"{fit['rms_after_cold_mm']:.3g}), held out {fit['cv_rms_mm']} mm, {fit['seconds']:.1f} s; "
                  + "; ".join(fit["warnings"]), flush=True)
            abs_rows.append([load_label, label, f"{info['rows']} of {info['asked']}", f"{fit['rms_before_mm']:.3g}",
                             f"{fit['rms_after_mm']:.3g}", f"{fit['cv_rms_before_mm']:.3g}",
                             NA if fit["cv_rms_mm"] is None else f"{fit['cv_rms_mm']:.3g}",
                             "yes" if fit["converged"] else "no", str(len(fit["warnings"])),
                             f"{fit['seconds']:.0f}"])
            vals = {p["name"]: p for p in fit["fitted"]}
            val_rows.append([load_label, label] + [
                f"{shown(n, vals[n]['value'])} \u00b1 {shown(n, vals[n]['standard_error'])}" if n in vals else NA
                for n in [*ABSORB, "base_z"]])
    ident, id_rows = [], []
    for label, kind, design, names in IDENTIFY:
        case = identifiability(label, kind, design, names, args.n, args.seed)
        ident.append(case)
        print(f"identifiability, {label}, {', '.join(names)}: smallest singular value "
              f"{case['smallest_singular_value']:.3g}; {'; '.join(case['warnings']) or 'no warning'}", flush=True)
        se = ", ".join(f"{n} {100 * v:.2g} %" for n, v in case["relative_se"].items() if v is not None)
        id_rows.append([label, ", ".join(f"`{n}`" for n in names), str(case["rows"]),
                        f"{case['smallest_singular_value']:.2g}",
                        NA if case["largest_correlation"] is None else f"{case['largest_correlation']:.3f}", se,
                        "yes" if case["warnings"] else "no"])
    identify_table = {"columns": ["sscr data, 0.5 mm noise", "fitted", "rows", "smallest normalised singular value",
                                  "largest abs(correlation)", "standard error / value", "warned"], "rows": id_rows}
    paper = paper_robot()
    val_rows.insert(0, ["paper robot (initial)", NA, shown("youngs_modulus", paper.backbone.youngs_modulus),
                        shown("shear_modulus", paper.backbone.shear), shown("friction.mu0", paper.friction.mu0),
                        shown("friction.decay_per_deg", paper.friction.decay_per_deg),
                        shown("tendon_radius", paper.tendons[0].radius), "0"])
    absorbs_table = {"columns": ["sscr data of the paper robot, tensions in [0, 20] N", "pcc fit", "rows",
                                 "RMS before mm", "RMS after mm",
                                 "held-out RMS before mm", "held-out RMS after mm (5-fold)", "converged",
                                 "warnings", "s"], "rows": abs_rows}
    values_table = {"columns": ["loads", "pcc fit"] + [f"`{n}` [{SHOWN[n][1]}] \u00b1 SE" for n in [*ABSORB, "base_z"]],
                    "rows": val_rows}
    seconds = time.perf_counter() - start
    print(f"total {seconds:.0f} s")
    write_result("calibration", {
        "n": args.n, "n_absorb": args.n_absorb, "replicates": args.replicates, "seed": args.seed, "sigma_m": SIGMA,
        "recovery": {"sets": SETS, "fits": fits}, "pcc_absorbs": cases, "identifiability": ident, "seconds": seconds,
        "table": recovery_table,
        "tables": {"recovery": recovery_table, "absorbs": absorbs_table, "absorbs_values": values_table,
                   "identifiability": identify_table},
    }, args.json, args.out)


if __name__ == "__main__":
    main()

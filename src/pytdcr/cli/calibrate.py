"""``tdcr calibrate``: fit a robot's parameters to measured tip positions (:mod:`pytdcr.calibrate`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from ..validate import escape_controls
from ._args import add_out, add_seed, count_type, parse_optional, real_type, robot_spec
from ._progress import Bar
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK

if TYPE_CHECKING:
    from ..calibrate import FittedParameter

__all__ = ["add_parser", "run"]

#: the losses, as :data:`pytdcr.calibrate.LOSSES` (not imported for ``--help``)
_LOSSES = ("soft_l1", "huber", "cauchy", "linear")
#: the models with exact derivatives through the equilibrium
_MODELS = ("pcc", "pcc2", "sscr")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``calibrate`` command and its options."""
    c = sub.add_parser("calibrate", help="fit a robot's parameters (moduli, friction, routing, offsets, the "
                       "measurement frame) to measured tip positions")
    c.add_argument("data", metavar="DATA.csv", help="one row per measurement: T1_N..Tn_N (or DK_m, a tendon's "
                   "pull-in), tip_x_m, tip_y_m, tip_z_m, optional sigma_m, force_[xyz]_N, moment_[xyz]_Nm, "
                   "axis_[xyz], diskK_[xyz]_m")
    c.add_argument("--fit", required=True, metavar="NAME,NAME",
                   help="the parameters to fit, e.g. youngs_modulus,friction.mu0,base_z; known: youngs_modulus, "
                   "shear_modulus, friction.mu, friction.mu0, friction.decay_per_deg, tendon_radius[_K], "
                   "tendon_angle_K, pretension[_K], payload, tendon_stiffness, displacement_offset[_K], base_x, "
                   "base_y, base_z, base_rx, base_ry, base_rz")
    g = c.add_argument_group("robot")
    g.add_argument("--robot", default="paper", help="built-in robot (paper, rao) or a TOML file: the values "
                   "before the fit and everything held fixed [paper]")
    grav = g.add_mutually_exclusive_group()
    grav.add_argument("--gravity", dest="gravity", action="store_true", default=None,
                      help="gravity -9.81 m/s^2 along base z (default: the robot's own)")
    grav.add_argument("--no-gravity", dest="gravity", action="store_false", help="no gravity")
    g.add_argument("--friction", help="none, paper or a constant MU (default: the robot's own law)")
    g.add_argument("--tendon-stiffness", metavar="K or K1,...,Kn",
                   help="the tendons' axial stiffness [N/m], for data that drive tendons by displacement (DK_m "
                   "columns): one value or one per tendon (- for an inextensible one) [the robot's own]; the start of "
                   "tendon_stiffness when that is fitted")
    c.add_argument("--model", choices=_MODELS, default="pcc", help="the model fitted (one with exact derivatives "
                   "through the equilibrium) [pcc]")
    c.add_argument("--loss", choices=_LOSSES, default="soft_l1", help="robust loss (linear: plain least "
                   "squares) [soft_l1]")
    c.add_argument("--loss-scale", type=real_type, default=3.0,
                   help="where the robust loss bends, in standard uncertainties [3]")
    c.add_argument("--folds", type=count_type, default=5, help="held-out cross-validation folds (0: none) [5]")
    c.add_argument("--max-evaluations", type=count_type, default=60,
                   help="the most evaluations of the fit (each solves every row) [60]")
    c.add_argument("--absolute-sigma", action="store_true",
                   help="trust the data's uncertainties as given (default: scale them by the fit's scatter)")
    add_seed(c)
    add_out(c, "out/calibrate", "output folder [out/calibrate]; a run stopped there is resumed by the same command, "
            "its finished stages (the fit, each fold) kept")
    c.add_argument("--restart", action="store_true", help="discard what the folder holds and start again")
    c.set_defaults(func=run)


def _line(p: FittedParameter) -> str:
    err = "undetermined" if p.standard_error == float("inf") else f"{p.standard_error:.4g}"
    bound = "  AT ITS BOUND" if p.at_bound else ""
    return f"  {p.name:<24} {p.initial:>12.5g} -> {p.value:>12.6g} +- {err:<10} {p.unit}{bound}"


def run(args: argparse.Namespace) -> int:
    """Fit; print the fitted values with their standard errors, the tip errors before and after (and held out),
    the warnings and what was written."""
    from ..calibrate import CalibrationOptions, read_measurements
    from ..runs import CalibrationSettings, run_calibration

    out = Path(args.out)
    robot = robot_spec(args).build()
    data = read_measurements(args.data, robot)
    fit = [n.strip() for n in args.fit.split(",") if n.strip()]
    stiffness = None if args.tendon_stiffness is None else parse_optional(args.tendon_stiffness, "--tendon-stiffness")
    options = CalibrationOptions(loss=args.loss, loss_scale=args.loss_scale, max_evaluations=args.max_evaluations,
                                 folds=args.folds, seed=args.seed, absolute_sigma=args.absolute_sigma)
    with Bar("calibrate", args.max_evaluations + args.folds, "step") as bar:
        settings = CalibrationSettings(tuple(fit), args.model, options, stiffness)
        res = run_calibration(robot, data, settings, out, restart=args.restart,
                              progress=lambda line: bar.step(1, line))
    r = res.result
    print(f"{r.model} fitted to {data.n_rows} rows of {escape_controls(data.source)} ({r.evaluations} evaluations, "
          f"{r.solves} solves, {r.seconds:.1f} s): {'converged' if r.converged else 'NOT converged'}")
    print(f"  {'parameter':<24} {'initial':>12}    {'fitted':>12}    standard error")
    for p in r.parameters:
        print(_line(p))
    held = ""
    if r.cross_validation is not None:
        cv = r.cross_validation
        held = f"; held out ({cv.folds}-fold) {cv.rms_m * 1e3:.3g} mm"
    print(f"  tip RMS error {r.rms_before_m * 1e3:.3g} mm before, {r.rms_after_m * 1e3:.3g} mm fitted{held}")
    for w in r.warnings:
        print(f"  warning: {w}")
    print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    return EXIT_OK if r.converged else EXIT_NOT_CONVERGED

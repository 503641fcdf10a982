"""``tdcr solve``: static equilibrium under tendon tensions and tip loads."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

import numpy as np

from ..runtime import dump_json
from ..statics import DEFAULT_ATOL
from ..validate import escape_controls
from ._args import (
    add_model,
    add_robot_and_loads,
    load_spec,
    model_spec,
    parse_floats,
    parse_optional,
    real_type,
    robot_spec,
)
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, CliError

if TYPE_CHECKING:  # the runs are imported when a command runs, not when the parser is built
    from ..results import Stability
    from ..runs import SolveRun

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``solve`` command and its options."""
    s = sub.add_parser("solve", help="static equilibrium under tendon tensions and tip loads")
    add_robot_and_loads(s)
    add_model(s)
    which = s.add_mutually_exclusive_group()
    which.add_argument("--tensions", metavar="T1,...,Tn",
                       help="actuator tensions [N] (with --displacements: of the tendons driven by tension)")
    which.add_argument("--cases", metavar="FILE.csv",
                       help="solve many tension vectors (one row each, one column per tendon [N]) and print one CSV "
                       "row per case (tensions, converged, residual, path, stable, tip), or write it to --csv")
    s.add_argument("--displacements", metavar="D1,...,Dn",
                   help="drive tendons by displacement: each tendon's pull-in [m] (negative: paid out), or - to "
                   "drive it by its --tensions value (default 0 N), e.g. 0.004,-,-,-,0.002,-,-,-; the driven "
                   "tendons' tensions are found with the equilibrium, and a tendon that would need a negative "
                   "tension is slack")
    s.add_argument("--tendon-stiffness", metavar="K or K1,...,Kn",
                   help="the tendons' axial stiffness [N/m] over their length in the robot: one value for every "
                   "tendon or one per tendon (- for an inextensible one) [the robot file's, each tendon's "
                   "stiffness, else inextensible]; sets the pull-ins reported and the tensions --displacements finds")
    s.add_argument("--atol", type=real_type, default=DEFAULT_ATOL,
                   help=f"convergence tolerance on max |residual| [N m], held within 1e-12..1e-8 of the "
                        f"problem's moment scale (docs/models.md) [{DEFAULT_ATOL:g}]")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--plot", metavar="FILE", help="write a 3D figure of the robot (PNG, PDF, SVG)")
    s.add_argument("--csv", metavar="FILE", help="write every disk's centre [m] and frame (rotation, base from disk) "
                   "as CSV, one row per disk from the base; with --cases, the cases' table")
    s.add_argument("--compliance", action="store_true",
                   help="the tip's 6x6 compliance, tensions held (displacement, rotation by force, moment; base "
                   "frame) and its translational stiffness: exact, models pcc, pcc2, sscr")
    s.add_argument("--jacobians", action="store_true",
                   help="the tip's position and axis and every disk's position by the tensions (exact; in --json)")
    s.set_defaults(func=run)


def stability_text(st: Stability | None) -> str:
    """One line on the equilibrium's static stability."""
    if st is None:
        return "stability: not tested by this model"
    words = ("stable" if st.stable else
             f"UNSTABLE: {st.n_real_nonpositive} real eigenvalue(s) of the tangent stiffness <= 0 "
             f"(lowest {st.min_real_eigenvalue:.3g})")
    if st.flutter_pairs:
        z = st.least_damped
        words += (f"; {st.flutter_pairs} complex pair(s) with a negative real part (least damped {z.real:.3g} "
                  f"+/- {abs(z.imag):.3g}i: possible flutter, which a static model cannot decide)")
    return f"stability: {words}"


def _derivative_lines(res: SolveRun) -> None:
    """The compliance's and the Jacobians' summary lines (when computed)."""
    if res.compliance is not None:
        c = res.compliance.matrix
        lo, hi, _, _ = res.compliance.stiffness_range()
        print(f"  tip compliance diag [{', '.join(f'{x:.3g}' for x in np.diag(c)[:3])}] m/N, "
              f"[{', '.join(f'{x:.3g}' for x in np.diag(c)[3:])}] rad/(N m); translational stiffness "
              f"{lo:.3g} to {hi:.3g} N/m")
    if res.jacobians is not None:
        g = np.linalg.norm(res.jacobians.tip_position, axis=0) * 1e3
        print(f"  tip moves per newton of each tension [{', '.join(f'{x:.2f}' for x in g)}] mm/N")


def _run_cases(args: argparse.Namespace) -> int:
    """``--cases``: every row of the file by one model; the table on stdout (or in ``--csv``), or ``--json``."""
    import csv
    import io

    from .. import solve_batch
    from ..runs import case_rows, check_csv_path, read_cases
    from ..runtime import write_csv

    for flag, given in (("--plot", args.plot), ("--compliance", args.compliance), ("--jacobians", args.jacobians)):
        if given:
            raise CliError(f"{flag} solves one case: drop it with --cases")
    out = check_csv_path(args.csv) if args.csv is not None else None
    robot = robot_spec(args).build()
    loads = load_spec(args).build(robot)
    m, options = model_spec(args, atol=args.atol).resolve(robot, loads)
    T = read_cases(args.cases, robot)
    batch = solve_batch(robot, T, loads, model=m, options=options)
    header, rows = case_rows(batch)
    if args.json:
        print(dump_json({"robot": robot.name, "model": m.name, "cases": [dict(zip(header, r, strict=True))
                                                                         for r in rows]}))
    elif out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out, header, rows)
        print(f"{int(batch.converged.sum())} of {len(rows)} cases converged; wrote {escape_controls(str(out))}")
    else:
        buf = io.StringIO()
        csv.writer(buf).writerows([header, *rows])
        print(buf.getvalue(), end="")
    return EXIT_OK if bool(np.all(batch.converged)) else EXIT_NOT_CONVERGED


def run(args: argparse.Namespace) -> int:
    """Solve; print a summary (or one JSON object) and write the figure asked for."""
    from ..runs import SolveSettings, check_figure_path, run_solve

    if args.cases is not None:
        if args.displacements is not None:
            raise CliError("--displacements solves one case: drop it with --cases")
        return _run_cases(args)
    if args.tensions is None and args.displacements is None:
        raise CliError("give --tensions, --displacements or --cases")
    if args.plot is not None:
        check_figure_path(args.plot)
    settings = SolveSettings(
        tensions=() if args.tensions is None else tuple(parse_floats(args.tensions, "--tensions")),
        robot=robot_spec(args), loads=load_spec(args), model=model_spec(args, atol=args.atol),
        displacements=None if args.displacements is None else parse_optional(args.displacements, "--displacements"),
        stiffness=None if args.tendon_stiffness is None else parse_optional(args.tendon_stiffness,
                                                                            "--tendon-stiffness"))
    res = run_solve(settings, plot=args.plot, compliance=args.compliance, jacobians=args.jacobians, csv=args.csv)
    robot, sol = res.robot, res.solution
    if args.json:
        print(dump_json(res.to_json()))
    else:
        status = ("converged" if res.converged else "NOT converged" if not sol.converged
                  else "NOT converged: the displacements are not met")
        print(f"robot {robot.name}: {robot.n_disks} disks, {robot.n_tendons} tendons; {res.model.name} model; "
              f"{status}")
        print(f"  max |residual| {sol.residual:.3e} N m, {sol.iterations} {res.model.iteration_unit}, "
              f"{sol.load_steps} load steps, {sol.seconds * 1e3:.2f} ms")
        if sol.failure:
            print(f"  refused: {sol.failure}")
        if not res.converged:
            _drive_lines(res)
        else:
            p = sol.tip_position
            print(f"  tip position  [{p[0]: .6f}, {p[1]: .6f}, {p[2]: .6f}] m, |p| = {sol.reach:.6f} m")
            z = sol.tip_rotation[:, 2]
            print(f"  tip direction [{z[0]: .4f}, {z[1]: .4f}, {z[2]: .4f}]")
            held = ("" if res.drive is None or sol.stability is None
                    else " (with the tensions held; not tested with the displacements held)")
            print(f"  {stability_text(sol.stability)}{held}")
            _drive_lines(res)
            _derivative_lines(res)
    if args.plot is not None and not res.converged:
        print("tdcr: not plotting: the solve did not converge", file=sys.stderr)
    if args.csv is not None and not res.converged:
        print("tdcr: no shape written: the solve did not converge", file=sys.stderr)
    return EXIT_OK if res.converged else EXIT_NOT_CONVERGED


def _drive_lines(res: SolveRun) -> None:
    """The pull-ins, and how the displacements were met (when given)."""
    d = res.drive
    if d is not None:
        status = (f"met to {d.residual * 1e6:.2g} um" if d.converged
                  else f"NOT met: {d.message} (off by {d.residual * 1e3:.3g} mm)")
        print(f"  displacements {status}; {d.iterations} Newton steps, {d.solves} equilibria")
        print(f"  tensions [{', '.join(f'{t:.3f}' for t in d.tensions)}] N"
              + (f"; slack: tendons {', '.join(str(k + 1) for k in np.flatnonzero(d.slack))}" if d.slack.any()
                 else ""))
    if (pull := res.pulled_in) is not None:
        print(f"  pulled in [{', '.join(f'{x * 1e3:.3f}' for x in pull)}] mm")

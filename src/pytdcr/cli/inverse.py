"""``tdcr inverse``: the tensions that put the tip at a target (inverse statics), or along a path of targets."""

from __future__ import annotations

import argparse
import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..runtime import dump_json
from ..validate import escape_controls
from ._args import (
    add_bounds,
    add_model,
    add_robot_and_loads,
    add_seed,
    bounds_spec,
    count_type,
    load_spec,
    model_spec,
    parse_floats,
    real_type,
    robot_spec,
)
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, CliError

if TYPE_CHECKING:
    from ..bounds import TensionBounds
    from ..loads import Loads
    from ..optimize import InverseResult
    from ..robot import Robot

__all__ = ["add_parser", "run"]

#: the objectives, as :data:`pytdcr.optimize.OBJECTIVES` (not imported for ``--help``)
_OBJECTIVES = ("least-squares", "least-max", "least-total")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``inverse`` command and its options."""
    s = sub.add_parser("inverse", help="the tensions that put the tip at a target (inverse statics)")
    which = s.add_mutually_exclusive_group(required=True)
    which.add_argument("--target", metavar="X,Y,Z", help="the tip position wanted, base frame [m]")
    which.add_argument("--targets", metavar="FILE.csv",
                       help="a path: one target x,y,z [m] a row, solved in order, each continued from the last; "
                       "one CSV row per target on stdout, or in --csv")
    s.add_argument("--direction", metavar="DX,DY,DZ", help="the tip axis wanted too (normalised)")
    s.add_argument("--objective", choices=_OBJECTIVES, default="least-squares",
                   help="which of the redundant solutions: least sum of squared tensions, least largest tension, "
                   "least total [least-squares]")
    add_robot_and_loads(s)
    add_model(s)
    add_bounds(s)
    s.add_argument("--workspace", metavar="DIR",
                   help="start from the samples of this finished `tdcr workspace` run (its robot, loads, bounds "
                   "and model are used: give none of those options)")
    s.add_argument("--tol", type=real_type, default=1e-6, help="the miss accepted as reaching [m] [1e-6]")
    s.add_argument("--starts", type=count_type, default=3, help="starts tried until one reaches [3]")
    s.add_argument("--max-solves", type=count_type, default=200, help="solves one target may spend [200]")
    add_seed(s)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--csv", metavar="FILE", help="write one row per target (target, tensions, tip, distance, "
                   "reachable, stable, path) as CSV")
    s.set_defaults(func=run, model_default=s.get_default("model"))


class Problem(NamedTuple):
    """What ``tdcr inverse`` solves on: the robot, its external loads, the tension bounds, the model's registered
    name and the search's pool of starts (tensions (K, n_tendons) [N], tips (K, 3) [m]; None: the built-in one)."""

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: str
    pool: tuple[np.ndarray, np.ndarray] | None


def _problem(args: argparse.Namespace) -> Problem:
    """The :class:`Problem` of the options, or of ``--workspace`` (its run's robot, loads, bounds and model, its
    samples as the pool)."""
    from ..runs import BoundsSpec, read_workspace_pool

    if args.workspace is None:
        robot = robot_spec(args).build()
        loads = load_spec(args).build(robot)
        bounds = (bounds_spec(args) or BoundsSpec()).build(robot)
        return Problem(robot, loads, bounds, args.model, None)
    given = [flag for flag, on in (
        ("--robot", args.robot != "paper"), ("--tip-force", args.tip_force), ("--tip-moment", args.tip_moment),
        ("--disk-force", args.disk_force), ("--disk-moment", args.disk_moment), ("--gravity", args.gravity is not None),
        ("--friction", args.friction), ("--release", args.release), ("--bounds", args.bounds or args.bounds_file),
        ("--model", args.model != args.model_default), ("--shear-extension", args.shear_extension)) if on]
    if given:
        raise CliError(f"--workspace takes the robot, loads, bounds and model of its run: drop {', '.join(given)}")
    ws = read_workspace_pool(args.workspace)
    return Problem(ws.robot, ws.loads, ws.bounds, ws.model, (ws.tensions, ws.tips))


def run(args: argparse.Namespace) -> int:
    """Solve the target (or the path); print the answer (or one JSON object, or the CSV table)."""
    from .. import InverseSearch, TipTarget, inverse_path, inverse_statics
    from ..runs import InverseRun, check_csv_path, read_targets

    out = check_csv_path(args.csv) if args.csv is not None else None
    direction = parse_floats(args.direction, "--direction", 3) if args.direction else None
    target = parse_floats(args.target, "--target", 3) if args.target else None
    targets = read_targets(args.targets) if args.targets else None
    robot, loads, bounds, model, pool = _problem(args)
    m, options = model_spec(args).resolve(robot, loads) if args.workspace is None else (model, None)
    # a setting out of range is a SettingsError naming its field: the runner calls it by its option (FLAGS)
    search = InverseSearch(tol=args.tol, starts=args.starts, max_solves=args.max_solves, seed=args.seed,
                           options=options, pool=pool)
    if target is not None:
        results = [inverse_statics(robot, loads, TipTarget(target, direction), bounds=bounds, model=m,
                                   objective=args.objective, search=search)]
    else:
        results = inverse_path(robot, loads, targets, bounds=bounds, model=m, objective=args.objective,
                               direction=direction, search=search)
    name = m if isinstance(m, str) else m.name
    if args.json:
        answers = InverseRun(robot.name, name, args.objective, tuple(results), along_path=target is None)
        print(dump_json(answers.to_json()))
    elif target is not None:
        _print_one(robot, name, results[0])
    else:
        _print_path(results, out)
    if out is not None:
        from ..runs import inverse_columns, inverse_rows
        from ..runtime import write_csv

        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out, inverse_columns(robot.n_tendons), inverse_rows(results))
        if not args.json:
            print(f"wrote {escape_controls(str(out))}")
    return EXIT_OK if all(r.reachable for r in results) else EXIT_NOT_CONVERGED


def _vec(v: np.ndarray, digits: int = 6) -> str:
    return "[" + ", ".join(f"{x:.{digits}f}" for x in v) + "]"


def _print_one(robot: Robot, model: str, r: InverseResult) -> None:
    """One answer in a few lines: where the tip is [m], the tensions [N], the objective, the stability."""
    turn = "" if r.axis_error_rad is None else f", its axis {np.degrees(r.axis_error_rad):.3g} deg off"
    where = (f"REACHED ({r.path}), {r.distance_m:.2e} m away{turn}" if r.reachable else
             f"NOT reachable: the nearest point found is {r.distance_m:.3g} m away{turn} ({r.path})")
    print(f"robot {robot.name}, {model} model, {r.objective}: target {_vec(r.target)} m {where}")
    unit = "N^2" if r.objective == "least-squares" else "N"
    print(f"  tensions {_vec(r.tensions, 4)} N ({r.objective} {r.objective_value:.4g} {unit})")
    if r.pulled_in is not None:
        print(f"  pull-ins {_vec(r.pulled_in * 1e3, 3)} mm (what motors driven by displacement set)")
    state = "stable" if r.stable else "UNSTABLE" if r.stable is False else "stability untested"
    print(f"  tip {_vec(r.tip_position)} m, axis {_vec(r.tip_axis, 4)}; {state}; {r.evaluations} solves, "
          f"{r.seconds * 1e3:.0f} ms")


def _print_path(results: Sequence[InverseResult], out: Path | None) -> None:
    """The path's table on stdout (without ``--csv``: ``out`` None) or its summary (the table goes to ``out``)."""
    from ..optimize import InversePath
    from ..runs import inverse_columns, inverse_rows

    if out is None:
        buf = io.StringIO()
        csv.writer(buf).writerows([inverse_columns(results[0].tensions.size), *inverse_rows(results)])
        print(buf.getvalue(), end="")
        return
    reached = [r for r in results if r.reachable]
    paths = {p: sum(r.path == p for r in reached) for p in (InversePath.CONTINUED, InversePath.LOADING_PATH,
                                                            InversePath.ANOTHER_BRANCH)}
    how = f" ({', '.join(f'{n} {p}' for p, n in paths.items() if n)})" if reached else ""
    missed = len(results) - len(reached)
    t = np.array([r.tensions for r in results])
    jump = float(np.max(np.abs(np.diff(t, axis=0)))) if len(results) > 1 else 0.0
    print(f"{len(results)} targets: {len(reached)} reached{how}" + (f", {missed} out of reach" if missed else "")
          + f"; largest tension change between neighbours {jump:.3g} N; {sum(r.seconds for r in results):.2f} s")

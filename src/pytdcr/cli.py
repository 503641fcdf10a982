"""The ``tdcr`` command. Nothing in the package imports this module.

Exit status: 0 success; 1 solved but not converged (a single solve, or a
batch where nothing converged, or a search that found no converged tension
vector); 2 bad input (one line on stderr naming what is wrong); 130
interrupted (Ctrl-C or SIGTERM: one line saying what was saved).

The command runs in a worker thread; the main thread waits for it and turns
Ctrl-C into a cancellation the solvers check between small chunks of work
(:func:`pytdcr.statics.cancellable`), so every command stops within about a
second and saves what it has (:func:`pytdcr.study.output_folder`).
"""

from __future__ import annotations

import argparse
import contextvars
import os
import re
import signal
import sys
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .design import ConstantFriction, ExponentialFriction, NoFriction, Robot
from .io import RobotFileError, load_robot, read_toml, robot_to_dict, write_robot
from .loads import Loads, check_tensions
from .paper import DEFAULT_BOUNDS
from .runtime import dump_json
from .statics import (
    DEFAULT_ATOL,
    MODELS,
    UnsupportedFeatureError,
    cancellable,
    configure,
    get_model,
    resolve,
    solve,
)
from .validate import as_real_array, escape_controls, parse_numbers, read_text_file, show, show_path

__all__ = ["build_parser", "entry", "main"]


class CliError(Exception):
    """Bad command-line input: reported on one line, exit status 2."""


def parse_floats(text: str, name: str, count: int | None = None) -> np.ndarray:
    """Comma-separated finite numbers, e.g. ``0.1,0.1,-0.1`` (:func:`pytdcr.validate.parse_numbers`)."""
    try:
        return parse_numbers(text, name, count)
    except ValueError as err:
        raise CliError(str(err)) from None


def seed_type(text: str) -> int:
    """argparse type of a random seed: an integer in [0, 2**32 - 1]."""
    if not re.fullmatch(r"[0-9]{1,10}", text.strip()) or int(text) >= 2**32:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 4294967295], got {show(text)}")
    return int(text)


def count_type(text: str, lowest: int = 1) -> int:
    """argparse type of a count: a decimal integer >= ``lowest`` (no underscores, at most 12 digits)."""
    if not re.fullmatch(r"[+-]?[0-9]{1,12}", text.strip()) or int(text) < lowest:
        raise argparse.ArgumentTypeError(f"must be an integer >= {lowest}, got {show(text)}")
    return int(text)


def count0_type(text: str) -> int:
    """argparse type of a count that may be 0."""
    return count_type(text, 0)


def real_type(text: str) -> float:
    """argparse type of a finite real number (no underscores)."""
    try:
        return float(parse_numbers(text, "value", 1)[0])
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).removeprefix("value: ")) from None


class _Parser(argparse.ArgumentParser):
    """argparse, its errors on one line (``tdcr: error: ...``, exit 2) instead of usage and a message."""

    def error(self, message: str) -> NoReturn:
        command = self.prog.removeprefix("tdcr").strip()
        raise CliError(f"{command + ': ' if command else ''}{message}")


def add_model_options(p: argparse.ArgumentParser) -> None:
    """Robot and load options shared by solve, sample, optimize and reproduce."""
    g = p.add_argument_group("robot and loads")
    g.add_argument("--robot", default="paper", help="built-in robot (paper, rao) or a TOML file [paper]")
    g.add_argument("--tip-force", metavar="FX,FY,FZ", help="tip force in the base frame [N]")
    g.add_argument("--tip-moment", metavar="MX,MY,MZ", help="tip moment in the base frame [N m]")
    grav = g.add_mutually_exclusive_group()
    grav.add_argument("--gravity", dest="gravity", action="store_true", default=None,
                      help="gravity -9.81 m/s^2 along base z (default: the robot's own)")
    grav.add_argument("--no-gravity", dest="gravity", action="store_false", help="no gravity")
    g.add_argument("--friction", help="none, paper (mu = 0.689 exp(-0.027 sigma_deg)) or a constant MU "
                   "(default: the robot's own law)")
    g.add_argument("--release", action="store_true", help="friction for releasing actuators (default: pulling)")


def models_help() -> str:
    """``--model``'s help: every registered model with its one-line description."""
    return "; ".join(f"{name}: {m.description}" for name, m in MODELS.items()) + " [pcc]"


def add_model_choice(p: argparse.ArgumentParser) -> None:
    """--model NAME (the registry's models) and --shear-extension (solve, sample, optimize)."""
    g = p.add_argument_group("static model")
    g.add_argument("--model", choices=list(MODELS), default="pcc", help=models_help())
    g.add_argument("--shear-extension", action="store_true",
                   help="let the backbone shear and stretch (models with that option; default inextensible)")


def options_from_args(model: str, atol: float | None = None, shear_extension: bool = False) -> Any:
    """The model's default options with the command line's overrides; CliError if the model lacks one."""
    overrides: dict[str, Any] = {}
    if atol is not None:
        overrides["atol"] = atol
    if shear_extension:
        overrides["shear_extension"] = True
    try:
        return configure(model, **overrides)
    except UnsupportedFeatureError as err:
        flag = "--shear-extension" if err.feature == "the option 'shear_extension'" else "--atol"
        raise CliError(f"{flag}: model '{model}' has no such option") from None


def solver_from_args(args: argparse.Namespace, robot: Robot, loads: Loads | None = None,
                     atol: float | None = None) -> tuple[str, Any]:
    """The chosen model's name and options, checked against the robot (friction) by the registry."""
    opts = options_from_args(args.model, atol, args.shear_extension)
    model, opts = resolve(args.model, robot, loads, opts)
    return model.name, opts


@dataclass(frozen=True)
class ModelSetup:
    """What :func:`add_model_options` parsed: robot and external loads (tensions zero)."""

    robot: Robot
    loads: Loads


def model_from_args(args: argparse.Namespace) -> ModelSetup:
    """Build the robot and the external loads from parsed options; CliError on bad input."""
    try:
        robot = load_robot(args.robot)
    except RobotFileError as err:
        raise CliError(str(err)) from None
    if args.gravity is True:
        robot = robot.with_gravity((0.0, 0.0, -9.81))
    elif args.gravity is False:
        robot = robot.with_gravity(None)
    if args.friction is not None:
        f = args.friction.strip().lower()
        if f == "none":
            robot = robot.with_friction(NoFriction())
        elif f == "paper":
            robot = robot.with_friction(ExponentialFriction())
        else:
            mu = parse_floats(f, "--friction", 1)[0]
            if not 0.0 <= mu <= 10.0:
                raise CliError(f"--friction: constant mu must be in [0, 10], got {mu}")
            robot = robot.with_friction(ConstantFriction(mu0=mu))
    tf = parse_floats(args.tip_force, "--tip-force", 3) if args.tip_force else np.zeros(3)
    tm = parse_floats(args.tip_moment, "--tip-moment", 3) if args.tip_moment else np.zeros(3)
    loads = Loads(np.zeros(robot.n_tendons), tip_force=tf, tip_moment=tm, release=args.release)
    return ModelSetup(robot, loads)


def parse_tensions(text: str, robot: Robot) -> np.ndarray:
    """Tensions for every tendon, finite and >= 0 [N]."""
    t = parse_floats(text, "--tensions")
    if t.size != robot.n_tendons:
        raise CliError(f"--tensions: robot '{robot.name}' has {robot.n_tendons} tendons, got {t.size} values")
    try:
        return check_tensions(t, robot.n_tendons, name="--tensions")
    except ValueError as err:
        raise CliError(str(err)) from None


def add_bounds_options(p: argparse.ArgumentParser) -> None:
    """--bounds LO,HI or --bounds-file F (TOML with lists ``lower`` and ``upper``, one entry per tendon)."""
    b = p.add_mutually_exclusive_group()
    b.add_argument("--bounds", metavar="LO,HI", help="tension bounds for every tendon [N] (default 0,20)")
    b.add_argument("--bounds-file", metavar="F", help="TOML file: lower = [...], upper = [...] (per tendon, N)")


def bounds_from_args(args: argparse.Namespace, robot: Robot):
    """Tension bounds from the options; CliError naming the problem."""
    from .workspace import TensionBounds

    nt = robot.n_tendons
    try:
        if args.bounds_file:
            data = read_toml(args.bounds_file, "--bounds-file")
            unknown = set(data) - {"lower", "upper"}
            if unknown:
                raise CliError(f"--bounds-file: unknown key(s) {show(sorted(unknown))}; allowed: lower, upper")
            if "lower" not in data or "upper" not in data:
                raise CliError("--bounds-file: needs both 'lower' and 'upper' lists")
            try:
                lo = as_real_array(data["lower"], "--bounds-file: lower").reshape(-1)
                hi = as_real_array(data["upper"], "--bounds-file: upper").reshape(-1)
            except TypeError as err:
                raise CliError(f"{err}; 'lower' and 'upper' must be lists of numbers") from None
            if lo.size != nt or hi.size != nt:
                raise CliError(f"--bounds-file: robot '{robot.name}' has {nt} tendons; lower has {lo.size} "
                               f"entries, upper {hi.size}")
            return TensionBounds(lo, hi)
        lo_hi = parse_floats(args.bounds, "--bounds", 2) if args.bounds else np.array(DEFAULT_BOUNDS)
        return TensionBounds.uniform(nt, lo_hi[0], lo_hi[1])
    except ValueError as err:
        raise CliError(str(err).replace("bounds:", "--bounds:", 1)) from None


class _Bar:
    """A tqdm progress bar on stderr, drawn from its first step: input refused before any work prints alone."""

    def __init__(self, desc: str, total: int, unit: str) -> None:
        self.desc, self.total, self.unit = desc, total, unit
        self.bar: Any = None

    def step(self, k: int = 1, label: str | None = None) -> None:
        """Advance by ``k``; ``label`` shows beside the bar."""
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, desc=self.desc, unit=self.unit, leave=False, file=sys.stderr)
        if label is not None:
            self.bar.set_postfix_str(label, refresh=False)
        self.bar.update(k)

    def generation(self, _gen: int, best: float, _mean: float) -> None:
        """The GA's progress callback."""
        self.step(1, f"best={best:.6f}")

    def __enter__(self) -> _Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.close()


def _check_out(text: str) -> Path:
    """--out: refused before any work if the output-folder rule will not use it (a file, other files, in use)."""
    from .runtime import check_output_folder

    check_output_folder(text)
    return Path(text)


def _cmd_sample(args: argparse.Namespace) -> int:

    from .study import run_sample

    out = _check_out(args.out)
    setup = model_from_args(args)
    bounds = bounds_from_args(args, setup.robot)
    model, options = solver_from_args(args, setup.robot, setup.loads)
    with _Bar("sample", args.n, "solve") as bar:
        run = run_sample(setup.robot, setup.loads, bounds, args.n, args.seed, out, model=model, options=options,
                         progress=bar.step)
    s = run.samples
    ok = int(s.converged.sum())
    reach = (f"reach {np.nanmin(s.reach):.4f} to {np.nanmax(s.reach):.4f} m" if ok else "no reach")
    print(f"{args.n} samples of robot '{setup.robot.name}' (seed {args.seed}): {ok} converged, "
          f"{args.n - ok} not; {reach}; {s.seconds:.2f} s")
    print(f"wrote {', '.join(run.files)} in {escape_controls(str(out))}")
    if ok == 0:
        print(f"tdcr: none of the {args.n} samples converged", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


class _Bars:
    """One progress bar per stage of a long run (``progress(stage, total)``), closed when the next opens."""

    def __init__(self) -> None:
        self.bar: _Bar | None = None

    def __call__(self, stage: str, total: int | None) -> Any:
        self.close()
        self.bar = _Bar(stage, total, "solve" if "h(d)" not in stage else "dir")  # type: ignore[arg-type]
        return self.bar.step

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__()
            self.bar = None


def _cmd_designs(args: argparse.Namespace) -> int:
    from .designs import DesignsRunOptions, format_measure, load_study, run_designs

    study, robot, text = load_study(args.study)
    if args.workers is not None and not 1 <= args.workers <= 4096:
        raise CliError(f"--workers = {args.workers}: must be in [1, 4096]")
    bar = _Bar("designs", 0, "design")

    def progress(done: int, failed: int, total: int) -> None:
        if bar.bar is None:
            bar.total = total
            bar.step(done, f"failed={failed}")
        else:
            bar.bar.total = total  # the optimiser's total is an upper bound until it ends
            bar.step(done - bar.bar.n, f"failed={failed}")

    try:
        run = run_designs(study, robot, args.out, study_text=text, options=DesignsRunOptions(
            scheduler=args.scheduler, workers=args.workers, restart=args.restart, progress=progress,
            figures=not args.no_figures))
    finally:
        bar.__exit__()
    s = run.summary
    print(f"design study '{study.name}': {s['designs']} designs, {s['designs_computed']} computed, "
          f"{s['designs_reused']} reused, {s['designs_failed']} failed, on {s['executor']} in {s['seconds']:.1f} s")
    t = run.table
    for b in s["best"]:
        m = b["measure"]
        ref = t[(t["load_case"] == b["load_case"]) & (t["design"] == -1) & (t["status"] == "ok")]
        err = f" ± {format_measure(b['error'], m)}" if b["error"] is not None else ""
        versus = f" (base robot {format_measure(ref[m].iloc[0], m)})" if not ref.empty else ""
        print(f"  {escape_controls(b['load_case'])}: best by {b['goal']} {m}: design {b['design']}, "
              f"{format_measure(b['value'], m)}{err}{versus}")
    if s.get("warnings"):
        print("  warning: at this budget the volumes are a screening index, not a measurement: their errors exceed "
              "the margins between the leading designs (see report.md)")
    figures = ", figures" if s.get("figures") else ""
    print(f"wrote designs.parquet, designs.csv, timings.csv, summary.json, report.md, best/{figures} in "
          f"{escape_controls(str(run.path))}")
    return EXIT_OK if s["designs_failed"] < s["designs"] else EXIT_NOT_CONVERGED


def _workspace_lines(name: str, s: dict[str, Any]) -> list[str]:
    out = [f"  {name}:"]
    for label, d in (("FSW", s), ("realisable", s["realisable"])):
        reach = f"{d['largest_reach_m']:.4f} m" if d["largest_reach_m"] is not None else "none"
        out.append(f"    {label}: volume {d['volume_m3'] * 1e6:.0f} ± {d['volume_err_m3'] * 1e6:.0f} cm^3, largest "
                   f"reach {reach}")
    c = s["counts"]
    search = s.get("boundary_search") or {}
    out.append(f"    {c['converged']} of {c['solved']} converged, {c['unstable']} unstable; warm starts: "
               f"{s['warm_start']['mode']}; boundary search: {search.get('solves', 0)} solves, "
               f"{search.get('stop', 'off')}")
    return out


def _cmd_workspace(args: argparse.Namespace) -> int:
    from .paper import workspace_load_cases
    from .region import WorkspaceSettings
    from .study import WorkspaceRunOptions, run_workspace, run_workspace_compare

    out = _check_out(args.out)
    setup = model_from_args(args)
    bounds = bounds_from_args(args, setup.robot)
    model, options = solver_from_args(args, setup.robot, setup.loads)
    try:  # the settings check their ranges; the message names the option
        settings = WorkspaceSettings(n=args.n, seed=args.seed, voxel=args.voxel, warm=not args.no_warm,
                                     search=not args.no_search, budget=args.budget,
                                     directions=args.directions).check(setup.robot)
    except ValueError as err:
        raise CliError(f"--{err}") from None
    bars = _Bars()
    kw = {"model": model, "options": options,
          "run_options": WorkspaceRunOptions(command=" ".join(["tdcr", *sys.argv[1:]]), progress=bars)}
    try:
        if args.compare_loads:
            cases = workspace_load_cases(setup.robot, setup.loads)
            run = run_workspace_compare(setup.robot, cases, bounds, settings, out, **kw)
        else:
            run = run_workspace(setup.robot, setup.loads, bounds, settings, out, **kw)
    finally:
        bars.close()
    print(f"workspace of robot '{setup.robot.name}' (n {args.n}, seed {args.seed}, bounds "
          f"{bounds.lower.min():g} to {bounds.upper.max():g} N):")
    for case in run.cases:
        print("\n".join(_workspace_lines(case.name, case.summary)))
    print(f"wrote {', '.join(run.files)} in {escape_controls(str(out))}")
    for case in run.cases:
        for w in case.summary["warnings"]:
            print(f"tdcr: {case.name}: {w}", file=sys.stderr)
    if any(c.summary["mesh"] is None for c in run.cases):
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _print_reach(res: Any, args: argparse.Namespace) -> None:
    ga = res.ga
    print(f"GA (population {args.pop}, seed {args.seed}): {res.generations} generations"
          f"{'' if res.stop_reason == 'tolerance' else ' (generation cap)'}, {res.evaluations} solves, "
          f"{res.nonconverged} not converged, {res.seconds:.1f} s")
    print(f"  GA best: tensions {np.round(ga.tensions, 4).tolist()} N, reach {ga.reach:.6f} m, cost {ga.cost:.6f} 1/m")
    if res.polished:
        print(f"  polished: reach {res.reach:.6f} m (cost {res.cost:.6f}, gain {res.polish_gain:.2e}), "
              f"tensions {np.round(res.tensions, 4).tolist()} N")
    print(f"  optimum tip {np.round(res.tip_position, 6).tolist()} m; "
          f"{'stable' if res.stable else 'UNSTABLE' if res.stable is False else 'stability untested'}"
          f"{f' ({res.unstable} unstable individuals refused)' if res.unstable else ''}")


def _cmd_optimize(args: argparse.Namespace) -> int:
    from .optimize import MemeticGA, ReachProblem, SearchFailed, Termination
    from .study import run_optimize

    out = _check_out(args.out) if args.out else None
    try:
        algorithm = MemeticGA(pop_size=args.pop, local_search=not args.no_local_search, polish=not args.no_polish)
        termination = Termination(tol=args.tol, window=args.window, max_gen=args.max_gen)
    except ValueError as err:
        name = str(err).split(" ", 1)[0]
        flag = {"pop_size": "--pop", "max_gen": "--max-gen", "window": "--window", "tol": "--tol"}.get(name, name)
        raise CliError(f"{flag}{str(err)[len(name):]}") from None
    setup = model_from_args(args)
    bounds = bounds_from_args(args, setup.robot)
    model, options = solver_from_args(args, setup.robot, setup.loads)
    problem = ReachProblem.create(setup.robot, setup.loads, bounds, model=model, options=options,
                                  stable_only=args.stable_only)
    try:
        with _Bar("GA", args.max_gen, "gen") as bar:
            res, files = run_optimize(problem, algorithm, termination, seed=args.seed, out=out,
                                      progress=None if args.json else bar.generation)
    except SearchFailed as err:
        print(f"tdcr: {_one_line(err)}; nothing written", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if args.json:
        print(dump_json(res.to_dict()))
    else:
        _print_reach(res, args)
        if files:
            print(f"wrote {', '.join(files)} in {escape_controls(str(out))}")
    return EXIT_OK


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .study import run_reproduce

    setup = model_from_args(args)
    if np.any(setup.loads.tip_force) or np.any(setup.loads.tip_moment):
        raise CliError("reproduce: the study sets its own tip loads; drop --tip-force/--tip-moment")
    out = _check_out(args.out)

    def progress(stage: str, total: int) -> Any:
        return _Bar(stage, total, "gen").generation

    from .study import ReproduceSettings

    settings = ReproduceSettings.full() if args.full else ReproduceSettings()
    summary = run_reproduce(setup.robot, out, seed=args.seed, progress=progress, settings=settings)
    print(f"reproduced the study on robot '{setup.robot.name}' in {summary['seconds']:.1f} s; "
          f"report: {out / 'report.md'}")
    return 0


def _read_cases(path: str, robot: Robot) -> np.ndarray:
    """Tension vectors from a CSV file: one row per case, one column per tendon.

    Blank lines and ``#`` comments are skipped. A first row with no number at all is a header; a row mixing
    numbers and words is an error, never a header. Fields are separated by commas only.
    """
    try:
        lines = read_text_file(path, "--cases file").splitlines()
    except ValueError as err:
        raise CliError(str(err)) from None
    rows = []
    for k, line in enumerate(lines, 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        for sep in (";", "\t"):
            if sep in line and "," not in line:
                raise CliError(f"--cases {show_path(path)}: line {k}: values must be separated by commas, found "
                               f"{show(sep)} in {show(line)}")
        fields = [f.strip() for f in line.split(",")]
        if not rows and all(not re.fullmatch(r"[+-]?[\d.]+(?:[eE][+-]?\d+)?", f) for f in fields):
            continue  # a header: no field is a number
        try:
            vals = parse_numbers(line, f"--cases {show_path(path)}: line {k}", robot.n_tendons)
            rows.append(check_tensions(vals, robot.n_tendons, name=f"--cases {show_path(path)}: line {k}: tensions"))
        except ValueError as err:
            raise CliError(f"{err} (robot '{robot.name}' has {robot.n_tendons} tendons)") from None
    if not rows:
        raise CliError(f"--cases {show_path(path)}: no cases (each line: {robot.n_tendons} comma-separated "
                       "tensions [N])")
    return np.array(rows, dtype=float)


def _compare_models(args: argparse.Namespace) -> tuple[str, ...]:
    names = tuple(x.strip() for x in args.models.split(",") if x.strip())
    for name in names:
        if name not in MODELS:
            raise CliError(f"--models: {name!r} is not a model; choose from {', '.join(MODELS)}")
    if len(names) < 2 or len(set(names)) != len(names):
        raise CliError(f"--models: give two or more distinct models, comma-separated, got {args.models!r}")
    return names


def _compare_robot(args: argparse.Namespace, robot: Robot, names: tuple[str, ...]) -> tuple[Robot, str]:
    """The robot's own friction law is turned off (for every model) when one of the models has none."""
    frictionless = [n for n in names if not get_model(n).capabilities.friction]
    explicit = args.friction is not None and args.friction.strip().lower() != "none"
    if robot.friction.is_frictionless or not frictionless or explicit:
        return robot, ""  # an explicit --friction is checked by the registry (and refused by such a model)
    note = (f" (friction of robot '{robot.name}' turned off for every model: {', '.join(frictionless)} "
            "has none)")
    return robot.with_friction(NoFriction()), note


def _cmd_compare(args: argparse.Namespace) -> int:

    from .study import run_compare

    names = _compare_models(args)
    out = _check_out(args.out)
    setup = model_from_args(args)
    robot, note = _compare_robot(args, setup.robot, names)
    options = {n: options_from_args(n, shear_extension=args.shear_extension and
                                    "shear_extension" in get_model(n).options_type.__dataclass_fields__)
               for n in names}
    for n in names:
        resolve(n, robot, setup.loads, options[n])  # refuses before any work
    if args.cases:
        if args.bounds or args.bounds_file:
            raise CliError("--cases: give either --cases or --n with --bounds, not both")
        T = _read_cases(args.cases, robot)
        source = {"cases": args.cases}
    else:
        bounds = bounds_from_args(args, robot)
        T = bounds.sample(args.n, np.random.default_rng(args.seed))
        source = {"cases": f"{args.n} random within bounds, seed {args.seed}", "bounds": bounds.to_dict(),
                  "seed": args.seed}
    with _Bar("compare", T.shape[0], "case") as bar:
        cmp, files = run_compare(robot, setup.loads, T, out, source=source, models=names, options=options,
                                 progress=bar.step)
    s = cmp.summary()

    def mm(v: float | None) -> str:
        return "n/a" if v is None else f"{v:.3f}"

    diffs = "; ".join(f"{n} from {cmp.reference}: median {mm(s[f'{n}_difference_median_mm'])} mm, max "
                      f"{mm(s[f'{n}_difference_max_mm'])} mm" for n in cmp.others)
    times = ", ".join(f"{n} {s[f'{n}_ms_median']:.2f} ms" for n in cmp.models)
    print(f"{s['cases']} cases on robot '{robot.name}'{note}: every model converged on {s['all_converged']}; "
          f"tip difference {diffs}; median solve {times}")
    print(f"wrote {', '.join(files)} in {escape_controls(str(out))}")
    if s["all_converged"] == 0:
        failed = ", ".join(f"{n} {s[f'{n}_not_converged']}" for n in cmp.models)
        print(f"tdcr: no case converged for every model (not converged of {s['cases']}: {failed})", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _int_list(text: str, name: str) -> list[int]:
    vals = parse_floats(text, name)
    if np.any(vals != np.round(vals)) or np.any(vals < 1):
        raise CliError(f"{name}: expected comma-separated integers >= 1, got {show(text)}")
    return [int(v) for v in vals]


def _check_accuracy_plan(robot: Robot, models: list[str], disks: list[int], steps: int, order: bool) -> None:
    """Every robot the accuracy study will build, the reference's steps and the memory, before any work."""
    from .accuracy import REFERENCE, reference_options
    from .statics import check_resources

    if order and (len(set(disks)) < 2 or len(set(disks)) != len(disks)):
        raise CliError(f"--disks: the order study needs two or more different disk counts, got {disks}")
    per = max(s.n_disks for s in robot.segments)
    for n in [per, *(disks if order else [])]:
        try:
            r = robot if n == per else robot.with_disks(n)
        except ValueError as err:
            raise CliError(f"--disks: {err}") from None
        try:
            ref = reference_options(n, steps)
        except ValueError:
            raise CliError(f"--reference-steps {steps}: with {n} disks per segment that is "
                           f"{-(-steps // n)} Runge-Kutta steps per subsegment, more than 1000") from None
        for m in models:
            check_resources(get_model(m), r, get_model(m).default_options())
        check_resources(get_model(REFERENCE), r, ref)


def _cmd_accuracy(args: argparse.Namespace) -> int:

    from .accuracy import default_groups
    from .study import run_accuracy

    out = _check_out(args.out)
    setup = model_from_args(args)
    if np.any(setup.loads.tip_force) or np.any(setup.loads.tip_moment):
        raise CliError("accuracy: the study sets its own load groups; drop --tip-force/--tip-moment")
    for name, val, lo in (("--n", args.n, 1), ("--order-cases", args.order_cases, 0),
                          ("--reference-steps", args.reference_steps, 16)):
        if val < lo:
            raise CliError(f"{name} must be >= {lo}, got {val}")
    if not (np.isfinite(args.payload_g) and 0 < args.payload_g <= 1000):
        raise CliError(f"--payload-g must be in (0, 1000] g, got {args.payload_g}")
    models = [m.strip() for m in args.models.split(",")] if args.models else list(MODELS)
    for m in models:
        if m not in MODELS:
            raise CliError(f"--models: {m!r} is not a model; choose from {', '.join(MODELS)}")
    disks = _int_list(args.disks, "--disks")
    _check_accuracy_plan(setup.robot, models, disks, args.reference_steps, args.order_cases > 0)
    bounds = bounds_from_args(args, setup.robot)
    groups = default_groups(args.payload_g / 1e3)
    total = len(groups) * (len(models) + 1) + (len(disks) * len(groups) if args.order_cases else 0)
    with _Bar("accuracy", total, "step") as bar:
        study, orders, files = run_accuracy(setup.robot, out, n=args.n, bounds=bounds, seed=args.seed,
                                            groups=groups, models=models, disks=disks, order_cases=args.order_cases,
                                            reference_steps=args.reference_steps,
                                            progress=lambda label: bar.step(1, label))
    print(f"{args.n} tension vectors on robot '{setup.robot.name}', {len(groups)} load groups, "
          f"{len(study.models)} models against sscr ({study.seconds:.1f} s):")
    for r in study.rows():
        if r["unsupported"]:
            print(f"  {r['group']:>18s}  {r['model']:9s} unsupported")
            continue
        print(f"  {r['group']:>18s}  {r['model']:9s} median {r['median_error_mm']:9.3f} mm, 95th pct "
              f"{r['p95_error_mm']:9.3f} mm, converged {r['converged']}/{r['reference_converged']}, "
              f"{r['median_ms']:.2f} ms")
    for st in orders:
        print(f"  order ({st.group}): " + ", ".join(f"{m} {o:.2f}" for m, o in st.order.items()))
    print(f"wrote {', '.join(files)} in {escape_controls(str(out))}")
    return 0


# ---------------------------------------------------------------- commands
def _check_plot_path(text: str | None) -> Path | None:
    """--plot: a file path with a figure suffix, whose folder exists or can be made; never a folder."""
    if text is None:
        return None
    path = Path(text)
    if path.is_dir():
        raise CliError(f"--plot {show_path(text)}: is a folder; give a file name ending in .png, .pdf or .svg")
    if path.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise CliError(f"--plot {show_path(text)}: the file name must end in .png, .pdf or .svg")
    if path.parent.exists() and not path.parent.is_dir():
        raise CliError(f"--plot {show_path(text)}: {show_path(path.parent)} is a file, not a folder")
    return path


def _cmd_solve(args: argparse.Namespace) -> int:
    plot = _check_plot_path(args.plot)
    setup = model_from_args(args)
    robot = setup.robot
    tensions = parse_tensions(args.tensions, robot)
    loads = setup.loads.with_tensions(tensions)
    model, options = solver_from_args(args, robot, loads, args.atol)
    sol = solve(robot, loads, model=model, options=options)
    if args.json:
        print(dump_json({"robot": robot.name, **sol.to_dict()}))
    else:
        status = "converged" if sol.converged else "NOT converged"
        print(f"robot {robot.name}: {robot.n_disks} disks, {robot.n_tendons} tendons; {model} model; {status}")
        print(f"  max |residual| {sol.residual:.3e} N m, {sol.iterations} {get_model(model).iteration_unit}, "
              f"{sol.load_steps} load steps, {sol.seconds * 1e3:.2f} ms")
        if sol.failure:
            print(f"  refused: {sol.failure}")
        if sol.converged:
            p = sol.tip_position
            print(f"  tip position  [{p[0]: .6f}, {p[1]: .6f}, {p[2]: .6f}] m, |p| = {sol.reach:.6f} m")
            z = sol.tip_rotation[:, 2]
            print(f"  tip direction [{z[0]: .4f}, {z[1]: .4f}, {z[2]: .4f}]")
            print(f"  {_stability_text(sol.stability)}")
    if plot is not None:
        if not sol.converged:
            print("tdcr: not plotting: the solve did not converge", file=sys.stderr)
        else:
            _plot_solution(sol, robot, loads, plot)
    return 0 if sol.converged else 1


def _stability_text(st: Any) -> str:
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


def _plot_solution(sol: Any, robot: Robot, loads: Loads, path: Path) -> None:
    from .plotting import plot_robot, save_figure_as

    arrows = []
    if np.any(loads.tip_force):
        f = loads.tip_force
        arrows.append((sol.tip_position, f / np.linalg.norm(f) * 0.25 * robot.length))
    ax = plot_robot(sol, robot, loads=arrows)
    ax.set_title(f"{robot.name}: tip at {np.array2string(sol.tip_position, precision=3)} m")
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure_as(ax.figure, path)  # whole or absent


def _cmd_robot(args: argparse.Namespace) -> int:
    try:
        robot = load_robot(args.robot)
        if args.out:
            write_robot(robot, args.out)
            return 0
    except RobotFileError as err:
        raise CliError(str(err)) from None
    import tomli_w

    print(tomli_w.dumps(robot_to_dict(robot)), end="")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``tdcr``."""
    p = _Parser(prog="tdcr", description="Statics and workspace of tendon-driven continuum robots.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("solve", help="static equilibrium under tendon tensions and tip loads")
    add_model_options(s)
    add_model_choice(s)
    s.add_argument("--tensions", required=True, metavar="T1,...,Tn", help="actuator tensions [N]")
    s.add_argument("--atol", type=real_type, default=DEFAULT_ATOL,
                   help=f"convergence tolerance on max |residual| [N m] [{DEFAULT_ATOL:g}]")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--plot", metavar="FILE", help="write a 3D figure of the robot (PNG, PDF, SVG)")
    s.set_defaults(func=_cmd_solve)

    sm = sub.add_parser("sample", help="random tension samples: CSV, Fig. 3(a) and Fig. 4")
    add_model_options(sm)
    add_model_choice(sm)
    add_bounds_options(sm)
    sm.add_argument("--n", type=count_type, default=100, help="number of samples [100]")
    sm.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    sm.add_argument("--out", default="out/sample", help="output folder [out/sample]")
    sm.set_defaults(func=_cmd_sample)

    ws = sub.add_parser("workspace", help="the feasible static workspace as a region: volume, boundary, "
                        "realisability")
    add_model_options(ws)
    add_model_choice(ws)
    add_bounds_options(ws)
    ws.add_argument("--n", type=count_type, default=4000, help="base (Sobol) samples [4000]")
    ws.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    ws.add_argument("--voxel", type=real_type, default=None, help="voxel edge [m] [robot length / 32]")
    ws.add_argument("--no-warm", action="store_true", help="every sample along the loading path (no warm starts)")
    ws.add_argument("--no-search", action="store_true", help="no boundary search: the region of the samples alone")
    ws.add_argument("--budget", type=count_type, default=None,
                    help="the boundary search's budget of solves [25 n]")
    ws.add_argument("--directions", type=int, default=200,
                    help="directions of the support function h(d) on a Fibonacci sphere; 0: none [200]")
    ws.add_argument("--compare-loads", action="store_true",
                    help="compare load cases: no load, gravity only, payloads 5/10/20 g, the paper's wrench, and "
                    "--tip-force/--tip-moment when given; one sub-folder each")
    ws.add_argument("--out", default="out/workspace", help="output folder [out/workspace]")
    ws.set_defaults(func=_cmd_workspace)

    op = sub.add_parser("optimize", help="GA maximising the tip's distance from the base (paper Eq. 29)")
    add_model_options(op)
    add_model_choice(op)
    add_bounds_options(op)
    op.add_argument("--pop", type=count_type, default=50, help="population size [50]")
    op.add_argument("--tol", type=real_type, default=1e-6, help="stop when the best cost improves by less [1e-6]")
    op.add_argument("--window", type=count_type, default=5, help="... over this many generations [5]")
    op.add_argument("--max-gen", type=count_type, default=100, help="generation cap [100]")
    op.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    op.add_argument("--no-polish", action="store_true", help="skip the gradient polish of the GA's best")
    op.add_argument("--no-local-search", action="store_true",
                    help="plain GA: no gradient search on each new leader (the default GA is memetic)")
    op.add_argument("--stable-only", action="store_true",
                    help="an equilibrium that fails the static stability test is infeasible (models with the test)")
    op.add_argument("--json", action="store_true", help="print one JSON object")
    op.add_argument("--out", help="write figures and data to this folder")
    op.set_defaults(func=_cmd_optimize)

    rp = sub.add_parser("reproduce", help="the paper's whole study: figures, data and report.md")
    add_model_options(rp)
    rp.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    rp.add_argument("--full", action="store_true",
                    help="the heavy version: the better models re-optimise the paper's optimum with the GA too "
                    "(default: a gradient polish from it)")
    rp.add_argument("--out", default="out/reproduce", help="output folder [out/reproduce]")
    rp.set_defaults(func=_cmd_reproduce)

    c = sub.add_parser("compare", help="two or more models on the same cases: table and overlay figure")
    add_model_options(c)
    add_bounds_options(c)
    c.add_argument("--cases", metavar="FILE", help="CSV of tension vectors, one case per row [N]")
    c.add_argument("--n", type=count_type, default=20, help="number of random cases when no --cases [20]")
    c.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    c.add_argument("--models", default="pcc,cosserat", metavar="A,B[,...]",
                   help=f"models to compare, the first the reference ({', '.join(MODELS)}) [pcc,cosserat]")
    c.add_argument("--shear-extension", action="store_true",
                   help="backbones shear and stretch (models with that option)")
    c.add_argument("--out", default="out/compare", help="output folder [out/compare]")
    c.set_defaults(func=_cmd_compare)

    a = sub.add_parser("accuracy", help="which model to trust: every model against sscr, by load group, and the "
                       "order study")
    add_model_options(a)
    add_bounds_options(a)
    a.add_argument("--n", type=count_type, default=20, help="random tension vectors [20]")
    a.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")
    a.add_argument("--models", metavar="A,B,...", help=f"models to compare (default all: {', '.join(MODELS)})")
    a.add_argument("--disks", default="5,10,20,40", metavar="N1,N2,...",
                   help="disks per segment of the order study [5,10,20,40]")
    a.add_argument("--order-cases", type=count0_type, default=3,
                   help="tension vectors of the order study (0: none) [3]")
    a.add_argument("--reference-steps", type=count_type, default=160,
                   help="Runge-Kutta steps per segment of the reference sscr [160]")
    a.add_argument("--payload-g", type=real_type, default=10.0, help="payload of the last load group [10 g]")
    a.add_argument("--out", default="out/accuracy", help="output folder [out/accuracy]")
    a.set_defaults(func=_cmd_accuracy)

    d = sub.add_parser("designs", help="a design study: a workspace study per design, on local processes or a "
                       "Dask cluster; resumable")
    d.add_argument("study", help="the study file (TOML; see examples/design_study_small.toml)")
    d.add_argument("--out", default="out/designs", help="output folder; a stopped study there resumes "
                   "[out/designs]")
    d.add_argument("--scheduler", help="a Dask scheduler's address (tcp://host:8786) to run on; default: local "
                   "processes")
    d.add_argument("--workers", type=int, help="local processes [all cores]")
    d.add_argument("--restart", action="store_true", help="discard what the folder holds and start again")
    d.add_argument("--no-figures", action="store_true", help="write no figures (the table and report only)")
    d.set_defaults(func=_cmd_designs)

    r = sub.add_parser("robot", help="print a robot as TOML (a starting point for your own)")
    r.add_argument("--robot", default="paper", help="built-in robot or TOML file [paper]")
    r.add_argument("--out", help="write to this file instead of stdout")
    r.set_defaults(func=_cmd_robot)
    return p


_VALUE_OPTIONS = ("--tip-force", "--tip-moment", "--tensions", "--bounds", "--friction")
_NUMBER_OPTIONS = ("--atol", "--tol", "--seed", "--n", "--pop", "--max-gen", "--window", "--payload-g")


def _glue_negative_values(argv: Sequence[str]) -> list[str]:
    """Let ``--tip-moment -0.1,0.1,0.1`` (or ``-inf``) through argparse, which takes ``-...`` for an option."""
    out: list[str] = []
    it = iter(argv)
    for tok in it:
        if tok in _VALUE_OPTIONS or tok in _NUMBER_OPTIONS:
            nxt = next(it, None)
            if nxt is None:
                out.append(tok)
            elif nxt[:1] == "-" and nxt[:2] != "--":
                out.append(f"{tok}={nxt}")
            else:
                out.extend([tok, nxt])
        else:
            out.append(tok)
    return out


#: exit statuses (README): success, a solve that did not converge, bad input, interrupted, a bug (sysexits'
#: EX_SOFTWARE)
EXIT_OK, EXIT_NOT_CONVERGED, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_INTERNAL = 0, 1, 2, 130, 70
#: the compute went away under a run that resumes (sysexits' EX_TEMPFAIL: try again)
EXIT_TRY_AGAIN = 75


def _one_line(message: object, limit: int = 600) -> str:
    """A message on one line: newlines folded, control characters escaped, at most ``limit`` characters."""
    text = " ".join(str(message).split())
    return show(text, limit)[1:-1]


class _Interrupted(Exception):
    """The command was interrupted; ``str()`` says what was saved."""


#: how long the main thread lets an interrupted command save what it has before it stops waiting [s]
SAVE_GRACE_S = 0.6


def _run_command(args: argparse.Namespace) -> int:
    """Run the chosen command in a worker thread within a cancellation scope; Ctrl-C here cancels it.

    The main thread waits on an event, not on ``Thread.join`` (an interrupted join can leave the thread
    reported as finished while it still runs).
    """
    outcome: dict[str, Any] = {}
    done = threading.Event()

    def target() -> None:
        try:
            outcome["code"] = int(args.func(args))
        except BaseException as err:  # handed to the main thread as it is
            outcome["error"] = err
        finally:
            done.set()

    with cancellable() as scope:
        threading.Thread(target=contextvars.copy_context().run, args=(target,), name="tdcr-command",
                         daemon=True).start()
        try:
            while not done.wait(0.1):
                pass
        except KeyboardInterrupt:
            scope.cancel()
            try:
                if not done.wait(SAVE_GRACE_S):
                    if not scope.saving.is_set():  # still inside one compiled call, with nothing to save
                        raise _Interrupted("nothing saved")
                    print("tdcr: interrupted; saving what was finished (Ctrl-C again to leave at once)",
                          file=sys.stderr, flush=True)
                    while not done.wait(0.1):
                        pass
            except KeyboardInterrupt:
                raise _Interrupted("left at once; nothing more saved") from None
            err = outcome.get("error")
            if err is None:
                raise _Interrupted("the run had finished; everything it wrote was saved") from None
            raise _Interrupted(getattr(err, "message", None) or "nothing saved") from None
    err = outcome.get("error")
    if err is None:
        return outcome["code"]
    if isinstance(err, KeyboardInterrupt):
        raise _Interrupted(getattr(err, "message", None) or "nothing saved") from None
    raise err


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``tdcr``; returns the exit status (0 success, 1 not converged, 2 bad input, 130 Ctrl-C,
    75 the compute went away under a resumable run, 70 a bug).

    Arguments are checked before any work starts; errors are one line on stderr. The command line writes
    figures to files and never opens a window: it alone picks matplotlib's Agg backend (unless
    ``MPLBACKEND`` says otherwise). Set ``PYTDCR_DEBUG=1`` to see the traceback behind an error message.
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    try:
        args = build_parser().parse_args(_glue_negative_values(sys.argv[1:] if argv is None else argv))
        return _run_command(args)
    except _Interrupted as stop:
        print(f"tdcr: interrupted; {_one_line(stop)}", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:
        print("tdcr: interrupted; nothing saved", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    except (CliError, ValueError, TypeError, OSError, MemoryError) as err:
        if os.environ.get("PYTDCR_DEBUG"):
            raise
        print(f"tdcr: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as err:  # a search with nothing converged, or a bug: one line, no traceback unless asked
        from .designs import WorkersLost
        from .optimize import SearchFailed

        if isinstance(err, SearchFailed):
            print(f"tdcr: {_one_line(err)}", file=sys.stderr)
            return EXIT_NOT_CONVERGED
        if isinstance(err, WorkersLost):
            print(f"tdcr: {_one_line(err)}", file=sys.stderr)
            return EXIT_TRY_AGAIN
        if os.environ.get("PYTDCR_DEBUG"):
            raise
        print(f"tdcr: internal error: {type(err).__name__}: {_one_line(err, 300)} (a bug in pytdcr: please report "
              "it; PYTDCR_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


def _terminate(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def entry() -> None:
    """The console script: :func:`main`, with SIGTERM treated as Ctrl-C; after an interrupt the process leaves
    without waiting for worker threads still finishing a chunk (everything saved has been written)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminate)
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    if code == EXIT_INTERRUPTED:
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    entry()

"""``tdcr workspace``: the feasible static workspace as a region (volume, boundary, realisability), under the
loads given or, with ``--compare-loads``, under each of the paper's load cases, or with ``--compare-models``,
by each of several models."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import TYPE_CHECKING

from ..paper import workspace_load_cases
from ..validate import escape_controls
from ._args import (
    add_bounds,
    add_model,
    add_n,
    add_out,
    add_robot_and_loads,
    add_seed,
    bounds_spec,
    check_out,
    count_type,
    load_spec,
    model_spec,
    real_type,
    robot_spec,
)
from ._progress import Bars, quiet, say
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, CliError

if TYPE_CHECKING:
    from ..bounds import TensionBounds
    from ..loads import Loads
    from ..robot import Robot
    from ..runs import WorkspaceCaseSpec
    from ..statics import ModelOptions
    from ..workspace import WorkspaceSettings, WorkspaceSummary

    #: the model the cases without one of their own are solved by: its name and options (None: its defaults)
    ModelChoice = tuple[str, ModelOptions | None]

__all__ = ["add_parser", "run"]

#: the region's equilibria (:attr:`pytdcr.workspace.WorkspaceSettings.EQUILIBRIA`: the parser is built without
#: importing the workspace package, so they are named here and a test checks them against the library's)
EQUILIBRIA_CHOICES = ("continuation", "loading-path")
#: the boundary search's rules at a fold (:attr:`pytdcr.workspace.WorkspaceSettings.FOLD_RULES`), likewise
FOLD_CHOICES = ("snap", "stop")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``workspace`` command and its options."""
    ws = sub.add_parser("workspace", help="the feasible static workspace as a region: volume, boundary, "
                        "realisability")
    add_robot_and_loads(ws)
    add_model(ws)
    add_bounds(ws)
    add_n(ws, 4000, "base (Sobol) samples")
    add_seed(ws)
    ws.add_argument("--voxel", type=real_type, default=None, help="voxel edge [m] [robot length / 32]")
    ws.add_argument("--no-warm", action="store_true", help="every sample along the loading path (no warm starts)")
    ws.add_argument("--no-search", action="store_true", help="no boundary search: the region of the samples alone")
    ws.add_argument("--budget", type=count_type, default=None,
                    help="the boundary search's budget of solves [25 n]")
    ws.add_argument("--search-folds", choices=FOLD_CHOICES, default=FOLD_CHOICES[0],
                    help="where a boundary-search step meets a fold: 'snap' through it and keep the equilibrium "
                    "past it, or 'stop' there and keep nothing (about half the search's time; the region grows "
                    "only along paths without a snap from its samples) [snap]")
    ws.add_argument("--directions", type=count_type, default=200,
                    help="directions of the support function h(d) on a Fibonacci sphere; 0: none [200]")
    ws.add_argument("--equilibria", choices=[*EQUILIBRIA_CHOICES, "both"], default=None,
                    help="which equilibrium of a tension vector the region holds: 'continuation', the one the robot "
                    "reaches from rest by quasi-static tension changes (each sample continued from a solved "
                    "parent), 'loading-path', each solved from rest with every load ramped together (the paper's), "
                    "or 'both' (one sub-folder each, compared) [continuation where the model can]")
    ws.add_argument("--multistability", type=count_type, default=200,
                    help="samples also solved along the other history, to measure how often the equilibrium "
                    "depends on it; 0: none (a loading-path region's check continues them from the root: models "
                    "that cannot continue a solved state need 0) [200]")
    ws.add_argument("--compare-loads", action="store_true",
                    help="compare load cases: no load, gravity only, payloads 5/10/20 g, the paper's wrench, and "
                    "--tip-force/--tip-moment when given; one sub-folder each")
    ws.add_argument("--compare-models", metavar="M1,M2,...", default=None,
                    help="compare the regions of several models under the same loads (e.g. pcc,pcc2,sscr): "
                    "volumes, the Hausdorff distance between boundaries, the share of each inside the others; one "
                    "sub-folder each")
    add_out(ws, "out/workspace")
    ws.set_defaults(func=run)


def _compare_models(args: argparse.Namespace, robot: Robot, loads: Loads) -> dict[str, WorkspaceCaseSpec] | None:
    """The cases of ``--compare-models`` (name → robot, loads, no settings of its own, model, options), or None
    without it; CliError for an unknown model, a repeated one, fewer than two, or another comparison asked
    (what each model can do is checked with every case's requirements: :func:`_check_cases`)."""
    from ..runs import ModelSpec, WorkspaceCaseSpec
    from ..statics import MODELS

    if args.compare_models is None:
        return None
    names = [n.strip() for n in args.compare_models.split(",")]
    unknown = [n for n in names if n not in MODELS]
    if unknown or len(set(names)) != len(names) or len(names) < 2:
        raise CliError(f"--compare-models: two or more distinct models of {', '.join(MODELS)}, comma-separated, "
                       f"got {escape_controls(args.compare_models)!r}")
    if args.compare_loads or args.equilibria == "both":
        raise CliError("--compare-models with --compare-loads or --equilibria both: choose one comparison")
    return {name: WorkspaceCaseSpec(robot, loads, None, name,
                                    ModelSpec(name, shear_extension=args.shear_extension).options())
            for name in names}


#: the settings a workspace's capability check names (``SettingsError.field``, ``UnsupportedFeatureError.setting``),
#: by their flags
_CHECKED_FLAGS = {"model": "--model", "equilibria": "--equilibria", "multistability": "--multistability"}


def _check_cases(args: argparse.Namespace, cases: dict[str, WorkspaceCaseSpec] | None, robot: Robot, loads: Loads,
                 settings: WorkspaceSettings, model: ModelChoice) -> None:
    """Every case's requirements against its model's capabilities, before the first solve (and before the
    estimate, which solves a few): CliError naming the flag that made the cases, the case and what its model
    lacks (:func:`pytdcr.runs.check_workspace_cases`); for a single case, the flag of the setting the error
    names (``--model``, ``--equilibria`` or ``--multistability``)."""
    from ..runs import check_workspace_cases
    from ..validate import SettingsError
    from ..workspace import check_workspace

    if cases is None:
        try:
            check_workspace(robot, loads, settings, model=model[0], options=model[1])
        except ValueError as err:
            at_fault = getattr(err, "field", None) or getattr(err, "setting", "model")
            raise CliError(SettingsError.about(at_fault, err).worded(_CHECKED_FLAGS)) from None
        return
    flag = ("--compare-models" if args.compare_models is not None else "--compare-loads" if args.compare_loads
            else "--equilibria both")
    try:
        check_workspace_cases(cases, settings.with_voxel_for(robot), model=model[0], options=model[1],
                              field_name="cases")
    except SettingsError as err:
        raise CliError(err.worded({"cases": flag})) from None


def _say_estimate(cases: dict[str, WorkspaceCaseSpec] | None, robot: Robot, loads: Loads, bounds: TensionBounds,
                  settings: WorkspaceSettings, model: ModelChoice) -> None:
    """Say the run's estimated time on stderr when it will take more than a minute (not with ``--quiet``)."""
    from ..runs import WorkspaceCaseSpec
    from ..workspace import workspace_estimate

    if quiet():
        return
    specs = list(cases.values()) if cases else [WorkspaceCaseSpec(robot, loads)]
    est = workspace_estimate([(c.robot, c.loads, replace(c.settings, voxel=settings.voxel) if c.settings else settings,
                               c.model if c.model is not None else model[0],
                               c.options if c.model is not None else model[1]) for c in specs], bounds)
    if est.seconds > 60:
        say(est.text())


def _workspace_lines(name: str, s: WorkspaceSummary) -> list[str]:
    """What the command prints of one case: each region's measure and largest reach, the samples, the
    equilibria, the boundary search and the multistability check."""
    from ..runs import format_measure_of

    out = [f"  {name}:"]
    for label, d in (("FSW", s.fsw), ("realisable", s.realisable)):
        reach = f"{d.largest_reach_m:.4f} m ({d.reach_rule})" if d.largest_reach_m is not None else "none"
        out.append(f"    {label}: {format_measure_of(d)}, largest reach {reach}")
    c, search = s.counts, s.boundary_search
    how = s.equilibria if s.equilibria == "continuation" else f"{s.equilibria} ({s.warm_start.mode})"
    out.append(f"    {c.converged} of {c.solved} converged, {s.stability_words()}; "
               f"equilibria: {how}; boundary search: {search.solves if search is not None else 0} solves, "
               f"{search.stop if search is not None else 'off'}")
    ms = s.multistability
    if ms is not None and ms.checked:
        out.append(f"    multistability: {ms.distinct} of {ms.checked} checked samples reach another equilibrium "
                   f"by the {ms.other} ({100 * (ms.fraction or 0.0):.1f} %)")
    return out


def run(args: argparse.Namespace) -> int:
    """The workspace study; print each case's volumes and reach, and what was written."""
    from ..runs import BoundsSpec, WorkspaceCaseSpec, WorkspaceRunOptions, run_workspace, run_workspace_compare
    from ..workspace import WorkspaceSettings

    out = check_out(args.out)
    robot = robot_spec(args).build()
    loads = load_spec(args).build(robot)
    bounds = (bounds_spec(args) or BoundsSpec()).build(robot, "there is no workspace to sample")
    m, options = model_spec(args).resolve(robot, loads)
    try:  # the settings check their ranges (the only place they live); the message names the option
        settings = WorkspaceSettings(n=args.n, seed=args.seed, voxel=args.voxel, warm=not args.no_warm,
                                     search=not args.no_search, budget=args.budget, directions=args.directions,
                                     folds=args.search_folds, multistability=args.multistability,
                                     equilibria=None if args.equilibria == "both" else args.equilibria
                                     ).check(robot)
    except ValueError as err:
        raise CliError(f"--{err}") from None
    if args.equilibria is not None:
        for kind in EQUILIBRIA_CHOICES if args.equilibria == "both" else (args.equilibria,):
            try:
                replace(settings, equilibria=kind).equilibria_of(m)
            except ValueError as err:
                raise CliError(f"--{err}") from None
    if args.equilibria == "both" and args.compare_loads:
        raise CliError("--equilibria both and --compare-loads: choose one comparison")
    by_model = _compare_models(args, robot, loads)
    if by_model is not None:
        cases = by_model
    elif args.compare_loads:
        cases = {k: WorkspaceCaseSpec(r, ld) for k, (r, ld) in workspace_load_cases(robot, loads).items()}
    elif args.equilibria == "both":
        cases = {k: WorkspaceCaseSpec(robot, loads, replace(settings, equilibria=k)) for k in EQUILIBRIA_CHOICES}
    else:
        cases = None
    _check_cases(args, cases, robot, loads, settings, (m.name, options))
    _say_estimate(cases, robot, loads, bounds, settings, (m.name, options))
    bars = Bars()
    kw = {"model": m.name, "options": options,
          "run_options": WorkspaceRunOptions(command=" ".join(["tdcr", *sys.argv[1:]]), progress=bars)}
    try:
        if cases is not None:
            res = run_workspace_compare(robot, cases, bounds, settings, out, **kw)
        else:
            res = run_workspace(robot, loads, bounds, settings, out, **kw)
    finally:
        bars.close()
    print(f"workspace of robot '{robot.name}' (n {args.n}, seed {args.seed}, bounds "
          f"{bounds.lower.min():g} to {bounds.upper.max():g} N):")
    for case in res.cases:
        print("\n".join(_workspace_lines(case.name, case.summary)))
    print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    for case in res.cases:
        for w in case.warnings:
            print(f"tdcr: {case.name}: {w}", file=sys.stderr)
    for name, why in res.failed.items():  # the others are kept, with their comparison
        print(f"tdcr: {escape_controls(name)}: failed while running, not compared: {escape_controls(why)}",
              file=sys.stderr)
    if res.failed or any(c.summary.fsw.points == 0 for c in res.cases):  # a case failed, or one has no region
        return EXIT_NOT_CONVERGED
    return EXIT_OK

"""``tdcr reproduce``: the paper's whole study, with figures, data and ``report.md``."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, Literal, overload

from ._args import add_out, add_robot_and_loads, add_seed, check_out, has_tip_wrench, robot_spec
from ._progress import Bars, quiet, say
from ._runtime import EXIT_OK, CliError

if TYPE_CHECKING:
    from ..optimize import ReachResult
    from ..runs import ReproduceRun

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``reproduce`` command and its options."""
    rp = sub.add_parser("reproduce", help="the paper's study at a modest budget (--full: all of it): figures, data "
                        "and report.md")
    add_robot_and_loads(rp)
    add_seed(rp)
    rp.add_argument("--full", action="store_true",
                    help="the paper's whole study: GA populations 50, 100 and 200 (default 50 and 100), bounds 10, 20 "
                    "and 40 N (default 20 and 40), the better models re-optimising the paper's optimum with the GA too "
                    "(default: a gradient polish from it) and the workspace at tdcr workspace's defaults")
    add_out(rp, "out/reproduce")
    rp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """The study on the robot asked for (the study sets its own loads); print where the report is."""
    from ..runs import ReproduceSettings, reproduce_estimate, run_reproduce

    robot = robot_spec(args).build()
    if has_tip_wrench(args):
        raise CliError("reproduce: the study sets its own tip loads; drop --tip-force/--tip-moment/--disk-force/"
                       "--disk-moment")
    out = check_out(args.out)

    settings = ReproduceSettings.full() if args.full else ReproduceSettings()
    if not quiet():
        est = reproduce_estimate(robot, settings, seed=args.seed)
        if est.seconds > 60:
            say(f"{est.text()}, for its workspace sections (the GAs and the better models run beside them)")
    with Bars() as bars:  # stages run at once, on threads: one row each in one live block

        @overload
        def progress(stage: str, total: int | None, unit: Literal["gen"]) -> Callable[[int, float, float], None]: ...

        @overload
        def progress(stage: str, total: int | None, unit: str) -> Callable[[int], None]: ...

        def progress(stage: str, total: int | None, unit: str) -> Callable[..., None]:
            """The study's ``progress(stage, total, unit)`` (:func:`~pytdcr.runs.run_reproduce`): a GA's
            ``on_generation`` for ``unit`` "gen", a stage's ``step(k)`` otherwise, each a row of the live block."""
            return bars.generations(stage, total) if unit == "gen" else bars(stage, total, unit)

        res = run_reproduce(robot, out, seed=args.seed, progress=progress, settings=settings)
    print(f"reproduced the study on robot '{robot.name}' in {res.seconds:.1f} s; report: {out / 'report.md'}")
    for line in closing_lines(res):
        print(f"  {line}")
    return EXIT_OK


def _optimum(r: ReachResult) -> str:
    """A reach optimum in a few words: the reach [mm] and its stability flag."""
    state = "" if r.stable is None else " (stable)" if r.stable else " (flagged UNSTABLE)"
    return f"{r.reach * 1e3:.1f} mm{state}"


def closing_lines(res: ReproduceRun) -> list[str]:
    """The key results of a reproduce run, one line each: a volume only where its error is below it, and called
    a screening estimate, with its relative error, where that error is above a quarter of it."""
    from ..validate import SCREENING_ERROR, measured, screening, unmeasured_text

    smp = res.sampling
    lines = [f"samples: {smp.converged} of {smp.n} converged, reach {smp.reach_min * 1e3:.1f} to "
             f"{smp.reach_max * 1e3:.1f} mm"]
    lines += [f"GA under the paper's load, population {pop}: largest reach {_optimum(r)}"
              for pop, r in sorted(res.ga.items())]
    lines.append(f"largest reach under a payload: {_optimum(res.payload)}")
    lines.append("largest reach by upper tension bound: " + "; ".join(f"{hi:g} N: {_optimum(r)}"
                                                                       for hi, r in res.bounds_study))
    lines += [f"the paper's optimum under {v.model}: " + (f"reach {v.reach * 1e3:.1f} mm, tip {v.tip_shift * 1e3:.1f} "
              "mm from pcc's" if v.converged else "not converged") for v in res.verdicts]
    for c in res.workspace.cases:
        reach = "none" if c.largest_reach_m is None else f"{c.largest_reach_m * 1e3:.1f} mm"
        err = f"{c.volume_err_m3 * 1e6:,.0f} cm3"
        volume = (f"{c.volume_m3 * 1e6:,.0f} +- {err}" if measured(c.volume_m3, c.volume_err_m3)
                  else "volume " + unmeasured_text(err, "tdcr reproduce --full"))
        if screening(c.volume_m3, c.volume_err_m3):
            volume = (f"screening estimate {volume} (error {100 * c.volume_err_m3 / c.volume_m3:.0f} %, above "
                      f"{100 * SCREENING_ERROR:.0f} %: a modest budget; tdcr reproduce --full measures it)")
        lines.append(f"workspace, {c.case}: {volume}, largest reach {reach}")
    return lines

"""``tdcr reproduce``: the paper's whole study, with figures, data and ``report.md``."""

from __future__ import annotations

import argparse
from typing import Any

from ._args import add_out, add_robot_and_loads, add_seed, check_out, has_tip_wrench, robot_spec
from ._progress import Bar
from ._runtime import EXIT_OK, CliError

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
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
    from ..study import ReproduceSettings, run_reproduce

    robot = robot_spec(args).build()
    if has_tip_wrench(args):
        raise CliError("reproduce: the study sets its own tip loads; drop --tip-force/--tip-moment/--disk-force/"
                       "--disk-moment")
    out = check_out(args.out)

    opened: list[Bar] = []  # stages may run at once, on threads: each its own bar, all closed at the end

    def progress(stage: str, total: int) -> Any:
        bar = Bar(stage, total, "gen")
        opened.append(bar)
        return bar.generation

    settings = ReproduceSettings.full() if args.full else ReproduceSettings()
    try:
        res = run_reproduce(robot, out, seed=args.seed, progress=progress, settings=settings)
    finally:
        for bar in opened:
            bar.__exit__()
    print(f"reproduced the study on robot '{robot.name}' in {res.seconds:.1f} s; report: {out / 'report.md'}")
    return EXIT_OK

"""``tdcr explore``: a local web page (127.0.0.1 only) to move the tendons and loads of a robot and watch its
equilibrium, continued from the last one shown; with ``--workspace``, a workspace run's boundary around it."""

from __future__ import annotations

import argparse

from ..statics import MODELS
from ._args import count_type, models_help, robot_spec
from ._runtime import EXIT_OK, CliError

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``explore`` command and its options."""
    ex = sub.add_parser("explore", help="a local web page to move the tendons and loads and watch the robot "
                        "(continuation from the last equilibrium shown)")
    ex.add_argument("--robot", default=None, help="built-in robot (paper, rao) or a TOML file [the workspace run's "
                    "robot with --workspace, else paper]")
    ex.add_argument("--workspace", metavar="DIR", default=None,
                    help="a finished `tdcr workspace` output folder: draw its FSW boundary and largest-reach pose")
    ex.add_argument("--port", type=count_type, default=8080, help="the port on 127.0.0.1 to serve on [8080]")
    ex.add_argument("--model", choices=list(MODELS), default=None,
                    help="the model selected first; " + models_help().removesuffix(" [pcc]")
                    + " [the workspace run's with --workspace, else pcc]")
    ex.add_argument("--open", action="store_true", help="open the page in the default web browser")
    ex.set_defaults(func=run, gravity=None, friction=None, serves=True)


def run(args: argparse.Namespace) -> int:
    """Serve the page until Ctrl-C."""
    from ..explore import PortError, check_port, serve
    from ..validate import SettingsError

    try:
        check_port(args.port)
    except SettingsError as err:
        raise CliError(f"--{err}") from None
    robot = robot_spec(args).build() if args.robot is not None else None
    try:  # model None: the workspace run's, else pcc
        serve(robot, workspace=args.workspace, port=args.port, model=args.model, open_browser=args.open)
    except PortError as err:
        raise CliError(f"--{err}") from None
    return EXIT_OK

"""``tdcr robot``: print a robot as TOML (a starting point for your own), or write it to a file."""

from __future__ import annotations

import argparse

from ..io import RobotFileError, robot_to_dict, write_robot
from ._runtime import EXIT_OK, CliError

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``robot`` command and its options."""
    r = sub.add_parser("robot", help="print a robot as TOML (a starting point for your own)")
    r.add_argument("--robot", default="paper", help="built-in robot or TOML file [paper]")
    r.add_argument("--out", help="write to this file instead of stdout")
    r.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the robot, or write it to ``--out``."""
    from ..runs import RobotSpec

    try:
        robot = RobotSpec(robot=args.robot).build()
    except RobotFileError as err:  # names the file or the built-in robot given with --robot
        raise CliError(str(err)) from None
    if args.out:
        try:
            write_robot(robot, args.out)
        except (ValueError, OSError) as err:  # the file to write: named with its option
            raise CliError(f"--out {err}") from None
        return EXIT_OK
    import tomli_w

    print(tomli_w.dumps(robot_to_dict(robot)), end="")
    return EXIT_OK

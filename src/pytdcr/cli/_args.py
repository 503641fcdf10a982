"""The command line's arguments: argparse types, the option groups the commands share (declared once) and
their translation into the study's settings.

Shared: robot and loads (``--robot``, ``--tip-force``, ``--tip-moment``, ``--gravity``/``--no-gravity``,
``--friction``, ``--release``), the static model (``--model``, ``--shear-extension``), the tension bounds
(``--bounds``/``--bounds-file``), ``--seed``, ``--out`` and ``--n``. Options that take numbers may be given
negative ones (``--tip-moment -0.1,0.1,0.1``): :func:`glue_negative_values`.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from ..runtime import check_output_folder
from ..statics import MODELS
from ..validate import MAX_SEED, parse_numbers, show
from ._runtime import CliError

if TYPE_CHECKING:
    from ..runs import BoundsSpec, LoadSpec, ModelSpec, RobotSpec

__all__ = ["FLAGS", "Parser", "add_bounds", "add_model", "add_n", "add_out", "add_robot_and_loads", "add_seed",
           "bounds_spec", "check_out", "count_type", "glue_negative_values", "has_tip_wrench",
           "load_spec", "model_spec", "parse_floats", "real_type", "robot_spec", "seed_type"]

#: the settings' fields by the options that set them (a :class:`~pytdcr.validate.SettingsError` names the option)
FLAGS = {name: "--" + name.replace("_", "-") for name in (
    "robot", "friction", "tip_force", "tip_moment", "tensions", "bounds", "bounds_file", "model", "shear_extension",
    "atol", "plot", "n", "seed", "pop", "tol", "window", "max_gen", "stable_only", "models", "cases", "disks",
    "order_cases", "reference_steps", "payload_g", "out", "compliance", "jacobians", "csv", "targets", "workspace",
    "target", "direction", "starts", "max_solves", "objective", "displacements", "loss", "loss_scale", "folds",
    "max_evaluations")}
FLAGS.update(disk_forces="--disk-force", disk_moments="--disk-moment", stiffness="--tendon-stiffness",
             parameters="--fit", data="DATA.csv")


def parse_floats(text: str, name: str, count: int | None = None) -> np.ndarray:
    """Comma-separated finite numbers, e.g. ``0.1,0.1,-0.1`` (:func:`pytdcr.validate.parse_numbers`)."""
    try:
        return parse_numbers(text, name, count)
    except ValueError as err:
        raise CliError(str(err)) from None


def parse_optional(text: str, name: str) -> tuple[float | None, ...]:
    """Comma-separated finite numbers where ``-`` leaves a place empty (None), e.g. ``0.004,-,-,0.002``."""
    fields = text.split(",") if isinstance(text, str) else []
    numbers = [f for f in fields if f.strip() != "-"]
    values = iter(parse_floats(",".join(numbers), name) if numbers else ())
    return tuple(None if f.strip() == "-" else float(next(values)) for f in fields)


def seed_type(text: str) -> int:
    """argparse type of a random seed: an integer in [0, 2**32 - 1]."""
    if not re.fullmatch(r"[0-9]{1,10}", text.strip()) or int(text) > MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, {MAX_SEED}], got {show(text)}")
    return int(text)


#: the most digits a count on the command line may have (a larger one would overflow the 64-bit integers
#: the work is counted in)
MAX_COUNT_DIGITS = 18


def count_type(text: str) -> int:
    """argparse type of a count: a decimal integer (a sign allowed; no underscores, at most
    :data:`MAX_COUNT_DIGITS` digits).

    Its range is not checked here but by the run's settings, the one place it lives: every value out of
    range, on the command line or from Python, is refused with the same words (``--pop = 0: must be an
    integer >= 2`` as ``--pop = 1: ...``).
    """
    t = text.strip()
    if not re.fullmatch(r"[+-]?[0-9]+", t):
        raise argparse.ArgumentTypeError(f"must be an integer, got {show(text)}")
    if len(t.lstrip("+-")) > MAX_COUNT_DIGITS:
        raise argparse.ArgumentTypeError(f"must be an integer of at most {MAX_COUNT_DIGITS} digits, got {show(text)}")
    return int(t)


def real_type(text: str) -> float:
    """argparse type of a finite real number (no underscores)."""
    try:
        return float(parse_numbers(text, "value", 1)[0])
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).removeprefix("value: ")) from None


class Parser(argparse.ArgumentParser):
    """argparse, its errors on one line (``tdcr: error: ...``, exit 2) instead of usage and a message."""

    def error(self, message: str) -> NoReturn:
        command = self.prog.removeprefix("tdcr").strip()
        raise CliError(f"{command + ': ' if command else ''}{message}")


# ---------------------------------------------------------------- the shared option groups
def add_robot_and_loads(p: argparse.ArgumentParser) -> None:
    """Robot and load options (solve, sample, workspace, optimize, reproduce, compare, accuracy)."""
    g = p.add_argument_group("robot and loads")
    g.add_argument("--robot", default="paper", help="built-in robot (paper, rao) or a TOML file [paper]")
    g.add_argument("--tip-force", metavar="FX,FY,FZ", help="tip force in the base frame [N]")
    g.add_argument("--tip-moment", metavar="MX,MY,MZ", help="tip moment in the base frame [N m]")
    g.add_argument("--disk-force", action="append", metavar="K:FX,FY,FZ", default=[],
                   help="a force on disk K (1 to N, N the tip) at its centre, base frame [N]; repeat for more")
    g.add_argument("--disk-moment", action="append", metavar="K:MX,MY,MZ", default=[],
                   help="a moment on disk K, base frame [N m]; repeat for more")
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


def add_model(p: argparse.ArgumentParser) -> None:
    """--model NAME (the registry's models) and --shear-extension (solve, sample, workspace, optimize)."""
    g = p.add_argument_group("static model")
    g.add_argument("--model", choices=list(MODELS), default="pcc", help=models_help())
    g.add_argument("--shear-extension", action="store_true",
                   help="let the backbone shear and stretch (models with that option; default inextensible)")


def add_bounds(p: argparse.ArgumentParser) -> None:
    """--bounds LO,HI or --bounds-file F (TOML with lists ``lower`` and ``upper``, one entry per tendon)."""
    b = p.add_mutually_exclusive_group()
    b.add_argument("--bounds", metavar="LO,HI", help="tension bounds for every tendon [N] (default 0,20)")
    b.add_argument("--bounds-file", metavar="F", help="TOML file: lower = [...], upper = [...] (per tendon, N)")


def add_n(p: argparse.ArgumentParser, default: int, what: str) -> None:
    """--n: how many of ``what``."""
    p.add_argument("--n", type=count_type, default=default, help=f"{what} [{default}]")


def add_seed(p: argparse.ArgumentParser) -> None:
    """--seed: the random seed."""
    p.add_argument("--seed", type=seed_type, default=0, help="random seed [0]")


def add_out(p: argparse.ArgumentParser, default: str | None, help: str | None = None) -> None:
    """--out: the output folder (``help`` replaces the usual text)."""
    p.add_argument("--out", default=default, help=help or f"output folder [{default}]")


# ---------------------------------------------------------------- from the options to the settings' groups
def robot_spec(args: argparse.Namespace) -> RobotSpec:
    """The robot of :func:`add_robot_and_loads`'s options."""
    from ..runs import RobotSpec

    friction: str | float | None = args.friction
    if friction is not None:
        f = friction.strip().lower()
        friction = f if f in ("none", "paper") else float(parse_floats(f, "--friction", 1)[0])
    return RobotSpec(robot=args.robot, gravity=args.gravity, friction=friction)


def load_spec(args: argparse.Namespace) -> LoadSpec:
    """The loads of :func:`add_robot_and_loads`'s options."""
    from ..runs import LoadSpec

    tf = parse_floats(args.tip_force, "--tip-force", 3) if args.tip_force else np.zeros(3)
    tm = parse_floats(args.tip_moment, "--tip-moment", 3) if args.tip_moment else np.zeros(3)
    return LoadSpec(tip_force=tuple(tf), tip_moment=tuple(tm), release=args.release,
                    disk_forces=tuple(_disk_wrench(t, "--disk-force") for t in getattr(args, "disk_force", [])),
                    disk_moments=tuple(_disk_wrench(t, "--disk-moment") for t in getattr(args, "disk_moment", [])))


def _disk_wrench(text: str, option: str) -> tuple[int, tuple[float, ...]]:
    """``K:X,Y,Z``: a disk number (an integer >= 1) and three finite numbers (CliError naming ``option``)."""
    disk, sep, vector = text.partition(":")
    # ASCII digits only (str.isdigit takes '²', which int() refuses), and few of them (no disk number has more)
    if not sep or not re.fullmatch(r"[0-9]{1,9}", disk.strip()) or int(disk) < 1:
        raise CliError(f"{option} {text!r}: give K:X,Y,Z with K a disk number from 1 (e.g. 10:0,0,-0.05)")
    return int(disk), tuple(float(x) for x in parse_floats(vector, option, 3))


def model_spec(args: argparse.Namespace, atol: float | None = None) -> ModelSpec:
    """The model of :func:`add_model`'s options (and a tolerance, for solve)."""
    from ..runs import ModelSpec

    return ModelSpec(args.model, shear_extension=args.shear_extension, atol=atol)


def bounds_spec(args: argparse.Namespace) -> BoundsSpec | None:
    """The bounds of :func:`add_bounds`'s options; None when neither is given."""
    from ..runs import BoundsSpec

    if args.bounds_file:
        return BoundsSpec(file=args.bounds_file)
    if args.bounds:
        lo, hi = parse_floats(args.bounds, "--bounds", 2)
        return BoundsSpec(lower=float(lo), upper=float(hi))
    return None


def check_out(text: str) -> Path:
    """--out: refused before any work if the output-folder rule will not use it (a file, other files, in use)."""
    check_output_folder(text)
    return Path(text)


def has_tip_wrench(args: argparse.Namespace) -> bool:
    """--tip-force or --tip-moment is given (and not zero)."""
    return load_spec(args).has_tip_wrench


# ---------------------------------------------------------------- negative numbers
_VALUE_OPTIONS = ("--tip-force", "--tip-moment", "--tensions", "--bounds", "--friction", "--target", "--direction",
                  "--displacements", "--tendon-stiffness")
_NUMBER_OPTIONS = ("--atol", "--tol", "--seed", "--n", "--pop", "--max-gen", "--window", "--payload-g", "--starts",
                   "--max-solves")


def glue_negative_values(argv: Sequence[str]) -> list[str]:
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

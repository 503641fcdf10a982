"""What every run records: its inputs, the load arrows of its figures, Markdown tables."""

from __future__ import annotations

import math
import platform
from collections.abc import Mapping, Sequence

import numpy as np

from .._version import __version__
from ..io import robot_to_dict
from ..loads import Loads
from ..palette import PALETTE
from ..records import JsonDict
from ..results import StaticSolution
from ..robot import Robot
from ..runtime import to_jsonable
from ..validate import direction_or_none

__all__ = ["inputs_record", "load_arrows", "markdown_table"]


def inputs_record(robot: Robot, loads: Loads, **extra: object) -> JsonDict:
    """The exact inputs of a run (JSON-ready: NumPy values made plain, :func:`~pytdcr.runtime.to_jsonable`):
    versions, robot, external loads and ``extra`` (the run's own settings, each a JSON-ready or NumPy value)."""
    return to_jsonable({
        "pytdcr": __version__,
        "python": platform.python_version(),
        "robot": robot_to_dict(robot),
        "loads": {"tip_force": loads.tip_force, "tip_moment": loads.tip_moment, "release": loads.release,
                  "point_loads": [{"disk": p.disk, "force": p.force, "moment": p.moment} for p in loads.point_loads]},
        **extra,
    })


def load_arrows(sol: StaticSolution, loads: Loads, robot: Robot) -> list[tuple[np.ndarray, np.ndarray, str, str]]:
    """Arrows for the tip force and the tip moment's axis (their :data:`~pytdcr.palette.PALETTE` colours), scaled
    to a quarter of the length.

    Each arrow is its load's unit vector (:func:`~pytdcr.validate.direction_or_none`, safe at any scale); a load
    whose components are all below :data:`~pytdcr.validate.MIN_DIRECTION` (zero, or too small to have a
    direction) has no arrow. Its label gives the load's magnitude (``math.hypot``: never 0 for a non-zero load).
    """
    arrows: list[tuple[np.ndarray, np.ndarray, str, str]] = []
    scale = 0.25 * robot.length
    for load, length, colour, what, unit in ((loads.tip_force, scale, PALETTE.tip_force, "tip force", "N"),
                                             (loads.tip_moment, scale * 0.6, PALETTE.tip_moment, "tip moment axis",
                                              "N m")):
        v = np.asarray(load, dtype=float)
        d = direction_or_none(v, what)
        if d is None:
            continue
        arrows.append((sol.tip_position, d * length, colour, f"{what}, {math.hypot(*v.tolist()):.3g} {unit}"))
    return arrows


def markdown_table(rows: Sequence[Mapping[str, object]], columns: Sequence[tuple[str, str, str]]) -> str:
    """A Markdown table of ``rows``; ``columns`` are (key, header, format); non-finite floats print as n/c."""
    head = "| " + " | ".join(c[1] for c in columns) + " |"
    sep = "|" + "|".join("---:" for _ in columns) + "|"
    body = []
    for r in rows:
        cells = []
        for key, _, fmt in columns:
            v = r[key]
            cells.append("n/c" if isinstance(v, float) and not np.isfinite(v) else format(v, fmt))
        body.append("| " + " | ".join(cells) + " |")
    return "\n".join([head, sep, *body])

"""What every run records: its inputs, the load arrows of its figures, Markdown tables."""

from __future__ import annotations

import platform
from typing import Any

import numpy as np

from .._version import __version__
from ..design import Robot
from ..io import robot_to_dict
from ..loads import Loads
from ..results import StaticSolution
from ..runtime import to_jsonable

__all__ = ["inputs_record", "load_arrows", "markdown_table"]


def inputs_record(robot: Robot, loads: Loads, **extra: Any) -> dict[str, Any]:
    """The exact inputs of a run (JSON-ready): versions, robot, external loads and ``extra``."""
    return to_jsonable({
        "pytdcr": __version__,
        "python": platform.python_version(),
        "robot": robot_to_dict(robot),
        "loads": {"tip_force": loads.tip_force, "tip_moment": loads.tip_moment, "release": loads.release,
                  "point_loads": [{"disk": p.disk, "force": p.force, "moment": p.moment} for p in loads.point_loads]},
        **extra,
    })


def load_arrows(sol: StaticSolution, loads: Loads, robot: Robot) -> list[tuple]:
    """Arrows for the tip force (purple) and the tip moment's axis (orange), scaled to a quarter of the length."""
    arrows: list[tuple] = []
    scale = 0.25 * robot.length
    if np.any(loads.tip_force):
        arrows.append((sol.tip_position, loads.tip_force / np.linalg.norm(loads.tip_force) * scale, "tab:purple",
                       f"tip force, {np.linalg.norm(loads.tip_force):.3g} N"))
    if np.any(loads.tip_moment):  # the moment's axis, drawn from the tip in another colour
        arrows.append((sol.tip_position, loads.tip_moment / np.linalg.norm(loads.tip_moment) * scale * 0.6,
                       "tab:orange", f"tip moment axis, {np.linalg.norm(loads.tip_moment):.3g} N m"))
    return arrows


def markdown_table(rows: list[dict[str, Any]], columns: list[tuple[str, str, str]]) -> str:
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

"""What every run writes: its inputs, figures in two formats, strict JSON, Markdown tables."""

from __future__ import annotations

import csv
import io
import json
import os
import platform
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..design import Robot
from ..io import robot_to_dict, to_jsonable
from ..loads import Loads
from ..plotting import pyplot
from ..results import StaticSolution
from ._folder import atomic_write_text

__all__ = ["inputs_record", "load_arrows", "markdown_table", "save_figure", "write_csv", "write_json"]


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


def save_figure(fig: Any, out: Path, stem: str) -> list[str]:
    """Write ``fig`` as ``stem``.png and ``stem``.pdf in ``out`` (each whole or absent), close it; returns the
    file names."""
    # the tight bounding box is measured once (it costs a full draw) and used for both formats
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    names = []
    for ext in ("png", "pdf"):
        path = out / f"{stem}.{ext}"
        tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
        fig.savefig(tmp, dpi=150, bbox_inches=bbox, format=ext)
        os.replace(tmp, path)
        names.append(path.name)
    pyplot().close(fig)
    return names


def write_json(path: Path, data: Any) -> None:
    """Strict JSON (non-finite numbers become null), indented, written atomically."""
    atomic_write_text(path, json.dumps(to_jsonable(data), indent=2, allow_nan=False))


def write_csv(path: Path, header: list[str], rows: Iterable[Iterable[Any]]) -> None:
    """A CSV file, written atomically."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def load_arrows(sol: StaticSolution, loads: Loads, robot: Robot) -> list[tuple]:
    """Arrows for the tip force (purple) and the tip moment's axis (orange), scaled to a quarter of the length."""
    arrows: list[tuple] = []
    scale = 0.25 * robot.length
    if np.any(loads.tip_force):
        arrows.append((sol.tip_position, loads.tip_force / np.linalg.norm(loads.tip_force) * scale))
    if np.any(loads.tip_moment):  # the moment's axis, drawn from the tip in another colour
        arrows.append((sol.tip_position, loads.tip_moment / np.linalg.norm(loads.tip_moment) * scale * 0.6,
                       "tab:orange"))
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

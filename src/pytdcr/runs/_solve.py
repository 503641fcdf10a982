"""``tdcr solve``: one static equilibrium, and a figure of it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..loads import Loads
from ..plotting import plot_robot, save_figure_as
from ..results import StaticSolution
from ..robot import Robot
from ..runtime import FileRefused, writable_file, write_csv
from ..statics import Jacobians, Model, TipCompliance, equilibrium_jacobians, solve, tip_compliance
from ..validate import SettingsError, show_path
from ._output import load_arrows
from ._settings import SolveSettings

__all__ = [
    "CASE_COLUMNS",
    "FIGURE_SUFFIXES",
    "SHAPE_COLUMNS",
    "SolveRun",
    "case_rows",
    "check_csv_path",
    "check_figure_path",
    "run_solve",
    "write_shape_csv",
]

#: the columns of ``tdcr solve --csv``: the disk (0 the base), its centre [m] and its frame (base from disk)
SHAPE_COLUMNS = ["disk", "x_m", "y_m", "z_m", *[f"R{i}{j}" for i in range(1, 4) for j in range(1, 4)]]

#: the figure formats a file name may ask for
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


@dataclass(frozen=True)
class SolveRun:
    """What :func:`run_solve` produced.

    Attributes
    ----------
    robot : Robot
    loads : Loads
        Tensions and external loads solved.
    model : Model
        The model that solved them.
    solution : StaticSolution
    plot : Path or None
        The figure written (None when none was asked for or the solve did not converge).
    compliance : TipCompliance or None
        The tip's compliance, when asked for and the solve converged.
    jacobians : Jacobians or None
        The shape's derivatives by the tensions, likewise.
    """

    robot: Robot
    loads: Loads
    model: Model
    solution: StaticSolution
    plot: Path | None = None
    compliance: TipCompliance | None = None
    jacobians: Jacobians | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the robot's name and :meth:`StaticSolution.to_dict` (what ``tdcr solve --json`` prints),
        with ``compliance`` and ``jacobians`` when computed."""
        out = {"robot": self.robot.name, **self.solution.to_dict()}
        if self.compliance is not None:
            out["compliance"] = self.compliance.to_dict()
        if self.jacobians is not None:
            out["jacobians"] = self.jacobians.to_dict()
        return out


def check_figure_path(path: str | Path) -> Path:
    """A figure's file: a name ending in .png, .pdf or .svg whose folder exists or can be made, never a folder
    (SettingsError naming ``plot``)."""
    p = Path(path)
    if p.is_dir():
        raise SettingsError("plot", f" {show_path(path)}: is a folder; give a file name ending in .png, .pdf or .svg")
    if p.suffix.lower() not in FIGURE_SUFFIXES:
        raise SettingsError("plot", f" {show_path(path)}: the file name must end in .png, .pdf or .svg")
    if p.parent.exists() and not p.parent.is_dir():
        raise SettingsError("plot", f" {show_path(path)}: {show_path(p.parent)} is a file, not a folder")
    if p.parent.is_dir():  # a device, a FIFO, a socket (or a link to one) is refused before the solve
        try:
            writable_file(p)
        except FileRefused as err:
            raise SettingsError("plot", f" {err}") from None
    return p


#: the columns of ``tdcr solve --cases`` after the tensions (``T1_N`` ...): one row per case
CASE_COLUMNS = ["converged", "residual_Nm", "path", "stable", "tip_x_m", "tip_y_m", "tip_z_m", "reach_m"]


def case_rows(batch: Any) -> tuple[list[str], list[list[Any]]]:
    """The header and rows of a batch of cases (``pytdcr.BatchSolution``): each case's tensions [N], whether it
    converged, its residual [N m], path, stability (1 stable, 0 unstable, empty untested or not converged) and
    tip [m] (empty where it did not converge)."""
    nt = batch.tensions.shape[1]
    header = ["case", *[f"T{c + 1}_N" for c in range(nt)], *CASE_COLUMNS]
    stable = batch.stable
    rows = []
    for k in range(batch.tensions.shape[0]):
        ok = bool(batch.converged[k])
        tip = [float(x) for x in batch.tip_position[k]] if ok else ["", "", ""]
        st = "" if not ok or not np.isfinite(stable[k]) else int(stable[k])
        rows.append([k + 1, *[float(t) for t in batch.tensions[k]], int(ok), float(batch.residual[k]),
                     str(batch.path[k]), st, *tip, float(np.linalg.norm(batch.tip_position[k])) if ok else ""])
    return header, rows


def check_csv_path(path: str | Path) -> Path:
    """The shape's CSV file: a name ending in .csv, never a folder or a device (SettingsError naming ``csv``)."""
    p = Path(path)
    if p.is_dir() or p.suffix.lower() != ".csv":
        raise SettingsError("csv", f" {show_path(path)}: give a file name ending in .csv")
    if p.parent.exists() and not p.parent.is_dir():
        raise SettingsError("csv", f" {show_path(path)}: {show_path(p.parent)} is a file, not a folder")
    if p.parent.is_dir():
        try:
            writable_file(p)
        except FileRefused as err:
            raise SettingsError("csv", f" {err}") from None
    return p


def write_shape_csv(path: str | Path, solution: StaticSolution) -> Path:
    """Every disk's centre [m] and frame (rotation base from disk, row by row) of a converged ``solution``, one
    row per disk from the base (:data:`SHAPE_COLUMNS`), written whole or not at all."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    pos, rot = solution.disk_positions, solution.disk_rotations
    return write_csv(p, SHAPE_COLUMNS, ([k, *pos[k], *rot[k].reshape(-1)] for k in range(pos.shape[0])))


def run_solve(settings: SolveSettings, plot: str | Path | None = None, *, compliance: bool = False,
              jacobians: bool = False, csv: str | Path | None = None) -> SolveRun:
    """Solve the settings' tensions under their loads; with ``plot``, a 3D figure of the converged robot there
    (PNG, PDF or SVG by its suffix; whole or absent); with ``compliance`` or ``jacobians``, the tip's
    compliance (:func:`~pytdcr.statics.tip_compliance`) or the shape's derivatives by the tensions
    (:func:`~pytdcr.statics.equilibrium_jacobians`) of a converged solve. Everything is checked before the solve
    (SettingsError naming ``compliance`` or ``jacobians`` for a model without exact derivatives); with ``csv``,
    every disk's centre and frame of a converged solve (:func:`write_shape_csv`)."""
    figure = check_figure_path(plot) if plot is not None else None
    table = check_csv_path(csv) if csv is not None else None
    robot = settings.robot.build()
    tensions = settings.tensions_for(robot)
    loads = settings.loads.build(robot).with_tensions(tensions)
    model, options = settings.model.resolve(robot, loads)
    for name, asked in (("compliance", compliance), ("jacobians", jacobians)):
        if asked and model.capabilities.gradient != "exact":
            raise SettingsError(name, f": model '{model.name}' has no exact derivatives; use pcc, pcc2 or sscr")
    sol = solve(robot, loads, model=model, options=options)
    if not sol.converged:
        return SolveRun(robot, loads, model, sol)
    c = tip_compliance(robot, loads, sol, model=model, options=options) if compliance else None
    j = equilibrium_jacobians(robot, loads, sol, model=model, options=options) if jacobians else None
    if figure is not None:
        _plot_solution(sol, robot, loads, figure)
    if table is not None:
        write_shape_csv(table, sol)
    return SolveRun(robot, loads, model, sol, figure, c, j)


def _plot_solution(sol: StaticSolution, robot: Robot, loads: Loads, path: Path) -> None:
    ax = plot_robot(robot, sol, loads=load_arrows(sol, loads, robot))
    x, y, z = sol.tip_position * 1e3
    ax.set_title(f"robot '{robot.name}': tip at ({x:.1f}, {y:.1f}, {z:.1f}) mm, {sol.reach * 1e3:.1f} mm from "
                 "the base", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure_as(ax.figure, path)  # whole or absent

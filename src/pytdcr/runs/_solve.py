"""``tdcr solve``: one static equilibrium, and a figure of it.

The run's result is :class:`SolveRun` (the live robot, loads, model and solution); what it reports is
:class:`SolveRecord`, a typed record of the numbers alone: :meth:`SolveRecord.to_json` is what ``tdcr solve
--json`` prints (today's keys, plus ``schema_version``: :data:`SCHEMA_VERSION`) and :meth:`SolveRecord.from_json`
reads such an object back, a missing key raising :class:`~pytdcr.records.RecordKeyError` naming its path
(``stability.flutter_pairs``) and an absent ``seconds`` (the golden baselines drop times) read as 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from ..loads import Loads
from ..plotting import plot_robot, save_figure_as
from ..records import JsonDict, JsonObject, check_schema, optional_part, part
from ..results import BatchSolution, Stability, StaticSolution
from ..robot import Robot
from ..runtime import FileRefused, writable_file, write_csv
from ..statics import (
    DisplacementSolution,
    Jacobians,
    Model,
    SolvePath,
    TipCompliance,
    equilibrium_jacobians,
    pulled_in,
    solve,
    solve_displacements,
    tip_compliance,
)
from ..validate import SettingsError, show_path
from ._output import load_arrows
from ._settings import SolveSettings

__all__ = [
    "CASE_COLUMNS",
    "FIGURE_SUFFIXES",
    "SCHEMA_VERSION",
    "SHAPE_COLUMNS",
    "DriveRecord",
    "SolutionRecord",
    "SolveRecord",
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

#: the layout of ``tdcr solve --json``'s object this module writes and reads
SCHEMA_VERSION = 1

#: the record errors name
_FILE = "solve result"
_read = partial(part, _FILE)
_optional = partial(optional_part, _FILE)


def _number(x: float | None) -> float:
    """A float of a JSON object: null (a non-finite number, as :func:`~pytdcr.runtime.dump_json` writes it) as
    NaN."""
    return float("nan") if x is None else float(x)


def _array(x: object) -> np.ndarray | None:
    """A JSON list of numbers (nested or not) as a float array (null entries as NaN), None for null."""
    return None if x is None else np.array(x, dtype=float)


def _listed(a: np.ndarray | None) -> list[object] | None:
    """An array as nested lists (as :meth:`StaticSolution.to_dict` writes it), None for None."""
    return None if a is None else a.tolist()


def _stability_from_json(d: JsonObject) -> Stability:
    """A :class:`Stability` from its JSON (the least damped pair ``[real, |imag|]`` as ``real + |imag| i``; a
    null lowest eigenvalue as NaN)."""
    pair = d["least_damped_pair"]
    return Stability(bool(d["stable"]), _number(d["min_real_eigenvalue"]), int(d["n_real_nonpositive"]),
                     int(d["flutter_pairs"]), None if pair is None else complex(_number(pair[0]), _number(pair[1])))


@dataclass(frozen=True, eq=False)
class SolutionRecord:
    """The numbers of one static solve (:meth:`StaticSolution.to_dict`'s), as typed fields.

    Attributes
    ----------
    converged : bool
    failure : str
        Why a solve with a small residual is still not converged ("" when none; null in JSON).
    stable : bool or None
        The equilibrium's static stability (None: not converged, or the model has no test).
    stability : Stability or None
        The eigenvalue test behind it.
    residual : float
        max |residual| [N m].
    iterations, load_steps : int
    model : str
        The model's registered name.
    path : SolvePath
        How the equilibrium was reached.
    seconds : float
        Wall time of the solve [s] (0 where a record dropped it).
    tip_position : ndarray, shape (3,), or None
        [m]; None (as every shape below) when not converged.
    tip_rotation : ndarray, shape (3, 3), or None
        The tip's frame in the base frame.
    disk_positions : ndarray, shape (N+1, 3), or None
        Disk centres [m], row 0 the base.
    q : ndarray or None
        The model's unknowns (:attr:`StaticSolution.q`).
    tensions : ndarray, shape (n_tendons, N), or None
        The tension in each tendon piece [N].
    """

    converged: bool
    failure: str
    stable: bool | None
    stability: Stability | None
    residual: float
    iterations: int
    load_steps: int
    model: str
    path: SolvePath
    seconds: float
    tip_position: np.ndarray | None
    tip_rotation: np.ndarray | None
    disk_positions: np.ndarray | None
    q: np.ndarray | None
    tensions: np.ndarray | None

    @classmethod
    def of(cls, sol: StaticSolution) -> SolutionRecord:
        """The numbers of a solve (its shape only when it converged)."""
        ok = bool(sol.converged)
        shape = (sol.tip_position, sol.tip_rotation, sol.disk_positions, sol.q, sol.tensions) if ok else (None,) * 5
        return cls(ok, sol.failure, sol.stable, sol.stability, float(sol.residual), int(sol.iterations),
                   int(sol.load_steps), sol.model, SolvePath(sol.path), float(sol.seconds), *shape)

    def to_json(self) -> JsonDict:
        """JSON-ready form: :meth:`StaticSolution.to_dict`'s keys, in its order."""
        return {"converged": self.converged, "failure": self.failure or None, "stable": self.stable,
                "stability": None if self.stability is None else self.stability.to_dict(),
                "residual": self.residual, "iterations": self.iterations, "load_steps": self.load_steps,
                "model": self.model, "path": self.path, "seconds": self.seconds,
                "tip_position": _listed(self.tip_position), "tip_rotation": _listed(self.tip_rotation),
                "disk_positions": _listed(self.disk_positions), "q": _listed(self.q),
                "tensions": _listed(self.tensions)}

    @classmethod
    def from_json(cls, d: JsonObject) -> SolutionRecord:
        """What :meth:`to_json` wrote (an absent ``seconds`` as 0); KeyError naming a missing key."""
        stable = d["stable"]
        return cls(bool(d["converged"]), d["failure"] or "", None if stable is None else bool(stable),
                   _optional("stability", _stability_from_json, d), _number(d["residual"]), int(d["iterations"]),
                   int(d["load_steps"]), str(d["model"]), SolvePath(d["path"]), float(d.get("seconds", 0.0)),
                   *(_array(d[k]) for k in ("tip_position", "tip_rotation", "disk_positions", "q", "tensions")))


def _compliance_from_json(d: JsonObject) -> TipCompliance:
    """The compliance of :meth:`TipCompliance.to_dict` (its matrix; the rest follows from it)."""
    return TipCompliance(np.array(d["compliance"], dtype=float))


def _jacobians_from_json(d: JsonObject) -> Jacobians:
    """The Jacobians of :meth:`Jacobians.to_dict`."""
    return Jacobians(*(np.array(d[k], dtype=float) for k in ("tip_position", "tip_rotation", "tip_axis",
                                                              "disk_positions")))


@dataclass(frozen=True, eq=False)
class DriveRecord:
    """How a displacement-driven solve (:func:`pytdcr.solve_displacements`) met its displacements.

    Attributes
    ----------
    displacements : ndarray, shape (n_tendons,)
        The pull-in asked of each displacement-driven tendon [m]; NaN (null in JSON) for a tension-driven one.
    stiffness : ndarray, shape (n_tendons,)
        The tendons' axial stiffness [N/m]; ``inf`` (null in JSON) for an inextensible one.
    tensions : ndarray, shape (n_tendons,)
        Every tendon's actuator tension [N]: found for the driven ones.
    slack : ndarray of bool, shape (n_tendons,)
        Tendons at 0 N.
    residual : float
        The largest violation of the displacement conditions [m].
    converged : bool
    iterations, solves : int
        Newton steps and equilibria solved.
    message : str
        Why it did not converge (empty when it did).
    """

    displacements: np.ndarray
    stiffness: np.ndarray
    tensions: np.ndarray
    slack: np.ndarray
    residual: float
    converged: bool
    iterations: int
    solves: int
    message: str = ""

    @classmethod
    def of(cls, d: DisplacementSolution) -> DriveRecord:
        """The record of a displacement-driven solve."""
        return cls(d.displacements, d.stiffness, d.tensions, d.slack, d.residual, d.converged, d.iterations,
                   d.solves, d.message)

    def to_json(self) -> JsonDict:
        """JSON-ready form (non-finite numbers as null)."""
        return {"displacements_m": [None if not np.isfinite(x) else float(x) for x in self.displacements],
                "stiffness_n_per_m": [None if not np.isfinite(x) else float(x) for x in self.stiffness],
                "tensions_n": _listed(self.tensions), "slack": [bool(x) for x in self.slack],
                "residual_m": self.residual, "converged": self.converged, "iterations": self.iterations,
                "solves": self.solves, "message": self.message or None}

    @classmethod
    def from_json(cls, d: JsonObject) -> DriveRecord:
        """What :meth:`to_json` wrote."""
        return cls(_array(d["displacements_m"]),
                   np.array([np.inf if x is None else float(x) for x in d["stiffness_n_per_m"]]),
                   _array(d["tensions_n"]), np.array(d["slack"], dtype=bool), _number(d["residual_m"]),
                   bool(d["converged"]), int(d["iterations"]), int(d["solves"]), d["message"] or "")


@dataclass(frozen=True, eq=False)
class SolveRecord:
    """What ``tdcr solve --json`` prints, typed.

    Attributes
    ----------
    robot : str
        The robot's name.
    solution : SolutionRecord
        The solve's numbers (at the top level of the JSON).
    compliance : TipCompliance or None
        The tip's compliance (``compliance``), when computed.
    jacobians : Jacobians or None
        The shape's derivatives by the tensions (``jacobians``), when computed.
    pulled_in : ndarray, shape (n_tendons,), or None
        Each tendon's pull-in [m] (:func:`pytdcr.pulled_in`, ``pulled_in_m``); None when not converged.
    drive : DriveRecord or None
        How the displacements were met (``drive``), for a displacement-driven solve.
    """

    robot: str
    solution: SolutionRecord
    compliance: TipCompliance | None = None
    jacobians: Jacobians | None = None
    pulled_in: np.ndarray | None = None
    drive: DriveRecord | None = None

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``schema_version``, the robot's name, the solution's keys, then ``pulled_in_m`` (of a
        converged solve), ``drive``, ``compliance`` and ``jacobians`` when there (each absent otherwise)."""
        out = {"schema_version": SCHEMA_VERSION, "robot": self.robot, **self.solution.to_json()}
        if self.pulled_in is not None:
            out["pulled_in_m"] = _listed(self.pulled_in)
        if self.drive is not None:
            out["drive"] = self.drive.to_json()
        if self.compliance is not None:
            out["compliance"] = self.compliance.to_dict()
        if self.jacobians is not None:
            out["jacobians"] = self.jacobians.to_dict()
        return out

    @classmethod
    def from_json(cls, d: JsonObject) -> SolveRecord:
        """The object :meth:`to_json` wrote (or ``tdcr solve --json`` printed before ``schema_version``
        existed). :class:`~pytdcr.records.RecordKeyError` naming the path of a missing key; ValueError for a part
        that is not a JSON object or another ``schema_version`` than :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> SolveRecord:
            check_schema(d, _FILE, SCHEMA_VERSION)
            return cls(str(d["robot"]), SolutionRecord.from_json(d), _optional("compliance", _compliance_from_json, d),
                       _optional("jacobians", _jacobians_from_json, d), _array(d.get("pulled_in_m")),
                       _optional("drive", DriveRecord.from_json, d))

        return _read("", read, d)


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
    drive : DisplacementSolution or None
        The displacement-driven solve, when displacements were given (``solution`` is its equilibrium).
    stiffness : list of float or None, or None
        The tendons' axial stiffness [N/m] the pull-ins are reported with (None: inextensible).
    """

    robot: Robot
    loads: Loads
    model: Model
    solution: StaticSolution
    plot: Path | None = None
    compliance: TipCompliance | None = None
    jacobians: Jacobians | None = None
    drive: DisplacementSolution | None = None
    stiffness: list[float | None] | None = None

    @property
    def converged(self) -> bool:
        """The equilibrium converged and, when displacements were given, they are met."""
        return bool(self.solution.converged and (self.drive is None or self.drive.converged))

    @property
    def pulled_in(self) -> np.ndarray | None:
        """Each tendon's pull-in [m] (:func:`pytdcr.pulled_in`), None when the solve did not converge."""
        if self.drive is not None and self.solution.converged:
            return self.drive.pulled_in
        return pulled_in(self.robot, self.solution, self.stiffness) if self.solution.converged else None

    @property
    def record(self) -> SolveRecord:
        """The numbers it reports, typed: the robot's name, the solution's numbers, the pull-ins, and the
        displacements met, the compliance and the Jacobians when there."""
        return SolveRecord(self.robot.name, SolutionRecord.of(self.solution), self.compliance, self.jacobians,
                           self.pulled_in, None if self.drive is None else DriveRecord.of(self.drive))

    def to_json(self) -> JsonDict:
        """What ``tdcr solve --json`` prints (:meth:`SolveRecord.to_json`)."""
        return self.record.to_json()

    def to_dict(self) -> JsonDict:
        """:meth:`to_json` (the name older code calls)."""
        return self.to_json()


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


def case_rows(batch: BatchSolution) -> tuple[list[str], list[list[int | float | str]]]:
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
    every disk's centre and frame of a converged solve (:func:`write_shape_csv`). With the settings'
    ``displacements``, the displacement-driven tendons' tensions are found with the equilibrium
    (:func:`~pytdcr.statics.solve_displacements`); the figure, table and derivatives then need both to converge."""
    figure = check_figure_path(plot) if plot is not None else None
    table = check_csv_path(csv) if csv is not None else None
    robot = settings.robot.build()
    tensions = settings.tensions_for(robot)
    loads = settings.loads.build(robot).with_tensions(tensions)
    model, options = settings.model.resolve(robot, loads)
    for name, asked in (("compliance", compliance), ("jacobians", jacobians)):
        if asked and model.capabilities.gradient != "exact":
            raise SettingsError(name, f": model '{model.name}' has no exact derivatives; use pcc, pcc2 or sscr")
    displacements, stiffness = settings.drive_for(robot)
    drive = None
    if displacements is None:
        sol = solve(robot, loads, model=model, options=options)
    else:
        try:
            drive = solve_displacements(robot, loads, displacements, stiffness=stiffness, model=model,
                                        options=options)
        except ValueError as err:  # a displacement beyond the robot's length
            raise SettingsError.about("displacements", err) from None
        sol = drive.solution
        loads = loads.with_tensions(drive.tensions)
    done = partial(SolveRun, robot, loads, model, sol, drive=drive, stiffness=stiffness)
    if not (sol.converged and (drive is None or drive.converged)):
        return done()
    c = tip_compliance(robot, loads, sol, model=model, options=options) if compliance else None
    j = equilibrium_jacobians(robot, loads, sol, model=model, options=options) if jacobians else None
    if figure is not None:
        _plot_solution(sol, robot, loads, figure)
    if table is not None:
        write_shape_csv(table, sol)
    return done(figure, c, j)


def _plot_solution(sol: StaticSolution, robot: Robot, loads: Loads, path: Path) -> None:
    ax = plot_robot(robot, sol, loads=load_arrows(sol, loads, robot))
    x, y, z = sol.tip_position * 1e3
    ax.set_title(f"robot '{robot.name}': tip at ({x:.1f}, {y:.1f}, {z:.1f}) mm, {sol.reach * 1e3:.1f} mm from "
                 "the base", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure_as(ax.figure, path)  # whole or absent

"""``tdcr inverse``'s data: a finished workspace run as the starts of inverse statics, the table of answers and
the run's answers as a typed record.

:class:`InverseRun` is what ``tdcr inverse --json`` prints (today's keys, plus ``schema_version``:
:data:`SCHEMA_VERSION`): the robot's and the model's names, the objective and the answers
(:class:`~pytdcr.optimize.InverseResult`), one target's keys at the top level or a path's under ``points``;
:meth:`InverseRun.from_json` reads such an object back, a missing key raising
:class:`~pytdcr.records.RecordKeyError` naming its path (``points[2].tensions``). The CSV table
(:func:`inverse_columns`, :func:`inverse_rows`) keeps its columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..io import robot_from_dict
from ..loads import Loads, PointLoad
from ..optimize import InverseResult
from ..records import JsonDict, JsonObject, check_schema, part
from ..robot import Robot
from ..runtime import RunDoc, RunFolder
from ..validate import MAX_FORCE_N, MAX_MOMENT_NM, SettingsError
from ._workspace_records import WorkspaceRecord

__all__ = ["BOUNDS_SLACK", "SCHEMA_VERSION", "InverseRun", "WorkspaceInputs", "WorkspacePool", "inside_bounds",
           "inverse_columns", "inverse_rows", "read_workspace_inputs", "read_workspace_pool"]

#: the layout of ``tdcr inverse --json``'s object (:class:`InverseRun`) this module writes and reads
SCHEMA_VERSION = 1

#: the record errors name
_FILE = "inverse answers"


def inverse_columns(n_tendons: int) -> list[str]:
    """The columns of ``tdcr inverse --csv``: the target [m], the tensions [N], the pull-ins [m], the tip [m] and
    what held."""
    return ["target_x_m", "target_y_m", "target_z_m", *[f"T{k}_N" for k in range(1, n_tendons + 1)],
            *[f"D{k}_m" for k in range(1, n_tendons + 1)],
            "tip_x_m", "tip_y_m", "tip_z_m", "distance_m", "reachable", "stable", "path", "objective_value",
            "evaluations", "seconds"]


def inverse_rows(results: Sequence[InverseResult]) -> list[list[float | bool | str | None]]:
    """One row per answer, in the order of :func:`inverse_columns`: numbers [m, N, s], ``reachable`` and
    ``stable`` (None untested) as they are, ``path`` as its text; pull-ins empty where unknown."""
    return [[*r.target.tolist(), *r.tensions.tolist(),
             *(r.pulled_in.tolist() if r.pulled_in is not None else [None] * r.tensions.size),
             *r.tip_position.tolist(), r.distance_m, r.reachable,
             r.stable, r.path.value, r.objective_value, r.evaluations, r.seconds] for r in results]


@dataclass(frozen=True, eq=False)
class InverseRun:
    """The answers of one ``tdcr inverse`` run, as ``--json`` prints them.

    Attributes
    ----------
    robot : str
        The robot's name.
    model : str
        The model's registered name.
    objective : str
        How the tensions were chosen (:data:`~pytdcr.optimize.OBJECTIVES`).
    results : tuple of InverseResult
        One answer per target, in order.
    along_path : bool
        The targets were a path (``--targets``: the answers under ``points``); False for one ``--target`` (its
        answer's keys at the top level, beside the robot, model and objective).
    """

    robot: str
    model: str
    objective: str
    results: tuple[InverseResult, ...]
    along_path: bool = False

    def __post_init__(self) -> None:
        if not self.along_path and len(self.results) != 1:
            raise ValueError(f"one target has one answer, got {len(self.results)} (a path: along_path=True)")

    def to_json(self) -> JsonDict:
        """``tdcr inverse --json``'s object: ``schema_version``, ``robot``, ``model``, ``objective`` and the one
        answer's keys (:meth:`~pytdcr.optimize.InverseResult.to_dict`), or ``points``, one such object per target
        of a path."""
        head: JsonDict = {"schema_version": SCHEMA_VERSION, "robot": self.robot, "model": self.model,
                          "objective": self.objective}
        if self.along_path:
            return {**head, "points": [r.to_dict() for r in self.results]}
        return {**head, **self.results[0].to_dict()}

    @classmethod
    def from_json(cls, d: JsonObject) -> InverseRun:
        """The run of a ``tdcr inverse --json`` object (any it printed; a path's when it holds ``points``);
        RecordKeyError naming a missing key, ValueError for another ``schema_version``."""
        def read(d: JsonObject) -> InverseRun:
            check_schema(d, _FILE, SCHEMA_VERSION)
            head = str(d["robot"]), str(d["model"]), str(d["objective"])
            if "points" not in d:
                return cls(*head, (InverseResult.from_json(d),))
            points = d["points"]
            if not isinstance(points, list):
                raise ValueError(f"{_FILE}: points must be a JSON list, got {type(points).__name__}")
            return cls(*head, tuple(part(_FILE, f"points[{k}]", InverseResult.from_json, p)
                                    for k, p in enumerate(points)), along_path=True)

        return part(_FILE, "", read, d)


@dataclass(frozen=True, eq=False)
class WorkspacePool:
    """A finished ``tdcr workspace`` run read as starts: its robot, external loads, bounds and model, and the
    tensions (K, n_tendons) [N] and tips (K, 3) [m] of its converged samples not found unstable (stable, or
    untested under a model without the test: the samples its FSW holds)."""

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: str
    tensions: np.ndarray
    tips: np.ndarray


class WorkspaceInputs(NamedTuple):
    """What a finished ``tdcr workspace`` run was made of: its robot, external loads, bounds and model (a
    registered name), and its whole ``workspace.json`` (``summary``) as read, its fields checked where they are
    read (:class:`~pytdcr.runtime.RunDoc`: the explorer reads the meshes it names and its largest reach so);
    :attr:`record` is that file as its typed :class:`~pytdcr.runs.WorkspaceRecord`."""

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: str
    summary: JsonObject

    @property
    def record(self) -> WorkspaceRecord:
        """``workspace.json`` as its typed record (its volumes, largest reach, inputs and warnings as
        attributes); RecordKeyError naming a key it lacks."""
        return WorkspaceRecord.from_json(self.summary)


#: the most point loads read back from a run (one per disk at most, as the command line gives them)
MAX_POINT_LOADS = 10_000
#: how far beyond its bounds a tension read back from a run may lie, relative to the upper bound (at least 1 N):
#: the rounding of the run that wrote it, never a real excursion
BOUNDS_SLACK = 1e-9


def inside_bounds(tensions: np.ndarray, bounds: TensionBounds) -> bool:
    """Whether ``tensions`` (n_tendons,) or (K, n_tendons) [N], read back from a run, are finite and inside the
    run's ``bounds``, each within :data:`BOUNDS_SLACK` times its upper bound (at least 1 N) of them: the one
    rule for tensions a run recorded (its samples, its largest-reach pose).

    Parameters
    ----------
    tensions : ndarray
        The tensions [N], one row per sample (or one sample).
    bounds : TensionBounds
        The run's bounds.

    Returns
    -------
    bool
        True when every tension is finite and inside the bounds (with the slack).
    """
    t = np.asarray(tensions, dtype=float)
    slack = BOUNDS_SLACK * np.maximum(bounds.upper, 1.0)
    return bool(np.all(np.isfinite(t)) and np.all(t >= bounds.lower - slack) and np.all(t <= bounds.upper + slack))


def _finished_run(folder: str | Path) -> RunFolder:
    """``folder`` as a :class:`~pytdcr.runtime.RunFolder` named by ``workspace``, refused unless it holds
    ``workspace.json`` and ``samples.npz``."""
    run = RunFolder(folder, "workspace")
    if not (run.root / "workspace.json").is_file() or not (run.root / "samples.npz").is_file():
        raise run.refuse("give the folder of one finished `tdcr workspace` run (with workspace.json and "
                         "samples.npz; of a comparison, one case's folder)")
    return run


def _loads(doc: RunDoc, robot: Robot) -> Loads:
    """The external loads of ``workspace.json``'s ``inputs.loads``, each field strictly of its type and range
    (forces within +/- :data:`~pytdcr.validate.MAX_FORCE_N`, moments +/- :data:`~pytdcr.validate.MAX_MOMENT_NM`),
    a refusal naming the field."""
    base = "inputs.loads"
    points = []
    for k in range(len(doc.read_list(f"{base}.point_loads", MAX_POINT_LOADS))):
        at = f"{base}.point_loads[{k}]"
        disk = doc.read_int(f"{at}.disk", 1, robot.n_disks)
        force = doc.read_vector(f"{at}.force", 3, MAX_FORCE_N)
        moment = doc.read_vector(f"{at}.moment", 3, MAX_MOMENT_NM)
        try:
            points.append(PointLoad(disk, force, moment))
        except (ValueError, TypeError) as err:
            raise doc.refuse(at, str(err)) from None
    tip_force = doc.read_vector(f"{base}.tip_force", 3, MAX_FORCE_N)
    tip_moment = doc.read_vector(f"{base}.tip_moment", 3, MAX_MOMENT_NM)
    release = doc.read_bool(f"{base}.release")
    try:
        return Loads(tip_force=tip_force, tip_moment=tip_moment, release=release, point_loads=tuple(points))
    except (ValueError, TypeError) as err:
        raise doc.refuse(base, str(err)) from None


def read_workspace_inputs(folder: str | Path) -> WorkspaceInputs:
    """The inputs of the workspace run in ``folder`` (``workspace.json``, beside ``samples.npz``), every field
    read strictly into its type (:class:`~pytdcr.runtime.RunDoc`); SettingsError naming ``workspace``, the file
    and the field when the folder is not one finished run or a field is not what that run writes."""
    return _inputs(_finished_run(folder))


def _inputs(run: RunFolder) -> WorkspaceInputs:
    """The inputs of the finished workspace run ``run`` (:func:`read_workspace_inputs`)."""
    from ..statics import MODELS

    doc = run.read_json("workspace.json")
    try:
        robot = robot_from_dict(doc.read_dict("inputs.robot"), "workspace.json: inputs.robot")
    except (ValueError, TypeError) as err:
        if isinstance(err, SettingsError):
            raise
        raise run.refuse(str(err)) from None
    loads = _loads(doc, robot)
    n = robot.n_tendons
    lower, upper = doc.read_vector("inputs.bounds.lower", n), doc.read_vector("inputs.bounds.upper", n)
    try:
        bounds = TensionBounds(lower, upper)
    except (ValueError, TypeError) as err:
        raise doc.refuse("inputs.bounds", str(err)) from None
    model = doc.read_str("inputs.solver.model", MODELS)
    return WorkspaceInputs(robot, loads, bounds, model, doc.data)


def _shape_text(shape: tuple[int | str, ...]) -> str:
    """A shape as Python writes it, a named length by its name: ``(M,)``, ``(M, 8)``."""
    return f"({', '.join(map(str, shape))}{',' if len(shape) == 1 else ''})"


def read_workspace_pool(folder: str | Path) -> WorkspacePool:
    """The workspace run in ``folder`` (its ``workspace.json`` inputs and ``samples.npz``) as a
    :class:`WorkspacePool`; SettingsError naming ``workspace``, the file and the field when the folder is not one
    finished run: ``samples.npz``'s arrays must be of their kinds (no pickles) and shapes, one row per sample,
    the tensions finite and inside the run's bounds (:func:`inside_bounds`), ``stable`` 1, 0 or NaN (untested),
    the converged tips finite."""
    run = _finished_run(folder)
    inputs = _inputs(run)
    z = run.read_npz("samples.npz", {"tensions": "f", "tip": "f", "converged": "b", "stable": "f"})
    m = z["converged"].shape[0] if z["converged"].ndim == 1 else None  # M, the number of samples
    n = inputs.robot.n_tendons
    for key, want in (("converged", ("M",)), ("stable", ("M",)), ("tensions", ("M", n)), ("tip", ("M", 3))):
        if m is None or z[key].shape != tuple(m if d == "M" else d for d in want):
            raise run.refuse(f"samples.npz: {key}: shape {z[key].shape}, not {_shape_text(want)} (one row per "
                             f"sample; the run's robot has {n} tendons)")
    t, tip, converged, stable = z["tensions"], z["tip"], z["converged"], z["stable"]
    if not inside_bounds(t, inputs.bounds):
        raise run.refuse("samples.npz: tensions: must be finite and inside the run's bounds (workspace.json: "
                         "inputs.bounds)")
    if not np.all(np.isnan(stable) | (stable == 0.0) | (stable == 1.0)):
        raise run.refuse("samples.npz: stable: must be 1 (stable), 0 (unstable) or NaN (untested)")
    if not np.all(np.isfinite(tip[converged])):
        raise run.refuse("samples.npz: tip: must be finite at every converged sample")
    keep = converged & (stable != 0.0)  # the run's FSW: converged and not found unstable (untested counts)
    if not np.any(keep):
        raise run.refuse(f"samples.npz: no converged sample not found unstable, of robot '{inputs.robot.name}'")
    return WorkspacePool(inputs.robot, inputs.loads, inputs.bounds, inputs.model, t[keep], tip[keep])

"""``tdcr inverse``'s data: a finished workspace run as the starts of inverse statics, and the table of answers."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..io import robot_from_dict
from ..loads import Loads, PointLoad
from ..robot import Robot
from ..runtime import RunDoc, RunFolder
from ..validate import MAX_FORCE_N, MAX_MOMENT_NM, SettingsError

__all__ = ["BOUNDS_SLACK", "WorkspaceInputs", "WorkspacePool", "inside_bounds", "inverse_columns", "inverse_rows",
           "read_workspace_inputs", "read_workspace_pool"]


def inverse_columns(n_tendons: int) -> list[str]:
    """The columns of ``tdcr inverse --csv``: the target [m], the tensions [N], the tip [m] and what held."""
    return ["target_x_m", "target_y_m", "target_z_m", *[f"T{k}_N" for k in range(1, n_tendons + 1)],
            "tip_x_m", "tip_y_m", "tip_z_m", "distance_m", "reachable", "stable", "path", "objective_value",
            "evaluations", "seconds"]


def inverse_rows(results: list[Any]) -> list[list[Any]]:
    """One row per :class:`~pytdcr.optimize.InverseResult`, in the order of :func:`inverse_columns`."""
    return [[*r.target.tolist(), *r.tensions.tolist(), *r.tip_position.tolist(), r.distance_m, r.reachable,
             r.stable, r.path, r.objective_value, r.evaluations, r.seconds] for r in results]


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
    registered name), and its whole ``workspace.json`` (``summary``)."""

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: str
    summary: dict[str, Any]


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

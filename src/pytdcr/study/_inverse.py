"""``tdcr inverse``'s data: a finished workspace run as the starts of inverse statics, and the table of answers."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..design import Robot
from ..io import robot_from_dict
from ..loads import Loads, PointLoad
from ..validate import SettingsError, show_path

__all__ = ["WorkspaceInputs", "WorkspacePool", "inverse_columns", "inverse_rows", "read_workspace_inputs",
           "read_workspace_pool"]


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
    """A finished ``tdcr workspace`` run read as starts: its robot, external loads, bounds and model, and its
    converged, stable samples' tensions (K, n_tendons) [N] and tips (K, 3) [m]."""

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


def read_workspace_inputs(folder: str | Path) -> WorkspaceInputs:
    """The inputs of the workspace run in ``folder`` (``workspace.json``, beside ``samples.npz``);
    SettingsError naming ``workspace`` when the folder is not one finished run."""
    from ..statics import MODELS

    d = Path(folder)
    where = show_path(d)
    if not (d / "workspace.json").is_file() or not (d / "samples.npz").is_file():
        raise SettingsError("workspace", f" {where}: give the folder of one finished `tdcr workspace` run (with "
                            "workspace.json and samples.npz; of a comparison, one case's folder)")
    try:
        summary = json.loads((d / "workspace.json").read_text(encoding="utf-8"))
        inputs = summary["inputs"]
        robot = robot_from_dict(inputs["robot"], f"{where}: robot")
        ld = inputs["loads"]
        loads = Loads(tip_force=np.asarray(ld["tip_force"], dtype=float),
                      tip_moment=np.asarray(ld["tip_moment"], dtype=float), release=bool(ld["release"]),
                      point_loads=tuple(PointLoad(int(p["disk"]), np.asarray(p["force"], dtype=float),
                                                  np.asarray(p["moment"], dtype=float)) for p in ld["point_loads"]))
        bounds = TensionBounds(inputs["bounds"]["lower"], inputs["bounds"]["upper"])
        model = str(inputs["solver"]["model"])
        if model not in MODELS:
            raise ValueError(f"its model {model!r} is not registered")
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise SettingsError("workspace", f" {where}: cannot read the run ({type(err).__name__}: {err})") from None
    return WorkspaceInputs(robot, loads, bounds, model, summary)


def read_workspace_pool(folder: str | Path) -> WorkspacePool:
    """The workspace run in ``folder`` (its ``workspace.json`` inputs and ``samples.npz``) as a
    :class:`WorkspacePool`; SettingsError naming ``workspace`` when the folder is not one finished run."""
    run = read_workspace_inputs(folder)
    d = Path(folder)
    try:
        with np.load(d / "samples.npz", allow_pickle=False) as z:
            keep = z["converged"] & (z["stable"] == 1.0)
            tensions, tips = z["tensions"][keep], z["tip"][keep]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise SettingsError("workspace", f" {show_path(d)}: cannot read the run ({type(err).__name__}: {err})"
                            ) from None
    if tensions.shape[0] == 0 or tensions.shape[1] != run.robot.n_tendons:
        raise SettingsError("workspace", f" {show_path(d)}: no converged, stable sample of robot '{run.robot.name}'")
    return WorkspacePool(run.robot, run.loads, run.bounds, run.model, tensions, tips)

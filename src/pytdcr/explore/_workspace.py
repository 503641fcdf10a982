"""A finished ``tdcr workspace`` run, read for drawing: its boundary mesh and its largest-reach pose."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bounds import TensionBounds
from ..design import Robot
from ..loads import Loads
from ..statics import MODELS, solve
from ..study import read_workspace_inputs
from ..validate import SettingsError, show_path

__all__ = ["MAX_FACES", "REACH_AGREES_M", "ReachPose", "WorkspaceView", "read_workspace"]

#: the most boundary faces drawn (every k-th face beyond: a drawing aid, not geometry)
MAX_FACES = 100_000
#: the loading path's tip and the recorded largest-reach tip agree within this [m]
REACH_AGREES_M = 1e-6


@dataclass(frozen=True, eq=False)
class ReachPose:
    """The run's largest-reach pose: its tensions [N], the tip the run recorded [m], and (when the loading path
    from rest at those tensions converged) its disk centres (N+1, 3) [m] and backbone points (K, 3) [m]."""

    tensions: np.ndarray
    tip: np.ndarray
    disks: np.ndarray | None
    backbone: np.ndarray | None
    note: str


@dataclass(frozen=True, eq=False)
class WorkspaceView:
    """What the explorer draws of a workspace run: the folder, its robot, loads, bounds and model name, the
    boundary mesh's vertices (V, 3) [m] and faces (F, 3) (None without a mesh), the realisable part's boundary
    (vertices, faces; None without one: the FSW less the poses with a disk below the base plane or two disks
    intersecting, ``fsw_realisable.ply``) and the largest-reach pose."""

    folder: Path
    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: str
    vertices: np.ndarray | None
    faces: np.ndarray | None
    faces_total: int
    reach: ReachPose | None
    realisable: tuple[np.ndarray, np.ndarray] | None = None


def read_workspace(folder: str | Path) -> WorkspaceView:
    """The workspace run in ``folder`` (``workspace.json``, ``samples.npz`` and its boundary mesh, e.g.
    ``fsw.ply``); :class:`~pytdcr.validate.SettingsError` naming ``workspace`` when it is not one finished run."""
    d = Path(folder)
    robot, loads, bounds, model, summary = read_workspace_inputs(d)
    vertices = faces = None
    total = 0
    if summary.get("mesh"):
        vertices, faces, total = _mesh(d / str(summary["mesh"]))
    real = (summary.get("realisable") or {}).get("mesh")
    realisable = _mesh(d / str(real))[:2] if real else None
    return WorkspaceView(d, robot, loads, bounds, model, vertices, faces, total,
                         _reach(robot, loads, model, summary.get("largest_reach")), realisable)


def _mesh(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    """Vertices (V, 3) [m], at most :data:`MAX_FACES` faces and the number of faces of the mesh at ``path``."""
    import trimesh

    try:
        mesh = trimesh.load(path, force="mesh")
    except (OSError, ValueError) as err:
        raise SettingsError("workspace", f" {show_path(path)}: cannot read the boundary mesh ({err})") from None
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    step = max(1, int(np.ceil(f.shape[0] / MAX_FACES)))
    return np.asarray(mesh.vertices, dtype=float).reshape(-1, 3), f[::step], int(f.shape[0])


def _reach(robot: Robot, loads: Loads, model: str, record: dict | None) -> ReachPose | None:
    """The largest-reach pose of ``record`` (``workspace.json``'s ``largest_reach``), solved along the loading
    path from rest under the run's robot, loads and model; None when the run recorded none."""
    if not record or record.get("tensions") is None:
        return None
    t = np.asarray(record["tensions"], dtype=float)
    tip = np.asarray(record["tip"], dtype=float)
    if t.shape != (robot.n_tendons,) or tip.shape != (3,):
        return None
    sol = solve(robot, loads.with_tensions(t), model=MODELS[model])
    if not sol.converged:
        return ReachPose(t, tip, None, None, "the loading path from rest did not converge at its tensions: "
                         "its recorded tip alone is drawn")
    gap = float(np.linalg.norm(sol.tip_position - tip))
    note = ("" if gap <= REACH_AGREES_M else
            f"the loading path from rest at its tensions ends {gap * 1e3:.1f} mm from the recorded tip (the run "
            "followed another branch): the marker is the recorded tip")
    return ReachPose(t, tip, sol.disk_positions, sol.backbone_points(robot), note)

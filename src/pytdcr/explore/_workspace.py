"""A finished ``tdcr workspace`` run, read for drawing: its boundary mesh and its largest-reach pose."""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..robot import Robot
from ..runs import inside_bounds, read_workspace_inputs
from ..runtime import RunDoc, RunFolder
from ..statics import MODELS, solve
from ..validate import show

__all__ = ["MAX_COORDINATE_M", "MAX_FACES", "MAX_MESH_BYTES", "REACH_AGREES_M", "ReachPose", "WorkspaceView",
           "read_workspace"]

#: the most boundary faces drawn (every k-th face beyond: a drawing aid, not geometry)
MAX_FACES = 100_000
#: the largest boundary mesh file read [bytes]
MAX_MESH_BYTES = 512 * 2**20
#: the largest coordinate of a mesh vertex or a recorded tip [m] (a robot is never a kilometre long)
MAX_COORDINATE_M = 1e3
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
    ``fsw.ply``), every field read strictly (:class:`~pytdcr.runtime.RunDoc`): the meshes it names must be files
    inside the folder of at most :data:`MAX_MESH_BYTES` bytes, with finite vertices and faces that index them;
    :class:`~pytdcr.validate.SettingsError` naming ``workspace``, the file and the field when it is not one
    finished run."""
    d = Path(folder)
    robot, loads, bounds, model, summary = read_workspace_inputs(d)
    run = RunFolder(d, "workspace")
    doc = RunDoc(run, "workspace.json", summary)
    vertices = faces = None
    total = 0
    if doc.has("mesh"):
        vertices, faces, total = _mesh(doc, "mesh")
    realisable = None
    if doc.has("realisable") and doc.read_dict("realisable").get("mesh") is not None:
        realisable = _mesh(doc, "realisable.mesh")[:2]
    return WorkspaceView(d, robot, loads, bounds, model, vertices, faces, total,
                         _reach(doc, robot, loads, bounds, model), realisable)


def _mesh(doc: RunDoc, field: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Vertices (V, 3) [m], at most :data:`MAX_FACES` faces and the number of faces of the mesh the field
    ``field`` of ``workspace.json`` names in the run's folder: a ``.ply`` file (what a run writes; any other
    suffix is refused, so no other loader of trimesh is ever reached), read as PLY from its bytes (never a file
    it names)."""
    import trimesh

    run, name = doc.run, doc.read_path(field)
    if PurePosixPath(name).suffix.lower() != ".ply":
        raise doc.refuse(field, "must name a .ply file (the boundary meshes a run writes are PLY)", name)
    data = run.read_bytes(name, MAX_MESH_BYTES)
    try:
        mesh = trimesh.load(io.BytesIO(data), file_type="ply", force="mesh",
                            process=False)  # as written: a NaN vertex is refused, not dropped
        v = np.asarray(mesh.vertices, dtype=float).reshape(-1, 3)
        f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    except Exception as err:  # a loader fails in its own ways on a file it cannot parse
        raise run.refuse(f"{name}: cannot read the boundary mesh ({type(err).__name__}: "
                         f"{show(str(err), 100)[1:-1]})") from None
    if not np.all(np.isfinite(v)) or np.any(np.abs(v) > MAX_COORDINATE_M):
        raise run.refuse(f"{name}: its vertices must be finite and within +/-{MAX_COORDINATE_M:g} m")
    if f.size and (int(f.min()) < 0 or int(f.max()) >= v.shape[0]):
        raise run.refuse(f"{name}: its faces must index its {v.shape[0]} vertices")
    step = max(1, int(np.ceil(f.shape[0] / MAX_FACES)))
    return v, f[::step], int(f.shape[0])


def _reach(doc: RunDoc, robot: Robot, loads: Loads, bounds: TensionBounds, model: str) -> ReachPose | None:
    """The largest-reach pose ``workspace.json``'s ``largest_reach`` records (its tensions inside the run's
    bounds, its tip finite), solved along the loading path from rest under the run's robot, loads and model; None
    when the run recorded none."""
    if not doc.has("largest_reach") or not doc.has("largest_reach.tensions"):
        return None
    t = doc.read_vector("largest_reach.tensions", robot.n_tendons)
    tip = doc.read_vector("largest_reach.tip", 3, MAX_COORDINATE_M)
    if not inside_bounds(t, bounds):
        raise doc.refuse("largest_reach.tensions", "must lie inside the run's bounds (inputs.bounds)", t.tolist())
    sol = solve(robot, loads.with_tensions(t), model=MODELS[model])
    if not sol.converged:
        return ReachPose(t, tip, None, None, "the loading path from rest did not converge at its tensions: "
                         "its recorded tip alone is drawn")
    gap = float(np.linalg.norm(sol.tip_position - tip))
    note = ("" if gap <= REACH_AGREES_M else
            f"the loading path from rest at its tensions ends {gap * 1e3:.1f} mm from the recorded tip (the run "
            "followed another branch): the marker is the recorded tip")
    return ReachPose(t, tip, sol.disk_positions, sol.backbone_points(robot), note)

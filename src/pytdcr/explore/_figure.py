"""The explorer's 3D figure (plotly, as plain dictionaries): the robot's traces and their data for one pose.

The figure is built once per page; each solve changes only the data of the traces that move (:data:`MOVING`),
sent as a partial update. Lengths are drawn in millimetres.
"""

from __future__ import annotations

import numpy as np

from ..loads import Loads
from ..palette import PALETTE
from ..records import JsonDict
from ..results import StaticSolution
from ..robot import Robot
from ..validate import direction_or_none
from ._workspace import WorkspaceView

__all__ = [
    "BACKBONE",
    "DISKS",
    "FORCE",
    "MISS",
    "MM",
    "MOMENT",
    "MOVING",
    "REALISABLE_NAME",
    "REST",
    "TARGET",
    "TARGET_NAME",
    "TENDONS",
    "TIP_AXES",
    "WORKSPACE_NAME",
    "backbone_name",
    "base_figure",
    "pose_data",
    "rest_data",
    "target_data",
]

#: metres to the figure's millimetres
MM = 1e3
#: the traces that move, by index: backbone, disks, tendons, the tip frame's x, y, z axes, the tip force and
#: moment arrows, the loading path's backbone (the pose's, :func:`pose_data`), then the target marker and the
#: dashed line from the tip to it (:func:`target_data`)
BACKBONE, DISKS, TENDONS = 0, 1, 2
TIP_AXES = (3, 4, 5)
FORCE, MOMENT = 6, 7
REST = 8
TARGET, MISS = 9, 10
MOVING = 11
#: the name of the workspace boundary's trace
WORKSPACE_NAME = "FSW boundary"
#: the name of the realisable part's boundary trace (the run's ``fsw_realisable.ply``)
REALISABLE_NAME = "realisable part"
#: the name of the target marker's trace
TARGET_NAME = "target"
_RING = 24  # points on a disk's circle
#: the workspace boundaries' opacity: light enough that the robot inside reads through them
BOUNDARY_OPACITY = 0.07


def _rgba(colour: str, alpha: float) -> str:
    """The hex ``colour`` (``"#rrggbb"``) with opacity ``alpha`` as plotly's ``rgba(r,g,b,a)``."""
    r, g, b = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha:g})"


def _line(name: str, colour: str, width: float, **extra: object) -> JsonDict:
    return {"type": "scatter3d", "mode": "lines", "name": name, "x": [], "y": [], "z": [],
            "line": {"color": colour, "width": width}, "hoverinfo": "skip", **extra}


def _columns(points: np.ndarray) -> dict[str, list]:
    """x, y, z lists [mm] of points (M, 3) [m]; rows of NaN break the line (null)."""
    p = np.round(np.asarray(points, dtype=float) * MM, 4)
    return {k: [None if v != v else v for v in p[:, i].tolist()] for i, k in enumerate("xyz")}


def _broken(parts: list[np.ndarray]) -> np.ndarray:
    """The polylines ``parts`` (each (M_i, 3)) joined into one array with a NaN row between them."""
    gap = np.full((1, 3), np.nan)
    out: list[np.ndarray] = []
    for p in parts:
        out += [p, gap]
    return np.vstack(out) if out else np.zeros((0, 3))


def base_figure(robot: Robot, workspace: WorkspaceView | None) -> JsonDict:
    """The figure of ``robot`` with no pose drawn yet (its traces empty), the workspace run's boundary and
    largest-reach pose when given; axes span the robot's length around the base [mm]."""
    c = PALETTE
    data = [_line("backbone", c.backbone, 8), _line("disks", c.disks, 3), _line("tendons", c.tendons, 2),
            _line("tip x", c.frame_x, 6, showlegend=False), _line("tip y", c.frame_y, 6, showlegend=False),
            _line("tip z", c.frame_z, 6, showlegend=False), _line("tip force", c.tip_force, 5),
            _line("tip moment (double head)", c.tip_moment, 5),
            _line("loading path from rest", _rgba(c.reference, 0.45), 14),
            {"type": "scatter3d", "mode": "markers", "name": TARGET_NAME, "x": [], "y": [], "z": [],
             "marker": {"size": 11, "color": c.target, "symbol": "circle-open", "line": {"width": 3}},
             "hoverinfo": "text", "hovertext": []},
            _line("tip to target", c.target, 3, showlegend=False)]
    data[MISS]["line"]["dash"] = "dash"
    if workspace is not None:
        data += _workspace_traces(workspace)
    span = 1.05 * robot.length * MM
    axis = {"range": [-span, span], "autorange": False, "zeroline": False, "showspikes": False}
    layout = {"uirevision": "explore", "margin": {"l": 0, "r": 0, "t": 0, "b": 0}, "paper_bgcolor": "#ffffff",
              "font": {"family": "system-ui, -apple-system, 'Segoe UI', Roboto, Arial, sans-serif", "size": 12},
              "legend": {"x": 0.01, "y": 0.99, "bgcolor": "rgba(255,255,255,0.8)", "bordercolor": "#dde1e6",
                         "borderwidth": 1},
              "scene": {"aspectmode": "cube", "xaxis": {**axis, "title": {"text": "x [mm]"}},
                        "yaxis": {**axis, "title": {"text": "y [mm]"}},
                        "zaxis": {**axis, "title": {"text": "z [mm]"}},
                        "camera": {"eye": {"x": 1.2, "y": -1.2, "z": 0.75}}}}
    return {"data": data, "layout": layout}


def _workspace_traces(ws: WorkspaceView) -> list[JsonDict]:
    """The boundary (translucent) and the largest-reach pose of a workspace run."""
    out: list[JsonDict] = []
    if ws.vertices is not None and ws.faces is not None and len(ws.faces):
        v, f = np.round(ws.vertices * MM, 3), ws.faces
        out.append({"type": "mesh3d", "name": WORKSPACE_NAME, "x": v[:, 0].tolist(), "y": v[:, 1].tolist(),
                    "z": v[:, 2].tolist(), "i": f[:, 0].tolist(), "j": f[:, 1].tolist(), "k": f[:, 2].tolist(),
                    "color": PALETTE.region, "opacity": BOUNDARY_OPACITY, "flatshading": True, "showlegend": True,
                    "lighting": {"ambient": 0.9, "diffuse": 0.2, "specular": 0.0},
                    "hovertemplate": "(%{x:.1f}, %{y:.1f}, %{z:.1f}) mm<br>click: the target<extra></extra>"})
    if ws.realisable is not None and len(ws.realisable[1]):
        v, f = np.round(ws.realisable[0] * MM, 3), ws.realisable[1]
        out.append({"type": "mesh3d", "name": REALISABLE_NAME, "x": v[:, 0].tolist(), "y": v[:, 1].tolist(),
                    "z": v[:, 2].tolist(), "i": f[:, 0].tolist(), "j": f[:, 1].tolist(), "k": f[:, 2].tolist(),
                    "color": PALETTE.realisable, "opacity": BOUNDARY_OPACITY, "flatshading": True, "showlegend": True,
                    "lighting": {"ambient": 0.9, "diffuse": 0.2, "specular": 0.0},
                    "hoverinfo": "skip"})
    r = ws.reach
    if r is not None:
        if r.backbone is not None:
            out.append(_line("largest reach (recorded)", _rgba(PALETTE.region_edge, 0.5), 5, **_columns(r.backbone)))
        out.append({"type": "scatter3d", "mode": "markers", "name": "largest-reach tip", **_columns(r.tip[None]),
                    "marker": {"size": 5, "color": PALETTE.region_edge, "symbol": "diamond"},
                    "hovertext": [f"largest reach {np.linalg.norm(r.tip) * MM:.1f} mm"], "hoverinfo": "text"})
    return out


def _arrow(origin: np.ndarray, vector: np.ndarray, length: float, heads: int = 1) -> np.ndarray:
    """An arrow from ``origin`` [m] along ``vector``, ``length`` [m] long, with ``heads`` heads of four barbs
    each, as polylines joined by NaN rows (:func:`_broken`); no points for a vector too small to have a direction
    (:func:`~pytdcr.validate.direction_or_none`)."""
    d = direction_or_none(vector, "arrow")
    if d is None:
        return np.zeros((0, 3))
    e1 = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    h = 0.12 * length
    parts = [np.vstack([origin, origin + length * d])]
    for k in range(heads):
        tip = origin + (1.0 - 0.12 * k) * length * d
        parts += [np.vstack([tip, tip - h * d + s * 0.45 * h * e]) for e in (e1, e2) for s in (1.0, -1.0)]
    return _broken(parts)


def pose_data(robot: Robot, sol: StaticSolution | None, loads: Loads | None) -> dict[int, JsonDict]:
    """The data of the pose's traces (by index, those before :data:`TARGET`) for a converged ``sol`` under
    ``loads``; with ``sol`` None (no equilibrium), every one empty, so that nothing is drawn as if it were one."""
    empty = {"x": [], "y": [], "z": []}
    if sol is None or not sol.converged:
        return {**{i: dict(empty) for i in range(TARGET)}, BACKBONE: {**empty, "name": "backbone"}}
    p, R = sol.disk_positions, sol.disk_rotations
    t = np.linspace(0.0, 2.0 * np.pi, _RING + 1)
    ring = robot.disk_radius * np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)  # (T, 3)
    disks = np.einsum("nij,tj->nti", R, ring) + p[:, None, :]
    holes = np.einsum("nij,kj->nki", R, robot.tendon_holes) + p[:, None, :]  # (N+1, n_tendons, 3)
    tendons = [holes[: a + 1, k] for k, a in enumerate(robot.anchor_disks)]
    out = {BACKBONE: {**_columns(sol.backbone_points(robot)), "name": backbone_name(sol)},
           DISKS: _columns(_broken(list(disks))), TENDONS: _columns(_broken(tendons))}
    tip, Rt, size = p[-1], R[-1], 0.1 * robot.length
    for k, i in enumerate(TIP_AXES):
        out[i] = _columns(np.vstack([tip, tip + size * Rt[:, k]]))
    for i, vec, what, heads in ((FORCE, loads.tip_force, "tip force {:.2f} N", 1),
                                (MOMENT, loads.tip_moment, "tip moment {:.3f} N m (double head)", 2)):
        v = np.asarray(vec, dtype=float)
        out[i] = {**_columns(_arrow(tip, v, 0.2 * robot.length, heads)), "name": what.format(np.linalg.norm(v))}
    out[REST] = empty
    return out


def backbone_name(sol: StaticSolution) -> str:
    """The backbone trace's legend entry for the converged ``sol``: ``backbone``, with the equilibrium's
    stability when it is not tested stable (``UNSTABLE``, ``stability untested``)."""
    return {True: "backbone", False: "backbone (UNSTABLE)", None: "backbone (stability untested)"}[sol.stable]


def target_data(target: np.ndarray | None, sol: StaticSolution | None) -> dict[int, JsonDict]:
    """The data of the target marker and of the dashed line from the tip of a converged ``sol`` to it (both
    empty without a target [m]; the line empty without an equilibrium)."""
    empty: JsonDict = {"x": [], "y": [], "z": []}
    if target is None:
        return {TARGET: {**empty, "hovertext": []}, MISS: empty}
    t = np.asarray(target, dtype=float)
    mm = t * MM
    marker = {**_columns(t[None]), "hovertext": [f"target ({mm[0]:.1f}, {mm[1]:.1f}, {mm[2]:.1f}) mm"]}
    if sol is None or not sol.converged:
        return {TARGET: marker, MISS: empty}
    return {TARGET: marker, MISS: _columns(np.vstack([sol.tip_position, t]))}


def rest_data(robot: Robot, rest: StaticSolution | None) -> JsonDict:
    """The loading path's backbone trace data (empty when there is none or it did not converge)."""
    if rest is None or not rest.converged:
        return {"x": [], "y": [], "z": []}
    return _columns(rest.backbone_points(robot))

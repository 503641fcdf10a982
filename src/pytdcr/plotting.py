"""Figures: robot shapes in 3D, samples and convergence.

Every function takes ``ax=None`` (a new axis is made only if none is given),
passes ``**kwargs`` to matplotlib and returns the axis. matplotlib is loaded
when a function here is first called, not when the module is imported, and
the backend is never changed here (the command line alone picks Agg).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .palette import PALETTE
from .results import StaticSolution
from .robot import Robot
from .runtime import atomic_write

if TYPE_CHECKING:
    from types import ModuleType

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.axes3d import Axes3D
    from trimesh import Trimesh

    from .accuracy import OrderStudy
    from .calibrate import CalibrationResult
    from .workspace import Region

__all__ = [
    "RobotStyle",
    "new_3d_axes",
    "plot_calibration",
    "plot_convergence",
    "plot_model_overlay",
    "plot_multistability",
    "plot_order",
    "plot_reach_samples",
    "plot_region_3d",
    "plot_region_slices",
    "plot_robot",
    "plot_robots",
    "plot_support_map",
    "pyplot",
    "region_colours",
    "save_figure",
    "save_figure_as",
    "set_equal_aspect",
    "write_region_html",
]


def pyplot() -> ModuleType:
    """``matplotlib.pyplot``, imported on first use."""
    import matplotlib.pyplot as plt

    return plt


def new_3d_axes(figsize: tuple[float, float] = (6.0, 6.0)) -> Axes3D:
    """A fresh figure with one 3D axis."""
    fig = pyplot().figure(figsize=figsize)
    return fig.add_subplot(projection="3d")


#: the resolution every figure file is written at [dots per inch]
SAVE_DPI = 150


def drawn_points(ax: Axes3D) -> np.ndarray:
    """The points (K, 3) [m] of every line drawn on the 3D axes ``ax`` (backbones, disks' rings, tendons): what
    limits shared by several axes must hold."""
    lines = [np.column_stack([np.ravel(a) for a in line.get_data_3d()]) for line in ax.lines]
    return np.vstack(lines).astype(float) if lines else np.zeros((0, 3))


def set_equal_aspect(ax: Axes3D, points: np.ndarray, margin: float = 0.05) -> None:
    """Equal scale on x, y, z around ``points`` (K, 3) [m], with at most five ticks an axis (more overlap in a
    3D view's foreshortened axes)."""
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=4))
    lo = points.min(axis=0)
    hi = points.max(axis=0)
    centre = (lo + hi) / 2.0
    half = max(float((hi - lo).max()) / 2.0, 1e-3) * (1.0 + margin)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))


def save_figure(fig: Figure, out: Path, stem: str) -> list[str]:
    """Write ``fig`` as ``stem``.png and ``stem``.pdf in the folder ``out`` (each whole or absent) and close it.

    Returns
    -------
    list of str
        The file names written.
    """
    # the tight bounding box is measured once (it costs a full draw) and used for both formats, at the dpi the
    # files are written at (text extents and a layout engine's placement depend on it: a box measured at the
    # screen's dpi clipped the PNG); a figure with a layout engine (constrained, tight) is drawn first: the
    # engine places the axes only when the figure is drawn, and a box measured before that clips
    fig.set_dpi(SAVE_DPI)
    fig.canvas.draw()
    if fig.get_layout_engine() is not None:  # the placement measured is the one written: a constrained layout
        fig.set_layout_engine("none")      # drawn again can move axes with an equal aspect and cut a label
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    names = []
    for ext in ("png", "pdf"):
        path = atomic_write(Path(out) / f"{stem}.{ext}",
                            lambda tmp, ext=ext: fig.savefig(tmp, dpi=SAVE_DPI, bbox_inches=bbox, format=ext))
        names.append(path.name)
    pyplot().close(fig)
    return names


def save_figure_as(fig: Figure, path: Path) -> Path:
    """Write ``fig`` to ``path`` in the format its suffix names (.png, .pdf, .svg), whole or absent, and close
    it."""
    try:
        return atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=SAVE_DPI, bbox_inches="tight",
                                                          format=Path(path).suffix[1:].lower()))
    finally:
        pyplot().close(fig)


def _frame_arrows(ax: Axes3D, origin: np.ndarray, rot: np.ndarray, size: float) -> None:
    for k, colour in enumerate((PALETTE.frame_x, PALETTE.frame_y, PALETTE.frame_z)):
        ax.quiver(*origin, *(rot[:, k] * size), color=colour, linewidth=1.5, arrow_length_ratio=0.25)


@dataclass(frozen=True)
class RobotStyle:
    """What :func:`plot_robot` draws besides the backbone.

    Attributes
    ----------
    disks : bool
        The disks, as rings.
    tendons : bool
        The tendons' paths (the palette's tendon colour).
    frames : bool
        The base and tip frames (red, green, blue: x, y, z).
    equal : bool
        Equal scale on the three axes around what was drawn.
    legend : bool
        A legend for the frames' axes and the labelled load arrows (when there are any).
    """

    disks: bool = True
    tendons: bool = True
    frames: bool = True
    equal: bool = True
    legend: bool = True


def plot_robot(
    robot: Robot,
    solution: StaticSolution,
    ax: Axes3D | None = None,
    *,
    style: RobotStyle | None = None,
    loads: Sequence[tuple] = (),
    **kwargs: Any,
) -> Axes3D:
    """Draw one equilibrium shape: backbone, disks as rings, tendons, base and tip frames.

    Parameters
    ----------
    robot : Robot
    solution : StaticSolution
        Must be converged (a non-converged solve has no shape and raises).
    ax : Axes3D, optional
    style : RobotStyle, optional
        What to draw besides the backbone (default: everything, on equal axes).
    loads : sequence of (point, vector), (point, vector, colour) or (point, vector, colour, label)
        Arrows to draw (e.g. the tip force) from ``point`` (3,) along ``vector`` (3,),
        both in the base frame, already scaled to metres (default colour: the palette's tip force); a label
        names it in the legend.
    **kwargs
        Passed to the backbone's ``plot`` call (default the palette's backbone colour, ``linewidth=2.0``;
        ``label`` names it in a legend).
    """
    style = style if style is not None else RobotStyle()
    if ax is None:
        ax = new_3d_axes()
    pos = solution.disk_positions  # raises if not converged
    rot = solution.disk_rotations
    curve = solution.backbone_points(robot)
    ax.plot(curve[:, 0], curve[:, 1], curve[:, 2],
            **{"color": PALETTE.backbone, "linewidth": 2.0, "label": None, **kwargs})
    holes = robot.tendon_holes
    ring_r = float(np.max(np.linalg.norm(holes, axis=1))) * 1.2 if robot.n_tendons else 0.01
    pts = [curve]
    if style.disks:
        phi = np.linspace(0.0, 2.0 * np.pi, 33)
        circle = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)]) * ring_r
        for i in range(pos.shape[0]):
            ring = pos[i][:, None] + rot[i] @ circle
            ax.plot(ring[0], ring[1], ring[2], color=PALETTE.disks, linewidth=0.8)
            pts.append(ring.T)
    if style.tendons and robot.n_tendons:
        anchors = robot.anchor_disks
        for c in range(robot.n_tendons):
            path = np.array([pos[i] + rot[i] @ holes[c] for i in range(anchors[c] + 1)])
            ax.plot(path[:, 0], path[:, 1], path[:, 2], color=PALETTE.tendons, linewidth=0.9)
    if style.frames:
        size = 0.12 * robot.length
        _frame_arrows(ax, pos[0], rot[0], size)
        _frame_arrows(ax, pos[-1], rot[-1], size)
    keys: list[tuple[str, str]] = []
    if style.frames:
        keys += [(PALETTE.frame_x, "frame x"), (PALETTE.frame_y, "frame y"), (PALETTE.frame_z, "frame z")]
    for arrow in loads:
        point = np.asarray(arrow[0], dtype=float)
        vec = np.asarray(arrow[1], dtype=float)
        colour = arrow[2] if len(arrow) > 2 else PALETTE.tip_force
        ax.quiver(*point, *vec, color=colour, linewidth=2.0, arrow_length_ratio=0.2)
        pts.append(np.stack([point, point + vec]))
        if len(arrow) > 3:
            keys.append((colour, arrow[3]))
    if style.legend and keys:
        from matplotlib.lines import Line2D

        ax.legend(handles=[Line2D([], [], color=c, linewidth=2.0, label=t) for c, t in keys], loc="upper left",
                  fontsize=7, framealpha=0.8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    if style.equal:
        set_equal_aspect(ax, np.vstack(pts))
    return ax


def plot_robots(
    robot: Robot, solutions: Sequence[StaticSolution], ax: Axes3D | None = None, **kwargs
) -> Axes3D:
    """Several converged shapes on one axis (non-converged ones are skipped), each coloured by its reach
    ||tip|| [mm] on a colour bar, its tip marked, the base as a black dot.

    Parameters
    ----------
    robot : Robot
    solutions : sequence of StaticSolution
    ax : Axes3D, optional
    **kwargs
        Passed to each backbone's ``plot`` call.
    """
    from matplotlib import colors as mcolors

    if ax is None:
        ax = new_3d_axes((7.0, 6.0))
    good = sorted((s for s in solutions if s.converged), key=lambda s: s.reach)
    if not good:
        return ax
    reach = np.array([s.reach for s in good]) * 1e3
    norm = mcolors.Normalize(float(reach.min()), float(max(reach.max(), reach.min() + 1e-9)))
    cmap = pyplot().get_cmap("viridis")
    pts = [np.zeros((1, 3))]
    for s, r in zip(good, reach, strict=True):
        colour = cmap(norm(r))
        plot_robot(robot, s, ax, style=RobotStyle(disks=False, tendons=False, frames=False, equal=False),
                   **{"color": colour, "linewidth": 1.6, **kwargs})
        tip = s.tip_position
        ax.scatter(*tip, color=colour, s=14, depthshade=False)
        pts.append(s.disk_positions)
    ax.scatter(0.0, 0.0, 0.0, color=PALETTE.backbone, s=18, depthshade=False)
    set_equal_aspect(ax, np.vstack(pts))
    bar = ax.figure.colorbar(pyplot().cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.6, pad=0.1)
    bar.set_label("reach ||tip|| [mm]")
    return ax


def plot_model_overlay(
    robot: Robot, groups: Sequence[Sequence[StaticSolution]], ax: Axes3D | None = None,
    labels: Sequence[str] | None = None,
    case_ids: Sequence[int] | None = None,
) -> Axes3D:
    """Overlay models' shapes case by case: the first solid, the others dashed, dotted..., one colour per case.

    Each entry of ``groups`` holds one solution per model (two or more, in the
    order of ``labels``, by default each solution's model name); entries where
    any solve did not converge are skipped. ``case_ids`` name the cases in the
    legend (default 1, 2, ...).
    """
    if ax is None:
        ax = new_3d_axes()
    pts = []
    k = 0
    styles = ("-", "--", ":", "-.")
    for j, group in enumerate(groups):
        if not all(s.converged for s in group):
            continue
        cid = case_ids[j] if case_ids is not None else j + 1
        names = labels if labels is not None else [s.model for s in group]
        if len(names) != len(group):
            raise ValueError(f"labels: {len(names)} given for {len(group)} solutions per case")
        for m, (sol, name) in enumerate(zip(group, names, strict=True)):
            style = styles[m % len(styles)]
            plot_robot(robot, sol, ax, style=RobotStyle(disks=False, tendons=False, frames=False, equal=False),
                       color=PALETTE.nth(k), linestyle=style, label=f"case {cid} {name}" if k < 10 else None)
            pts.append(sol.backbone_points(robot))
        k += 1
    if pts:
        set_equal_aspect(ax, np.vstack(pts))
        ax.legend(loc="upper left", fontsize="small")
    return ax


def plot_reach_samples(reach: np.ndarray, converged: np.ndarray, ax: Axes | None = None, **kwargs: Any) -> Axes:
    """The paper's Fig. 3(a): ||^0P_n|| against sample number.

    Converged samples are drawn as points with a smoothing spline through
    them; non-converged samples are marked apart along the bottom axis and
    never enter the spline.

    Parameters
    ----------
    reach : array-like, shape (n,)
        [m]; ignored where not converged.
    converged : array-like of bool, shape (n,)
    """
    from scipy.interpolate import make_smoothing_spline

    if ax is None:
        ax = pyplot().figure(figsize=(7.0, 4.0)).add_subplot()
    reach = np.asarray(reach, dtype=float)
    ok = np.asarray(converged, dtype=bool)
    idx = np.arange(1, reach.size + 1)
    ax.plot(idx[ok], reach[ok], "o", ms=4, color=PALETTE.samples, label="converged samples", **kwargs)
    if ok.sum() >= 5:
        spline = make_smoothing_spline(idx[ok].astype(float), reach[ok])
        xs = np.linspace(idx[ok][0], idx[ok][-1], 400)
        ax.plot(xs, spline(xs), "-", color=PALETTE.fit, label="smoothing spline")
    if np.any(~ok):
        lo = np.nanmin(reach[ok]) if np.any(ok) else 0.0
        ax.plot(idx[~ok], np.full((~ok).sum(), lo), "x", color=PALETTE.failed, label=f"not converged ({(~ok).sum()})")
    ax.set_xlabel("sample number")
    ax.set_ylabel(r"$\|{}^0P_n\|_2$ [m]")
    ax.legend(loc="best", fontsize=8)
    return ax


def plot_convergence(best: Sequence[float], mean: Sequence[float], ax: Axes | None = None, **kwargs: Any) -> Axes:
    """The paper's Fig. 5: best and mean feasible cost (1/reach) per generation."""
    if ax is None:
        ax = pyplot().figure(figsize=(6.0, 4.0)).add_subplot()
    gens = np.arange(1, len(best) + 1)
    ax.plot(gens, best, "o-", color=PALETTE.fit, markersize=4, label="best cost", **kwargs)
    ax.plot(gens, mean, "s", color=PALETTE.samples, markersize=3, label="mean cost (feasible)")
    ax.set_xlabel("generation")
    ax.set_ylabel(r"cost $1/\|{}^0P_n\|_2$ [1/m]")
    ax.legend(loc="best", fontsize=8)
    return ax


def plot_order(studies: Sequence[OrderStudy], ax: Axes | None = None, **kwargs: Any) -> Axes:
    """Tip error against disk spacing on log-log axes, one line per model and load group, with fitted orders.

    Parameters
    ----------
    studies : sequence of pytdcr.accuracy.OrderStudy
        Each holds ``spacing`` [m], ``errors_mm`` per model and the fitted ``order``.
    """
    if ax is None:
        ax = pyplot().figure(figsize=(6.5, 4.5)).add_subplot()
    markers = ("o", "s", "^", "D")
    styles = ("-", "--", ":", "-.")
    for g, st in enumerate(studies):
        for j, (name, e) in enumerate(st.errors_mm.items()):
            ok = np.isfinite(e) & (e > 0)
            ax.loglog(st.spacing[ok] * 1e3, e[ok], marker=markers[j % 4], color=PALETTE.model(name),
                      linestyle=styles[g % 4],
                      label=f"{name}, {st.group}: order {st.order[name]:.2f}", **kwargs)
    ax.set_xlabel("disk spacing [mm]")
    ax.set_ylabel("tip error against sscr [mm]")
    ax.legend(loc="best", fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    return ax


def plot_calibration(result: CalibrationResult, measured: np.ndarray | None = None) -> Figure:
    """A calibration's tip errors [mm] row by row in the data's order (before the fit, fitted, and held out with
    cross-validation), and, with the ``measured`` tips (B, 3) [m], the predicted against the measured coordinates
    before and after the fit (a perfect model lies on the diagonal).

    Parameters
    ----------
    result : pytdcr.calibrate.CalibrationResult
    measured : ndarray, shape (B, 3), optional
        The measured tips [m], measurement frame (the data's ``tip_position``).
    """
    fig = pyplot().figure(figsize=(10.0, 4.0))
    rows, parity = fig.subplots(1, 2, gridspec_kw={"width_ratios": (3, 2)})
    x = np.arange(1, result.errors_before_m.size + 1)
    series = [("before the fit", result.errors_before_m, PALETTE.nth(0), "o"),
              ("fitted", result.errors_after_m, PALETTE.nth(1), "s")]
    cv = result.cross_validation
    if cv is not None:
        series.append((f"held out ({cv.folds}-fold)", cv.errors_m, PALETTE.nth(2), "^"))
    for label, e, colour, marker in series:
        rms = np.sqrt(np.nanmean(e**2)) * 1e3
        rows.plot(x, e * 1e3, marker=marker, linestyle="none", markersize=4, color=colour,
                  label=f"{label}: RMS {rms:.3g} mm")
    if np.any(result.errors_after_m > 0):
        rows.set_yscale("log")
    rows.xaxis.get_major_locator().set_params(integer=True)
    rows.set_xlabel("row (the data's order)")
    rows.set_ylabel("tip error [mm]")
    rows.legend(loc="best", fontsize=8)
    rows.grid(True, alpha=0.3)
    if measured is not None:
        m = np.asarray(measured, dtype=float) * 1e3
        for label, tips, colour, marker in (("before the fit", result.predicted_before, PALETTE.nth(0), "o"),
                                            ("fitted", result.predicted_after, PALETTE.nth(1), "s")):
            parity.plot(m.ravel(), np.asarray(tips).ravel() * 1e3, marker=marker, linestyle="none", markersize=3,
                        color=colour, label=label)
        lo, hi = float(m.min()), float(m.max())
        parity.plot([lo, hi], [lo, hi], color="0.5", linewidth=0.8)
        parity.set_xlabel("measured tip coordinate (x, y, z) [mm]")
        parity.set_ylabel("predicted [mm]")
        parity.legend(loc="best", fontsize=8)
        parity.grid(True, alpha=0.3)
    else:
        parity.set_axis_off()
    names = ", ".join(p.name for p in result.parameters)
    fig.suptitle(f"{result.model} fitted to {result.data_source} ({names})", fontsize=9)
    fig.tight_layout()
    return fig


def region_colours(labels: Sequence[str]) -> list[str]:
    """The colour of each region drawn together: the first the palette's region colour, one labelled
    ``realisable`` the realisable colour, the others the numbered series (skipping those two)."""
    others = [c for c in PALETTE.series if c not in (PALETTE.region_edge, PALETTE.realisable)]
    out, k = [], 0
    for n, label in enumerate(labels):
        if n == 0:
            out.append(PALETTE.region_edge)
        elif label == "realisable":
            out.append(PALETTE.realisable)
        else:
            out.append(others[k % len(others)])
            k += 1
    return out


def _note(fig: Figure, title: str, note: str) -> None:
    """``title`` as the figure's title, with ``note`` (a warning, e.g. an unconverged run) on a line below it;
    a title with a note is drawn in the palette's warning colour."""
    text = "\n".join(t for t in (title, note) if t)
    if text:
        fig.suptitle(text, color=PALETTE.warning if note else "black")


def _occupied_box(regions: Sequence[Region]) -> tuple[np.ndarray, np.ndarray] | None:
    """The smallest box [m] (lower and upper corners, (3,) each) holding every occupied voxel of ``regions``
    and the base's centre (the origin); None when no region has a voxel."""
    lo, hi = np.zeros(3), np.zeros(3)
    found = False
    for region in regions:
        idx = np.argwhere(region.occupied)
        if idx.size == 0:
            continue
        found = True
        lo = np.minimum(lo, region.origin + idx.min(axis=0) * region.voxel)
        hi = np.maximum(hi, region.origin + (idx.max(axis=0) + 1) * region.voxel)
    return (lo, hi) if found else None


def plot_region_slices(regions: dict[str, Region], length: float, title: str = "", note: str = "") -> Figure:
    """Slices of workspace regions (:class:`pytdcr.workspace.Region`), overlaid: each region's voxels in the
    plane filled in its colour (translucent) and outlined along the voxels' edges (a line style each, so that
    equal boundaries stay visible); the xz plane (y = 0), the yz plane (x = 0) and the xy plane at 1/4, 1/2 and
    3/4 of ``length`` [m]. The axes hold every region's voxels and the base (x = y = z = 0); ``note`` (e.g.
    that the run did not converge) is written under the title in the warning colour. Returns the figure."""
    from matplotlib.patches import Patch

    plt = pyplot()
    box = _occupied_box(list(regions.values()))
    lo, hi = box if box is not None else (np.array([-length, -length, -0.5 * length]), np.full(3, length))
    pad = 0.04 * float(np.max(hi - lo)) + 1e-3
    lo, hi = lo - pad, hi + pad
    planar = ((0, 2), (1, 2), (0, 1), (0, 1), (0, 1))
    widths = [hi[u] - lo[u] for u, _ in planar]
    fig, axes = plt.subplots(1, 5, figsize=(18, 4.8), layout="constrained", gridspec_kw={"width_ratios": widths})
    cuts = [("xz plane (y = 0)", 1, 0.0), ("yz plane (x = 0)", 0, 0.0)] + [
        (f"xy plane (z = {f * length * 1e3:.0f} mm)", 2, f * length) for f in (0.25, 0.5, 0.75)]
    colours = region_colours(list(regions))
    styles = ("-", "--", ":", "-.")
    for ax, (name, axis, at), (u, v) in zip(axes, cuts, planar, strict=True):
        for k, region in enumerate(regions.values()):
            _slice_cells(ax, region, axis, at, colours[k], styles[k % 4])
        ax.set_title(name)
        ax.set_aspect("equal")
        ax.set_xlim(lo[u], hi[u])
        ax.set_ylim(lo[v], hi[v])
        ax.set_xlabel("xyz"[u] + " [m]")
        ax.set_ylabel("xyz"[v] + " [m]")
        ax.grid(alpha=0.25)
    handles = [Patch(facecolor=colours[k], alpha=_FILL_ALPHA, edgecolor=colours[k], linestyle=styles[k % 4],
                     label=label + ("" if region.occupied.any() else " (empty)"))
               for k, (label, region) in enumerate(regions.items())]  # one entry per region, drawn or empty
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 6), fontsize=9)
    _note(fig, title, note)
    return fig


def plot_multistability(tips: np.ndarray, checked: np.ndarray, other: np.ndarray, distinct: np.ndarray,
                        length: float, labels: tuple[str, str], title: str = "") -> Figure:
    """Where a region's equilibria depend on the robot's history: the region's tips ``tips`` (M, 3) [m] in the
    samples' colour, the checked ones ``checked`` (K, 3) [m], and where the other history reaches another
    equilibrium (``distinct`` (K,) of bool) both tips joined by a line, ``other`` (K, 3) [m] the other
    history's. ``labels`` name the two histories (the region's, the other). Three projections (xz, yz, xy),
    whose axes hold every point drawn and the base. Returns the figure."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2), layout="constrained")
    same = ~distinct
    drawn = np.vstack([np.zeros((1, 3)), *(np.asarray(p, dtype=float).reshape(-1, 3) for p in (tips, checked, other))])
    drawn = drawn[np.all(np.isfinite(drawn), axis=1)]
    pad = 0.05 * float(np.ptp(drawn, axis=0).max()) + 1e-3
    lo, hi = drawn.min(axis=0) - pad, drawn.max(axis=0) + pad
    for ax, (u, v, name) in zip(axes, ((0, 2, "xz"), (1, 2, "yz"), (0, 1, "xy")), strict=True):
        ax.scatter(tips[:, u], tips[:, v], s=2, color=PALETTE.samples, label="region's tips", rasterized=True)
        ax.scatter(checked[same, u], checked[same, v], s=9, color=PALETTE.region_edge,
                   label="checked: the same equilibrium")
        for a, b in zip(checked[distinct], other[distinct], strict=True):
            ax.plot([a[u], b[u]], [a[v], b[v]], color=PALETTE.warning, linewidth=0.6)
        ax.scatter(checked[distinct, u], checked[distinct, v], s=16, color=PALETTE.warning,
                   label=f"another equilibrium: {labels[0]}")
        ax.scatter(other[distinct, u], other[distinct, v], s=16, facecolors="none", edgecolors=PALETTE.warning,
                   label=f"... and {labels[1]}")
        ax.set_title(f"{name} projection")
        ax.set_aspect("equal")
        ax.set_xlim(lo[u], hi[u])
        ax.set_ylim(lo[v], hi[v])
        ax.set_xlabel("xyz"[u] + " [m]")
        ax.set_ylabel("xyz"[v] + " [m]")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=4, fontsize=9)
    if title:
        fig.suptitle(title)
    return fig


#: the opacity of a region's fill in a slice (and of its legend entry)
_FILL_ALPHA = 0.35


def _slice_cells(ax: Axes, region: Region, axis: int, at: float, colour: str, style: str) -> None:
    """The voxels of ``region`` in the plane ``coordinate[axis] = at``: filled (translucent) and outlined along
    the edges between an occupied and an empty voxel."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import ListedColormap

    i = int(np.floor((at - region.origin[axis]) / region.voxel))
    if not (0 <= i < region.occupied.shape[axis]):
        return
    plane = np.take(region.occupied, i, axis=axis)
    if not plane.any():
        return
    keep = [a for a in range(3) if a != axis]
    h = region.voxel
    u = region.origin[keep[0]] + np.arange(plane.shape[0] + 1) * h
    v = region.origin[keep[1]] + np.arange(plane.shape[1] + 1) * h
    ax.pcolormesh(u, v, np.ma.masked_where(~plane.T, np.ones(plane.T.shape)), cmap=ListedColormap([colour]),
                  alpha=_FILL_ALPHA, shading="flat", rasterized=True, linewidth=0)
    padded = np.pad(plane, 1)
    segments = []
    for du, dv in ((1, 0), (0, 1)):  # edges where a voxel and its neighbour along u (then v) differ
        diff = padded[du:, dv:] != padded[:padded.shape[0] - du, :padded.shape[1] - dv]
        for a, b in np.argwhere(diff):
            if du:  # between (a - 1, b - 1) and (a, b - 1): an edge at u[a] from v[b - 1] to v[b]
                if 1 <= b <= plane.shape[1]:
                    segments.append([(u[a], v[b - 1]), (u[a], v[b])])
            elif 1 <= a <= plane.shape[0]:
                segments.append([(u[a - 1], v[b]), (u[a], v[b])])
    ax.add_collection(LineCollection(segments, colors=[colour], linewidths=1.2, linestyles=style),
                      autolim=False)


def _decimated(mesh: Trimesh, faces: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and at most ``faces`` faces of a trimesh mesh (every k-th face: a drawing aid, not geometry)."""
    f = np.asarray(mesh.faces)
    step = max(1, int(np.ceil(f.shape[0] / max(faces, 1))))
    return np.asarray(mesh.vertices), f[::step]


def plot_region_3d(meshes: Mapping[str, Trimesh | None], robot_positions: np.ndarray | None = None, title: str = "",
                   max_faces: int = 12_000, note: str = "") -> Figure:
    """Workspace boundaries (``trimesh.Trimesh``, base frame, metres) as translucent surfaces, one colour each
    (:func:`region_colours`), overlaid; the robot's disk centres ``robot_positions`` (N+1, 3) [m] as a line
    with markers (its largest-reach configuration, say) and the base plane's outline. Big meshes are thinned to
    ``max_faces`` faces for the drawing; the regions after the first (e.g. the realisable part, inside it) are
    drawn more opaque and over it, so that their colour is not blended with the first's. Each legend entry has
    its surface's colour and opacity; ``note`` (e.g. that the run did not converge) is written under the title,
    both in the warning colour. Returns the figure."""
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = pyplot().figure(figsize=(7.5, 7.4), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False  # drawn in order (first region, those inside it, the robot): each keeps its colour
    colours, handles, pts = region_colours(list(meshes)), [], [np.zeros((1, 3))]
    for k, (label, mesh) in enumerate(meshes.items()):
        if mesh is None or len(mesh.faces) == 0:
            continue
        v, f = _decimated(mesh, max_faces // max(len(meshes), 1))
        face = to_rgba(colours[k], 0.12 if k == 0 else 0.5)
        ax.add_collection3d(Poly3DCollection(v[f], facecolors=[face], edgecolors="none", shade=False, zorder=k + 1))
        handles.append(Patch(facecolor=face, edgecolor=colours[k], label=label))
        pts.append(v)
    if robot_positions is not None:
        p = np.asarray(robot_positions)
        ax.plot(p[:, 0], p[:, 1], p[:, 2], "-o", color=PALETTE.backbone, markersize=3, linewidth=2, zorder=10)
        handles.append(Line2D([], [], color=PALETTE.backbone, marker="o", markersize=3, linewidth=2,
                              label="robot at the largest reach"))
        pts.append(p)
    allp = np.vstack(pts)
    r = float(np.abs(allp[:, :2]).max()) if allp.size else 0.1
    ring = np.linspace(0, 2 * np.pi, 90)
    outline = np.column_stack([r * np.cos(ring), r * np.sin(ring), 0 * ring])
    ax.plot(*outline.T, color=PALETTE.disks, linewidth=0.8, linestyle=":")
    set_equal_aspect(ax, np.vstack([allp, outline]))  # the limits hold the base plane's outline too
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.view_init(elev=18, azim=-60)
    if handles:
        ax.figure.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 3), fontsize=8)
    _note(fig, title, note)
    return ax.figure


def _wrapped_triangulation(az: np.ndarray, el: np.ndarray, h: np.ndarray):
    """A triangulation of the map's values ``h`` at azimuths ``az`` and elevations ``el`` [deg] that covers the
    map up to its seam at ±180 deg and not past it: ``h`` on the seam is interpolated linearly across it (from
    copies of the points shifted by a full turn) and added at -180 and +180 deg. Returns (triangulation, values)
    as ``tricontourf`` takes them."""
    import matplotlib.tri as mtri

    az3, el3, h3 = np.concatenate([az - 360, az, az + 360]), np.tile(el, 3), np.tile(h, 3)
    seam_el = np.unique(np.concatenate([el, [-90.0, 90.0]]))
    seam_h = np.ma.filled(mtri.LinearTriInterpolator(mtri.Triangulation(az3, el3), h3)(
        np.full_like(seam_el, 180.0), seam_el), np.nan)
    keep = np.isfinite(seam_h)
    inside = np.abs(az) < 180.0
    a = np.concatenate([az[inside], np.full(keep.sum(), -180.0), np.full(keep.sum(), 180.0)])
    e = np.concatenate([el[inside], seam_el[keep], seam_el[keep]])
    return mtri.Triangulation(a, e), np.concatenate([h[inside], seam_h[keep], seam_h[keep]])


def plot_support_map(directions: np.ndarray, h: np.ndarray, title: str = "") -> Figure:
    """The support function h(d) [m] over the sphere of directions ``directions`` (K, 3): azimuth against
    elevation [deg], filled contours in mm (the map wraps at ±180 deg), the directions as dots; directions too
    few to contour (one, or all on one parallel) are drawn as coloured dots. Returns the figure."""
    plt = pyplot()
    d = np.asarray(directions, dtype=float)
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    el = np.degrees(np.arcsin(np.clip(d[:, 2], -1, 1)))
    hm = np.asarray(h, dtype=float) * 1e3
    fig, ax = plt.subplots(figsize=(9, 4.6))
    spread = np.unique(np.round(el, 9)).size > 1 and np.ptp(hm) > 0 if hm.size else False
    try:  # contours need directions that span an area of the sphere and an h(d) that varies
        if not spread:
            raise ValueError("too few directions to contour")
        cs = ax.tricontourf(*_wrapped_triangulation(az, el, hm), levels=14, cmap="viridis")
        ax.plot(az, el, ".", color="white", markersize=2.5)
    except (ValueError, RuntimeError):  # one direction, a great circle, or a constant h: the directions alone
        cs = ax.scatter(az, el, c=hm, cmap="viridis", s=60, edgecolors="black")
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_xticks(range(-180, 181, 45))
    ax.set_yticks(range(-90, 91, 30))
    ax.set_xlabel("azimuth of d [deg] (from +x towards +y)")
    ax.set_ylabel("elevation of d [deg] (towards +z)")
    fig.colorbar(cs, ax=ax, label="h(d) = max d · tip [mm]")
    if title:
        ax.set_title(title)
    return fig


def write_region_html(path: str | Path, meshes: Mapping[str, Trimesh | None],
                      points: dict[str, np.ndarray] | None = None, robot_positions: np.ndarray | None = None,
                      title: str = "", max_points: int = 20_000) -> None:
    """A self-contained interactive view (plotly, its script embedded: it opens with no network) of workspace
    boundaries (``trimesh.Trimesh`` [m]), point clouds (K, 3) [m] (every k-th point beyond ``max_points``) and
    the robot's disk centres (N+1, 3) [m]; written whole or not at all."""

    import plotly.graph_objects as go

    traces = []
    colours = region_colours(list(meshes))
    for k, (label, mesh) in enumerate(meshes.items()):
        if mesh is None or len(mesh.faces) == 0:
            continue
        v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        traces.append(go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2], i=f[:, 0], j=f[:, 1], k=f[:, 2], name=label,
                                opacity=0.3, color=colours[k % len(colours)], showlegend=True))
    for label, p in (points or {}).items():
        p = np.asarray(p, dtype=float)
        p = p[np.all(np.isfinite(p), axis=1)]
        p = p[:: max(1, int(np.ceil(p.shape[0] / max_points)))]
        traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", name=label,
                                   marker={"size": 1.5, "color": PALETTE.samples}, visible="legendonly"))
    if robot_positions is not None:
        r = np.asarray(robot_positions)
        traces.append(go.Scatter3d(x=r[:, 0], y=r[:, 1], z=r[:, 2], mode="lines+markers", name="robot",
                                   line={"color": PALETTE.backbone, "width": 6},
                                   marker={"size": 3, "color": PALETTE.backbone}))
    fig = go.Figure(traces)
    fig.update_layout(title=title, scene={"aspectmode": "data", "xaxis_title": "x [m]", "yaxis_title": "y [m]",
                                          "zaxis_title": "z [m]"}, legend={"itemsizing": "constant"})
    atomic_write(path, lambda tmp: fig.write_html(tmp, include_plotlyjs=True, full_html=True))

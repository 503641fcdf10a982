"""Figures fit for a paper (issue 50, item 2): what a test can check of every figure a command draws.

- the data inside the axes: every point, line, cell and bar drawn in data coordinates lies within the axis
  limits (a region cut at the bottom of a panel fails);
- the legend's colours are the drawn colours: each legend entry's colour is the colour of an artist drawn in
  the figure (a legend saying orange over a grey surface fails);
- labels in words: no code name (an identifier with an underscore, e.g. ``realisable_volume``) in a title, an
  axis label, a colour bar's label or a legend entry (names in quotes, a robot's or a study's, are the user's);
- error bars on measured volumes: an axis that draws a volume draws its error bars.

Each check is shown to catch a figure broken on purpose; the figures of the plotting functions are checked on
small synthetic inputs, and (marked slow) those of the commands at small settings.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import Collection, LineCollection, PathCollection, QuadMesh
from matplotlib.colors import to_rgb
from matplotlib.container import ErrorbarContainer
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

ROOT = Path(__file__).resolve().parents[1]
WRENCH = ["--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1"]
#: an identifier with an underscore (``realisable_volume``, ``fraction_converged``): a code name
CODE_NAME = re.compile(r"\b[A-Za-z][A-Za-z0-9]*_[A-Za-z0-9_]*[A-Za-z0-9]\b")


# --- the checks ---------------------------------------------------------------------------------------------

def _plot_axes(fig) -> list:
    """The figure's axes that draw data (colour bars' axes left out)."""
    bars = {id(cb.ax) for ax in fig.axes for cb in [getattr(ax, "_colorbar", None)] if cb is not None}
    return [ax for ax in fig.axes if id(ax) not in bars and ax.get_label() != "<colorbar>"]


def _points(artist) -> np.ndarray:
    """The data-coordinate points (K, 2) of a 2D artist, or (K, 3) of a 3D one; (0, 2) for none."""
    if hasattr(artist, "get_data_3d"):
        return np.column_stack([np.ravel(a) for a in artist.get_data_3d()]).astype(float)
    if hasattr(artist, "_offsets3d"):
        return np.column_stack([np.ravel(a) for a in artist._offsets3d]).astype(float)
    if isinstance(artist, Line2D):
        return np.column_stack([np.asarray(artist.get_xdata(), dtype=float),
                                np.asarray(artist.get_ydata(), dtype=float)])
    if isinstance(artist, QuadMesh):
        c = artist.get_coordinates()
        a = artist.get_array()
        mask = np.ma.getmaskarray(a).reshape(c.shape[0] - 1, c.shape[1] - 1)
        cells = [c[i:i + 2, j:j + 2].reshape(-1, 2) for i, j in np.argwhere(~mask)]
        return np.vstack(cells) if cells else np.zeros((0, 2))
    if isinstance(artist, LineCollection):
        segs = artist.get_segments()
        return np.vstack(segs) if segs else np.zeros((0, 2))
    if isinstance(artist, PathCollection):
        return np.asarray(artist.get_offsets(), dtype=float).reshape(-1, 2)
    if isinstance(artist, Collection) and not hasattr(artist, "do_3d_projection"):  # contours, fills
        paths = [p.vertices for p in artist.get_paths() if len(p.vertices)]
        return np.vstack(paths) if paths else np.zeros((0, 2))
    return np.zeros((0, 2))


def data_outside(fig) -> list[str]:
    """The artists of ``fig`` with a point drawn in data coordinates outside their axis limits."""
    bad = []
    for ax in _plot_axes(fig):
        is3d = hasattr(ax, "get_zlim")
        limits = [ax.get_xlim(), ax.get_ylim(), *([ax.get_zlim()] if is3d else [])]
        for artist in [*ax.lines, *ax.collections]:
            if not artist.get_visible() or (not is3d and artist.get_transform() != ax.transData):
                continue
            p = _points(artist)
            if p.size == 0 or p.shape[1] != len(limits):
                continue
            p = p[np.all(np.isfinite(p), axis=1)]
            for k, (lo, hi) in enumerate(limits):
                lo, hi = min(lo, hi), max(lo, hi)
                tol = 1e-6 * (hi - lo)
                if p.size and (p[:, k].min() < lo - tol or p[:, k].max() > hi + tol):
                    bad.append(f"{ax.get_title() or ax.get_xlabel()}: {type(artist).__name__} "
                               f"'{artist.get_label()}' leaves the {'xyz'[k]} limits ({lo:.3g}, {hi:.3g})")
                    break
    return bad


def _rgb(colour) -> tuple[float, ...]:
    return tuple(round(float(c), 3) for c in to_rgb(colour))


def _artist_colours(artist) -> set[tuple[float, ...]]:
    """The RGB colours an artist draws with (alpha left out)."""
    out: set[tuple[float, ...]] = set()
    if isinstance(artist, Line2D):
        for c in (artist.get_color(), artist.get_markerfacecolor(), artist.get_markeredgecolor()):
            if not (isinstance(c, str) and c == "none"):
                out.add(_rgb(c))
    elif isinstance(artist, Patch):
        out |= {_rgb(artist.get_facecolor()), _rgb(artist.get_edgecolor())}
    elif isinstance(artist, QuadMesh):
        out |= {_rgb(c) for c in artist.cmap(np.linspace(0, 1, 2))}
    elif isinstance(artist, Collection):
        for c in (*artist.get_facecolors(), *artist.get_edgecolors()):
            out.add(_rgb(c))
    return out


def _handle_colour(handle) -> tuple[float, ...] | None:
    if isinstance(handle, Line2D):
        c = handle.get_color()
        return _rgb(handle.get_markeredgecolor() if handle.get_linestyle() == "None" and c == "none" else c)
    if isinstance(handle, Patch):
        return _rgb(handle.get_facecolor())
    if isinstance(handle, Collection):
        fc = handle.get_facecolors()
        return _rgb(fc[0] if len(fc) else handle.get_edgecolors()[0])
    return None


def legend_mismatches(fig) -> list[str]:
    """Legend entries of ``fig`` whose colour is no drawn artist's colour (entries of an empty region aside)."""
    drawn: set[tuple[float, ...]] = set()
    for ax in _plot_axes(fig):
        for artist in [*ax.lines, *ax.collections, *ax.patches]:
            drawn |= _artist_colours(artist)
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend() is not None)]
    bad = []
    for legend in legends:
        for handle, text in zip(legend.legend_handles, legend.get_texts(), strict=False):
            colour = _handle_colour(handle)
            if colour is None or text.get_text().endswith("(empty)"):
                continue
            if colour not in drawn:
                bad.append(f"legend entry '{text.get_text()}' has the colour {colour}, drawn nowhere")
    return bad


def texts(fig) -> list[str]:
    """The figure's words: titles, axis and colour-bar labels, legend entries and titles, figure texts."""
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for ax in fig.axes:
        out += [ax.get_title(loc) for loc in ("left", "center", "right")]
        out += [ax.get_xlabel(), ax.get_ylabel(), *([ax.get_zlabel()] if hasattr(ax, "get_zlabel") else [])]
        out += [t.get_text() for t in ax.texts]
    for legend in [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend() is not None)]:
        out += [t.get_text() for t in legend.get_texts()] + [legend.get_title().get_text()]
    return [t for t in out if t]


def code_names(fig) -> list[str]:
    """Code names in the figure's words (quoted names and TeX math left out)."""
    found = []
    for t in texts(fig):
        plain = re.sub(r"'[^']*'|\$[^$]*\$", "", t)
        found += [f"{m!r} in {t!r}" for m in CODE_NAME.findall(plain)]
    return found


def volumes_without_errors(fig) -> list[str]:
    """Axes drawing a volume (an axis label naming one) with no error bars."""
    bad = []
    for ax in _plot_axes(fig):
        if "volume" in (ax.get_xlabel() + ax.get_ylabel()).lower():
            bars = [c for c in ax.containers if (isinstance(c, ErrorbarContainer) and c.has_yerr) or
                    (isinstance(c, ErrorbarContainer) and c.has_xerr)]
            if not bars:
                bad.append(f"{ax.get_ylabel()!r} against {ax.get_xlabel()!r}: no error bars")
    return bad


def problems(fig) -> list[str]:
    """Every check's findings on ``fig``."""
    return [*data_outside(fig), *legend_mismatches(fig), *code_names(fig), *volumes_without_errors(fig)]


# --- the checks catch a broken figure ------------------------------------------------------------------------

def test_data_cut_by_the_limits_is_caught():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="a line")
    assert data_outside(fig) == []
    ax.set_ylim(0.2, 1.0)  # the panel cut at the bottom, as the slices' xz panel was
    assert data_outside(fig)
    plt.close(fig)


def test_a_legend_in_another_colour_is_caught():
    fig, ax = plt.subplots()
    ax.fill_between([0, 1], [0, 1], color="0.6")
    ax.legend(handles=[Patch(facecolor="#ff7f0e", label="realisable")])  # says orange, draws grey
    assert legend_mismatches(fig)
    ax.get_legend().remove()
    ax.legend(handles=[Patch(facecolor="0.6", label="realisable")])
    assert legend_mismatches(fig) == []
    plt.close(fig)


def test_a_code_name_in_a_label_is_caught():
    fig, ax = plt.subplots()
    ax.set_ylabel("realisable_volume [cm³]")
    assert code_names(fig)
    ax.set_ylabel("realisable volume [cm³]")
    ax.set_title("design study 'small_study'")  # a name the user gave, quoted
    assert code_names(fig) == []
    plt.close(fig)


def test_a_volume_without_error_bars_is_caught():
    fig, ax = plt.subplots()
    ax.scatter([1, 2], [3, 4])
    ax.set_ylabel("FSW volume [cm³]")
    assert volumes_without_errors(fig)
    ax.errorbar([1, 2], [3, 4], yerr=[0.5, 0.5], fmt="none")
    assert volumes_without_errors(fig) == []
    plt.close(fig)


# --- the plotting functions on synthetic inputs --------------------------------------------------------------

def _region(centre, size, voxel=0.01, thin=False):
    from pytdcr.workspace import Region

    n = np.array([20, 20, 30])
    origin = np.asarray(centre, dtype=float) - n * voxel / 2
    g = np.indices(n).transpose(1, 2, 3, 0) * voxel + origin + voxel / 2
    occupied = np.linalg.norm((g - centre) / np.asarray(size), axis=-1) < 1.0
    if thin:  # a shell one voxel thick: the no-load region's slices are scattered voxels
        occupied &= np.linalg.norm((g - centre) / np.asarray(size), axis=-1) > 0.85
    return Region(origin, voxel, occupied, 0, int(occupied.sum()))


def test_slices_hold_the_regions_and_say_unconverged():
    from pytdcr.palette import PALETTE
    from pytdcr.plotting import plot_region_slices

    regions = {"FSW": _region((0.02, 0.0, -0.05), (0.09, 0.08, 0.14)),  # reaches below z = -0.18 m
               "realisable": _region((0.02, 0.0, 0.0), (0.05, 0.05, 0.08)),
               "no load": _region((0.0, 0.0, 0.05), (0.08, 0.08, 0.1), thin=True)}
    fig = plot_region_slices(regions, 0.2, "robot 'paper' (pcc): workspace slices", "not converged")
    assert problems(fig) == []
    assert fig.axes[0].get_ylim()[0] < -0.18
    assert fig._suptitle.get_color() == PALETTE.warning
    plt.close(fig)


def test_boundary_3d_legend_is_its_surfaces_colours():
    from pytdcr.plotting import plot_region_3d

    regions = {"FSW": _region((0.02, 0.0, 0.05), (0.09, 0.08, 0.1)),
               "realisable": _region((0.02, 0.0, 0.05), (0.05, 0.05, 0.06))}
    pose = np.column_stack([np.zeros(5), np.zeros(5), np.linspace(0, 0.2, 5)])
    fig = plot_region_3d({k: r.mesh() for k, r in regions.items()}, pose, "robot 'paper': FSW boundary")
    assert problems(fig) == []
    plt.close(fig)


def test_multistability_reach_below_the_base():
    from pytdcr.plotting import plot_multistability

    rng = np.random.default_rng(1)
    tips = rng.normal(0, 0.1, (200, 3)) - [0, 0, 0.15]  # low tips, as a loaded robot's
    checked, other = tips[:10], tips[10:20] + 0.01
    fig = plot_multistability(tips, checked, other, np.arange(10) % 2 == 0, 0.2, ("continuation", "loading path"))
    assert problems(fig) == []
    plt.close(fig)


def test_samples_convergence_and_order():
    from pytdcr.accuracy import OrderStudy
    from pytdcr.plotting import plot_convergence, plot_order, plot_reach_samples

    reach = np.linspace(0.1, 0.2, 30)
    ok = np.arange(30) % 7 != 0
    for ax in (plot_reach_samples(reach, ok), plot_convergence([5.0, 4.5, 4.4], [6.0, 5.0, 4.6]),
               plot_order([OrderStudy((2, 4, 8), np.array([0.02, 0.01, 0.005]),
                                      {"pcc": np.array([3.0, 1.5, 0.7]), "pcc2": np.array([1.0, 0.3, 0.1])},
                                      {"pcc": 1.0, "pcc2": 1.7}, "tensions", 5)])):
        assert problems(ax.figure) == []
        plt.close(ax.figure)


def test_configurations_coloured_by_reach():
    from pytdcr import paper_loads, paper_robot, solve
    from pytdcr.plotting import plot_robots

    robot = paper_robot()
    sols = [solve(robot, paper_loads(np.array(t, dtype=float)))
            for t in ([3, 0, 0, 0, 1, 0, 0, 0], [0, 4, 0, 0, 0, 2, 0, 0])]
    ax = plot_robots(robot, sols)
    assert problems(ax.figure) == []
    assert any(a.get_label() == "<colorbar>" for a in ax.figure.axes)
    plt.close(ax.figure)


# --- every command's figures ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def command_figures(tmp_path_factory):
    """Every figure the commands draw at small settings, by command and file stem, kept open: ``plt.close``
    is held while they run (the figures are saved as usual)."""
    from pytdcr.cli import main

    tmp = tmp_path_factory.mktemp("figures")
    runs = {
        "solve": ["solve", "--tensions", "4,0,0,0,2,0,0,0", *WRENCH, "--plot", str(tmp / "solve" / "robot.png")],
        "sample": ["sample", "--n", "40", "--seed", "3", *WRENCH, "--out", str(tmp / "sample")],
        "optimize": ["optimize", "--pop", "10", "--max-gen", "2", "--seed", "1", *WRENCH, "--out",
                     str(tmp / "optimize")],
        "workspace": ["workspace", "--n", "80", "--seed", "5", "--directions", "4", "--budget", "400", *WRENCH,
                      "--multistability", "10", "--out", str(tmp / "workspace")],
        "compare": ["compare", "--n", "4", "--seed", "2", "--models", "pcc,pcc2", "--out", str(tmp / "compare")],
        "designs": ["designs", str(ROOT / "examples" / "design_study_small.toml"), "--workers", "1", "--out",
                    str(tmp / "designs")],
    }
    held: dict[str, list] = {}
    close = plt.close
    current = [""]

    def hold(fig=None):
        if fig is not None and not isinstance(fig, str):
            held.setdefault(current[0], []).append(fig)
        else:  # pragma: no cover - the commands close the figures they made
            close(fig)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plt, "close", hold)
        for name, args in runs.items():
            current[0] = name
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                assert main(args) in (0, 1), name
    yield held
    for figs in held.values():
        for fig in figs:
            close(fig)


@pytest.mark.slow
def test_every_command_draws_figures(command_figures):
    assert set(command_figures) == {"solve", "sample", "optimize", "workspace", "compare", "designs"}


@pytest.mark.slow
@pytest.mark.parametrize("command", ["solve", "sample", "optimize", "workspace", "compare", "designs"])
def test_command_figures_fit_for_a_paper(command_figures, command):
    found = {}
    for fig in command_figures.get(command, []):
        title = fig._suptitle.get_text() if fig._suptitle is not None else fig.axes[0].get_title()
        if p := problems(fig):
            found[title] = p
    assert not found, found


@pytest.mark.slow
def test_design_measures_draw_volume_errors(command_figures):
    measures = [f for f in command_figures["designs"]
                if f._suptitle is not None and "each measure" in f._suptitle.get_text()]
    assert len(measures) == 1
    volume_axes = [ax for ax in measures[0].axes if "volume" in ax.get_ylabel()]
    assert volume_axes and all(any(isinstance(c, ErrorbarContainer) for c in ax.containers) for ax in volume_axes)

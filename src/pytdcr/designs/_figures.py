"""A study's figures: the Pareto front of its objectives, each measure against each parameter, and the best
designs drawn at the tensions that reach farthest. matplotlib is loaded when a figure is made."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..palette import PALETTE
from ..plotting import RobotStyle, drawn_points, plot_robot, pyplot, save_figure, set_equal_aspect
from ..robot import Robot
from ._optimize import measures_nothing
from ._records import DesignRecord
from ._spec import DesignStudy

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["write_design_figures"]

#: the measures drawn against the parameters (h along the study's directions are added)
DRAWN = ("volume_m3", "realisable_volume_m3", "largest_reach_m", "peak_stress_pa", "fraction_converged")
#: how a measure is shown: (factor, unit)
_UNITS = {"m3": (1e6, "cm³"), "m": (1e3, "mm"), "pa": (1e-6, "MPa"), "converged": (100.0, "%"),
          "realisable": (100.0, "%")}
#: a measure's name in words (h along a named direction: :func:`_words`)
_WORDS = {"volume_m3": "FSW volume", "realisable_volume_m3": "realisable volume", "largest_reach_m": "largest reach",
          "peak_stress_pa": "peak bending stress", "fraction_converged": "samples converged",
          "fraction_realisable": "converged samples realisable", "arc_length_m": "robot length"}
#: a parameter's unit as drawn: (factor from the parameter's unit, unit shown)
_PARAM_UNITS = {"m": (1e3, "mm"), "Pa": (1e-9, "GPa"), "deg": (1.0, "deg"), "": (1.0, "")}


def _scale(measure: str) -> tuple[float, str]:
    return _UNITS.get(measure.rsplit("_", 1)[-1], (1.0, ""))


def _words(measure: str) -> str:
    """A measure's name in words: ``h_<name>_m`` is the support value h(d) along the study's direction ``name``."""
    if measure in _WORDS:
        return _WORDS[measure]
    if measure.startswith("h_") and measure.endswith("_m"):
        return f"h(d) along {measure[2:-2].replace('_', ' ')}"
    return measure.replace("_", " ")


def _label(measure: str, case: str | None = None) -> str:
    unit = _scale(measure)[1]
    text = f"{_words(measure)} [{unit}]" if unit else _words(measure)
    return text + (f"\n({case})" if case else "")


def _error(measure: str) -> str | None:
    """The column of a measure's error (only the volumes have one)."""
    return measure.replace("_m3", "_err_m3") if measure.endswith("volume_m3") else None


def _parameter_axis(name: str) -> tuple[float, str]:
    """A design parameter's factor to its drawn unit and its axis label in words (e.g. ``routing_radius_1``:
    1000, "routing radius, segment 1 [mm]")."""
    from ._space import parameter_info

    try:
        info = parameter_info(name)
    except ValueError:  # pragma: no cover - a study's parameters are validated when it is read
        return 1.0, name.replace("_", " ")
    factor, unit = _PARAM_UNITS.get(info.unit, (1.0, info.unit))
    text = info.base.replace("_", " ") + (f", segment {info.segment}" if info.segment is not None else "")
    if info.base == "disks":
        text = "disks per segment" + (f" (segment {info.segment})" if info.segment is not None else "")
    return factor, text + (f" [{unit}]" if unit else "")


def _objective_values(study: DesignStudy, table: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """One row per design (the reference included): the objectives' values in display units."""
    cols = []
    wide = table[["design", "generation", "pareto", "status"]].drop_duplicates("design").set_index("design")
    for o in study.objectives:
        case = study.objective_case(o)
        sub = table[table["load_case"] == case].set_index("design")[o.measure]
        name = f"{o.goal} {_label(o.measure, case)}"
        wide[name] = sub * _scale(o.measure)[0]
        err = _error(o.measure)
        wide[f"{name} error"] = (table[table["load_case"] == case].set_index("design")[err] * _scale(o.measure)[0]
                                 if err is not None and err in table else np.nan)
        cols.append(name)
    return wide, cols


def _pareto_figure(study: DesignStudy, table: pd.DataFrame) -> Figure:
    plt = pyplot()
    wide, cols = _objective_values(study, table)
    ok = wide[(wide["status"] == "ok") & (wide.index >= 0)]
    pairs = list(itertools.combinations(range(len(cols)), 2))[:6] or [(0, 0)]
    fig, axes = plt.subplots(1, len(pairs), figsize=(4.6 * len(pairs), 4.0), squeeze=False, layout="constrained")
    by_generation = study.designs.method == "optimize"
    for ax, (i, j) in zip(axes[0], pairs, strict=True):
        x = ok[cols[i]] if i != j else ok.index.to_series()
        y = ok[cols[j]]
        colour = {"c": ok["generation"], "cmap": "viridis"} if by_generation else {"color": PALETTE.samples}
        sc = ax.scatter(x, y, s=14, label="designs", zorder=2, **colour)
        xerr = ok[f"{cols[i]} error"].to_numpy() if i != j else None
        ax.errorbar(x, y, xerr=xerr, yerr=ok[f"{cols[j]} error"].to_numpy(), fmt="none", ecolor=PALETTE.samples,
                    elinewidth=0.8, zorder=1)
        front = ok[ok["pareto"]]
        fx = front[cols[i]] if i != j else front.index.to_series()
        order = np.argsort(fx.to_numpy())
        ax.plot(fx.to_numpy()[order], front[cols[j]].to_numpy()[order], "o-", color=PALETTE.fit, ms=5, lw=1,
                label="Pareto front", zorder=3)
        if -1 in wide.index and wide.loc[-1, "status"] == "ok":
            rx = wide.loc[-1, cols[i]] if i != j else -1
            ax.plot(rx, wide.loc[-1, cols[j]], "*", color=PALETTE.backbone, ms=14, label=f"base robot '{study.robot}'",
                    zorder=4)
        ax.set_xlabel(cols[i] if i != j else "design number")
        ax.set_ylabel(cols[j])
        ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=8)
    if by_generation:
        bar = fig.colorbar(sc, ax=axes[0].tolist(), label="generation")
        from matplotlib.ticker import MaxNLocator

        bar.ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(f"Design study '{study.name}': objectives and Pareto front")
    return fig


def _measures_figure(study: DesignStudy, table: pd.DataFrame) -> Figure:
    plt = pyplot()
    params = list(study.parameters)
    measures = [*DRAWN, *[f"h_{k}_m" for k in study.measures.directions]]
    fig, axes = plt.subplots(len(measures), len(params), figsize=(2.9 * len(params) + 0.8, 2.3 * len(measures)),
                             squeeze=False, sharex="col", sharey="row", layout="constrained")
    ok = table[table["status"] == "ok"]
    cases = list(dict.fromkeys(ok["load_case"]))
    for (r, m), (c, p) in itertools.product(enumerate(measures), enumerate(params)):
        ax = axes[r][c]
        factor, (pf, plabel) = _scale(m)[0], _parameter_axis(p)
        err = _error(m)
        for k, case in enumerate(cases):
            sub = ok[(ok["load_case"] == case) & (ok["design"] >= 0)]
            yerr = sub[err].to_numpy() * factor if err is not None and err in sub else None
            ax.errorbar(sub[p] * pf, sub[m] * factor, yerr=yerr, fmt="o", ms=3, color=PALETTE.nth(k), alpha=0.8,
                        elinewidth=0.8, capsize=1.5, label=case)
            ref = ok[(ok["load_case"] == case) & (ok["design"] == -1)]
            if not ref.empty:
                y0 = float(ref[m].iloc[0]) * factor
                ax.axhline(y0, color=PALETTE.nth(k), ls="--", lw=0.8)
                if err is not None and err in ref:  # the base robot's volume error: a band about its line
                    e = float(ref[err].iloc[0]) * factor
                    ax.axhspan(y0 - e, y0 + e, color=PALETTE.nth(k), alpha=0.1, lw=0)
        if r == len(measures) - 1:
            ax.set_xlabel(plabel)
        if c == 0:
            ax.set_ylabel(_label(m))
        ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 4), fontsize=8,
               title="load case (dashed: base robot; bars and band: volume error)", title_fontsize=8)
    fig.suptitle(f"Design study '{study.name}': each measure against each parameter")
    return fig


def _picked(study: DesignStudy, table: pd.DataFrame) -> list[int]:
    """The designs drawn: the best for each objective among the Pareto front (at most 3), reference first; none
    for an objective that is 0 for every design (:func:`measures_nothing`: it names no best)."""
    wide, cols = _objective_values(study, table)
    front = wide[wide["pareto"] & (wide.index >= 0)]
    picked = [-1] if -1 in wide.index and wide.loc[-1, "status"] == "ok" else []
    for o, col in zip(study.objectives, cols, strict=True):
        if not front.empty and not measures_nothing(front[col]):
            k = int(front[col].idxmax() if o.goal == "max" else front[col].idxmin())
            if k not in picked:
                picked.append(k)
    return picked[:4]


def _best_figure(study: DesignStudy, robot: Robot, table: pd.DataFrame, records: dict[int, DesignRecord]) -> Figure:
    from ..statics import solve
    from ._space import apply_parameters

    plt = pyplot()
    case = study.objective_case(study.objectives[0])
    picked = _picked(study, table)
    fig = plt.figure(figsize=(4.2 * max(len(picked), 1), 4.6))
    axes, points = [], []
    for n, k in enumerate(picked):
        ax = fig.add_subplot(1, len(picked), n + 1, projection="3d")
        axes.append(ax)
        row = records[k].row(case)
        if row is None:  # pragma: no cover - a picked design is ok, with a row per load case
            continue
        design = apply_parameters(robot, records[k].params)
        case_robot, loads = study.load_cases(design)[case]
        title = "base robot" if k < 0 else f"design {k}"
        t = row.reach_tensions_n
        sol = solve(case_robot, loads.with_tensions(np.asarray(t)), model=study.model) if t is not None else None
        if sol is None or not sol.converged:
            ax.set_title(f"{title}: farthest shape not converged", fontsize=9)
            continue
        if abs(float(np.linalg.norm(sol.tip_position)) - row.largest_reach_m) > 1e-3:
            title += " (re-solved on another branch)"
        plot_robot(case_robot, sol, ax, style=RobotStyle(frames=False, equal=False))
        points.append(drawn_points(ax))  # the disks' rings reach past the backbone
        ax.set_title(f"{title}\nreach {row.largest_reach_m * 1e3:.0f} mm, FSW {row.volume_m3 * 1e6:.0f} cm³",
                     fontsize=9)
    if points:
        allp = np.vstack([*points, np.zeros((1, 3))])
        for ax in axes:
            set_equal_aspect(ax, allp)
    fig.suptitle(f"Farthest-reaching shapes under '{case}' (best designs of the Pareto front)")
    return fig


def write_design_figures(out: Path, study: DesignStudy, robot: Robot, table: pd.DataFrame,
                         records: dict[int, DesignRecord]) -> list[str]:
    """Write ``pareto``, ``measures`` and ``best_designs`` (.png and .pdf) in ``out`` from the study's table
    (:func:`~pytdcr.designs._report.build_table`) and its designs' records (by index); returns the file
    names."""
    names = save_figure(_pareto_figure(study, table), out, "pareto")
    names += save_figure(_measures_figure(study, table), out, "measures")
    names += save_figure(_best_figure(study, robot, table, records), out, "best_designs")
    return names

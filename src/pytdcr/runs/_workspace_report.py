"""The reporting half of ``tdcr workspace`` (:mod:`._workspace` runs it): the files, figures and Markdown a
workspace run writes, made from its typed results alone (:class:`~._workspace.WorkspaceCase`,
:class:`WorkspaceRecord`, :class:`WorkspaceComparison`, :class:`~pytdcr.workspace.WorkspaceSummary`,
:class:`WorkspaceSection`): one case's folder (meshes, ``samples.npz``, ``support.csv``, figures, HTML,
``report.md``, ``workspace.json``), a comparison's (``comparison.md``, ``comparison.json``, overlaid figures),
the warnings' texts and ``tdcr reproduce``'s workspace section's text."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..plotting import (
    plot_multistability,
    plot_region_3d,
    plot_region_slices,
    plot_support_map,
    save_figure,
    write_region_html,
)
from ..records import RunWarning
from ..robot import Robot
from ..runtime import atomic_write, atomic_write_text, write_csv, write_json
from ..statics import feasible_words, solve
from ..validate import measured
from ..workspace import Region, WorkspaceSummary
from ..workspace.parts import BoundarySearch, RegionNumbers, RegionSamples
from ._workspace_records import CaseComparison, FailedCase, PairComparison, WorkspaceComparison, WorkspaceSection

if TYPE_CHECKING:  # the running imports this module; its results are read here, by attribute
    from ._reproduce import ReproduceSettings
    from ._workspace import WorkspaceCase

__all__ = ["format_measure_of", "search_stop_words", "workspace_text"]


def _cell(value: float | None, fmt: str = ".4f", scale: float = 1.0) -> str:
    """A table cell: ``value`` times ``scale`` in ``fmt``, or "—" where there is none (None or NaN)."""
    if value is None or not np.isfinite(value):
        return "—"
    return format(value * scale, fmt)


def _volume_cells(volume_m3: float, error_m3: float) -> str:
    """Two table cells, ``volume | error`` in cm³: the volume only where its error is below it
    (:func:`~pytdcr.validate.measured`; a region without volume, 0 ± 0, shows 0), else "not measured" beside the
    error, so that no table shows as a result a number whose error bar is larger than itself."""
    err = _cell(error_m3, ".0f", 1e6)
    if measured(volume_m3, error_m3) or (volume_m3 == 0.0 and error_m3 == 0.0):
        return f"{_cell(volume_m3, '.0f', 1e6)} | {err}"
    return f"not measured | {err}"


def _ratio_cell(ratio: float | None, *volumes: tuple[float, float]) -> str:
    """A ratio of volumes, shown only where every volume it divides (``(volume, error)`` [m³]) is measured."""
    if all(measured(v, e) for v, e in volumes):
        return _cell(ratio, ".2f")
    return "—"


def format_measure_of(region: RegionNumbers) -> str:
    """A region's measure in words (:meth:`RegionNumbers.measure_words`): its volume with error in cm³, or,
    below three dimensions, what it is and its area or length."""
    return region.measure_words()


def _error_words(growth_m3: float, error_m3: float) -> str:
    """What a budget-stopped region's volume error holds, as the numbers say: mostly the growth the last rounds
    of the boundary search point to, some of it, or none (then the estimators' spread alone)."""
    g, e = round(growth_m3 * 1e6), round(error_m3 * 1e6)
    if g <= 0:
        return "is the estimators' spread alone (the last rounds point to no further growth)"
    if g >= 0.5 * e:
        return f"is mostly the growth the last rounds point to ({g} cm³)"
    return f"holds {g} cm³ of growth the last rounds point to, the rest the estimators' spread"


def search_stop_words(search: BoundarySearch) -> str:
    """Why a boundary search stopped, as it records (``boundary_search`` of ``workspace.json``)."""
    rule = f"{search.tol:.1%} of the voxels"
    if search.stop == "converged":
        return f"converged (its last round added less than {rule})"
    if search.stop == "budget":
        return (f"its budget ({search.solves} solves) ran out before a round added less than {rule}, which "
                "would have meant converged")
    if search.stop == "no boundary left":
        return "no boundary face was left untried (every face of the region's boundary voxels was searched)"
    if search.stop == "rounds":
        return f"its cap of rounds, before a round added less than {rule}"
    return str(search.stop)


def _warnings(summary: WorkspaceSummary) -> list[RunWarning]:
    """One line per region with too few points to mesh (what was not written, and why), and one when the
    boundary search ran out of budget before the region converged (the volume is then a lower bound).
    ``summary`` holds the meshes' names (:meth:`WorkspaceSummary.with_meshes`)."""
    out = []
    root = summary.root
    if root is not None and root not in ("stable", "stability untested"):
        why = ("is not stable at zero tension under this load (an axial load past buckling?)" if root == "unstable"
               else "did not converge at zero tension under this load")
        out.append(RunWarning("root-missing", f"the robot {why}: the root every continued sample is reached from "
                              "is missing, no sample has a stable parent and the region is empty; --equilibria "
                              "loading-path solves each sample from rest"))
    search, fsw, vol = summary.boundary_search, summary.fsw, summary.fsw.volume
    if search is not None and search.stop == "budget" and fsw.points and fsw.dimension == 3:
        why = _error_words(vol.search_m3, vol.error_m3)
        out.append(RunWarning("search-budget", f"the boundary search stopped at its budget ({search.solves} "
                              f"solves) before the region converged: the volume {vol.volume_m3 * 1e6:.0f} cm³ is "
                              f"close to a lower bound and its error (± {vol.error_m3 * 1e6:.0f} cm³) {why}; raise "
                              "--budget for a measurement"))
    for label, d, name in (("FSW", fsw, "fsw.ply"), ("realisable region", summary.realisable,
                                                     "fsw_realisable.ply")):
        if d.dimension < 3 and d.points:
            extents = ", ".join(f"{e:.2g}" for e in (d.volume.dimension.extents_m if d.volume.dimension else ()))
            out.append(RunWarning("low-dimension", f"the {label}'s tips span {d.dimension} dimension"
                                  f"{'s' * (d.dimension != 1)} at the voxel's resolution (extents {extents} m along "
                                  f"their principal axes): it is {format_measure_of(d)}; {name} is not written"))
        elif d.mesh is None:
            plural = "s" * (d.points != 1)
            out.append(RunWarning("too-few-points", f"the {label} holds {d.points} feasible sample{plural} "
                                  f"({feasible_words(summary.stability_test)}), fewer than the "
                                  f"{Region.MIN_MESH_POINTS} a boundary needs: {name} is not written and its "
                                  f"volume is that of the occupied voxels alone"))
    return out


def _save_samples(out: Path, s: RegionSamples) -> None:
    """``samples.npz`` in ``out``, written aside and renamed (a reader never sees half of it)."""
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            extra = {} if s.parent is None else {"parent": s.parent}
            np.savez_compressed(f, tensions=s.tensions, source=s.source, tip=s.tip_position, stage=s.stage,
                                converged=s.converged, stable=s.stable, below_base=s.below_base,
                                disks_touch=s.disks_touch, sources=np.array(RegionSamples.SOURCES), **extra)

    atomic_write(out / "samples.npz", write)


def unfinished_note(cases: Sequence[WorkspaceCase]) -> str:
    """A figure's warning line naming the ``cases`` whose boundary search stopped at its budget before the
    region converged (their regions are unfinished: the drawn region is close to a lower bound); "" for none."""
    short = [c.name for c in cases
             if c.summary.boundary_search is not None and c.summary.boundary_search.stop == "budget"]
    if not short:
        return ""
    what = f" under {', '.join(short)}" if len(cases) > 1 else ""
    return f"not converged{what}: the boundary search stopped at its budget (the region drawn is unfinished)"


def _robot_at(case: WorkspaceCase, robot: Robot) -> np.ndarray | None:
    """Disk centres (N+1, 3) [m] at the reach search's tensions, or None."""
    if case.reach is None:
        return None
    sol = solve(robot, case.loads.with_tensions(np.asarray(case.reach.tensions)), model=case.study.model,
                options=case.study.options)
    return sol.disk_positions if sol.converged else None


def _write_case(out: Path, case: WorkspaceCase, robot: Robot, command: str) -> list[str]:
    """Every file of one case in ``out``: meshes, samples, h(d), figures, HTML, report, JSON."""
    wr, s = case.region, case.region.samples
    files = []
    meshed = {"fsw.ply": case.summary.fsw.mesh is not None,
              "fsw_realisable.ply": case.summary.realisable.mesh is not None}
    for name, reg in (("fsw.ply", wr.fsw_region), ("fsw_realisable.ply", wr.realisable_region)):
        if not meshed[name]:
            continue
        atomic_write(out / name, lambda tmp, reg=reg: reg.mesh().export(tmp, file_type="ply"))
        files.append(name)
    _save_samples(out, s)
    files.append("samples.npz")
    if case.support is not None:
        sf = case.support
        stable = sf.stable if sf.stable is not None else np.full(sf.h.size, np.nan)
        write_csv(out / "support.csv", ["dx", "dy", "dz", "h_m", "tip_x_m", "tip_y_m", "tip_z_m",
                                        *[f"T{k + 1}_N" for k in range(robot.n_tendons)], "stable"],
                  ([*d, h, *tip, *t, "" if not np.isfinite(st) else int(st)]
                   for d, h, tip, t, st in zip(sf.directions, sf.h, sf.tip_position, sf.tensions, stable,
                                               strict=True)))
        files.append("support.csv")
        files += save_figure(plot_support_map(sf.directions, sf.h, f"robot '{robot.name}': h(d), {case.name}"),
                             out, "support_map")
    meshes = {"FSW": wr.fsw_region.mesh() if meshed["fsw.ply"] else None,
              "realisable": wr.realisable_region.mesh() if meshed["fsw_realisable.ply"] else None}
    pose = _robot_at(case, robot)
    files += save_figure(plot_region_slices({"FSW": wr.fsw_region, "realisable": wr.realisable_region},
                                            robot.length, f"robot '{robot.name}' ({case.study.model.name}): "
                                            f"workspace slices, {case.name}", unfinished_note([case])),
                         out, "slices")
    files += save_figure(plot_region_3d(meshes, pose, f"robot '{robot.name}' ({case.study.model.name}): FSW "
                                        f"boundary, {case.name}", note=unfinished_note([case])), out, "boundary_3d")
    ms = wr.multistability
    if ms is not None and ms.checked:
        files += save_figure(plot_multistability(s.tip_position[s.feasible], s.tip_position[ms.rows], ms.other_tip,
                                                 ms.distinct, robot.length, (ms.equilibria, ms.other),
                                                 f"robot '{robot.name}': {int(ms.distinct.sum())} of {ms.checked} "
                                                 f"checked tension vectors hold the robot in two equilibria, "
                                                 f"{case.name}"), out, "multistability")
    write_region_html(out / "workspace.html", meshes, {"feasible tips": s.tip_position[s.feasible]}, pose,
                      f"robot '{robot.name}': feasible static workspace, {case.name}")
    files.append("workspace.html")
    atomic_write_text(out / "report.md", _report(case, robot.name, command))
    write_json(out / "workspace.json", case.record((*files, "report.md", "workspace.json")).to_json())
    return [*files, "report.md", "workspace.json"]


def _report(case: WorkspaceCase, robot_name: str, command: str) -> str:
    """One case's ``report.md``: the regions' table, the notes on the reach, the stability and the equilibria,
    the convergence, the boundary search, the samples and h(d)."""
    summary = case.summary
    f, r, c = summary.fsw, summary.realisable, summary.counts

    def pct(d: RegionNumbers) -> str:
        return f" ({d.volume_err_m3 / d.volume_m3:.0%})" if d.volume_m3 else ""

    lines = [f"# Feasible static workspace of robot '{robot_name}'", "",
             f"Made by `{command}`.", "", *[f"**Warning:** {w}." for w in case.warnings],
             *([""] if case.warnings else []),
             "| region | volume [cm³] | error [cm³] | largest reach [m] | points |", "|---|---|---|---|---|",
             f"| FSW ({feasible_words(summary.stability_test)}) | "
             f"{_volume_cells(f.volume_m3, f.volume_err_m3)}{pct(f)} | "
             f"{_cell(f.largest_reach_m)} | {f.points} |",
             f"| realisable (no disk below the base, no disks touching) | "
             f"{_volume_cells(r.volume_m3, r.volume_err_m3)}{pct(r)} | {_cell(r.largest_reach_m)} | {r.points} |",
             "",
             _reach_note(f, r), "", *_untested_note(summary, case.study.model.name),
             "Convergence with the base samples (FSW): "
             + ", ".join(f"n = {s.n_base}: {s.estimate_m3 * 1e6:.0f} cm³" for s in f.volume.scales)
             + ".", ""]
    search = summary.boundary_search
    if search is not None:
        sizes = ("n/4", "n/2", "n")
        ran = sorted({x.stage for x in search.rounds})
        tail = f.volume.search_m3
        lines[-1:-1] = [f"The boundary search ran at {', '.join(sizes[k] for k in ran) or 'no size'}"
                        + ("" if len(ran) == 3 else " only (its budget ran out): a larger size adds its base "
                           "samples to the smaller sizes' search points, unsearched")
                        + (f". The error includes {tail * 1e6:.0f} cm³ of growth the last rounds point to (the "
                           "budget stopped the search)." if tail else ".")]
        lines += [f"Boundary search: {search.solves} extra solves in {len(search.rounds)} rounds; stopped: "
                  f"{search_stop_words(search)}.", "",
                  "| stage | round | faces tried | solves | FSW voxels | realisable voxels |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {x.stage} | {x.round} | {x.faces} | {x.steps} | {x.voxels} | "
                  f"{x.voxels_realisable} |" for x in search.rounds]
        lines.append("")
    lines += [f"Samples: {c.solved} solved ({c.by_source}), {c.converged} converged, "
              f"{summary.stability_words()}; of the converged, "
              f"{c.fraction_below_base:.1%} have a disk below the base plane, "
              f"{c.fraction_disks_touch:.1%} two disks touching; {c.fraction_realisable:.1%} are realisable.",
              "", _equilibria_note(summary), "",
              "Boundary voxels holding a sample, by source: "
              + ", ".join(f"{k} {v:.0%}" for k, v in summary.boundary_sources.items()) + ".", ""]
    sup = summary.support
    if sup is not None:
        h = sup.h
        lines += [f"Support function over {h.size} directions: h(d) from {h.min() * 1e3:.1f} to {h.max() * 1e3:.1f} mm "
                  "(support.csv, support_map.png).", ""]
    return "\n".join(lines)


def _untested_note(summary: WorkspaceSummary, model: str) -> list[str]:
    """For a run whose ``model`` has no static stability test, what its regions then hold (no line otherwise)."""
    if summary.stability_test != "untested":
        return []
    root = " (its root too)" if summary.root == "stability untested" else ""
    return [f"Stability untested: model '{model}' has no static stability test, so both regions hold every "
            f"converged sample{root} and none is known stable or unstable.", ""]


def _equilibria_note(summary: WorkspaceSummary) -> str:
    """Which equilibria the region holds, how its samples were solved and how often the history mattered."""
    w, ms = summary.warm_start, summary.multistability
    if summary.equilibria == "continuation":
        text = ("Equilibria: each sample continued from a solved parent (the robot's own history of quasi-static "
                "tension changes from rest; samples.npz holds each sample's parent).")
    else:
        text = (f"Equilibria: each sample solved from rest with every load ramped together (the loading path); "
                f"warm starts: {w.mode} ({w.agreed} of {w.checked} checked warm starts agreed with the "
                f"loading path; {w.required:.1%} required).")
    if ms is not None and ms.checked:
        text += (f" Multistability: {ms.distinct} of {ms.checked} checked samples ({ms.fraction:.1%}) reach "
                 f"another equilibrium by the {ms.other} (multistability.png).")
    return text


def _reach_note(fsw: RegionNumbers, real: RegionNumbers) -> str:
    """What each region's largest reach is (``reach_rule``): the realisable region's is a sample, never searched,
    and can be below the FSW's even where the FSW's optimum is realisable."""
    text = f"Largest reach: the FSW's is {fsw.reach_rule}; the realisable region's is {real.reach_rule}"
    fsw_sample = fsw.reach_rule.startswith("the farthest feasible sample")  # then both are samples: compared
    if (fsw.largest_reach_m is not None and real.largest_reach_m is not None and not fsw_sample
            and real.largest_reach_m < fsw.largest_reach_m):
        text += (", so it may be below the FSW's even where the FSW's farthest tip is realisable (whether it is "
                 "was not checked)")
    return text + "."


def _slug(name: str) -> str:
    """A case's name as a folder or file name: lower case, every character but letters and digits ``_``."""
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def _pairs_lines(pairs: Sequence[PairComparison]) -> list[str]:
    """The pairs' table: Hausdorff distance between the boundaries, and the share of each FSW inside the other."""
    def pct(x: float | None) -> str:
        return "—" if x is None else f"{100 * x:.1f} %"

    lines = ["", "How the FSWs differ, pair by pair: the Hausdorff distance between their boundaries (the farthest a "
             "point of either lies from the other, to about half a voxel) and the share of each region's voxels "
             "inside the other's:", "", "| a | b | Hausdorff [mm] | a in b | b in a |", "|---|---|---|---|---|"]
    for p in pairs:
        o = p.overlap
        h = "—" if o.hausdorff_m is None else f"{o.hausdorff_m * 1e3:.0f}"
        lines.append(f"| {p.a} | {p.b} | {h} | {pct(o.a_in_b)} | {pct(o.b_in_a)} |")
    return lines


def _compare_report(rows: Sequence[CaseComparison], cases: Sequence[WorkspaceCase], command: str,
                    pairs: Sequence[PairComparison]) -> str:
    """``comparison.md`` but for the failed cases: a row per case (``rows``), the models and equilibria, the
    pairs' table, the largest reach's rule, a warning for budget-stopped searches and h(d) along the axes."""
    lines = ["# Feasible static workspaces compared", "", f"Made by `{command}`. Each case's folder "
             "holds its own workspace.json, meshes, figures and report.", "",
             "| case | FSW [cm³] | ± | realisable [cm³] | ± | largest reach [m] | FSW / first | centroid shift "
             "[mm] |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sh = np.asarray(r.centroid_shift_m) * 1e3
        first = (rows[0].volume_m3, rows[0].volume_err_m3)
        lines.append(f"| {r.case} | {_volume_cells(r.volume_m3, r.volume_err_m3)} | "
                     f"{_volume_cells(r.realisable_m3, r.realisable_err_m3)} | {_cell(r.largest_reach_m)} | "
                     f"{_ratio_cell(r.volume_ratio, (r.volume_m3, r.volume_err_m3), first)} | "
                     + ("—" if not np.all(np.isfinite(sh)) else f"({sh[0]:.0f}, {sh[1]:.0f}, {sh[2]:.0f})") + " |")
    lines += ["", "Models and equilibria: " + "; ".join(f"{r.case}: {r.model}, {r.equilibria}"
                                                       for r in rows) + "."]
    untested = [r.case for r in rows if r.stability_test == "untested"]
    if untested:
        lines += ["", f"Stability untested under {', '.join(untested)}: their models have no static stability "
                  f"test, so their FSWs hold every converged sample ({feasible_words('untested')}); the others' "
                  f"hold the converged samples not found unstable ({feasible_words('run')})."]
    lines += _pairs_lines(pairs)
    rules = dict.fromkeys(r.reach_rule for r in rows)
    lines += ["", "Largest reach: the FSW's, " + ("; ".join(f"{r.case}: {r.reach_rule}" for r in rows)
                                                  if len(rules) > 1 else next(iter(rules))) + "."]
    short = [c.name for c in cases
             if c.summary.boundary_search is not None and c.summary.boundary_search.stop == "budget"]
    if short:
        lines += ["", f"**Warning:** the boundary search ran out of budget before the region converged under "
                  f"{', '.join(short)}: those volumes are close to lower bounds with large errors, and their "
                  "ratios compare unfinished searches, not regions. Raise `--budget` to compare the regions."]
    supports = [c.support for c in cases if c.support is not None]
    if len(supports) == len(cases):
        d = supports[0].directions
        pick = [int(np.argmax(d @ e)) for e in np.vstack([np.eye(3), -np.eye(3)])]
        lines += ["", "h(d) [mm] along the base axes (the nearest of the support directions):", "",
                  "| case | " + " | ".join(("+x", "+y", "+z", "-x", "-y", "-z")) + " |", "|---" * 7 + "|"]
        lines += [f"| {c.name} | " + " | ".join(f"{sf.h[k] * 1e3:.0f}" for k in pick) + " |"
                  for c, sf in zip(cases, supports, strict=True)]
    return "\n".join([*lines, ""])


def _write_comparison(out: Path, cases: Sequence[WorkspaceCase], robot: Robot, command: str,
                      comparison: WorkspaceComparison) -> list[str]:
    """The comparison of the finished ``cases`` in ``out`` (figures, HTML, CSV, ``comparison.md`` and
    ``comparison.json``): ``comparison`` holds their rows, their pairs and the cases that failed (its files are
    those written here); with no finished case, the report and the JSON alone. Returns the files written."""
    if not cases:
        text = "\n".join(["# Feasible static workspaces compared", "", f"Made by `{command}`.", "",
                          *_failed_lines(comparison.failed), ""])
        atomic_write_text(out / "comparison.md", text)
        write_json(out / "comparison.json", replace(comparison, files=("comparison.md", "comparison.json")).to_json())
        return ["comparison.md", "comparison.json"]
    files = save_figure(plot_region_slices({c.name: c.region.fsw_region for c in cases}, robot.length,
                                           f"robot '{robot.name}': FSW of each case", unfinished_note(cases)),
                        out, "slices_compare")
    meshes = {c.name: c.region.fsw_region.mesh() for c in cases if c.region.fsw.has_volume}
    files += save_figure(plot_region_3d(meshes, None, f"robot '{robot.name}': FSW boundaries",
                                        note=unfinished_note(cases)), out, "boundaries_compare")
    write_region_html(out / "comparison.html", meshes, None, None, f"robot '{robot.name}': FSW of each case")
    files.append("comparison.html")
    supports = [c.support for c in cases if c.support is not None]
    if len(supports) == len(cases):
        d = supports[0].directions
        write_csv(out / "support_compare.csv", ["dx", "dy", "dz", *[f"h_{_slug(c.name)}_m" for c in cases]],
                  ([*d[k], *[sf.h[k] for sf in supports]] for k in range(d.shape[0])))
        files.append("support_compare.csv")
    atomic_write_text(out / "comparison.md", "\n".join([_compare_report(comparison.cases, cases, command,
                                                                         comparison.pairs),
                                                         *_failed_lines(comparison.failed)]))
    written = [*files, "comparison.md", "comparison.json"]
    write_json(out / "comparison.json", replace(comparison, files=tuple(written)).to_json())
    return written


def _failed_lines(failed: Sequence[FailedCase]) -> list[str]:
    """The report's lines on the cases that failed while running (none: no line)."""
    if not failed:
        return []
    return [f"**Failed:** {len(failed)} case{'s' * (len(failed) != 1)} failed while running and "
            f"{'are' if len(failed) != 1 else 'is'} not compared:", "",
            *[f"- {f.case}: {f.error}" for f in failed], ""]


def _write_section(out: Path, cases: Sequence[WorkspaceCase], robot: Robot, title: str, stem: str, *,
                   meshes: bool = False) -> list[str]:
    """``tdcr reproduce``'s files of a workspace section's ``cases`` in ``out``: with ``meshes``, each FSW's
    boundary with a volume (``workspace_fsw_<case>.ply``), then their slices overlaid (``stem``, PNG and PDF,
    titled ``title``). Returns the files written."""
    files = []
    for case in (c for c in cases if meshes and c.region.fsw.has_volume):
        name = f"workspace_fsw_{_slug(case.name)}.ply"
        case.region.fsw_region.mesh().export(out / name, file_type="ply")
        files.append(name)
    files += save_figure(plot_region_slices({c.name: c.region.fsw_region for c in cases}, robot.length,
                                            f"robot '{robot.name}': {title}", unfinished_note(cases)), out, stem)
    return files


def workspace_text(ws: WorkspaceSection, s: ReproduceSettings) -> list[str]:
    """The report's workspace section."""
    lines = ["## The feasible static workspace as a region", "",
             f"Base samples n = {ws.n} (scrambled Sobol, with the tension box's corners and edges), voxels of "
             f"{ws.voxel_m * 1e3:.1f} mm, boundary search within {ws.budget} solves, "
             f"{s.workspace_directions} support directions"
             + ("" if s.workspace_directions else " (the largest reach is the farthest sample's)")
             + ": a modest budget for the demo, whose error is wide (`tdcr reproduce --full` or `tdcr workspace "
             "--compare-loads` for the full one). Slices: workspace_slices.png.", "",
             "| load | FSW volume [cm³] | ± | realisable [cm³] | ± | largest reach [m] |", "|---|---|---|---|---|---|"]
    for r in ws.cases:
        lines.append(f"| {r.case} | {_volume_cells(r.volume_m3, r.volume_err_m3)} | "
                     f"{_volume_cells(r.realisable_m3, r.realisable_err_m3)} | {_cell(r.largest_reach_m)} |")
    models = ws.models
    if models:
        lines += ["", "### The workspace by model", "",
                  f"The FSW under the paper's wrench by each model (n = {models.n}, voxels of "
                  f"{models.voxel_m * 1e3:.1f} mm, each model's own equilibria; sscr, the subsegment Cosserat "
                  "rod, is the reference): how much of the paper's workspace is its model's error. Slices: "
                  "workspace_models_slices.png.", "",
                  "| model | FSW volume [cm³] | ± | FSW / pcc's |", "|---|---|---|---|"]
        first = (models.cases[0].volume_m3, models.cases[0].volume_err_m3) if models.cases else (0.0, 0.0)
        lines += [f"| {r.model} | {_volume_cells(r.volume_m3, r.volume_err_m3)} | "
                  f"{_ratio_cell(r.volume_ratio, (r.volume_m3, r.volume_err_m3), first)} |" for r in models.cases]
        lines += _pairs_lines(models.pairs)
    return [*lines, ""]

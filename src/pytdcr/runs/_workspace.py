"""``tdcr workspace``: the feasible static workspace as a region, with its volume, boundary, support function
and realisability, for one load or a comparison of loads."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..limits import ResourceLimitError
from ..loads import Loads
from ..optimize import SearchFailed
from ..plotting import (
    plot_multistability,
    plot_region_3d,
    plot_region_slices,
    plot_support_map,
    save_figure,
    write_region_html,
)
from ..records import RunWarning
from ..results import NotConvergedError
from ..robot import Robot
from ..runtime import atomic_write, atomic_write_text, output_folder, write_csv, write_json
from ..statics import Model, feasible_words, options_record, saving, solve
from ..validate import SettingsError
from ..workspace import (
    BoundarySearch,
    Estimate,
    LargestReach,
    Region,
    RegionNumbers,
    RegionSamples,
    SearchRound,
    SupportFunction,
    WorkspaceHooks,
    WorkspaceRegion,
    WorkspaceSettings,
    WorkspaceStudy,
    WorkspaceSummary,
    check_workspace,
    region_overlap,
    workspace_estimate,
    workspace_study,
)
from ._output import inputs_record
from ._workspace_records import (
    CaseComparison,
    FailedCase,
    ModelsSection,
    PairComparison,
    WorkspaceComparison,
    WorkspaceRecord,
    WorkspaceSection,
)

if TYPE_CHECKING:  # the reproduce run imports this module
    from ._reproduce import ReproduceSettings

__all__ = [
    "WorkspaceCase",
    "WorkspaceCaseSpec",
    "WorkspaceRun",
    "WorkspaceRunOptions",
    "check_workspace_cases",
    "format_measure_of",
    "run_workspace",
    "run_workspace_compare",
]

#: ``progress(stage, total)`` returns a callable advanced by the work done (total None: unknown)
Progress = Callable[[str, "int | None"], Callable[[int], None]]


@dataclass(frozen=True)
class WorkspaceRunOptions:
    """How a workspace run reports itself.

    Attributes
    ----------
    command : str
        The command that made it, named in each ``report.md``.
    progress : callable or None
        ``progress(stage, total)`` returns a callable advanced by the work done
        (:class:`pytdcr.workspace.WorkspaceHooks`).
    on_round : callable or None
        Sees each round of the boundary search.
    """

    command: str = "tdcr workspace"
    progress: Progress | None = None
    on_round: Callable[[SearchRound], None] | None = None


class WorkspaceCaseSpec(NamedTuple):
    """One case of :func:`run_workspace_compare`: its robot and loads, and where it differs from the run, its
    settings (the run's voxel still holds) or its model (with options; None: the model's defaults)."""

    robot: Robot
    loads: Loads
    settings: WorkspaceSettings | None = None
    model: str | Model | None = None
    options: Any = None


@dataclass(frozen=True, eq=False)
class WorkspaceCase:
    """One load case's workspace: the study (regions, support function, largest reach), its numbers with the
    meshes' names (``summary``), the inputs' record and the warnings; :meth:`record` is its ``workspace.json``
    (:class:`WorkspaceRecord`) but for the files."""

    name: str
    loads: Loads
    study: WorkspaceStudy
    summary: WorkspaceSummary
    inputs: dict[str, Any]
    warnings: tuple[RunWarning, ...]

    def record(self, files: tuple[str, ...] = ()) -> WorkspaceRecord:
        """``workspace.json``: the numbers with the meshes, the inputs, the warnings and the ``files``."""
        return WorkspaceRecord(self.summary, self.inputs, self.warnings, files)

    @property
    def region(self) -> WorkspaceRegion:
        """The samples, the regions and their volumes."""
        return self.study.region

    @property
    def support(self) -> SupportFunction | None:
        """h(d), when computed."""
        return self.study.support

    @property
    def reach(self) -> LargestReach | None:
        """The reach search, when it ran."""
        return self.study.reach_search


@dataclass(frozen=True, eq=False)
class WorkspaceRun:
    """What :func:`run_workspace` or :func:`run_workspace_compare` produced: the cases finished, the record
    written (``workspace.json``'s :class:`WorkspaceRecord` for one case, ``comparison.json``'s
    :class:`WorkspaceComparison` for several), the files, and the cases that failed while running (name → the
    error, one line; their finished neighbours are kept)."""

    cases: list[WorkspaceCase]
    record: WorkspaceRecord | WorkspaceComparison
    files: list[str]
    failed: dict[str, str] = field(default_factory=dict)

    @property
    def case(self) -> WorkspaceCase:
        """The first (for :func:`run_workspace`, the only) case."""
        return self.cases[0]


def _cell(value: float | None, fmt: str = ".4f", scale: float = 1.0) -> str:
    """A table cell: ``value`` times ``scale`` in ``fmt``, or "—" where there is none (None or NaN)."""
    if value is None or not np.isfinite(value):
        return "—"
    return format(value * scale, fmt)


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


def _directions_record(settings: WorkspaceSettings) -> int | list[list[float]]:
    d = settings.directions
    return d if isinstance(d, int) else [list(v) for v in d]


def _case(name: str, robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings,
          model: str | Model, options: Any, hooks: WorkspaceHooks) -> WorkspaceCase:
    """Compute one load case (:func:`pytdcr.workspace.workspace_study`) and its summary."""
    ws = workspace_study(robot, loads, bounds, settings, model=model, options=options, hooks=hooks)
    summary = ws.summary.with_meshes("fsw.ply", "fsw_realisable.ply")
    inputs = inputs_record(robot, loads, bounds=bounds.to_dict(), n=settings.n, seed=settings.seed,
                           solver=options_record(ws.model, ws.options), warm_starts=settings.warm,
                           boundary_search=settings.search, search_budget=settings.budget,
                           directions=_directions_record(settings), equilibria=settings.equilibria,
                           multistability=settings.multistability, search_folds=settings.folds)
    return WorkspaceCase(name, loads, ws, summary, inputs, tuple(_warnings(summary)))


def _save_samples(out: Path, s: RegionSamples) -> None:
    """``samples.npz`` in ``out``, written aside and renamed (a reader never sees half of it)."""
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            extra = {} if s.parent is None else {"parent": s.parent}
            np.savez_compressed(f, tensions=s.tensions, source=s.source, tip=s.tip_position, stage=s.stage,
                                converged=s.converged, stable=s.stable, below_base=s.below_base,
                                disks_touch=s.disks_touch, sources=np.array(RegionSamples.SOURCES), **extra)

    atomic_write(out / "samples.npz", write)


def _checkpoint(out: Path, run: Any, before: str = "", where: str = "") -> Callable[[RegionSamples], None]:
    """Save the samples solved so far in ``out``: a study interrupted later keeps them (``run``'s note says so,
    after ``before``; ``where`` is ``out``'s place in the run's folder, with a trailing slash)."""
    def save(s: RegionSamples) -> None:
        with saving():
            _save_samples(out, s)
        run.interrupted_note = (f"{before}saved {s.source.size} solved samples ({int(s.converged.sum())} converged) in "
                                f"{where}samples.npz, no region")
    return save


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
                                            robot.length, f"robot '{robot.name}': workspace slices, {case.name}"),
                         out, "slices")
    files += save_figure(plot_region_3d(meshes, pose, f"robot '{robot.name}': FSW boundary, {case.name}"),
                         out, "boundary_3d")
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


def run_workspace(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings, out: str | Path,
                  *, model: str | Model = "pcc", options: Any = None,
                  run_options: WorkspaceRunOptions | None = None) -> WorkspaceRun:
    """The workspace under ``loads`` (:func:`pytdcr.workspace.workspace_study` with ``settings``), written to ``out``
    (the output-folder rule): ``workspace.json``, ``fsw.ply``, ``fsw_realisable.ply``, ``samples.npz``,
    ``support.csv``, figures (slices, 3D boundary with the robot at its largest reach, h(d) map; PNG and PDF),
    ``workspace.html`` and ``report.md``. ``run_options`` names the command in the report and carries the
    progress and search-round callbacks; the samples are saved as they are solved (an interrupted run keeps
    them).
    """
    how = run_options if run_options is not None else WorkspaceRunOptions()
    check_workspace(robot, loads, settings, model=model, options=options)  # every capability, before any solve
    with output_folder(out, "workspace", {"n": settings.n, "seed": settings.seed, "bounds": bounds.to_dict()}) as run:
        hooks = WorkspaceHooks(how.progress, how.on_round, _checkpoint(run.staging, run))
        case = _case("as given", robot, loads, bounds, settings, model, options, hooks)
        with saving():
            files = _write_case(run.staging, case, robot, how.command)
    return WorkspaceRun([case], case.record(tuple(files)), files)


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
             f"| FSW ({feasible_words(summary.stability_test)}) | {f.volume_m3 * 1e6:.0f} | "
             f"{f.volume_err_m3 * 1e6:.0f}{pct(f)} | "
             f"{_cell(f.largest_reach_m)} | {f.points} |",
             f"| realisable (no disk below the base, no disks touching) | {r.volume_m3 * 1e6:.0f} | "
             f"{r.volume_err_m3 * 1e6:.0f}{pct(r)} | {_cell(r.largest_reach_m)} | {r.points} |", "",
             _reach_note(f, r), "", *_untested_note(summary, case.study.model.name),
             "Convergence with the base samples (FSW): "
             + ", ".join(f"n = {s['n_base']}: {s['estimate_m3'] * 1e6:.0f} cm³" for s in f.volume.scales)
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
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def _centroid(region: Region) -> np.ndarray:
    """The centre of the occupied voxels [m] (NaN when empty)."""
    idx = np.argwhere(region.occupied)
    if idx.size == 0:
        return np.full(3, np.nan)
    return region.origin + (idx.mean(axis=0) + 0.5) * region.voxel


def _pairs(cases: list[WorkspaceCase]) -> list[PairComparison]:
    """Per pair of cases (a before b): how their FSWs differ (:func:`pytdcr.workspace.region_overlap`)."""
    return [PairComparison(a.name, b.name, region_overlap(a.region.fsw_region, b.region.fsw_region))
            for i, a in enumerate(cases) for b in cases[i + 1:]]


def _comparison(cases: list[WorkspaceCase]) -> list[CaseComparison]:
    """Per case: volumes, largest reach, and how far the region shrank and shifted from the first case."""
    if not cases:
        return []
    ref = cases[0]
    v0, c0 = ref.summary.fsw.volume_m3, _centroid(ref.region.fsw_region)
    rows = []
    for c in cases:
        s, f = c.summary, c.summary.fsw
        shift = _centroid(c.region.fsw_region) - c0
        rows.append(CaseComparison(c.name, c.study.model.name, s.equilibria, s.stability_test, f.volume_m3,
                                   f.volume_err_m3, s.realisable.volume_m3, s.realisable.volume_err_m3,
                                   f.largest_reach_m, f.reach_rule, f.volume_m3 / v0 if v0 else None,
                                   tuple(_centroid(c.region.fsw_region).tolist()), tuple(shift.tolist()),
                                   _slug(c.name)))
    return rows


def _pairs_lines(pairs: list[PairComparison]) -> list[str]:
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


def _compare_report(rows: list[CaseComparison], cases: list[WorkspaceCase], command: str,
                    pairs: list[PairComparison]) -> str:
    lines = ["# Feasible static workspaces compared", "", f"Made by `{command}`. Each case's folder "
             "holds its own workspace.json, meshes, figures and report.", "",
             "| case | FSW [cm³] | ± | realisable [cm³] | ± | largest reach [m] | FSW / first | centroid shift "
             "[mm] |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sh = np.asarray(r.centroid_shift_m) * 1e3
        lines.append(f"| {r.case} | {r.volume_m3 * 1e6:.0f} | {r.volume_err_m3 * 1e6:.0f} | "
                     f"{r.realisable_m3 * 1e6:.0f} | {r.realisable_err_m3 * 1e6:.0f} | "
                     f"{_cell(r.largest_reach_m)} | {_cell(r.volume_ratio, '.2f')} | "
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
    if all(c.support is not None for c in cases):
        d = cases[0].support.directions
        pick = [int(np.argmax(d @ e)) for e in np.vstack([np.eye(3), -np.eye(3)])]
        lines += ["", "h(d) [mm] along the base axes (the nearest of the support directions):", "",
                  "| case | " + " | ".join(("+x", "+y", "+z", "-x", "-y", "-z")) + " |", "|---" * 7 + "|"]
        lines += [f"| {c.name} | " + " | ".join(f"{c.support.h[k] * 1e3:.0f}" for k in pick) + " |" for c in cases]
    return "\n".join([*lines, ""])


def _case_settings(spec: WorkspaceCaseSpec, settings: WorkspaceSettings) -> WorkspaceSettings:
    """A case's settings: its own with the run's voxel (one grid; its own when the run has none), or the run's."""
    if spec.settings is None:
        return settings
    voxel = settings.voxel if settings.voxel is not None else spec.settings.voxel
    return replace(spec.settings, voxel=voxel).check(spec.robot)


def check_workspace_cases(specs: Mapping[str, WorkspaceCaseSpec], settings: WorkspaceSettings, *,
                          model: str | Model = "pcc", options: Any = None, field_name: str = "cases") -> None:
    """Every planned case's requirements against its model's capabilities, before the first solve: the check
    each case's study makes first (:func:`pytdcr.workspace.check_workspace`), for all of them at once.

    ``specs`` name → :class:`WorkspaceCaseSpec` (a case without a model of its own is solved by ``model`` with
    ``options``); ``settings`` the run's, with its voxel fixed (:meth:`WorkspaceSettings.with_voxel_for`).

    Raises
    ------
    SettingsError
        Naming ``field_name``, the first case that cannot run and the capability its model lacks (or the setting
        that does not suit it).
    """
    for name, spec in specs.items():
        m, opts = (model, options) if spec.model is None else (spec.model, spec.options)
        try:
            check_workspace(spec.robot, spec.loads, _case_settings(spec, settings), model=m, options=opts)
        except ValueError as err:  # UnsupportedFeatureError among them
            raise SettingsError(field_name, f": case '{name}': {err}") from None


#: what a case can meet only while running, and its user can act on: a solve that gave no shape or a search
#: that found nothing (the project's solver errors), a numerical failure, the memory budget or the machine's
#: memory exceeded, a file that could not be written (its checkpoint, its results). Such a case is reported
#: and the others go on; anything else is a bug (:func:`run_workspace_compare`)
_RUN_FAILURES: tuple[type[Exception], ...] = (NotConvergedError, SearchFailed, FloatingPointError, OverflowError,
                                             np.linalg.LinAlgError, ResourceLimitError, MemoryError, OSError)


def _failed_case(sub: Path, err: Exception) -> str:
    """One line for a case that failed while running; its folder keeps only the samples it had saved (its
    checkpoint, written whole), or goes."""
    for p in sub.iterdir() if sub.is_dir() else ():
        if p.name != "samples.npz":
            shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
    kept = (sub / "samples.npz").is_file()
    if not kept:
        shutil.rmtree(sub, ignore_errors=True)
    text = " ".join(f"{type(err).__name__}: {err}".split())[:300]
    return text + (f" (the samples it had solved are in {sub.name}/samples.npz, no region)" if kept else "")


def run_workspace_compare(robot: Robot, cases: dict[str, tuple[Any, ...]], bounds: TensionBounds,
                          settings: WorkspaceSettings, out: str | Path, *, model: str | Model = "pcc",
                          options: Any = None, run_options: WorkspaceRunOptions | None = None) -> WorkspaceRun:
    """The workspace of each case (name → :class:`WorkspaceCaseSpec`, or a tuple of its fields: robot, loads,
    and optionally settings, model and options; :func:`pytdcr.paper.workspace_load_cases` gives the load
    cases), one sub-folder each with :func:`run_workspace`'s files, and their comparison in ``out``:
    ``comparison.json`` (per case, and per pair the Hausdorff distance between the boundaries and the share of
    each region inside the other), ``comparison.md``, ``support_compare.csv``, overlaid slices and 3D
    boundaries (PNG, PDF) and ``comparison.html``. Every case has ``robot``'s voxel
    (:meth:`~pytdcr.workspace.WorkspaceSettings.voxel_for`: one grid). A case with settings of its own (``tdcr
    workspace --equilibria both``) keeps the run's voxel; one with a model of its own (``--compare-models``)
    is solved by it, the others by ``model``.

    Every case is checked against its model's capabilities before the first solve
    (:func:`check_workspace_cases`: SettingsError naming ``cases``). A case that fails while running in a way
    its user can act on (the project's solver errors, a numerical failure, memory, a file not written) is
    reported (:attr:`WorkspaceRun.failed`, ``comparison.json``'s ``failed``, the report) and the others go on:
    the finished cases' files and their comparison are kept. Any other exception is a bug: the cases finished
    before it are saved the same way, the case it stopped and those not run listed as failed, and then it is
    raised again (the command line's internal error, its traceback with ``PYTDCR_DEBUG=1``)."""
    how = run_options if run_options is not None else WorkspaceRunOptions()
    settings = settings.check(robot).with_voxel_for(robot)
    specs = {name: WorkspaceCaseSpec(*value) for name, value in cases.items()}
    check_workspace_cases(specs, settings, model=model, options=options)
    done: list[WorkspaceCase] = []
    failed: dict[str, str] = {}
    bug: Exception | None = None
    with output_folder(out, "workspace --compare", {"n": settings.n, "seed": settings.seed,
                                                    "bounds": bounds.to_dict(), "cases": list(cases)}) as run:
        files = []
        for name, spec in specs.items():
            if bug is not None:
                failed[name] = "not run: an earlier case stopped the run with an internal error"
                continue
            sub = run.staging / _slug(name)
            sub.mkdir()
            whole = f"saved {len(done)} of {len(cases)} cases whole; "
            hooks = WorkspaceHooks(_named(how.progress, name), how.on_round,
                                   _checkpoint(sub, run, whole, f"{sub.name}/"))
            m, opts = (model, options) if spec.model is None else (spec.model, spec.options)
            try:
                case = _case(name, spec.robot, spec.loads, bounds, _case_settings(spec, settings), m, opts, hooks)
                with saving():
                    _write_case(sub, case, spec.robot, how.command)
            except Exception as err:  # _RUN_FAILURES: reported, the others go on; a bug: the rest are not run
                if not isinstance(err, _RUN_FAILURES):
                    bug = err
                with saving():
                    failed[name] = _failed_case(sub, err) + ("" if bug is None else " (an internal error: a bug in "
                                                             "pytdcr; the cases after it were not run)")
                if sub.is_dir():
                    files.append(sub.name)
                continue
            done.append(case)
            files.append(sub.name)
            run.interrupted_note = f"saved {len(done)} of {len(cases)} cases whole, not their comparison"
        pairs = _pairs(done)
        with saving():
            files += _write_comparison(run.staging, done, robot, how.command, pairs, failed)
    if bug is not None:  # what finished is saved (finished work is never lost); the bug goes on up, as it was
        raise bug
    record = WorkspaceComparison(tuple(_comparison(done)), tuple(pairs),
                                 tuple(FailedCase(k, v) for k, v in failed.items()), tuple(files))
    return WorkspaceRun(done, record, files, failed)


def _named(progress: Any, name: str) -> Any:
    """``progress`` with every stage it shows named after the case (``"paper wrench: sampling"``)."""
    if progress is None:
        return None
    return lambda stage, total: progress(f"{name}: {stage}", total)


def _write_comparison(out: Path, cases: list[WorkspaceCase], robot: Robot, command: str,
                      pairs: list[PairComparison], failed: dict[str, str] | None = None) -> list[str]:
    """The comparison of the finished ``cases`` in ``out`` (figures, HTML, CSV, ``comparison.md`` and
    ``comparison.json``) and the cases that ``failed`` (name → why); with no finished case, the report and the
    JSON alone."""
    failed = failed or {}
    rows = _comparison(cases)
    record = tuple(FailedCase(k, v) for k, v in failed.items())
    if not cases:
        text = "\n".join(["# Feasible static workspaces compared", "", f"Made by `{command}`.", "",
                          *_failed_lines(failed), ""])
        atomic_write_text(out / "comparison.md", text)
        write_json(out / "comparison.json",
                   WorkspaceComparison((), (), record, ("comparison.md", "comparison.json")).to_json())
        return ["comparison.md", "comparison.json"]
    files = save_figure(plot_region_slices({c.name: c.region.fsw_region for c in cases}, robot.length,
                                           f"robot '{robot.name}': FSW of each case"), out, "slices_compare")
    meshes = {c.name: c.region.fsw_region.mesh() for c in cases if c.region.fsw.has_volume}
    files += save_figure(plot_region_3d(meshes, None, f"robot '{robot.name}': FSW boundaries"), out,
                         "boundaries_compare")
    write_region_html(out / "comparison.html", meshes, None, None, f"robot '{robot.name}': FSW of each case")
    files.append("comparison.html")
    if all(c.support is not None for c in cases):
        d = cases[0].support.directions
        write_csv(out / "support_compare.csv", ["dx", "dy", "dz", *[f"h_{_slug(c.name)}_m" for c in cases]],
                  ([*d[k], *[c.support.h[k] for c in cases]] for k in range(d.shape[0])))
        files.append("support_compare.csv")
    atomic_write_text(out / "comparison.md", "\n".join([_compare_report(rows, cases, command, pairs),
                                                          *_failed_lines(failed)]))
    write_json(out / "comparison.json", WorkspaceComparison(tuple(rows), tuple(pairs), record,
                                                            (*files, "comparison.md", "comparison.json")).to_json())
    return [*files, "comparison.md", "comparison.json"]


def _failed_lines(failed: dict[str, str]) -> list[str]:
    """The report's lines on the cases that failed while running (none: no line)."""
    if not failed:
        return []
    return [f"**Failed:** {len(failed)} case{'s' * (len(failed) != 1)} failed while running and "
            f"{'are' if len(failed) != 1 else 'is'} not compared:", "",
            *[f"- {k}: {v}" for k, v in failed.items()], ""]


_SectionCases = dict[str, tuple[Robot, Loads, WorkspaceSettings, str]]


def _section_cases(robot: Robot, s: ReproduceSettings, seed: int) -> tuple[_SectionCases, _SectionCases]:
    """The workspace cases of :func:`workspace_section` and those of its models' comparison (empty without
    ``s.workspace_models``), each name → robot, loads, settings, model."""
    from ..paper import workspace_load_cases

    cases = {k: v for k, v in workspace_load_cases(robot).items() if k in ("no load", "paper wrench")}
    voxel = robot.length / s.workspace_voxels  # the demo's own grid, coarser than the default
    settings = WorkspaceSettings(n=s.workspace_n, seed=seed, voxel=voxel, budget=s.workspace_budget,
                                 directions=s.workspace_directions, multistability=0, equilibria="loading-path",
                                 reach="search" if s.workspace_directions else "samples")
    out = {name: (r, loads, settings, "pcc") for name, (r, loads) in cases.items()}
    # the search stops at folds: snapping through them, an sscr search takes hours (docs/workspace.md)
    settings = WorkspaceSettings(n=s.models_n, seed=seed, voxel=robot.length / s.models_voxels, directions=0,
                                 multistability=0, reach="samples", folds="stop")
    r, loads = cases["paper wrench"]
    return out, {m: (r, loads, settings, m) for m in s.workspace_models}


def section_check(robot: Robot, s: ReproduceSettings, *, seed: int = 0) -> None:
    """Every case of :func:`workspace_section` (and of its models' comparison) against its model's capabilities,
    before any solve (:func:`check_workspace_cases`: SettingsError naming ``workspace_models`` for a model of the
    comparison, ``robot`` for the section's own cases)."""
    cases, models = _section_cases(robot, s, seed)
    for field_name, group in (("robot", cases), ("workspace_models", models)):
        specs = {name: WorkspaceCaseSpec(r, loads, st, m) for name, (r, loads, st, m) in group.items()}
        check_workspace_cases(specs, WorkspaceSettings(), field_name=field_name)


def section_estimate(robot: Robot, bounds: TensionBounds, s: ReproduceSettings, *, seed: int = 0) -> Estimate:
    """The expected length of :func:`workspace_section` at the settings ``s``
    (:func:`~pytdcr.workspace.workspace_estimate`)."""
    cases, models = _section_cases(robot, s, seed)
    return workspace_estimate([(r, loads, st, m, None) for r, loads, st, m in [*cases.values(), *models.values()]],
                              bounds)


def workspace_section(robot: Robot, bounds: TensionBounds, s: ReproduceSettings, out: Path, files: list[str], *,
                      seed: int = 0, progress: Any = None) -> WorkspaceSection:
    """``tdcr reproduce``'s workspace section: the FSW under the paper's tip wrench next to no load, at the
    budget of ``s`` (:class:`~pytdcr.runs.ReproduceSettings`); writes ``workspace_slices`` (PNG, PDF) and the
    two boundaries (``workspace_fsw_paper.ply``, ``workspace_fsw_no_load.ply``), appends them to ``files``.
    The paper's definition of the equilibria (each sample from rest, ``equilibria="loading-path"``: this is the
    paper's study), and no multistability check (``tdcr workspace`` has both): at the demo's budget it would
    cost more than the region. With ``s.workspace_models``, also :func:`_models_section`.
    ``progress(stage, total, unit)``, if given, is told each stage (named "workspace, <case>: <stage>")."""

    def hooks(name: str) -> WorkspaceHooks:
        if progress is None:
            return WorkspaceHooks()
        return WorkspaceHooks(lambda stage, total: progress(f"workspace, {name}: {stage}", total, "solve"))

    cases, models = _section_cases(robot, s, seed)
    done = [_case(name, r, loads, bounds, st, m, None, hooks(name)) for name, (r, loads, st, m) in cases.items()]
    for case in (c for c in done if c.region.fsw.has_volume):
        name = f"workspace_fsw_{_slug(case.name)}.ply"
        case.region.fsw_region.mesh().export(out / name, file_type="ply")
        files.append(name)
    files += save_figure(plot_region_slices({c.name: c.region.fsw_region for c in done}, robot.length,
                                            f"robot '{robot.name}': FSW, no load and the paper's wrench"),
                         out, "workspace_slices")
    return WorkspaceSection(s.workspace_n, cases["no load"][2].voxel, s.workspace_budget, tuple(_comparison(done)),
                            _models_section(robot, models, bounds, s, out, files, hooks) if models else None)


def _models_section(robot: Robot, models: dict[str, tuple[Any, ...]], bounds: TensionBounds, s: ReproduceSettings,
                    out: Path, files: list[str], hooks: Callable[[str], WorkspaceHooks]) -> ModelsSection:
    """The FSWs of ``models`` (name → robot, loads, settings, model: the paper's wrench, each model's own
    equilibria, continued where it can, at ``s.models_n`` samples and ``s.models_voxels`` voxels per length),
    compared: per model its volume with its error, per pair the Hausdorff distance and the share of each inside
    the other; writes ``workspace_models_slices`` (PNG, PDF)."""
    done = [_case(name, r, loads, bounds, st, m, None, hooks(f"model {name}"))
            for name, (r, loads, st, m) in models.items()]
    files += save_figure(plot_region_slices({c.name: c.region.fsw_region for c in done}, robot.length,
                                            f"robot '{robot.name}': FSW under the paper's wrench, by model"),
                         out, "workspace_models_slices")
    voxel = next(iter(models.values()))[2].voxel
    return ModelsSection(s.models_n, voxel, tuple(_comparison(done)), tuple(_pairs(done)))


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
        lines.append(f"| {r.case} | {r.volume_m3 * 1e6:.0f} | {r.volume_err_m3 * 1e6:.0f} | "
                     f"{r.realisable_m3 * 1e6:.0f} | {r.realisable_err_m3 * 1e6:.0f} | {_cell(r.largest_reach_m)} |")
    models = ws.models
    if models:
        lines += ["", "### The workspace by model", "",
                  f"The FSW under the paper's wrench by each model (n = {models.n}, voxels of "
                  f"{models.voxel_m * 1e3:.1f} mm, each model's own equilibria; sscr, the subsegment Cosserat "
                  "rod, is the reference): how much of the paper's workspace is its model's error. Slices: "
                  "workspace_models_slices.png.", "",
                  "| model | FSW volume [cm³] | ± | FSW / pcc's |", "|---|---|---|---|"]
        lines += [f"| {r.model} | {r.volume_m3 * 1e6:.0f} | {r.volume_err_m3 * 1e6:.0f} | "
                  f"{_cell(r.volume_ratio, '.2f')} |" for r in models.cases]
        lines += _pairs_lines(list(models.pairs))
    return [*lines, ""]

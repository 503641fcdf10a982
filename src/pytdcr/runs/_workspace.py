"""``tdcr workspace``: the feasible static workspace as a region, with its volume, boundary, support function
and realisability, for one load or a comparison of loads; and ``tdcr reproduce``'s workspace section.

This module runs them (settings → cases → :class:`WorkspaceRun`); :mod:`._workspace_report` writes their files,
figures and reports from the typed results."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..bounds import TensionBounds
from ..limits import ResourceLimitError
from ..loads import Loads
from ..optimize import SearchFailed
from ..records import JsonDict, RunWarning
from ..results import NotConvergedError
from ..robot import Robot
from ..runtime import OutputRun, output_folder
from ..statics import Model, ModelOptions, options_record, saving
from ..validate import SettingsError
from ..workspace import (
    LargestReach,
    Region,
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
from ..workspace.parts import Estimate, RegionSamples, SearchRound
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
from ._workspace_report import _save_samples, _slug, _warnings, _write_case, _write_comparison, _write_section
from ._workspace_report import workspace_text as workspace_text  # importable from here, as before it moved

if TYPE_CHECKING:  # the reproduce run imports this module
    from ._reproduce import ReproduceSettings

__all__ = [
    "WorkspaceCase",
    "WorkspaceCaseSpec",
    "WorkspaceRun",
    "WorkspaceRunOptions",
    "check_workspace_cases",
    "run_workspace",
    "run_workspace_compare",
]

#: ``progress(stage, total)`` returns a callable advanced by the work done (total None: unknown)
Progress = Callable[[str, "int | None"], Callable[[int], None]]
#: ``progress(stage, total, unit)`` of ``tdcr reproduce`` (its unit: ``"solve"``), likewise
SectionProgress = Callable[[str, "int | None", str], Callable[[int], None]]


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
    options: ModelOptions | None = None


#: a case of :func:`run_workspace_compare` given as the plain tuple of :class:`WorkspaceCaseSpec`'s fields (robot,
#: loads, then optionally settings, model and options: :func:`pytdcr.paper.workspace_load_cases` gives the first two)
CaseFields = (tuple[Robot, Loads] | tuple[Robot, Loads, WorkspaceSettings | None]
              | tuple[Robot, Loads, WorkspaceSettings | None, str | Model | None]
              | tuple[Robot, Loads, WorkspaceSettings | None, str | Model | None, ModelOptions | None])


@dataclass(frozen=True, eq=False)
class WorkspaceCase:
    """One load case's workspace: the study (regions, support function, largest reach), its numbers with the
    meshes' names (``summary``), the inputs' record and the warnings; :meth:`record` is its ``workspace.json``
    (:class:`WorkspaceRecord`) but for the files."""

    name: str
    loads: Loads
    study: WorkspaceStudy
    summary: WorkspaceSummary
    inputs: JsonDict
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


def _directions_record(settings: WorkspaceSettings) -> int | list[list[float]]:
    d = settings.directions
    """The support directions as ``inputs`` records them: their count, or the unit vectors given (k, 3)."""
    return d if isinstance(d, int) else [list(v) for v in d]


def _case(name: str, robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings,
          model: str | Model, options: ModelOptions | None, hooks: WorkspaceHooks) -> WorkspaceCase:
    """Compute one load case (:func:`pytdcr.workspace.workspace_study`) and its summary."""
    ws = workspace_study(robot, loads, bounds, settings, model=model, options=options, hooks=hooks)
    summary = ws.summary.with_meshes("fsw.ply", "fsw_realisable.ply")
    inputs = inputs_record(robot, loads, bounds=bounds.to_dict(), n=settings.n, seed=settings.seed,
                           solver=options_record(ws.model, ws.options), warm_starts=settings.warm,
                           boundary_search=settings.search, search_budget=settings.budget,
                           directions=_directions_record(settings), equilibria=settings.equilibria,
                           multistability=settings.multistability, search_folds=settings.folds)
    return WorkspaceCase(name, loads, ws, summary, inputs, tuple(_warnings(summary)))


def _checkpoint(out: Path, run: OutputRun, before: str = "", where: str = "") -> Callable[[RegionSamples], None]:
    """Save the samples solved so far in ``out``: a study interrupted later keeps them (``run``'s note says so,
    after ``before``; ``where`` is ``out``'s place in the run's folder, with a trailing slash)."""
    def save(s: RegionSamples) -> None:
        with saving():
            _save_samples(out, s)
        run.interrupted_note = (f"{before}saved {s.source.size} solved samples ({int(s.converged.sum())} converged) in "
                                f"{where}samples.npz, no region")
    return save


def run_workspace(robot: Robot, loads: Loads, bounds: TensionBounds, settings: WorkspaceSettings, out: str | Path,
                  *, model: str | Model = "pcc", options: ModelOptions | None = None,
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




def _case_settings(spec: WorkspaceCaseSpec, settings: WorkspaceSettings) -> WorkspaceSettings:
    """A case's settings: its own with the run's voxel (one grid; its own when the run has none), or the run's."""
    if spec.settings is None:
        return settings
    voxel = settings.voxel if settings.voxel is not None else spec.settings.voxel
    return replace(spec.settings, voxel=voxel).check(spec.robot)


def check_workspace_cases(specs: Mapping[str, WorkspaceCaseSpec], settings: WorkspaceSettings, *,
                          model: str | Model = "pcc", options: ModelOptions | None = None,
                          field_name: str = "cases") -> None:
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


def run_workspace_compare(robot: Robot, cases: Mapping[str, WorkspaceCaseSpec | CaseFields],
                          bounds: TensionBounds, settings: WorkspaceSettings, out: str | Path, *,
                          model: str | Model = "pcc", options: ModelOptions | None = None,
                          run_options: WorkspaceRunOptions | None = None) -> WorkspaceRun:
    """The workspace of each case (name → :class:`WorkspaceCaseSpec`, or a tuple of its fields, :data:`CaseFields`:
    robot, loads, and optionally settings, model and options; :func:`pytdcr.paper.workspace_load_cases` gives the
    load cases), one sub-folder each with :func:`run_workspace`'s files, and their comparison in ``out``:
    ``comparison.json`` (per case, and per pair the Hausdorff distance between the boundaries and the share of each
    region inside the other), ``comparison.md``, ``support_compare.csv``, overlaid slices and 3D boundaries (PNG,
    PDF) and ``comparison.html``. Every case has ``robot``'s voxel
    (:meth:`~pytdcr.workspace.WorkspaceSettings.voxel_for`: one grid). A case with settings of its own (``tdcr
    workspace --equilibria both``) keeps the run's voxel; one with a model of its own (``--compare-models``) is
    solved by it, the others by ``model``.

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
        compared = WorkspaceComparison(tuple(_comparison(done)), tuple(_pairs(done)),
                                       tuple(FailedCase(k, v) for k, v in failed.items()))
        with saving():
            files += _write_comparison(run.staging, done, robot, how.command, compared)
    if bug is not None:  # what finished is saved (finished work is never lost); the bug goes on up, as it was
        raise bug
    return WorkspaceRun(done, replace(compared, files=tuple(files)), files, failed)


def _named(progress: Progress | None, name: str) -> Progress | None:
    """``progress`` with every stage it shows named after the case (``"paper wrench: sampling"``)."""
    if progress is None:
        return None
    return lambda stage, total: progress(f"{name}: {stage}", total)


#: name → case of :func:`workspace_section`: robot, loads, its own settings and model (no options: the model's)
_SectionCases = dict[str, WorkspaceCaseSpec]


def _section_cases(robot: Robot, s: ReproduceSettings, seed: int) -> tuple[_SectionCases, _SectionCases]:
    """The workspace cases of :func:`workspace_section` and those of its models' comparison (empty without
    ``s.workspace_models``), each with its settings and model."""
    from ..paper import workspace_load_cases

    cases = {k: v for k, v in workspace_load_cases(robot).items() if k in ("no load", "paper wrench")}
    voxel = robot.length / s.workspace_voxels  # the demo's own grid, coarser than the default
    settings = WorkspaceSettings(n=s.workspace_n, seed=seed, voxel=voxel, budget=s.workspace_budget,
                                 directions=s.workspace_directions, multistability=0, equilibria="loading-path",
                                 reach="search" if s.workspace_directions else "samples")
    out = {name: WorkspaceCaseSpec(r, loads, settings, "pcc") for name, (r, loads) in cases.items()}
    # the search stops at folds: snapping through them, an sscr search takes hours (docs/workspace.md)
    settings = WorkspaceSettings(n=s.models_n, seed=seed, voxel=robot.length / s.models_voxels, directions=0,
                                 multistability=0, reach="samples", folds="stop")
    r, loads = cases["paper wrench"]
    return out, {m: WorkspaceCaseSpec(r, loads, settings, m) for m in s.workspace_models}


def _section_settings(spec: WorkspaceCaseSpec) -> WorkspaceSettings:
    """A case of :func:`_section_cases`'s settings (each has its own)."""
    if spec.settings is None:
        raise AssertionError("a case of the reproduce workspace section has settings of its own")
    return spec.settings


def _run_section_cases(cases: _SectionCases, bounds: TensionBounds, hooks: Callable[[str], WorkspaceHooks],
                       prefix: str = "") -> list[WorkspaceCase]:
    """Each case of :func:`_section_cases` computed (:func:`_case`, the model's default options), its progress
    named ``prefix`` and the case's name."""
    return [_case(name, c.robot, c.loads, bounds, _section_settings(c), c.model or "pcc", None,
                  hooks(f"{prefix}{name}")) for name, c in cases.items()]


def section_check(robot: Robot, s: ReproduceSettings, *, seed: int = 0) -> None:
    """Every case of :func:`workspace_section` (and of its models' comparison) against its model's capabilities,
    before any solve (:func:`check_workspace_cases`: SettingsError naming ``workspace_models`` for a model of the
    comparison, ``robot`` for the section's own cases)."""
    cases, models = _section_cases(robot, s, seed)
    for field_name, group in (("robot", cases), ("workspace_models", models)):
        check_workspace_cases(group, WorkspaceSettings(), field_name=field_name)


def section_estimate(robot: Robot, bounds: TensionBounds, s: ReproduceSettings, *, seed: int = 0) -> Estimate:
    """The expected length of :func:`workspace_section` at the settings ``s``
    (:func:`~pytdcr.workspace.workspace_estimate`)."""
    cases, models = _section_cases(robot, s, seed)
    return workspace_estimate([(c.robot, c.loads, _section_settings(c), c.model or "pcc", None)
                               for c in [*cases.values(), *models.values()]], bounds)


def workspace_section(robot: Robot, bounds: TensionBounds, s: ReproduceSettings, out: Path, files: list[str], *,
                      seed: int = 0, progress: SectionProgress | None = None) -> WorkspaceSection:
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
    done = _run_section_cases(cases, bounds, hooks)
    files += _write_section(out, done, robot, "FSW, no load and the paper's wrench", "workspace_slices", meshes=True)
    return WorkspaceSection(s.workspace_n, _section_settings(cases["no load"]).voxel, s.workspace_budget,
                            tuple(_comparison(done)),
                            _models_section(robot, models, bounds, s, out, files, hooks) if models else None)


def _models_section(robot: Robot, models: _SectionCases, bounds: TensionBounds, s: ReproduceSettings,
                    out: Path, files: list[str], hooks: Callable[[str], WorkspaceHooks]) -> ModelsSection:
    """The FSWs of ``models`` (name → case: the paper's wrench, each model's own equilibria, continued where it
    can, at ``s.models_n`` samples and ``s.models_voxels`` voxels per length), compared: per model its volume
    with its error, per pair the Hausdorff distance and the share of each inside the other; writes
    ``workspace_models_slices`` (PNG, PDF)."""
    done = _run_section_cases(models, bounds, hooks, "model ")
    files += _write_section(out, done, robot, "FSW under the paper's wrench, by model", "workspace_models_slices")
    voxel = _section_settings(next(iter(models.values()))).voxel
    return ModelsSection(s.models_n, voxel, tuple(_comparison(done)), tuple(_pairs(done)))

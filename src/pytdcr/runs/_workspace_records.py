"""The files of a workspace run as typed records: ``workspace.json`` (:class:`WorkspaceRecord`) and, for
``tdcr workspace --compare-loads``/``--compare-models``/``--equilibria both``, ``comparison.json``
(:class:`WorkspaceComparison`, its rows :class:`CaseComparison`, :class:`PairComparison` and
:class:`FailedCase`), and ``tdcr reproduce``'s workspace section (:class:`WorkspaceSection`). Each writes today's
keys (``to_json``) with a ``schema_version`` where it is a file, and reads back any file a run wrote
(``from_json``; a file without ``schema_version`` is version 1), a missing key named by its path
(:class:`~pytdcr.records.RecordKeyError`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, fields
from typing import TypeVar

from ..records import JsonDict, JsonObject, RunWarning, check_schema, part
from ..workspace import WorkspaceSummary
from ..workspace.parts import RegionOverlap

__all__ = ["SCHEMA_VERSION", "WARNING_KINDS", "CaseComparison", "FailedCase", "ModelsSection", "PairComparison",
           "WorkspaceComparison", "WorkspaceRecord", "WorkspaceSection"]

#: the layout of ``workspace.json`` and ``comparison.json`` these records write and read
SCHEMA_VERSION = 1

#: a workspace run's warnings: code → the start of its text (:meth:`~pytdcr.records.RunWarning.from_text`)
WARNING_KINDS = {
    "root-missing": r"the robot (is not stable|did not converge) at zero tension",
    "search-budget": r"the boundary search stopped at its budget",
    "low-dimension": r"the (FSW|realisable region)'s tips span",
    "too-few-points": r"the (FSW|realisable region) holds \d+ feasible sample",
}

_R = TypeVar("_R")

_WORKSPACE, _COMPARISON, _REPRODUCE = "workspace.json", "comparison.json", "reproduce.json"


@dataclass(frozen=True, eq=False)
class WorkspaceRecord:
    """One case's ``workspace.json``: its numbers, the inputs that repeat it, its warnings and its files.

    Attributes
    ----------
    summary : WorkspaceSummary
        The numbers, with the meshes' names.
    inputs : dict
        The inputs record (robot, loads, bounds, seeds, solver options, the study's settings:
        :func:`pytdcr.runs.inputs_record`), passed through as the run wrote it.
    warnings : tuple of RunWarning
        Codes in :data:`WARNING_KINDS`.
    files : tuple of str
        The files of the case's folder (empty before they are written).
    """

    summary: WorkspaceSummary
    inputs: JsonDict
    warnings: tuple[RunWarning, ...]
    files: tuple[str, ...] = ()

    def to_json(self) -> JsonDict:
        """``workspace.json``: the numbers with the meshes, the inputs, the warnings' texts and, once written,
        the files."""
        out = {**self.summary.to_json(meshes=True), "inputs": self.inputs,
               "warnings": [w.text for w in self.warnings]}
        return {**out, "files": list(self.files)} if self.files else out

    @classmethod
    def from_json(cls, d: JsonObject) -> WorkspaceRecord:
        """The record of a ``workspace.json`` (any a run wrote); RecordKeyError naming a missing key."""
        def read(d: JsonObject) -> WorkspaceRecord:
            check_schema(d, _WORKSPACE, SCHEMA_VERSION)
            return cls(WorkspaceSummary.from_json(d), dict(d["inputs"]),
                       tuple(RunWarning.from_text(str(w), WARNING_KINDS) for w in d["warnings"]),
                       tuple(str(f) for f in d.get("files", ())))

        return part(_WORKSPACE, "", read, d)


@dataclass(frozen=True)
class CaseComparison:
    """One case's row of ``comparison.json``: its numbers, and how its FSW shrank and shifted from the first
    case's.

    Attributes
    ----------
    case, model, equilibria, stability_test : str
    volume_m3, volume_err_m3, realisable_m3, realisable_err_m3 : float
        The FSW's and the realisable region's volumes and errors [m^3].
    largest_reach_m : float or None
        [m]; ``reach_rule`` says what it is.
    reach_rule : str
    volume_ratio : float or None
        FSW volume over the first case's (None when that is 0).
    centroid_m, centroid_shift_m : tuple of float
        The FSW's centroid [m] and its shift from the first case's [m] (NaN without a region).
    folder : str
        The case's sub-folder.
    """

    case: str
    model: str
    equilibria: str
    stability_test: str
    volume_m3: float
    volume_err_m3: float
    realisable_m3: float
    realisable_err_m3: float
    largest_reach_m: float | None
    reach_rule: str
    volume_ratio: float | None
    centroid_m: tuple[float, ...]
    centroid_shift_m: tuple[float, ...]
    folder: str

    def to_json(self) -> JsonDict:
        """The row, today's keys in order."""
        return {**asdict(self), "centroid_m": list(self.centroid_m), "centroid_shift_m": list(self.centroid_shift_m)}

    @classmethod
    def from_json(cls, d: JsonObject) -> CaseComparison:
        """The row :meth:`to_json` wrote; KeyError naming a missing key."""
        values = {f.name: d[f.name] for f in fields(cls)}
        return cls(**{**values, "centroid_m": _floats(values["centroid_m"]),
                      "centroid_shift_m": _floats(values["centroid_shift_m"])})


def _floats(values: Iterable[float | None]) -> tuple[float, ...]:
    """A JSON list of numbers (null: NaN) as floats."""
    return tuple(float("nan") if v is None else float(v) for v in values)


@dataclass(frozen=True)
class PairComparison:
    """How the FSWs of cases ``a`` and ``b`` differ (:func:`pytdcr.workspace.region_overlap`)."""

    a: str
    b: str
    overlap: RegionOverlap

    def to_json(self) -> JsonDict:
        """``{"a", "b", **overlap}``."""
        return {"a": self.a, "b": self.b, **self.overlap.to_dict()}

    @classmethod
    def from_json(cls, d: JsonObject) -> PairComparison:
        """The pair :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["a"], d["b"], RegionOverlap(**{f.name: d[f.name] for f in fields(RegionOverlap)}))


@dataclass(frozen=True)
class FailedCase:
    """A case that failed while running, and why (one line)."""

    case: str
    error: str

    def to_json(self) -> JsonDict:
        """``{"case", "error"}``."""
        return {"case": self.case, "error": self.error}

    @classmethod
    def from_json(cls, d: JsonObject) -> FailedCase:
        """The case :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["case"], d["error"])


@dataclass(frozen=True)
class WorkspaceComparison:
    """``comparison.json``: a row per finished case, one per pair of them, the cases that failed, the files."""

    cases: tuple[CaseComparison, ...]
    pairs: tuple[PairComparison, ...]
    failed: tuple[FailedCase, ...]
    files: tuple[str, ...] = ()

    def to_json(self) -> JsonDict:
        """``comparison.json``'s object."""
        return {"schema_version": SCHEMA_VERSION, "cases": [c.to_json() for c in self.cases],
                "pairs": [p.to_json() for p in self.pairs], "failed": [f.to_json() for f in self.failed],
                "files": list(self.files)}

    @classmethod
    def from_json(cls, d: JsonObject) -> WorkspaceComparison:
        """The comparison of a ``comparison.json`` (any a run wrote); RecordKeyError naming a missing key."""
        def read(d: JsonObject) -> WorkspaceComparison:
            check_schema(d, _COMPARISON, SCHEMA_VERSION)
            return cls(_rows(_COMPARISON, "cases", CaseComparison.from_json, d),
                       _rows(_COMPARISON, "pairs", PairComparison.from_json, d),
                       _rows(_COMPARISON, "failed", FailedCase.from_json, d), tuple(str(f) for f in d.get("files", ())))

        return part(_COMPARISON, "", read, d)


def _rows(file: str, key: str, read: Callable[[JsonObject], _R], d: JsonObject) -> tuple[_R, ...]:
    """The rows of the list at ``key`` of ``d`` (an object of ``file``), each read by ``read``; a missing key is
    named with the row's index (``cases[1].volume_m3``)."""
    return tuple(part(file, f"{key}[{k}]", read, row) for k, row in enumerate(d[key]))


@dataclass(frozen=True)
class ModelsSection:
    """``tdcr reproduce``'s FSWs of several models under the paper's wrench (``workspace.models`` of
    ``reproduce.json``): base samples ``n``, the voxel [m], a row per model, a row per pair."""

    n: int
    voxel_m: float
    cases: tuple[CaseComparison, ...]
    pairs: tuple[PairComparison, ...]

    def to_json(self) -> JsonDict:
        """``{"n", "voxel_m", "cases", "pairs"}``."""
        return {"n": self.n, "voxel_m": self.voxel_m, "cases": [c.to_json() for c in self.cases],
                "pairs": [p.to_json() for p in self.pairs]}

    @classmethod
    def from_json(cls, d: JsonObject) -> ModelsSection:
        """The section :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(int(d["n"]), float(d["voxel_m"]), _rows(_REPRODUCE, "cases", CaseComparison.from_json, d),
                   _rows(_REPRODUCE, "pairs", PairComparison.from_json, d))


@dataclass(frozen=True)
class WorkspaceSection:
    """``tdcr reproduce``'s workspace section (``workspace`` of ``reproduce.json``'s ``summary``): the FSW under
    the paper's wrench next to no load at the demo's budget (base samples ``n``, the voxel [m], the boundary
    search's ``budget`` in solves), a row per load case, and the models' comparison when asked for."""

    n: int
    voxel_m: float
    budget: int
    cases: tuple[CaseComparison, ...]
    models: ModelsSection | None = None

    def to_json(self) -> JsonDict:
        """``{"n", "voxel_m", "budget", "cases"}``, and ``"models"`` when compared."""
        out: JsonDict = {"n": self.n, "voxel_m": self.voxel_m, "budget": self.budget,
                         "cases": [c.to_json() for c in self.cases]}
        return out if self.models is None else {**out, "models": self.models.to_json()}

    @classmethod
    def from_json(cls, d: JsonObject) -> WorkspaceSection:
        """The section :meth:`to_json` wrote; KeyError naming a missing key."""
        models = d.get("models")
        return cls(int(d["n"]), float(d["voxel_m"]), int(d["budget"]),
                   _rows(_REPRODUCE, "cases", CaseComparison.from_json, d),
                   None if models is None else part(_REPRODUCE, "models", ModelsSection.from_json, models))

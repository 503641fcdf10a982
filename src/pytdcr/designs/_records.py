"""A design's evaluation as one typed record (:class:`DesignRecord`, a :class:`CaseRow` per load case), made by
:func:`~pytdcr.designs.evaluate_design` wherever the design ran and written to its file ``designs/NNNNNN.json``
(``designs/reference.json`` for the base robot); JSON at one boundary: :meth:`DesignRecord.to_json` is the file's
record, key for key and in order (with ``schema_version`` first), and :meth:`DesignRecord.from_json` reads it back.

The records are frozen dataclasses of plain values (numbers, strings, tuples, dicts of numbers), so that a Dask
worker or a local process pickles them back to the run.

A file is input another hand may have edited: :meth:`DesignRecord.from_json` refuses anything but a record this
code writes (a key unknown or missing, a measure that is not a finite number or null, tensions that are not
finite numbers, another ``schema_version``) with a ValueError naming the key (a
:class:`~pytdcr.records.RecordKeyError` for a missing one). Whether a well-formed record is the one a study
writes for a given design (its index and values, one row per load case with the study's directions, the robot's
tendons) is :meth:`RecordShape.mismatch`'s question. A resumed run computes again a design whose file fails
either.

A study's summary (``summary.json``) is :class:`DesignsSummary`, its best designs :class:`BestDesign` and the load
cases without one :class:`Unranked`: written by :mod:`pytdcr.designs._report`, read back by
:meth:`DesignsSummary.from_json`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, cast

import numpy as np

from ..records import JsonDict, JsonObject, check_schema, part
from ..validate import finite_real
from ._spec import MEASURES, DesignStudy

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["SCHEMA_VERSION", "STATUSES", "BestDesign", "CaseRow", "DesignRecord", "DesignsSummary", "RecordShape",
           "Timing", "Unranked", "is_number", "same_params"]

#: the layout of a design's file this module writes and reads
SCHEMA_VERSION = 1
#: a design's status: evaluated under every load case, or failed (with a reason)
STATUSES = ("ok", "failed")
#: the file a record is read from, as errors name it
_FILE = "design record"
_read = partial(part, _FILE)
#: a row's key of h along a named direction
_H_KEY = re.compile(r"h_(.+)_m")


def is_number(v: object) -> bool:
    """``v`` is a finite JSON number (not a bool, a string, NaN, 1e400, nor an integer beyond the floats):
    :func:`~pytdcr.validate.finite_real`'s rule."""
    return finite_real(v) is not None


def _whole(v: object) -> bool:
    """``v`` is an integer of JSON (not a bool)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def same_params(got: object, planned: Mapping[str, float]) -> bool:
    """``got`` holds exactly the planned design's values: the same names, each the same number of the same JSON
    type (a whole-number parameter an integer, never ``true`` or ``3.0``; any other a number)."""
    if not isinstance(got, Mapping) or got.keys() != planned.keys():
        return False
    for name, want in planned.items():
        v = got[name]
        if not is_number(v) or (_whole(want) and not isinstance(v, int)) or v != want:
            return False
    return True


def _measure(d: Mapping[str, object], key: str) -> float:
    """The measure at ``key`` of a row: a finite number as written (an integer stays one), null as NaN."""
    v = d[key]
    if v is None:
        return math.nan
    if not is_number(v):
        raise ValueError(f"{_FILE}: {key} must be a finite number or null, got {str(v)[:40]!r}")
    return cast(float, v)  # a finite int or float (is_number): an integer stays one


def _check_keys(d: Mapping[str, object], known: set[str], where: str) -> None:
    """Refuse a key of ``d`` outside ``known``, naming it."""
    extra = sorted(str(k) for k in d.keys() - known)
    if extra:
        raise ValueError(f"{_FILE}: {where or 'the record'} holds the key {extra[0]!r}, which no record of this "
                         "version writes")


@dataclass(frozen=True)
class CaseRow:
    """One load case's numbers of a design: its workspace study's
    (:attr:`~pytdcr.workspace.WorkspaceStudy.summary`) and the robot's. A measure not computed is NaN (null in
    the file).

    Attributes
    ----------
    load_case : str
        The load case's name.
    volume_m3, volume_err_m3 : float
        The FSW's volume and its error [m^3].
    realisable_volume_m3, realisable_volume_err_m3 : float
        The realisable region's volume and its error [m^3].
    fsw_dimension : float
        The dimensions (0..3) the FSW's tips span at the voxel's resolution: an integer as the study writes it.
    fraction_converged : float
        Converged samples / samples solved (NaN for none solved).
    fraction_realisable : float
        Realisable samples / converged samples.
    peak_stress_pa : float
        The largest backbone bending stress E kappa r over the converged samples [Pa] (NaN for none converged).
    arc_length_m : float
        The robot's length [m].
    h_m : dict of str to float
        h(d) [m] along each of the study's named directions, by name (the file's ``h_<name>_m``), in order.
    largest_reach_m : float
        The largest ||tip|| [m] (NaN without a feasible sample).
    reach_tensions_n : tuple of float or None
        The tensions that reach farthest [N], one per tendon (not a column of the table: they draw the design);
        None when nothing was reached.
    """

    load_case: str
    volume_m3: float
    volume_err_m3: float
    realisable_volume_m3: float
    realisable_volume_err_m3: float
    fsw_dimension: float
    fraction_converged: float
    fraction_realisable: float
    peak_stress_pa: float
    arc_length_m: float
    h_m: dict[str, float]
    largest_reach_m: float
    reach_tensions_n: tuple[float, ...] | None

    def measure(self, name: str) -> float:
        """The measure ``name`` (a key of :data:`MEASURES` or ``h_<direction>_m``); NaN for a direction it does
        not hold."""
        if name in MEASURES:
            return getattr(self, name)  # as written: the dimension stays an integer
        m = _H_KEY.fullmatch(name)
        if m is None:
            raise KeyError(name)
        return self.h_m.get(m.group(1), math.nan)

    def measures(self) -> dict[str, float]:
        """Every measure by its column name: :data:`MEASURES`' then h's, as :meth:`measure` gives them."""
        return {**{m: getattr(self, m) for m in MEASURES}, **{f"h_{k}_m": v for k, v in self.h_m.items()}}

    def to_json(self) -> JsonDict:
        """The row as a design's file holds it: the load case, the measures (NaN is written null by
        :func:`~pytdcr.runtime.dump_json`), h along each direction, the largest reach and the farthest
        tensions."""
        return {"load_case": self.load_case, "volume_m3": self.volume_m3, "volume_err_m3": self.volume_err_m3,
                "realisable_volume_m3": self.realisable_volume_m3,
                "realisable_volume_err_m3": self.realisable_volume_err_m3, "fsw_dimension": self.fsw_dimension,
                "fraction_converged": self.fraction_converged, "fraction_realisable": self.fraction_realisable,
                "peak_stress_pa": self.peak_stress_pa, "arc_length_m": self.arc_length_m,
                **{f"h_{k}_m": v for k, v in self.h_m.items()}, "largest_reach_m": self.largest_reach_m,
                "reach_tensions_n": None if self.reach_tensions_n is None else list(self.reach_tensions_n)}

    @classmethod
    def from_json(cls, d: JsonObject) -> CaseRow:
        """The row :meth:`to_json` wrote: every measure a finite number or null (NaN), the tensions null or a
        list of finite numbers. KeyError for a missing key; ValueError for a key unknown or a value not one."""
        h_keys = {m.group(1): k for k in d if isinstance(k, str) and (m := _H_KEY.fullmatch(k))}  # name: key
        case, t = d["load_case"], d["reach_tensions_n"]
        if not isinstance(case, str):
            raise ValueError(f"{_FILE}: load_case must be a string")
        if t is not None and not (isinstance(t, list) and all(map(is_number, t))):
            raise ValueError(f"{_FILE}: reach_tensions_n must be null or a list of finite numbers")
        num = partial(_measure, d)
        measures = {m: num(m) for m in MEASURES}  # a missing one first: a renamed key is named as missing
        _check_keys(d, {"load_case", "reach_tensions_n", *MEASURES, *h_keys.values()}, "a row")
        return cls(case, **measures, h_m={name: num(k) for name, k in h_keys.items()},
                   reach_tensions_n=None if t is None else tuple(float(x) for x in t))


@dataclass(frozen=True)
class Timing:
    """Where and how long a design ran.

    Attributes
    ----------
    seconds : float
        Its wall time [s] (NaN when unknown: a design whose workers died).
    host : str
        The machine's name ("" when unknown).
    pid : int
        The process's id (-1 when unknown).
    """

    seconds: float
    host: str
    pid: int

    def to_json(self) -> JsonDict:
        """``{"seconds", "host", "pid"}``."""
        return {"seconds": self.seconds, "host": self.host, "pid": self.pid}

    @classmethod
    def from_json(cls, d: JsonObject) -> Timing:
        """What :meth:`to_json` wrote: seconds a finite number >= 0 or null (NaN), host a string, pid an
        integer. KeyError for a missing key; ValueError otherwise."""
        seconds, host, pid = d["seconds"], d["host"], d["pid"]
        _check_keys(d, {"seconds", "host", "pid"}, "timing")
        if not (seconds is None or (is_number(seconds) and seconds >= 0)) or not isinstance(host, str) or \
                not isinstance(pid, int) or isinstance(pid, bool):
            raise ValueError(f"{_FILE}: timing must hold seconds >= 0 (or null), a host's name and a pid")
        return cls(math.nan if seconds is None else float(seconds), host, pid)


@dataclass(frozen=True)
class DesignRecord:
    """One design's evaluation under every load case of its study.

    Attributes
    ----------
    design : int
        Its index in the study (-1: the base robot, the reference row).
    params : dict of str to float
        Its parameter values, by name (a whole-number parameter an int); empty for the reference.
    status : str
        ``"ok"`` or ``"failed"`` (:data:`STATUSES`).
    reason : str
        Why it failed ("" when ok).
    rows : tuple of CaseRow
        One per load case, in the study's order; none for a design that failed before its load cases.
    timing : Timing
        Where and how long it ran.
    generation : int
        The optimiser's generation that asked for it (0 for a grid or Sobol set; -1 until the run writes it, and
        for the reference).
    traceback : str or None
        The end of the traceback of a design whose evaluation raised (None otherwise).
    """

    design: int
    params: dict[str, float]
    status: str
    reason: str
    rows: tuple[CaseRow, ...]
    timing: Timing
    generation: int = -1
    traceback: str | None = None

    @property
    def ok(self) -> bool:
        """Whether it was evaluated under every load case."""
        return self.status == "ok"

    def row(self, case: str) -> CaseRow | None:
        """Its row of load case ``case`` (None when it has none)."""
        return next((r for r in self.rows if r.load_case == case), None)

    def to_json(self) -> JsonDict:
        """The record as its file holds it: ``schema_version``, design, params, status, reason, rows,
        traceback (when there is one), timing and generation."""
        out: JsonDict = {"schema_version": SCHEMA_VERSION, "design": self.design, "params": dict(self.params),
                         "status": self.status, "reason": self.reason, "rows": [r.to_json() for r in self.rows]}
        if self.traceback is not None:
            out["traceback"] = self.traceback
        return {**out, "timing": self.timing.to_json(), "generation": self.generation}

    @classmethod
    def from_json(cls, d: object) -> DesignRecord:
        """The record of a design's file (or of :meth:`to_json`), checked field by field.

        Raises
        ------
        RecordKeyError
            A key it must hold is missing (``design``, ``params``, ``status``, ``rows``, ``timing``, or one of a
            row's measures: ``rows[0].volume_m3``).
        ValueError
            ``d`` is not a JSON object, holds a key no record writes, another ``schema_version``, a status other
            than ok or failed, a design index or generation that is not an integer, parameter values that are
            not finite numbers, a measure that is not a finite number or null, or a malformed timing.
        """
        return _read("", _record, d)


def _record(d: JsonObject) -> DesignRecord:
    """:meth:`DesignRecord.from_json` of a JSON object ``d``."""
    check_schema(d, _FILE, SCHEMA_VERSION)
    design, params, status, rows, timing = d["design"], d["params"], d["status"], d["rows"], d["timing"]
    _check_keys(d, {"schema_version", "design", "params", "status", "reason", "rows", "timing", "generation",
                    "traceback"}, "")
    reason, generation, trace = d.get("reason", ""), d.get("generation", -1), d.get("traceback")
    if not isinstance(design, int) or isinstance(design, bool):
        raise ValueError(f"{_FILE}: design must be an integer, got {str(design)[:40]!r}")
    if status not in STATUSES or not isinstance(reason, str) or not (trace is None or isinstance(trace, str)):
        raise ValueError(f"{_FILE}: status must be ok or failed, reason and traceback strings")
    if not isinstance(params, Mapping) or not all(isinstance(k, str) and is_number(v) for k, v in params.items()):
        raise ValueError(f"{_FILE}: params must map names to finite numbers")
    if not isinstance(generation, int) or isinstance(generation, bool):
        raise ValueError(f"{_FILE}: generation must be an integer")
    if not isinstance(rows, list):
        raise ValueError(f"{_FILE}: rows must be a list")
    checked = tuple(_read(f"rows[{i}]", CaseRow.from_json, r) for i, r in enumerate(rows))
    return DesignRecord(design, dict(params), status, reason, checked, _read("timing", Timing.from_json, timing),
                        generation, trace)


@dataclass(frozen=True)
class RecordShape:
    """What a study's record of a design holds: its load cases (in order), the study's named directions (a
    row's ``h_<name>_m``) and the robot's tendons (the length of a row's ``reach_tensions_n``).

    Attributes
    ----------
    cases : tuple of str
    directions : tuple of str
    n_tendons : int
    """

    cases: tuple[str, ...]
    directions: tuple[str, ...]
    n_tendons: int

    @classmethod
    def of(cls, study: DesignStudy, robot: Robot) -> RecordShape:
        """The shape of ``study``'s records, base robot ``robot``."""
        return cls(tuple(study.load_cases(robot)), tuple(study.measures.directions), robot.n_tendons)

    @property
    def measures(self) -> tuple[str, ...]:
        """The measures of each row (:data:`MEASURES`, then h along each direction): the table's columns."""
        return (*MEASURES, *[f"h_{k}_m" for k in self.directions])

    def mismatch(self, rec: DesignRecord, index: int, params: Mapping[str, float]) -> str | None:
        """Why ``rec`` is not the record this study writes for design ``index`` of values ``params``: another
        design or other values (:func:`same_params`), rows other than one per load case in order (a failed
        design may have none), another set of directions, tensions not one per tendon; None when it is."""
        if rec.design != index or not same_params(rec.params, params):
            return f"a record of another design than {index} or of other values"
        if not (len(rec.rows) == len(self.cases) or (rec.status == "failed" and not rec.rows)):
            return f"{len(rec.rows)} rows, not one per load case ({len(self.cases)})"
        for row, case in zip(rec.rows, self.cases, strict=False):
            if row.load_case != case:
                return f"a row of load case {row.load_case!r} where the study's is {case!r}"
            if row.h_m.keys() != set(self.directions):
                return f"h along {sorted(row.h_m)}, not along the study's directions {sorted(self.directions)}"
            if row.reach_tensions_n is not None and len(row.reach_tensions_n) != self.n_tendons:
                return f"{len(row.reach_tensions_n)} tensions, not one per tendon ({self.n_tendons})"
        return None


@dataclass(frozen=True)
class BestDesign:
    """The best design under a load case, by the study's first objective (``summary.json``'s ``best``).

    Attributes
    ----------
    load_case : str
    design : int
        Its index.
    robot_file : str
        Its robot file in the run's folder (``best/design_NNNNNN.toml``).
    measure, goal : str
        The first objective's measure and goal (``"max"`` or ``"min"``).
    value : float
        Its value of the measure (in the measure's unit: m^3, m, Pa or a share).
    error : float or None
        The value's error (a volume's, m^3); None for a measure without one.
    """

    load_case: str
    design: int
    robot_file: str
    measure: str
    goal: str
    value: float
    error: float | None

    def to_json(self) -> JsonDict:
        """``summary.json``'s entry, key for key."""
        return {"load_case": self.load_case, "design": self.design, "robot_file": self.robot_file,
                "measure": self.measure, "goal": self.goal, "value": self.value, "error": self.error}

    @classmethod
    def from_json(cls, d: JsonObject) -> BestDesign:
        """What :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["load_case"], d["design"], d["robot_file"], d["measure"], d["goal"], d["value"], d["error"])


@dataclass(frozen=True)
class Unranked:
    """A load case under which no design is named best: the first objective's measure is 0 for every design
    (``summary.json``'s ``unranked``).

    Attributes
    ----------
    load_case, measure, goal : str
    reason : str
        Why, in words.
    """

    load_case: str
    measure: str
    goal: str
    reason: str

    def to_json(self) -> JsonDict:
        """``summary.json``'s entry, key for key."""
        return {"load_case": self.load_case, "measure": self.measure, "goal": self.goal, "reason": self.reason}

    @classmethod
    def from_json(cls, d: JsonObject) -> Unranked:
        """What :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["load_case"], d["measure"], d["goal"], d["reason"])


#: the file a study's summary is read from, as errors name it
_SUMMARY = "summary.json"


@dataclass(frozen=True)
class DesignsSummary:
    """What a design study's run did and found (``summary.json``).

    Attributes
    ----------
    study, digest : str
        The study's name; what the folder's designs rest on (:func:`~pytdcr.designs._run.run_digest`).
    seed : int
    designs, designs_reused, designs_computed, designs_failed : int
        Designs of the study (the reference not counted): all, reused from their files, computed, failed.
    reference : str
        The base robot's row: ``"ok"``, ``"failed"`` or ``"off"`` (not measured).
    load_cases : tuple of str
    executor : str
        Where the designs ran, in words.
    seconds : float
        The run's wall time [s].
    inputs : dict
        The study as JSON (its settings record, passed through unread).
    versions : dict of str to str
        The software that made it (:func:`~pytdcr.runtime.versions_record`).
    measures : dict of str to str
        The table's measures with their units (:func:`~pytdcr.designs.measures_for`).
    unranked : tuple of Unranked
        Load cases under which no design is named best.
    figures : tuple of str
        The figures' file names.
    best : tuple of BestDesign
        The best design under each ranked load case.
    warnings : tuple of str
        Load cases whose ranking rests on margins smaller than the volumes' errors, in words.
    """

    study: str
    digest: str
    seed: int
    designs: int
    designs_reused: int
    designs_computed: int
    designs_failed: int
    reference: str
    load_cases: tuple[str, ...]
    executor: str
    seconds: float
    inputs: JsonDict
    versions: dict[str, str]
    measures: dict[str, str]
    unranked: tuple[Unranked, ...] = ()
    figures: tuple[str, ...] = ()
    best: tuple[BestDesign, ...] = ()
    warnings: tuple[str, ...] = ()

    def to_json(self) -> JsonDict:
        """``summary.json``, key for key and in order, with ``schema_version`` first."""
        return {"schema_version": SCHEMA_VERSION, "study": self.study, "digest": self.digest, "seed": self.seed,
                "designs": self.designs, "designs_reused": self.designs_reused,
                "designs_computed": self.designs_computed, "designs_failed": self.designs_failed,
                "reference": self.reference, "load_cases": list(self.load_cases), "executor": self.executor,
                "seconds": self.seconds, "inputs": self.inputs, "versions": dict(self.versions),
                "measures": dict(self.measures), "unranked": [u.to_json() for u in self.unranked],
                "figures": list(self.figures), "best": [b.to_json() for b in self.best],
                "warnings": list(self.warnings)}

    @classmethod
    def from_json(cls, d: object) -> DesignsSummary:
        """A ``summary.json`` (or :meth:`to_json`). :class:`~pytdcr.records.RecordKeyError` naming the path of a
        missing key; ValueError for a part that is not a JSON object or another ``schema_version``. The keys a
        record without times and versions lacks (as the golden baselines keep them: ``executor``, ``seconds``,
        ``versions``) read as "", 0 and {}."""
        return part(_SUMMARY, "", _summary, d)


def _summary(d: JsonObject) -> DesignsSummary:
    """:meth:`DesignsSummary.from_json` of a JSON object ``d``."""
    check_schema(d, _SUMMARY, SCHEMA_VERSION)
    return DesignsSummary(
        d["study"], d["digest"], d["seed"], d["designs"], d["designs_reused"], d["designs_computed"],
        d["designs_failed"], d["reference"], tuple(d["load_cases"]), d.get("executor", ""), d.get("seconds", 0.0),
        part(_SUMMARY, "inputs", dict, d["inputs"]), dict(d.get("versions", {})),
        part(_SUMMARY, "measures", dict, d["measures"]),
        tuple(part(_SUMMARY, f"unranked[{i}]", Unranked.from_json, u) for i, u in enumerate(d["unranked"])),
        tuple(d["figures"]),
        tuple(part(_SUMMARY, f"best[{i}]", BestDesign.from_json, b) for i, b in enumerate(d["best"])),
        tuple(d["warnings"]))

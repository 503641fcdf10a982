"""``tdcr reproduce``'s result as typed records: :class:`ReproduceRun`, its parts :class:`SamplingRecord`
(Fig. 3(a)'s samples) and :class:`PassiveSolveRecord` (Fig. 3(b)'s passive solve), and the study's progress
callback :class:`Progress`.

JSON happens at one boundary: :meth:`ReproduceRun.to_json` is what ``reproduce.json`` holds (the keys of every
file written before, plus ``schema_version``: :data:`SCHEMA_VERSION`) and :meth:`ReproduceRun.from_json` reads
any ``reproduce.json`` back (a file without ``schema_version`` is version 1), a missing key raising
:class:`~pytdcr.records.RecordKeyError` naming its path (``summary.sampling.reach_max``,
``bounds_study[0].upper``). A non-finite number is written null (:func:`~pytdcr.runtime.to_jsonable`) and read
back as NaN; absent times (``seconds``, as the golden baselines drop them) read as 0.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, Protocol, overload

import numpy as np

from ..optimize import ReachResult
from ..records import JsonDict, JsonObject, check_schema, part
from ..runtime import to_jsonable
from ._survival import ModelVerdict
from ._workspace_records import WorkspaceSection

__all__ = ["SCHEMA_VERSION", "OnGeneration", "PassiveSolveRecord", "Progress", "ReproduceRun", "SamplingRecord",
           "Step"]

#: the layout of ``reproduce.json`` these records write and read
SCHEMA_VERSION = 1

#: the file the records' errors name
_FILE = "reproduce.json"

#: a stage's callback, advanced by the work done: ``step(k)``, ``k`` more units of the stage's work
Step = Callable[[int], None]
#: a GA stage's callback: ``on_generation(generation, best_cost, mean_cost)`` (costs [1/m])
OnGeneration = Callable[[int, float, float], None]


class Progress(Protocol):
    """``progress(stage, total, unit)``: the callback of the study's stage named ``stage``, of ``total`` steps of
    ``unit`` (None: not known). For ``unit`` ``"gen"`` (a GA's generations) an :data:`OnGeneration`, for any
    other unit (``"solve"``, ``"run"``) a :data:`Step`. The callback's ``close()``, where it has one, is called
    when the stage ends (:func:`~pytdcr.runtime.end_stage`)."""

    @overload
    def __call__(self, stage: str, total: int | None, unit: Literal["gen"]) -> OnGeneration: ...

    @overload
    def __call__(self, stage: str, total: int | None, unit: str) -> Step: ...


def _number(x: object) -> float:
    """A float of the file: null (a non-finite number, as :func:`~pytdcr.runtime.to_jsonable` writes it) as NaN."""
    if x is None:
        return float("nan")
    if isinstance(x, (int, float)):
        return float(x)
    raise ValueError(f"{_FILE}: a number was expected, got {type(x).__name__}")


@dataclass(frozen=True)
class SamplingRecord:
    """Fig. 3(a)'s random samples under the paper's load (``summary.sampling`` of ``reproduce.json``).

    Attributes
    ----------
    n : int
        Tension vectors sampled.
    converged : int
        Of them, the solves that converged.
    seconds : float
        Their solves' wall time [s].
    reach_max, reach_min : float
        The largest and smallest reach among the samples [m]; NaN when no sample has a reach.
    """

    n: int
    converged: int
    seconds: float
    reach_max: float
    reach_min: float

    @classmethod
    def of(cls, n: int, converged: np.ndarray, reach: np.ndarray, seconds: float) -> SamplingRecord:
        """The record of ``n`` samples: ``converged`` (n,) bool, ``reach`` (n,) [m] (NaN where not converged),
        solved in ``seconds`` [s]. The reach range ignores NaN, as ``np.nanmax``/``np.nanmin`` do, and is NaN
        (without numpy's warning) when every reach is NaN."""
        r = np.asarray(reach, dtype=float)
        r = r[~np.isnan(r)]
        hi, lo = (float(r.max()), float(r.min())) if r.size else (float("nan"), float("nan"))
        return cls(n, int(np.sum(converged)), float(seconds), hi, lo)

    def to_json(self) -> JsonDict:
        """``{"n", "converged", "seconds", "reach_max", "reach_min"}`` (a NaN reach as null)."""
        return to_jsonable({"n": self.n, "converged": self.converged, "seconds": self.seconds,
                            "reach_max": self.reach_max, "reach_min": self.reach_min})

    @classmethod
    def from_json(cls, d: JsonObject) -> SamplingRecord:
        """The record :meth:`to_json` wrote (null reach: NaN; absent ``seconds``: 0); KeyError naming a missing
        key."""
        return cls(int(d["n"]), int(d["converged"]), _number(d.get("seconds", 0.0)), _number(d["reach_max"]),
                   _number(d["reach_min"]))


@dataclass(frozen=True)
class PassiveSolveRecord:
    """Fig. 3(b)'s solve: the robot under the paper's load with every tension 0 (``summary.passive`` of
    ``reproduce.json``).

    Attributes
    ----------
    converged : bool
    tip : tuple of 3 float or None
        The tip position [m], None when the solve did not converge.
    reach : float or None
        ||tip|| [m], None when the solve did not converge.
    """

    converged: bool
    tip: tuple[float, float, float] | None = None
    reach: float | None = None

    @classmethod
    def of(cls, converged: bool, tip_position: np.ndarray, reach: float) -> PassiveSolveRecord:
        """The record of a solve: its tip (3,) [m] and reach [m] kept only where it ``converged``."""
        if not converged:
            return cls(False)
        x, y, z = (float(v) for v in np.asarray(tip_position, dtype=float).reshape(3))
        return cls(True, (x, y, z), float(reach))

    def to_json(self) -> JsonDict:
        """``{"converged", "tip", "reach"}`` (tip and reach null without a converged solve)."""
        return to_jsonable({"converged": self.converged, "tip": None if self.tip is None else list(self.tip),
                            "reach": self.reach})

    @classmethod
    def from_json(cls, d: JsonObject) -> PassiveSolveRecord:
        """The record :meth:`to_json` wrote; KeyError naming a missing key; ValueError for a tip that is not 3
        numbers."""
        tip, reach = d["tip"], d["reach"]
        converged, reach_m = bool(d["converged"]), None if reach is None else _number(reach)
        if tip is None:
            return cls(converged, None, reach_m)
        if not isinstance(tip, list) or len(tip) != 3:
            raise ValueError(f"{_FILE}: passive.tip must be a list of 3 numbers, got {tip!r}")
        x, y, z = (_number(v) for v in tip)
        return cls(converged, (x, y, z), reach_m)


@dataclass(frozen=True)
class ReproduceRun:
    """What :func:`~pytdcr.runs.run_reproduce` produced, and what ``reproduce.json`` holds.

    Attributes
    ----------
    seed : int
    files : list of str
        Every file written, in order (``report.md`` last but for ``reproduce.json``).
    sampling : SamplingRecord
        Fig. 3(a)'s samples: n, converged, reach range [m], time [s].
    passive : PassiveSolveRecord
        Fig. 3(b)'s passive solve.
    workspace : WorkspaceSection
        The workspace section.
    seconds : float
        The whole run [s].
    ga : dict of int to ReachResult
        The GA under the paper's load, by population.
    payload : ReachResult
        The GA under a payload hanging along the robot's gravity (:func:`~pytdcr.paper.payload_loads`).
    bounds_study : list of (float, ReachResult)
        The optimum by upper tension bound [N].
    verdicts : list of ModelVerdict
        The optimum under the better models.
    inputs : dict
        The inputs record (robot, loads, bounds, seed, the payload's mass, the settings, the solver options:
        :func:`~pytdcr.runs.inputs_record`), passed through to ``reproduce.json`` as the run wrote it; empty
        until the run writes that file.
    """

    seed: int
    files: list[str]
    sampling: SamplingRecord
    passive: PassiveSolveRecord
    workspace: WorkspaceSection
    seconds: float
    ga: dict[int, ReachResult]
    payload: ReachResult
    bounds_study: list[tuple[float, ReachResult]]
    verdicts: list[ModelVerdict]
    inputs: JsonDict = field(default_factory=dict)

    def summary(self) -> JsonDict:
        """Seed, files, sampling, passive solve and workspace section (``reproduce.json``'s ``summary``)."""
        return {"seed": self.seed, "files": list(self.files), "sampling": self.sampling.to_json(),
                "passive": self.passive.to_json(), "workspace": self.workspace.to_json()}

    def to_dict(self) -> JsonDict:
        """:meth:`summary` and the run's time [s]."""
        return {**self.summary(), "seconds": self.seconds}

    def to_json(self) -> JsonDict:
        """``reproduce.json``: ``schema_version``, ``inputs``, ``summary``, ``ga`` (by population, as text),
        ``payload``, ``bounds_study`` (each optimum with its ``upper`` bound [N]), ``better_models`` and
        ``seconds``, by :func:`~pytdcr.runtime.to_jsonable`'s rule (a non-finite number as null)."""
        return to_jsonable({
            "schema_version": SCHEMA_VERSION,
            "inputs": self.inputs,
            "summary": self.summary(),
            "ga": {str(p): r.to_json() for p, r in self.ga.items()},
            "payload": self.payload.to_json(),
            "bounds_study": [{"upper": hi, **r.to_json()} for hi, r in self.bounds_study],
            "better_models": [v.to_json() for v in self.verdicts],
            "seconds": self.seconds,
        })

    @classmethod
    def from_json(cls, d: JsonObject) -> ReproduceRun:
        """The run of a ``reproduce.json`` (any a run wrote). :class:`~pytdcr.records.RecordKeyError` naming the
        path of a missing key; ValueError for a part that is not a JSON object or another ``schema_version``
        than :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> ReproduceRun:
            check_schema(d, _FILE, SCHEMA_VERSION)
            seed, files, sampling, passive, workspace = part(_FILE, "summary", _summary, d["summary"])
            ga = part(_FILE, "ga", _by_population, d["ga"])
            bounds = [part(_FILE, f"bounds_study[{k}]", _bound_row, row)
                      for k, row in enumerate(_list(d, "bounds_study"))]
            verdicts = [part(_FILE, f"better_models[{k}]", ModelVerdict.from_json, row)
                        for k, row in enumerate(_list(d, "better_models"))]
            return cls(seed, files, sampling, passive, workspace, _number(d.get("seconds", 0.0)), ga,
                       part(_FILE, "payload", ReachResult.from_json, d["payload"]), bounds, verdicts,
                       part(_FILE, "inputs", dict, d["inputs"]))

        return part(_FILE, "", read, d)


def _list(d: JsonObject, key: str) -> list[object]:
    """The JSON list at ``key`` of ``d``; KeyError when absent, ValueError naming it when not a list."""
    rows = d[key]
    if not isinstance(rows, list):
        raise ValueError(f"{_FILE}: {key} must be a JSON list, got {type(rows).__name__}")
    return rows


def _summary(d: JsonObject) -> tuple[int, list[str], SamplingRecord, PassiveSolveRecord, WorkspaceSection]:
    """``summary``'s seed, files, sampling, passive solve and workspace section."""
    return (int(d["seed"]), [str(f) for f in _list(d, "files")],
            part(_FILE, "sampling", SamplingRecord.from_json, d["sampling"]),
            part(_FILE, "passive", PassiveSolveRecord.from_json, d["passive"]),
            part(_FILE, "workspace", WorkspaceSection.from_json, d["workspace"]))


def _by_population(d: JsonObject) -> dict[int, ReachResult]:
    """``ga``: the GA's results by population (keys, JSON text, read as int)."""
    return {int(p): part(_FILE, p, ReachResult.from_json, r) for p, r in d.items()}


def _bound_row(d: JsonObject) -> tuple[float, ReachResult]:
    """A row of ``bounds_study``: its upper bound [N] and the optimum there."""
    return float(d["upper"]), ReachResult.from_json(d)

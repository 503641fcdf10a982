"""``tdcr compare``: two or more models on the same cases, with a table, a Markdown summary and an overlay figure.

What a run writes in ``compare.json`` is one typed result, :class:`CompareResult`: the run's inputs, the cases'
source (:class:`CaseSource`), the comparison's numbers (:class:`~pytdcr.compare.ComparisonSummary`) and the files;
:meth:`CompareResult.to_json` writes the file's keys and :meth:`CompareResult.from_json` reads any file a run wrote
(``schema_version`` :data:`SCHEMA_VERSION`; a file without one is version 1, the same layout). A missing key raises
:class:`~pytdcr.records.RecordKeyError` naming its path (``summary.cosserat_difference_max_mm``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..bounds import TensionBounds
from ..compare import ComparisonSummary, ModelComparison, compare_models
from ..loads import Loads
from ..plotting import plot_model_overlay, save_figure
from ..records import JsonDict, JsonObject, check_schema, part
from ..robot import NoFriction, Robot
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import get_models, options_record, resolve, saving
from ._output import inputs_record, markdown_table
from ._reproduce_report import number_text
from ._settings import CompareSettings

__all__ = ["SCHEMA_VERSION", "CaseSource", "CompareResult", "CompareRun", "run_compare"]

#: cases drawn in the overlay figure
N_OVERLAY = 4
#: the layout of ``compare.json`` this module writes and reads
SCHEMA_VERSION = 1
#: the file these records are read from, as errors name it
_FILE = "compare.json"
_read = partial(part, _FILE)
#: how a source of given tension vectors describes itself (:meth:`CompareSettings.tensions`)
_GIVEN = re.compile(r"\d+ given tension vectors")
#: the keys of a source in ``compare.json``'s ``inputs`` (and in the manifest's)
SOURCE_KEYS = ("cases", "bounds", "seed")


@dataclass(frozen=True, eq=False)
class CaseSource:
    """What the cases of a comparison are.

    Attributes
    ----------
    cases : str
        In words, as ``compare.json``'s ``inputs.cases`` holds it: the file's path (``kind`` ``"file"``),
        ``"B given tension vectors"`` (``"given"``) or ``"B random within bounds, seed S"`` (``"random"``).
    bounds : TensionBounds or None
        The box random cases were drawn from [N] (None unless random).
    seed : int or None
        Their random seed (None unless random).
    """

    cases: str
    bounds: TensionBounds | None = None
    seed: int | None = None

    @property
    def kind(self) -> Literal["file", "given", "random"]:
        """``"random"`` (drawn within bounds with a seed), ``"given"`` (an array) or ``"file"`` (read from one)."""
        if self.seed is not None:
            return "random"
        return "given" if _GIVEN.fullmatch(self.cases) else "file"

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``cases``, with ``bounds`` (``lower``, ``upper`` [N]) and ``seed`` when random."""
        out: dict[str, Any] = {"cases": self.cases}
        if self.bounds is not None:
            out["bounds"] = self.bounds.to_dict()
        if self.seed is not None:
            out["seed"] = self.seed
        return out

    @classmethod
    def from_json(cls, d: JsonObject) -> CaseSource:
        """The source :meth:`to_json` wrote (or the ``inputs`` holding it, other keys ignored); KeyError naming a
        missing key. Random cases need both ``bounds`` and ``seed``."""
        seed = d.get("seed")
        if seed is None and "bounds" not in d:
            return cls(str(d["cases"]))
        b = _read("bounds", lambda b: TensionBounds(b["lower"], b["upper"]), d["bounds"])
        return cls(str(d["cases"]), b, int(d["seed"]))


@dataclass(frozen=True, eq=False)
class CompareResult:
    """What a comparison run records (``compare.json``).

    Attributes
    ----------
    inputs : dict
        The run's inputs but the cases' source, as written (versions, robot, loads, the tensions [N], the
        solvers' options: :func:`~pytdcr.runs._output.inputs_record`); passed through to the file unread.
    source : CaseSource
        What the cases are (in the file, within ``inputs``).
    summary : ComparisonSummary
        The comparison's numbers.
    files : tuple of str
        The files written beside ``compare.json``.
    """

    inputs: Mapping[str, Any]
    source: CaseSource
    summary: ComparisonSummary
    files: tuple[str, ...]

    def to_json(self) -> JsonDict:
        """``compare.json``: ``schema_version``, ``inputs`` (the source's keys before the solvers' options, as a
        run writes them), ``summary`` and ``files``."""
        inputs = {k: v for k, v in self.inputs.items() if k != "solvers"}
        inputs.update(self.source.to_json())
        if "solvers" in self.inputs:
            inputs["solvers"] = self.inputs["solvers"]
        return {"schema_version": SCHEMA_VERSION, "inputs": inputs, "summary": self.summary.to_json(),
                "files": list(self.files)}

    @classmethod
    def from_json(cls, d: object) -> CompareResult:
        """The record of a ``compare.json`` (or of :meth:`to_json`): :class:`~pytdcr.records.RecordKeyError`
        naming the path of a missing key; ValueError for a part that is not a JSON object or another
        ``schema_version`` than :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> CompareResult:
            check_schema(d, _FILE, SCHEMA_VERSION)
            inputs = _read("inputs", dict, d["inputs"])
            return cls({k: v for k, v in inputs.items() if k not in SOURCE_KEYS},
                       _read("inputs", CaseSource.from_json, inputs),
                       _read("summary", ComparisonSummary.from_json, d["summary"]),
                       tuple(str(f) for f in d["files"]))

        return _read("", read, d)


@dataclass(frozen=True)
class CompareRun:
    """What :func:`run_compare` produced.

    Attributes
    ----------
    robot : Robot
        The robot every model solved (its friction turned off when ``friction_off`` names models).
    comparison : ModelComparison
    files : list of str
    source : CaseSource
        What the cases are (a file, given, or random within bounds with a seed), as ``compare.json`` records.
    friction_off : tuple of str
        The models without friction for which the robot's own friction law was turned off, for every model
        (empty if it was not).
    """

    robot: Robot
    comparison: ModelComparison
    files: list[str]
    source: CaseSource
    friction_off: tuple[str, ...] = ()

    def to_dict(self) -> JsonDict:
        """JSON-ready: the robot's name, the cases' source, the summary (as in ``compare.json``), the files."""
        return {"robot": self.robot.name, "source": self.source.to_json(), "friction_off": list(self.friction_off),
                "summary": self.comparison.summary().to_json(), "files": list(self.files)}


def _comparable(robot: Robot, settings: CompareSettings) -> tuple[Robot, tuple[str, ...]]:
    """The robot's own friction law is turned off (for every model) when one of the models has none; a friction
    asked for explicitly is left to the registry (which refuses it for such a model)."""
    frictionless = tuple(m.name for m in get_models(settings.models) if not m.capabilities.friction)
    if robot.friction.is_frictionless or not frictionless or settings.robot.explicit_friction:
        return robot, ()
    return robot.with_friction(NoFriction()), frictionless


def run_compare(settings: CompareSettings, out: str | Path, *, robot: Robot | None = None,
                loads: Loads | None = None, progress: Callable[[int, int], None] | None = None) -> CompareRun:
    """Every model on every case: ``compare.csv``, ``compare.md``, ``compare.json`` and the overlay figure in
    ``out`` (the output-folder rule; an interrupted comparison saves nothing).

    ``robot`` and ``loads`` are built from ``settings`` unless given; every model is checked against them and
    the cases are read before any work. ``progress`` is called after each case with the cases done and their
    number.
    """
    base = robot if robot is not None else settings.robot.build()
    robot, off = _comparable(base, settings)
    loads = loads if loads is not None else settings.loads.build(robot)
    options = {name: spec.options() for name, spec in settings.model_specs().items()}
    for name in settings.models:
        resolve(name, robot, loads, options[name])  # refuses before any work
    T, record = settings.tensions(robot)
    source = CaseSource.from_json(record)
    done = [0]

    def step() -> None:
        done[0] += 1
        progress(done[0], len(T))  # type: ignore[misc]

    with output_folder(out, "compare", {"models": list(settings.models), **source.to_json()}) as run:
        cmp = compare_models(robot, loads, T, models=settings.models, options=options,
                             progress=step if progress is not None else None)
        with saving():
            files = _write_compare(run.staging, cmp, robot, loads, source, options)
    return CompareRun(robot, cmp, files, source, off)


def _compare_markdown(cmp: ModelComparison, robot: Robot, loads: Loads, source: CaseSource | None) -> str:
    """``compare.md``: what was compared, the typed summaries' numbers and a row per case
    (:meth:`~pytdcr.compare.ModelComparison.cases`); without a ``source`` the cases read "random"."""
    per = cmp.summaries()
    ref = cmp.reference

    def fmt(v: float | None) -> str:
        return "n/a" if v is None else number_text(v)

    rows = []
    for case in cmp.cases():  # differences as text: 3 decimals, never a non-zero one as 0 (a NaN stays: n/c)
        row = case.to_row()
        for d in case.differences:
            for key, v in ((f"{d.model}_difference_mm", d.mm), (f"{d.model}_difference_pct_length", d.pct_length)):
                row[key] = number_text(v) if np.isfinite(v) else v
        rows.append(row)
    cols = [("case", "case", "d")]
    for name in cmp.models:
        cols += [(f"{name}_{a}_m", f"{name} {a} [m]", ".5f") for a in "xyz"]
    for name in cmp.others:
        cols += [(f"{name}_difference_mm", f"{name} diff [mm]", ""),
                 (f"{name}_difference_pct_length", f"{name} diff [% L]", "")]
    cols += [(f"{name}_ms", f"{name} [ms]", ".2f") for name in cmp.models]
    text = [
        f"# Models compared: robot '{robot.name}'", "",
        f"{len(cmp)} cases ({source.cases if source else 'random'}), tip force {loads.tip_force.tolist()} N, "
        f"tip moment {loads.tip_moment.tolist()} N m, gravity {list(robot.gravity)} m/s^2, friction law "
        f"`{robot.friction.law}`. Every model follows the loading path from the unloaded robot; differences are "
        f"tip distances from `{ref}`.", "",
        f"- every model converged: {cmp.n_all_converged} of {len(cmp)} ("
        + ", ".join(f"{n} failed {s.not_converged}" for n, s in per.items()) + ")",
    ]
    for name in cmp.others:
        s = per[name]
        text.append(f"- `{name}` from `{ref}`: median {fmt(s.difference_median_mm)} mm "
                    f"({fmt(s.difference_median_pct_length)} % of the {robot.length:g} m "
                    f"length), max {fmt(s.difference_max_mm)} mm")
    text.append("- median solve time: " + ", ".join(f"{n} {s.ms_median:.2f} ms" for n, s in per.items()))
    text += ["", "n/c: that model did not converge on the case (its residual is in compare.csv).", "",
             markdown_table(rows, cols), ""]
    return "\n".join(text)


def _write_compare(out: Path, cmp: ModelComparison, robot: Robot, loads: Loads, source: CaseSource,
                   options: Mapping[str, object]) -> list[str]:
    """The comparison's files in ``out``: the table, the report, the overlay figure and ``compare.json`` (a
    :class:`CompareResult`); their names."""
    rows = cmp.rows()
    files = ["compare.csv", "compare.md"]
    write_csv(out / "compare.csv", list(rows[0]),
              ([(f"{v:.12g}" if isinstance(v, float) else v) for v in r.values()] for r in rows))
    atomic_write_text(out / "compare.md", _compare_markdown(cmp, robot, loads, source))
    shown = np.flatnonzero(cmp.all_converged)[:N_OVERLAY]
    groups = [[cmp.solutions[name][k] for name in cmp.models] for k in shown]
    ax = plot_model_overlay(robot, groups, labels=cmp.models, case_ids=[int(k) + 1 for k in shown])
    ax.set_title(f"{robot.name}: " + ", ".join(f"{n} ({s})" for n, s in zip(cmp.models, ("solid", "dashed", "dotted",
                                                                                          "dash-dot"), strict=False))
                 + f"; {len(groups)} cases")
    files += save_figure(ax.figure, out, "fig_compare")
    solvers = {name: options_record(name, options.get(name)) for name in cmp.models}
    result = CompareResult(inputs_record(robot, loads, tensions=cmp.tensions, solvers=solvers), source,
                           cmp.summary(), tuple(files))
    write_json(out / "compare.json", result.to_json())
    return [*files, "compare.json"]

"""``tdcr accuracy``: the accuracy table of every model against the subsegment Cosserat rod, and the order study.

What a run writes in ``accuracy.json`` is one typed result, :class:`AccuracyResult`: the run's inputs, the
study's numbers (:class:`~pytdcr.accuracy.AccuracySummary`) and the files; :meth:`AccuracyResult.to_json` writes
the file's keys and :meth:`AccuracyResult.from_json` reads any file a run wrote (``schema_version``
:data:`SCHEMA_VERSION`; a file without one is version 1, the same layout). A missing key raises
:class:`~pytdcr.records.RecordKeyError` naming its path (``summary.rows[0].median_error_mm``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..accuracy import (
    AccuracyStudy,
    AccuracySummary,
    LoadGroup,
    OrderStudy,
    check_accuracy_plan,
    model_accuracy,
    order_study,
    reference_options,
)
from ..bounds import TensionBounds
from ..loads import Loads
from ..plotting import plot_order, save_figure
from ..records import JsonDict, JsonObject, check_schema, part
from ..robot import Robot
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import saving
from ._output import inputs_record
from ._reproduce_report import number_text
from ._settings import AccuracySettings

__all__ = ["SCHEMA_VERSION", "AccuracyResult", "AccuracyRun", "accuracy_markdown", "run_accuracy"]

#: the layout of ``accuracy.json`` this module writes and reads
SCHEMA_VERSION = 1
#: the file these records are read from, as errors name it
_FILE = "accuracy.json"
_read = partial(part, _FILE)


@dataclass(frozen=True)
class AccuracyResult:
    """What an accuracy run records (``accuracy.json``).

    Attributes
    ----------
    inputs : mapping
        The run's inputs as written (versions, robot, loads, the tensions [N], bounds, seed, load groups, models,
        disks, order cases, reference steps: :func:`~pytdcr.runs._output.inputs_record`); passed through to the
        file unread.
    summary : AccuracySummary
        The study's numbers.
    files : tuple of str
        The files written beside ``accuracy.json``.
    """

    inputs: Mapping[str, Any]
    summary: AccuracySummary
    files: tuple[str, ...]

    def to_json(self) -> JsonDict:
        """``accuracy.json``: ``schema_version``, ``inputs``, ``summary`` and ``files``."""
        return {"schema_version": SCHEMA_VERSION, "inputs": dict(self.inputs), "summary": self.summary.to_json(),
                "files": list(self.files)}

    @classmethod
    def from_json(cls, d: object) -> AccuracyResult:
        """The record of an ``accuracy.json`` (or of :meth:`to_json`): :class:`~pytdcr.records.RecordKeyError`
        naming the path of a missing key; ValueError for a part that is not a JSON object or list, or another
        ``schema_version`` than :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> AccuracyResult:
            check_schema(d, _FILE, SCHEMA_VERSION)
            return cls(_read("inputs", dict, d["inputs"]), _read("summary", AccuracySummary.from_json, d["summary"]),
                       tuple(str(f) for f in d["files"]))

        return _read("", read, d)


@dataclass(frozen=True)
class AccuracyRun:
    """What :func:`run_accuracy` produced.

    Attributes
    ----------
    study : AccuracyStudy
        Every model under every load group against the reference.
    orders : list of OrderStudy
        The order study of each group (empty without one).
    files : list of str
    """

    study: AccuracyStudy
    orders: list[OrderStudy]
    files: list[str]

    def summary(self) -> AccuracySummary:
        """The rows, time and orders as one typed result (``accuracy.json``'s ``summary`` is its
        :meth:`~pytdcr.accuracy.AccuracySummary.to_json`)."""
        return self.study.summary(self.orders)

    def to_dict(self) -> JsonDict:
        """:meth:`summary` (JSON-ready) and the files."""
        return {**self.summary().to_json(), "files": list(self.files)}


def _fmt(x: float, decimals: int = 3) -> str:
    """``x`` with ``decimals`` decimals, never a non-zero value as 0 (:func:`number_text`); "-" if not finite."""
    return "-" if not np.isfinite(x) else number_text(x, decimals)


def _per_segment(disks: int, steps: int) -> int:
    """The reference's Runge-Kutta steps over a segment of ``disks`` disks, asked for ``steps`` per segment (at
    least 4 per subsegment: :func:`pytdcr.accuracy.reference_options`)."""
    return reference_options(disks, steps).steps_per_subsegment * disks


def _reference_steps(robot: Robot, steps: int) -> str:
    """The reference's integration as used on ``robot`` (``steps`` asked for per segment of its most disks)."""
    per = max(s.n_disks for s in robot.segments)
    k = reference_options(per, steps).steps_per_subsegment
    used = sorted({k * s.n_disks for s in robot.segments})
    return (f"{k} Runge-Kutta steps per subsegment between its disks ({' or '.join(map(str, used))} per segment; "
            f"{steps} asked for, at least 4 per subsegment)")


def accuracy_markdown(study: AccuracyStudy, orders: Sequence[OrderStudy], source: str) -> str:
    """The accuracy table and the order study as Markdown."""
    why = study.nothing_compared()
    lines = [
        f"# Which model to trust: robot '{study.robot.name}'", "",
        *([f"**Nothing could be compared:** {why}; the table below holds no tip error.", ""] if why else []),
        f"{len(study.tensions)} tension vectors ({source}), solved by every model under each load group; the "
        f"reference is `sscr` of the same robot with {_reference_steps(study.robot, study.reference_steps)}. Tip "
        f"error: distance from the reference's tip. Friction law: `{study.robot.friction.law}`.", "",
        "| load group | model | median error [mm] | 95th percentile [mm] | max [mm] | converged | median time [ms] |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in study.rows():
        if r.unsupported:
            lines.append(f"| {r.group} | {r.model} | unsupported: {r.unsupported.split('; ')[0]} | | | | |")
            continue
        lines.append(f"| {r.group} | {r.model} | {_fmt(r.median_error_mm)} | {_fmt(r.p95_error_mm)} | "
                     f"{_fmt(r.max_error_mm)} | {r.converged}/{r.reference_converged} | {_fmt(r.median_ms, 2)} |")
    if orders:
        disks = orders[0].disks
        lines += ["", "## Order of convergence against `sscr` of the same robot", "",
                  f"Median tip error over {orders[0].cases} tension vectors [mm], by disks per segment (same lengths, "
                  "routing and total disk mass); the order is the slope of log(error) on log(spacing) "
                  "(`fig_order.png`). The reference's Runge-Kutta steps per segment: "
                  + ", ".join(f"{_per_segment(d, study.reference_steps)} with {d} disks" for d in disks) + ".", "",
                  "| load group | model | " + " | ".join(f"{d} disks" for d in disks) + " | order |",
                  "|---|---|" + "---:|" * (len(disks) + 1)]
        for st in orders:
            for name, e in st.errors_mm.items():
                lines.append(f"| {st.group} | {name} | " + " | ".join(_fmt(x, 4) for x in e)
                             + f" | {_fmt(st.order[name], 2)} |")
    lines.append("")
    return "\n".join(lines)


def run_accuracy(settings: AccuracySettings, out: str | Path, *, robot: Robot | None = None,
                 groups: Sequence[LoadGroup] | None = None,
                 progress: Callable[[str], None] | None = None) -> AccuracyRun:
    """The accuracy table and the order study; writes CSV, Markdown, the log-log figure and JSON in ``out``
    (the output-folder rule; an interrupted study saves nothing).

    ``robot`` is built from ``settings`` unless given, ``groups`` default to the settings' (:meth:`AccuracySettings
    .groups`). Every robot the study will build is checked first (:func:`pytdcr.accuracy.check_accuracy_plan`).
    ``progress`` is called with a label after each step (:attr:`AccuracySettings.steps` in all).
    """
    s = settings
    robot = robot if robot is not None else s.robot.build()
    check_accuracy_plan(robot, models=s.models, disks=s.disks, reference_steps=s.reference_steps,
                        order=s.order_cases > 0)
    b = s.bounds.build(robot)
    T = b.sample(s.n, np.random.default_rng(s.seed))
    groups = tuple(groups or s.groups())
    with output_folder(out, "accuracy", {"n": s.n, "seed": s.seed, "bounds": b.to_dict()}) as run:
        study = model_accuracy(robot, T, groups=groups, models=s.models, reference_steps=s.reference_steps,
                               progress=progress)
        orders = [order_study(robot, T[:s.order_cases], g, disks=s.disks, reference_steps=s.reference_steps,
                              progress=progress) for g in groups] if s.order else []
        with saving():
            files = _write_accuracy(run.staging, AccuracyRun(study, orders, []), s, T, b, groups)
    return AccuracyRun(study, orders, files)


def _write_accuracy(out: Path, run: AccuracyRun, s: AccuracySettings, T: np.ndarray, b: TensionBounds,
                    groups: Sequence[LoadGroup]) -> list[str]:
    """The study's files in ``out``: the table, the report, the order study's table and figure (with one) and
    ``accuracy.json`` (an :class:`AccuracyResult`); their names."""
    study, robot = run.study, run.study.robot
    summary = run.summary()
    files = ["accuracy.csv", "accuracy.md"]
    rows = [r.to_json() for r in summary.rows]
    write_csv(out / "accuracy.csv", list(rows[0]), (list(r.values()) for r in rows))
    source = f"uniform in [{b.lower.min():g}, {b.upper.max():g}] N, seed {s.seed}"
    atomic_write_text(out / "accuracy.md", accuracy_markdown(study, run.orders, source))
    if summary.orders:
        write_csv(out / "order.csv", ["group", "model", "disks_per_segment", "spacing_m", "median_error_mm", "order"],
                  ([o.group, f.model, d, f"{h:.6g}", f"{x:.6g}", f"{f.order:.4f}"]
                   for o in summary.orders for f in o.fits
                   for d, h, x in zip(o.disks, o.spacing_m, f.errors_mm, strict=True)))
        files.append("order.csv")
        ax = plot_order(run.orders)
        ax.set_title(f"{robot.name}: PCC models against sscr as the disks multiply")
        files += save_figure(ax.figure, out, "fig_order")
    inputs = inputs_record(robot, Loads(np.zeros(robot.n_tendons)), tensions=T, bounds=b.to_dict(), seed=s.seed,
                           groups=[asdict(g) for g in groups], models=list(study.models), disks=list(s.disks),
                           order_cases=s.order_cases, reference_steps=s.reference_steps)
    write_json(out / "accuracy.json", AccuracyResult(inputs, summary, tuple(files)).to_json())
    files.append("accuracy.json")
    return files

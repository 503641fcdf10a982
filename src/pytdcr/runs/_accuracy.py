"""``tdcr accuracy``: the accuracy table of every model against the subsegment Cosserat rod, and the order study."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..accuracy import (
    AccuracyStudy,
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
from ..robot import Robot
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import saving
from ._output import inputs_record
from ._report import number_text
from ._settings import AccuracySettings

__all__ = ["AccuracyRun", "accuracy_markdown", "run_accuracy"]


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

    def summary(self) -> dict[str, Any]:
        """The rows, time and orders, JSON-ready (``accuracy.json``'s ``summary``)."""
        return {"rows": self.study.rows(), "compared": self.study.compared,
                "reference_steps_per_subsegment": self.study.reference_steps_per_subsegment,
                "seconds": self.study.seconds,
                "orders": [{"group": st.group, "disks": list(st.disks), "spacing_m": st.spacing,
                            "errors_mm": st.errors_mm, "order": st.order, "seconds": st.seconds}
                           for st in self.orders]}

    def to_dict(self) -> dict[str, Any]:
        """:meth:`summary` and the files."""
        return {**self.summary(), "files": list(self.files)}


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
        if r["unsupported"]:
            lines.append(f"| {r['group']} | {r['model']} | unsupported: {r['unsupported'].split('; ')[0]} | | | | |")
            continue
        lines.append(f"| {r['group']} | {r['model']} | {_fmt(r['median_error_mm'])} | {_fmt(r['p95_error_mm'])} | "
                     f"{_fmt(r['max_error_mm'])} | {r['converged']}/{r['reference_converged']} | "
                     f"{_fmt(r['median_ms'], 2)} |")
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
    study, orders, robot = run.study, run.orders, run.study.robot
    files = ["accuracy.csv", "accuracy.md"]
    rows = study.rows()
    write_csv(out / "accuracy.csv", list(rows[0]), (list(r.values()) for r in rows))
    source = f"uniform in [{b.lower.min():g}, {b.upper.max():g}] N, seed {s.seed}"
    atomic_write_text(out / "accuracy.md", accuracy_markdown(study, orders, source))
    if orders:
        write_csv(out / "order.csv", ["group", "model", "disks_per_segment", "spacing_m", "median_error_mm", "order"],
                  ([st.group, name, d, f"{h:.6g}", f"{x:.6g}", f"{st.order[name]:.4f}"]
                   for st in orders for name, e in st.errors_mm.items()
                   for d, h, x in zip(st.disks, st.spacing, e, strict=True)))
        files.append("order.csv")
        ax = plot_order(orders)
        ax.set_title(f"{robot.name}: PCC models against sscr as the disks multiply")
        files += save_figure(ax.figure, out, "fig_order")
    write_json(out / "accuracy.json", {
        "inputs": inputs_record(robot, Loads(np.zeros(robot.n_tendons)), tensions=T, bounds=b.to_dict(), seed=s.seed,
                                groups=[g.__dict__ for g in groups], models=list(study.models),
                                disks=list(s.disks), order_cases=s.order_cases, reference_steps=s.reference_steps),
        "summary": run.summary(), "files": files})
    files.append("accuracy.json")
    return files

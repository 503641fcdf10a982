"""``tdcr accuracy``: the accuracy table of every model against the subsegment Cosserat rod, and the order study."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..accuracy import AccuracyStudy, LoadGroup, OrderStudy, default_groups, model_accuracy, order_study
from ..bounds import TensionBounds
from ..design import Robot
from ..loads import Loads
from ..plotting import plot_order, save_figure
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import saving
from ._output import inputs_record

__all__ = ["accuracy_markdown", "run_accuracy"]


def _fmt(x: float, f: str = ".3f") -> str:
    return "-" if not np.isfinite(x) else format(x, f)


def accuracy_markdown(study: AccuracyStudy, orders: Sequence[OrderStudy], source: str) -> str:
    """The accuracy table and the order study as Markdown."""
    lines = [
        f"# Which model to trust: robot '{study.robot.name}'", "",
        f"{len(study.tensions)} tension vectors ({source}), solved by every model under each load group; the "
        f"reference is `sscr` of the same robot with {study.reference_steps} Runge-Kutta steps per segment "
        f"between its disks. Tip error: distance from the reference's tip. Friction law: "
        f"`{study.robot.friction.law}`.", "",
        "| load group | model | median error [mm] | 95th percentile [mm] | max [mm] | converged | median time [ms] |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in study.rows():
        if r["unsupported"]:
            lines.append(f"| {r['group']} | {r['model']} | unsupported: {r['unsupported'].split('; ')[0]} | | | | |")
            continue
        lines.append(f"| {r['group']} | {r['model']} | {_fmt(r['median_error_mm'])} | {_fmt(r['p95_error_mm'])} | "
                     f"{_fmt(r['max_error_mm'])} | {r['converged']}/{r['reference_converged']} | "
                     f"{_fmt(r['median_ms'], '.2f')} |")
    if orders:
        disks = orders[0].disks
        lines += ["", "## Order of convergence against `sscr` of the same robot", "",
                  f"Median tip error over {orders[0].cases} tension vectors [mm], by disks per segment (same lengths, "
                  "routing and total disk mass); the order is the slope of log(error) on log(spacing) "
                  "(`fig_order.png`).", "",
                  "| load group | model | " + " | ".join(f"{d} disks" for d in disks) + " | order |",
                  "|---|---|" + "---:|" * (len(disks) + 1)]
        for st in orders:
            for name, e in st.errors_mm.items():
                lines.append(f"| {st.group} | {name} | " + " | ".join(_fmt(x, '.4f') for x in e)
                             + f" | {_fmt(st.order[name], '.2f')} |")
    lines.append("")
    return "\n".join(lines)


def run_accuracy(robot: Robot, out: str | Path, *, n: int = 20, bounds: TensionBounds | None = None, seed: int = 0,
                 groups: Sequence[LoadGroup] | None = None, models: Sequence[str] | None = None,
                 disks: Sequence[int] = (5, 10, 20, 40), order_cases: int = 3, reference_steps: int = 160,
                 progress: Callable[[str], None] | None = None) -> tuple[AccuracyStudy, list[OrderStudy], list[str]]:
    """The accuracy table and the order study; writes CSV, Markdown, the log-log figure and JSON in ``out``
    (the output-folder rule; an interrupted study saves nothing)."""
    b = bounds or TensionBounds.uniform(robot.n_tendons, 0.0, 20.0)
    b.check_robot(robot)
    T = b.sample(n, np.random.default_rng(seed))
    groups = tuple(groups or default_groups())
    with output_folder(out, "accuracy", {"n": n, "seed": seed, "bounds": b.to_dict()}) as run:
        study = model_accuracy(robot, T, groups=groups, models=models, reference_steps=reference_steps,
                               progress=progress)
        orders = [order_study(robot, T[:order_cases], g, disks=disks, reference_steps=reference_steps,
                              progress=progress) for g in groups] if order_cases > 0 and disks else []
        with saving():
            files = _write_accuracy(run.staging, robot, study, orders, T, b, seed, groups, disks, order_cases,
                                    reference_steps)
    return study, orders, files


def _write_accuracy(out: Path, robot: Robot, study: AccuracyStudy, orders: list[OrderStudy], T: np.ndarray,
                    b: TensionBounds, seed: int, groups: Sequence[LoadGroup], disks: Sequence[int], order_cases: int,
                    reference_steps: int) -> list[str]:
    files = ["accuracy.csv", "accuracy.md"]
    rows = study.rows()
    write_csv(out / "accuracy.csv", list(rows[0]), (list(r.values()) for r in rows))
    source = f"uniform in [{b.lower.min():g}, {b.upper.max():g}] N, seed {seed}"
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
    summary: dict[str, Any] = {"rows": rows, "seconds": study.seconds,
                               "orders": [{"group": st.group, "disks": list(st.disks), "spacing_m": st.spacing,
                                           "errors_mm": st.errors_mm, "order": st.order, "seconds": st.seconds}
                                          for st in orders]}
    write_json(out / "accuracy.json", {
        "inputs": inputs_record(robot, Loads(np.zeros(robot.n_tendons)), tensions=T, bounds=b.to_dict(), seed=seed,
                                groups=[g.__dict__ for g in groups], models=list(study.models),
                                disks=list(disks), order_cases=order_cases, reference_steps=reference_steps),
        "summary": summary, "files": files})
    files.append("accuracy.json")
    return files

"""``tdcr compare``: two or more models on the same cases, with a table, a Markdown summary and an overlay figure."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..compare import ModelComparison, compare_models
from ..loads import Loads
from ..plotting import plot_model_overlay, save_figure
from ..robot import NoFriction, Robot
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import get_models, options_record, resolve, saving
from ._output import inputs_record, markdown_table
from ._report import number_text
from ._settings import CompareSettings

__all__ = ["CompareRun", "run_compare"]

#: cases drawn in the overlay figure
N_OVERLAY = 4


@dataclass(frozen=True)
class CompareRun:
    """What :func:`run_compare` produced.

    Attributes
    ----------
    robot : Robot
        The robot every model solved (its friction turned off when ``friction_off`` names models).
    comparison : ModelComparison
    files : list of str
    source : dict
        What the cases are (a file, given, or random within bounds with a seed), as ``compare.json`` records.
    friction_off : tuple of str
        The models without friction for which the robot's own friction law was turned off, for every model
        (empty if it was not).
    """

    robot: Robot
    comparison: ModelComparison
    files: list[str]
    source: dict[str, Any]
    friction_off: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the robot's name, the cases' source, the summary (as in ``compare.json``), the files."""
        return {"robot": self.robot.name, "source": self.source, "friction_off": list(self.friction_off),
                "summary": self.comparison.summary(), "files": list(self.files)}


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
    T, source = settings.tensions(robot)
    done = [0]

    def step() -> None:
        done[0] += 1
        progress(done[0], len(T))  # type: ignore[misc]

    with output_folder(out, "compare", {"models": list(settings.models), **source}) as run:
        cmp = compare_models(robot, loads, T, models=settings.models, options=options,
                             progress=step if progress is not None else None)
        with saving():
            files = _write_compare(run.staging, cmp, robot, loads, source, options)
    return CompareRun(robot, cmp, files, source, off)


def _compare_markdown(cmp: ModelComparison, robot: Robot, loads: Loads, source: Mapping[str, Any]) -> str:
    per = cmp.summaries()
    ref = cmp.reference

    def fmt(v: float | None) -> str:
        return "n/a" if v is None else number_text(v)

    rows = cmp.rows()
    cols = [("case", "case", "d")]
    for name in cmp.models:
        cols += [(f"{name}_{a}_m", f"{name} {a} [m]", ".5f") for a in "xyz"]
    for name in cmp.others:  # differences as text: 3 decimals, never a non-zero one as 0 (a NaN stays: n/c)
        for key, head in ((f"{name}_difference_mm", f"{name} diff [mm]"),
                          (f"{name}_difference_pct_length", f"{name} diff [% L]")):
            for r in rows:
                r[key] = number_text(r[key]) if np.isfinite(r[key]) else r[key]
            cols.append((key, head, ""))
    cols += [(f"{name}_ms", f"{name} [ms]", ".2f") for name in cmp.models]
    text = [
        f"# Models compared: robot '{robot.name}'", "",
        f"{len(cmp)} cases ({source.get('cases', 'random')}), tip force {loads.tip_force.tolist()} N, "
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


def _write_compare(out: Path, cmp: ModelComparison, robot: Robot, loads: Loads, source: dict[str, Any],
                   options: Mapping[str, Any]) -> list[str]:
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
    write_json(out / "compare.json", {
        "inputs": inputs_record(robot, loads, tensions=cmp.tensions, **source, solvers=solvers),
        "summary": cmp.summary(), "files": files,
    })
    return [*files, "compare.json"]

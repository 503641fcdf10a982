"""A design study's results, written from its typed records: the table (``designs.parquet``, ``designs.csv``), the
timings (``timings.csv``), the best designs' robot files (``best/``), the figures, ``summary.json`` and the
Markdown report (``report.md``). :mod:`pytdcr.designs._run` runs the designs and hands their records here.

The table has one row per design and load case, sorted by design (the reference, design -1, first); "best" is the
first objective's measure and goal; a load case under which that measure is 0 for every design names no best.
"""

from __future__ import annotations

import os
import shutil
import stat
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..io import write_robot
from ..runtime import atomic_write, atomic_write_text, write_json
from ..validate import measured
from ..workspace import WorkspaceSettings
from ._figures import write_design_figures
from ._optimize import measures_nothing, objective_matrix, pareto_front
from ._records import BestDesign, DesignRecord, DesignsSummary, Unranked
from ._space import apply_parameters, read_parameter
from ._spec import MEASURES, DesignStudy

if TYPE_CHECKING:
    import pandas as pd

    from ..robot import Robot

__all__ = ["build_table", "clear_name", "format_measure", "own_folder", "write_results"]


def clear_name(path: Path) -> None:
    """Make ``path``, a name the run owns in its folder, free to be written: a link there is removed (the link,
    never its target), and so are a FIFO, socket or device and a folder; a regular file stays, to be replaced."""
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return
    try:
        if stat.S_ISDIR(mode):
            shutil.rmtree(path)  # the run's name: a folder there is not its own (links inside are not followed)
        elif not stat.S_ISREG(mode):
            os.unlink(path)
    except OSError:
        pass


def own_folder(path: Path) -> Path:
    """The run's sub-folder ``path``, made a real folder: whatever else is at its name (a link to a folder
    elsewhere, a file) is removed first, so nothing of the run is written or read through it."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISDIR(mode):
        os.unlink(path)  # a link itself, never what it points to
    path.mkdir(exist_ok=True)
    return path


def build_table(study: DesignStudy, robot: Robot, records: dict[int, DesignRecord],
                generation_of: dict[int, int]) -> pd.DataFrame:
    """One row per design and load case, sorted (the reference, design -1, first, with the base robot's
    values): design, generation, load case, the parameters, status, reason, whether on the Pareto front, and the
    measures (:data:`MEASURES`, then h along the study's directions; NaN where not computed). A failed design has
    one row with no load case."""
    import pandas as pd

    names = list(study.parameters)
    measures = list(MEASURES) + [f"h_{k}_m" for k in study.measures.directions]
    order = sorted(records)
    F, ok = objective_matrix(study, [records[k] for k in order])
    designs = np.array(order) >= 0
    front = np.zeros(len(order), dtype=bool)
    front[designs] = pareto_front(F[designs], ok[designs])
    base = {n: read_parameter(robot, n) for n in names}
    rows = []
    for k, on_front in zip(order, front, strict=True):
        rec = records[k]
        params = base if k < 0 else rec.params
        head = {"design": k, "generation": generation_of.get(k, -1), **{n: params[n] for n in names},
                "status": rec.status, "reason": rec.reason, "pareto": bool(on_front)}
        if not rec.rows:
            rows.append({**head, "load_case": "", **{m: np.nan for m in measures}})
        for r in rec.rows:
            rows.append({**head, "load_case": r.load_case, **{m: r.measure(m) for m in measures}})
    cols = ["design", "generation", "load_case", *names, "status", "reason", "pareto", *measures]
    return pd.DataFrame(rows, columns=cols)


def format_measure(value: float, measure: str) -> str:
    """A measure in the unit a person reads (cm³, mm, MPa, %)."""
    if not np.isfinite(value):
        return "—"
    if measure.endswith("volume_m3"):
        return f"{value * 1e6:.0f} cm³"
    if measure.endswith("_m"):
        return f"{value * 1e3:.1f} mm"
    if measure.endswith("_pa"):
        return f"{value / 1e6:.0f} MPa"
    return f"{100 * value:.1f} %"


def _versus_reference(study: DesignStudy, ok: pd.DataFrame, case: str, index: int) -> list[str]:
    """How the best design compares with the base robot under ``case`` (same budget and measures)."""
    ref = ok[(ok["design"] == -1) & (ok["load_case"] == case)]
    if ref.empty:
        return []
    best = ok[(ok["design"] == index) & (ok["load_case"] == case)].iloc[0]
    ref = ref.iloc[0]
    lines = ["", f"Against the base robot '{study.robot}' (the reference row, design -1):", "",
             "| measure | base robot | best design | change |", "|---|---|---|---|"]
    for m in ("volume_m3", "realisable_volume_m3", "largest_reach_m", "peak_stress_pa", "arc_length_m",
              *[f"h_{k}_m" for k in study.measures.directions]):
        change = (best[m] / ref[m] - 1.0) * 100 if ref[m] else np.nan
        err = _error_column(m)
        a, b = (_with_error(r, m, err) for r in (ref, best))
        lines.append(f"| {m} | {a} | {b} | {f'{change:+.0f} %' if np.isfinite(change) else '—'} |")
    return lines


def _with_error(row: pd.Series, measure: str, err: str | None) -> str:
    """A measure of a table row in its unit, with its error where it has one; a volume whose error is not below
    it (:func:`~pytdcr.validate.measured`) is "not measured" beside its error, never shown as a result."""
    if err is None:
        return format_measure(row[measure], measure)
    if not measured(row[measure], row[err]) and not (row[measure] == 0.0 and row[err] == 0.0):
        return f"not measured (± {format_measure(row[err], measure)})"
    return f"{format_measure(row[measure], measure)} ± {format_measure(row[err], measure)}"


def _volume_cell(volume_m3: float, error_m3: float) -> str:
    """A volume [m³] in cm³ for a table, or "not measured" where its error is not below it (0 ± 0 shows 0)."""
    if measured(volume_m3, error_m3) or (volume_m3 == 0.0 and error_m3 == 0.0):
        return f"{volume_m3 * 1e6:.0f}"
    return "not measured"


def _error_column(measure: str) -> str | None:
    """The column of a measure's error: only the volumes have one."""
    return measure.replace("_m3", "_err_m3") if measure.endswith("volume_m3") else None


def _ranked_by(study: DesignStudy) -> tuple[str, str]:
    """What "best" means in the report and ``best/``: the first objective's measure and goal."""
    return study.objectives[0].measure, study.objectives[0].goal


def _screening_note(study: DesignStudy, ok: pd.DataFrame, case: str, index: int, robot_file: str) -> list[str]:
    """A warning when the volume errors are larger than the margins the ranking rests on.

    At a screening budget (few samples, an unfinished boundary search) the error of each volume can exceed the
    differences between designs: the order is then an index to shortlist designs, not a measurement. Only a
    ranking by a volume has an error to compare (the other measures have none).
    """
    measure, goal = _ranked_by(study)
    err = _error_column(measure)
    if err is None:
        return []
    sub = ok[ok["load_case"] == case]
    measured = sub[sub[measure] > 0]  # a region without volume (planar) has no relative error
    rel = (measured[err] / measured[measure]).median() if len(measured) else np.nan
    ranked = sub[sub["design"] >= 0][measure].dropna().sort_values(ascending=goal == "min").to_numpy()
    best = sub[sub["design"] == index].iloc[0]
    margin = abs(ranked[0] - ranked[1]) if len(ranked) > 1 else np.inf
    why = []
    if best[err] > margin:
        why.append(f"the best design's error ({format_measure(best[err], measure)}) exceeds its margin over the next "
                   f"design ({format_measure(margin, measure)})")
    if rel > 0.5:
        why.append(f"the median error is {100 * rel:.0f} % of the volume")
    if not why:
        return []
    return ["", "**At this budget the volumes are a screening index, not a measurement:** " + "; and ".join(why)
            + f". Confirm the leading designs at a full budget under '{case}' (e.g. `tdcr workspace --robot "
            f"{robot_file} --n 1000 --budget 60000` with that load), beside the base robot measured the same way."]


def _front_table(study: DesignStudy, ok: pd.DataFrame) -> list[str]:
    """The designs on the Pareto front: their parameters and objective values, by the first objective."""
    front = ok[ok["pareto"]].drop_duplicates("design")["design"].tolist()
    heads = [f"{o.goal} {o.measure} ({study.objective_case(o)})" for o in study.objectives]
    rows = []
    for k in front:
        vals = [ok[(ok["design"] == k) & (ok["load_case"] == study.objective_case(o))][o.measure].iloc[0]
                for o in study.objectives]
        params = ok[ok["design"] == k].iloc[0]
        rows.append((vals, f"| {k} | " + " | ".join(f"{params[p]:.6g}" for p in study.parameters) + " | "
                     + " | ".join(format_measure(v, o.measure) for v, o in zip(vals, study.objectives, strict=True))
                     + " |"))
    first = study.objectives[0]
    rows.sort(key=lambda r: -r[0][0] if first.goal == "max" else r[0][0])
    return [f"{len(front)} designs (no other design is better on one objective and as good on the rest):", "",
            "| design | " + " | ".join(study.parameters) + " | " + " | ".join(heads) + " |",
            "|---" * (1 + len(study.parameters) + len(heads)) + "|", *(r[1] for r in rows)]


#: how the report says what the search's steps do at folds, by rule
#: (:attr:`~pytdcr.workspace.WorkspaceSettings.FOLD_RULES`)
_FOLD_WORDS = dict(zip(WorkspaceSettings.FOLD_RULES, ("snapping through", "stopping"), strict=True))


def _best_section(study: DesignStudy, ok: pd.DataFrame, best: BestDesign) -> list[str]:
    """The report's section on the best design under a load case: the five leading designs, the comparison with
    the base robot and, at a screening budget, the warning."""
    measure, goal = best.measure, best.goal
    extra = [] if measure in ("volume_m3", "largest_reach_m", "peak_stress_pa") else [measure]
    case, index, robot_file = best.load_case, best.design, best.robot_file
    sub = ok[(ok["load_case"] == case) & (ok["design"] >= 0)].dropna(subset=[measure])
    sub = sub.sort_values(measure, ascending=goal == "min").head(5)
    lines = [f"## Best under '{case}' ({goal} {measure}, the first objective)", "",
             f"Best: design {index}, robot file `{robot_file}` (`tdcr workspace --robot {robot_file}`).", "",
             "| design | " + " | ".join(study.parameters) + " | FSW [cm³] | ± | reach [mm] | peak stress [MPa] |"
             + "".join(f" {m} |" for m in extra), "|---" * (len(study.parameters) + 5 + len(extra)) + "|"]
    for _, r in sub.iterrows():
        lines.append(f"| {r['design']} | " + " | ".join(f"{r[p]:.6g}" for p in study.parameters)
                     + f" | {_volume_cell(r['volume_m3'], r['volume_err_m3'])} | {r['volume_err_m3'] * 1e6:.0f} | "
                     f"{r['largest_reach_m'] * 1e3:.1f} | {r['peak_stress_pa'] / 1e6:.0f} |"
                     + "".join(f" {format_measure(r[m], m)} |" for m in extra))
    return [*lines, *_versus_reference(study, ok, case, index), *_screening_note(study, ok, case, index, robot_file),
            ""]


def _report(study: DesignStudy, table: pd.DataFrame, summary: DesignsSummary) -> str:
    """``report.md``: what ran, the best design under each load case, the load cases without one, the Pareto
    front, the figures and the failed designs."""
    lines = [f"# Design study '{study.name}'", "",
             f"{summary.designs} designs ({study.designs.method}) of robot '{study.robot}', load cases "
             f"{', '.join(summary.load_cases)}, tensions in [{study.bounds[0]:g}, {study.bounds[1]:g}] N, model "
             f"{study.model}, {study.budget.samples} samples and {study.budget.search} search solves per design "
             f"and load case (search steps {_FOLD_WORDS[study.budget.folds]} at folds); seed {study.seed}.", "",
             f"Computed {summary.designs_computed}, reused {summary.designs_reused}, failed "
             f"{summary.designs_failed}; ran on {summary.executor} in {summary.seconds:.0f} s.", ""]
    ok = table[table["status"] == "ok"]
    for best in summary.best:
        lines += _best_section(study, ok, best)
    for u in summary.unranked:
        lines += [f"## No best under '{u.load_case}' ({u.goal} {u.measure}, the first objective)", "",
                  f"No design is named best: {u.reason}. Rank by a measure that differs between them (the "
                  "study's `[[objectives]]`, e.g. `largest_reach_m` or an `h_<name>_m`).", ""]
    goals = ", ".join(f"{o.goal} {o.measure} under '{study.objective_case(o)}'" for o in study.objectives)
    lines += [f"## Pareto front ({goals})", "", *_front_table(study, ok), ""]
    lines += [f"![{f}]({f})" for f in summary.figures if f.endswith(".png")] + [""]
    failed = table[table["status"] == "failed"]
    if len(failed):
        lines += ["## Failed designs", ""] + [f"- design {r['design']}: {r['reason']}" for _, r in
                                              failed.drop_duplicates("design").iterrows()] + [""]
    return "\n".join(lines)


def _unranked(study: DesignStudy, table: pd.DataFrame) -> list[Unranked]:
    """The load cases under which the first objective's measure is 0 for every design (:func:`measures_nothing`:
    the volume of designs that are all planar): no design is named best there. Each with its reason."""
    measure, goal = _ranked_by(study)
    ok = table[(table["status"] == "ok") & (table["design"] >= 0)].dropna(subset=[measure])
    out = []
    for case in dict.fromkeys(ok["load_case"]):
        sub = ok[ok["load_case"] == case]
        if not measures_nothing(sub[measure]):
            continue
        reason = f"every design's {measure} is 0"
        if measure.endswith("volume_m3"):
            dims = ", ".join(str(int(d)) for d in sorted(set(sub["fsw_dimension"].dropna())))
            reason += (f" (FSW dimension {dims}: no region of these designs has a volume; their areas or lengths "
                       "are in workspace studies of each, not ranked here)")
        out.append(Unranked(case, measure, goal, reason))
    return out


def _write_best(out: Path, study: DesignStudy, robot: Robot, table: pd.DataFrame, records: dict[int, DesignRecord],
                skip: set[str]) -> list[BestDesign]:
    """The robot file of the best design (by the first objective's measure and goal) under each load case but
    those in ``skip`` (where the measure ranks nothing), in ``best/``; returns each with its value and error."""
    measure, goal = _ranked_by(study)
    err = _error_column(measure)
    ok = table[(table["status"] == "ok") & (table["design"] >= 0)].dropna(subset=[measure])
    best = []
    for case in dict.fromkeys(ok["load_case"]):
        if case in skip:
            continue
        own_folder(out / "best")
        sub = ok[ok["load_case"] == case]
        at = sub[measure].idxmax() if goal == "max" else sub[measure].idxmin()
        k = int(sub.loc[at, "design"])
        name = f"best/design_{k:06d}.toml"
        clear_name(out / name)
        write_robot(apply_parameters(robot, records[k].params).model_copy(
            update={"name": f"{study.name}-design-{k}"}), out / name)
        row = table[(table["design"] == k) & (table["load_case"] == case)].iloc[0]
        best.append(BestDesign(case, k, name, measure, goal, float(row[measure]),
                               None if err is None else float(row[err])))
    return best


def write_results(out: Path, study: DesignStudy, robot: Robot, records: dict[int, DesignRecord],
                  generation_of: dict[int, int], summary: DesignsSummary, figures: bool
                  ) -> tuple[pd.DataFrame, DesignsSummary]:
    """Write the study's results in its folder ``out`` from the designs' ``records`` (by index; -1 the
    reference) and what ran (``summary``, its results not yet filled): the table, the timings, the best
    designs, the figures (when ``figures``), ``summary.json`` and ``report.md``. Returns the table and the
    summary with the best designs, the load cases without one, the figures and the warnings."""
    import pandas as pd

    table = build_table(study, robot, records, generation_of)
    atomic_write(out / "designs.parquet", lambda tmp: table.to_parquet(tmp, index=False))
    atomic_write_text(out / "designs.csv", table.to_csv(index=False))
    timing = [{"design": k, **records[k].timing.to_json()} for k in sorted(records)]
    atomic_write_text(out / "timings.csv", pd.DataFrame(timing).to_csv(index=False))
    ok = (table["status"] == "ok") & (table["design"] >= 0)
    unranked = _unranked(study, table)
    skip = {u.load_case for u in unranked}
    best = _write_best(out, study, robot, table, records, skip) if ok.any() else []
    written = write_design_figures(out, study, robot, table, records) if figures and ok.any() else []
    oks = table[table["status"] == "ok"]
    warnings = [f"{b.load_case}: " + " ".join(note).replace("**", "").strip() for b in best
                if (note := _screening_note(study, oks, b.load_case, b.design, b.robot_file))]
    summary = replace(summary, unranked=tuple(unranked), figures=tuple(written), best=tuple(best),
                      warnings=tuple(warnings))
    write_json(out / "summary.json", summary.to_json())
    atomic_write_text(out / "report.md", _report(study, table, summary))
    return table, summary

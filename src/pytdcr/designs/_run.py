"""Running a design study where the compute is: local processes or a Dask cluster, resumable, never mixed.

Each design's result is written to ``designs/NNNNNN.json`` (atomically) as soon as it arrives; a run of the
same study into the same folder computes only the designs that have no file it can trust (a file that is not a
regular one, or whose record is not exactly what this study writes for that design, is computed again; a link
is never followed). The table is made from those files at the end, sorted by design and load case, so it does
not depend on where, in what order or how many at a time the designs ran.
"""

from __future__ import annotations

import gc
import hashlib
import json
import math
import os
import shutil
import signal
import stat
import time
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..io import write_robot
from ..robot import Robot
from ..runtime import (
    MAX_JSON_BYTES,
    RunInterrupted,
    atomic_write,
    atomic_write_text,
    default_threads,
    dump_json,
    process_pool,
    regular_file_bytes,
    resumable_folder,
    versions_record,
    write_json,
)
from ..statics import check_cancelled, mark_saving
from ..validate import check_count, finite_real
from ..workspace import FOLD_RULES
from ._evaluate import check_capabilities, evaluate_design
from ._figures import write_design_figures
from ._optimize import design_batches, measures_nothing, objective_matrix, pareto_front
from ._space import apply_parameters, choose_designs, read_parameter
from ._spec import MEASURES, DesignStudy, StudyError, measures_for

__all__ = ["DesignsRun", "DesignsRunOptions", "WorkersLost", "format_measure", "run_designs"]

#: files and folders a study's folder holds
LAYOUT = ("study.toml", "designs", "designs.csv", "designs.parquet", "timings.csv", "summary.json", "report.md",
          "best", "pareto.png", "pareto.pdf", "measures.png", "measures.pdf", "best_designs.png", "best_designs.pdf")
#: how often the waiting loop looks for finished designs and for Ctrl-C [s]
POLL_S = 0.1


class WorkersLost(RuntimeError):
    """The compute went away under the run (a local worker process died, the Dask scheduler closed): what was
    finished is saved and the same command resumes it."""


#: the most local worker processes a design study starts
MAX_WORKERS = 4096


@dataclass(frozen=True)
class DesignsRunOptions:
    """Where and how :func:`run_designs` runs.

    Attributes
    ----------
    scheduler : str or None
        A Dask scheduler's address (``tcp://host:8786``) to run on; None: local processes.
    workers : int or None
        Local processes, in [1, :data:`MAX_WORKERS`] (default: all cores; at most one per design).
    restart : bool
        Discard what the folder holds and start again (otherwise a stopped study resumes).
    progress : callable or None
        ``progress(done, failed, total)``, called as designs finish (the optimiser's total is an upper bound
        until it ends).
    figures : bool
        Draw the Pareto front, the measures against the parameters and the best designs.
    """

    scheduler: str | None = None
    workers: int | None = None
    restart: bool = False
    progress: Callable[[int, int, int], None] | None = None
    figures: bool = True

    def __post_init__(self) -> None:
        if self.workers is not None:
            object.__setattr__(self, "workers", check_count(self.workers, "workers", lo=1, hi=MAX_WORKERS))


@dataclass(frozen=True)
class DesignsRun:
    """A finished study: the table (pandas DataFrame, one row per design and load case), the summary."""

    table: Any
    summary: dict[str, Any]
    path: Path


def _design_file(out: Path, index: int) -> Path:
    return out / "designs" / (f"{index:06d}.json" if index >= 0 else "reference.json")


#: failures that a resume tries again: what more memory, or workers that stay alive, can change
RETRIED_FAILURES = ("ResourceLimitError", "KilledWorker")


@dataclass(frozen=True)
class _RecordShape:
    """What a design record of the study holds: its load cases (in order), the measures of each row and the
    robot's tendons (the length of a row's ``reach_tensions_n``)."""

    cases: tuple[str, ...]
    measures: tuple[str, ...]
    n_tendons: int

    @classmethod
    def of(cls, study: DesignStudy, robot: Robot) -> _RecordShape:
        return cls(tuple(study.load_cases(robot)), (*MEASURES, *[f"h_{k}_m" for k in study.measures.directions]),
                   robot.n_tendons)


def _number(v: Any) -> bool:
    """``v`` is a finite JSON number (not a bool, a string, NaN, 1e400, nor an integer beyond the floats):
    :func:`~pytdcr.validate.finite_real`'s rule."""
    return finite_real(v) is not None


def _same_params(got: Any, planned: dict[str, float]) -> bool:
    """``got`` holds exactly the planned design's values: the same names, each the same number of the same JSON
    type (a whole-number parameter an integer, never ``true`` or ``3.0``; any other a number)."""
    if not isinstance(got, dict) or got.keys() != planned.keys():
        return False
    for name, want in planned.items():
        v = got[name]
        whole = isinstance(want, (int, np.integer)) and not isinstance(want, bool)
        if not _number(v) or (whole and not isinstance(v, int)) or v != want:
            return False
    return True


def _row(raw: Any, case: str, shape: _RecordShape) -> dict[str, Any] | None:
    """A row of load case ``case`` as :func:`~pytdcr.designs.evaluate_design` writes it, its missing measures
    (written as null) NaN; None when it is anything else (another load case, a key too many or too few, a
    measure that is not a finite number or null, tensions that are not ``n_tendons`` finite numbers)."""
    if not isinstance(raw, dict) or raw.keys() != {"load_case", "reach_tensions_n", *shape.measures} \
            or raw["load_case"] != case:
        return None
    t = raw["reach_tensions_n"]
    if t is not None and not (isinstance(t, list) and len(t) == shape.n_tendons and all(map(_number, t))):
        return None
    if not all(raw[m] is None or _number(raw[m]) for m in shape.measures):
        return None
    return {"load_case": case, **{m: math.nan if raw[m] is None else raw[m] for m in shape.measures},
            "reach_tensions_n": None if t is None else [float(x) for x in t]}


def _timing(raw: Any) -> dict[str, Any] | None:
    """A record's ``timing`` (seconds, a finite number or null for NaN; host; pid), else None."""
    if not isinstance(raw, dict) or raw.keys() != {"seconds", "host", "pid"}:
        return None
    seconds, host, pid = raw["seconds"], raw["host"], raw["pid"]
    if not (seconds is None or (_number(seconds) and seconds >= 0)) or not isinstance(host, str) or \
            not isinstance(pid, int) or isinstance(pid, bool):
        return None
    return {"seconds": math.nan if seconds is None else float(seconds), "host": host, "pid": pid}


def _record(raw: Any, index: int, params: dict[str, float], shape: _RecordShape) -> dict[str, Any] | None:
    """Design ``index``'s record (values ``params``) as :func:`~pytdcr.designs.evaluate_design` made it and
    :meth:`_Runner._keep` wrote it, rebuilt from its checked fields alone; None when ``raw`` is anything else: a
    record of another design or other values, a status other than ok or failed, rows other than one per load case
    of the study (a failed design may have none), a measure that is not a finite number or null, a key unknown."""
    known = {"design", "params", "status", "reason", "rows", "timing", "generation", "traceback"}
    if not isinstance(raw, dict) or not raw.keys() <= known or not {"design", "params", "status", "rows",
                                                                    "timing"} <= raw.keys():
        return None
    design, status, reason, rows = raw["design"], raw["status"], raw.get("reason", ""), raw["rows"]
    if not isinstance(design, int) or isinstance(design, bool) or design != index or status not in ("ok", "failed") \
            or not isinstance(reason, str) or not isinstance(raw.get("traceback", ""), str) \
            or not _same_params(raw["params"], params) or not isinstance(rows, list):
        return None
    generation = raw.get("generation", -1)
    if not isinstance(generation, int) or isinstance(generation, bool):
        return None
    if not (len(rows) == len(shape.cases) or (status == "failed" and not rows)):
        return None
    checked = [_row(r, case, shape) for r, case in zip(rows, shape.cases, strict=False)]
    timing = _timing(raw["timing"])
    if timing is None or any(r is None for r in checked):
        return None
    rec = {"design": index, "params": dict(params), "status": status, "reason": reason, "rows": checked,
           "timing": timing, "generation": generation}
    if "traceback" in raw:
        rec["traceback"] = raw["traceback"]
    return rec


def _reuse(out: Path, index: int, params: dict[str, float], shape: _RecordShape) -> dict[str, Any] | None:
    """Design ``index``'s record in the folder, if it is there for these values (else it is redone).

    The file is read as input another hand may have edited or replaced (:func:`~pytdcr.runtime._readback.
    regular_file_bytes`: a regular file, never through a link, a FIFO never waited on, of bounded size) and its
    record checked field by field (:func:`_record`); a file that cannot be read or trusted, or a failure more
    memory or live workers may mend (:data:`RETRIED_FAILURES`), is computed again, never an error.
    """
    try:
        raw = json.loads(regular_file_bytes(_design_file(out, index), MAX_JSON_BYTES, follow=False).decode("utf-8"),
                         parse_constant=_no_constant)
    except (OSError, ValueError, RecursionError, UnicodeDecodeError):
        return None
    rec = _record(raw, index, params, shape)
    if rec is None or (rec["status"] == "failed" and rec["reason"].startswith(RETRIED_FAILURES)):
        return None
    return rec


def _no_constant(name: str) -> float:
    """JSON's ``NaN`` and ``Infinity`` are not strict JSON, and no record this run writes holds them."""
    raise ValueError(f"{name} is not strict JSON")


def _clear(path: Path) -> None:
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


def _own_folder(path: Path) -> Path:
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


@contextmanager
def _sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread for the block (delivered, if it came, when it ends); a no-op off POSIX."""
    mask = getattr(signal, "pthread_sigmask", None)
    if mask is None:  # pragma: no cover - not POSIX
        yield
        return
    old = mask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        mask(signal.SIG_SETMASK, old)


class _Local:
    """Designs on local processes (spawned: a clean interpreter each, whatever the parent holds), which end
    with this process however it ends (:func:`pytdcr.runtime.process_pool`: killed outright, its workers
    notice and exit)."""

    def __init__(self, workers: int) -> None:
        self.name = f"{workers} local process{'es' * (workers != 1)}"
        self.pool = process_pool(workers)

    def submit(self, *args: Any) -> Any:
        # the worker processes start with SIGINT blocked (a spawned process inherits its parent thread's signal
        # mask): a Ctrl-C sent to the process group, as a terminal sends it, reaches this process alone, which
        # stops them; before, workers still importing printed tracebacks and left semaphores behind
        with _sigint_blocked():
            return self.pool.submit(evaluate_design, *args)

    def close(self, cancel: bool) -> None:
        if cancel:
            procs = list(getattr(self.pool, "_processes", {}).values())
            self.pool.shutdown(wait=False, cancel_futures=True)
            for p in procs:  # a design in progress is lost either way: stop it now
                p.terminate()
            for p in procs:
                p.join(timeout=2.0)
            # let the pool's queues go now, their named semaphores unlinked by their finalizers: an interrupted
            # command leaves at once (os._exit), and the resource tracker would warn of them as leaked
            self.pool.shutdown(wait=True)
            self.pool = None
            gc.collect()
        else:
            self.pool.shutdown(wait=True)


class _Dask:
    """Designs on an existing Dask distributed cluster (its scheduler's address)."""

    def __init__(self, address: str) -> None:
        from distributed import Client

        try:
            self.client = Client(address, timeout="20s")
        except (OSError, TimeoutError) as err:
            raise StudyError(f"--scheduler {address}: cannot reach the Dask scheduler ({err})") from None
        self.name = f"Dask scheduler {address} ({len(self.client.scheduler_info()['workers'])} workers)"
        self.futures: list[Any] = []

    def submit(self, *args: Any) -> Any:
        fut = self.client.submit(evaluate_design, *args, pure=False)
        self.futures.append(fut)
        return fut

    def close(self, cancel: bool) -> None:
        if cancel:
            self.client.cancel(self.futures)
        self.client.close()


def _killed(index: int, params: dict[str, float], err: BaseException) -> dict[str, Any]:
    """The record of a design whose Dask workers died running it (the scheduler gave up on it): failed."""
    return {"design": int(index), "params": dict(params), "status": "failed", "rows": [],
            "reason": f"{type(err).__name__}: the workers running this design died (out of memory, or a crash "
                      f"in compiled code): {err}"[:500],
            "timing": {"seconds": float("nan"), "host": "", "pid": -1}}


def _wait(executor: Any, jobs: dict[Any, tuple[int, dict[str, float]]],
          on_result: Callable[[dict[str, Any]], None]) -> None:
    """Hand each finished design to ``on_result`` as it comes; Ctrl-C (the run's cancel scope) stops at once.

    A design that killed the Dask workers that ran it (``KilledWorker``) is recorded as failed and the study goes
    on; a local pool whose worker process died is broken for every design in it: :class:`WorkersLost`.
    """
    from distributed import KilledWorker

    pending = dict(jobs)
    while pending:
        check_cancelled()
        finished = [f for f in pending if f.done()]
        if not finished:
            time.sleep(POLL_S)
            continue
        for f in finished:
            index, params = pending.pop(f)
            try:
                rec = f.result()
            except KilledWorker as err:
                rec = _killed(index, params, err)
            except (BrokenProcessPool, CancelledError, OSError) as err:
                running = sorted(k for k, _ in [*pending.values(), (index, params)])
                raise WorkersLost(f"the compute stopped under the run while designs {running[:8]}"
                                  f"{' ...' if len(running) > 8 else ''} were to run ({type(err).__name__}: "
                                  f"{err or 'a worker process died: killed, out of memory, or a crash'})") from None
            on_result(rec)


def _table(study: DesignStudy, robot: Robot, records: dict[int, dict[str, Any]],
           generation_of: dict[int, int]) -> Any:
    """One row per design and load case, sorted (the reference, design -1, first); a failed design has one row
    with no load case."""
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
        params = base if k < 0 else rec["params"]
        head = {"design": k, "generation": generation_of.get(k, -1), **{n: params[n] for n in names},
                "status": rec["status"], "reason": rec["reason"], "pareto": bool(on_front)}
        if not rec["rows"]:
            rows.append({**head, "load_case": "", **{m: np.nan for m in measures}})
        for r in rec["rows"]:
            rows.append({**head, "load_case": r["load_case"], **{m: r.get(m, np.nan) for m in measures}})
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


def _versus_reference(study: DesignStudy, ok: Any, case: str, index: int) -> list[str]:
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
        a, b = ((format_measure(r[m], m) + (f" ± {format_measure(r[err], m)}" if err else ""))
                for r in (ref, best))
        lines.append(f"| {m} | {a} | {b} | {f'{change:+.0f} %' if np.isfinite(change) else '—'} |")
    return lines


def _error_column(measure: str) -> str | None:
    """The column of a measure's error: only the volumes have one."""
    return measure.replace("_m3", "_err_m3") if measure.endswith("volume_m3") else None


def _ranked_by(study: DesignStudy) -> tuple[str, str]:
    """What "best" means in the report and ``best/``: the first objective's measure and goal."""
    return study.objectives[0].measure, study.objectives[0].goal


def _screening_note(study: DesignStudy, ok: Any, case: str, index: int, robot_file: str) -> list[str]:
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


def _front_table(study: DesignStudy, ok: Any) -> list[str]:
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


#: how the report says what the search's steps do at folds, by rule (:data:`~pytdcr.workspace.FOLD_RULES`)
_FOLD_WORDS = dict(zip(FOLD_RULES, ("snapping through", "stopping"), strict=True))


def _report(study: DesignStudy, table: Any, summary: dict[str, Any], best: list[tuple[str, int, str]],
            figures: list[str]) -> str:
    lines = [f"# Design study '{study.name}'", "",
             f"{summary['designs']} designs ({study.designs.method}) of robot '{study.robot}', load cases "
             f"{', '.join(summary['load_cases'])}, tensions in [{study.bounds[0]:g}, {study.bounds[1]:g}] N, model "
             f"{study.model}, {study.budget.samples} samples and {study.budget.search} search solves per design "
             f"and load case (search steps {_FOLD_WORDS[study.budget.folds]} at folds); seed {study.seed}.", "",
             f"Computed {summary['designs_computed']}, reused {summary['designs_reused']}, failed "
             f"{summary['designs_failed']}; ran on {summary['executor']} in {summary['seconds']:.0f} s.", ""]
    ok = table[table["status"] == "ok"]
    measure, goal = _ranked_by(study)
    extra = [] if measure in ("volume_m3", "largest_reach_m", "peak_stress_pa") else [measure]
    for case, index, robot_file in best:
        sub = ok[(ok["load_case"] == case) & (ok["design"] >= 0)].dropna(subset=[measure])
        sub = sub.sort_values(measure, ascending=goal == "min").head(5)
        lines += [f"## Best under '{case}' ({goal} {measure}, the first objective)", "",
                  f"Best: design {index}, robot file `{robot_file}` (`tdcr workspace --robot {robot_file}`).", "",
                  "| design | " + " | ".join(study.parameters) + " | FSW [cm³] | ± | reach [mm] | peak stress [MPa] |"
                  + "".join(f" {m} |" for m in extra), "|---" * (len(study.parameters) + 5 + len(extra)) + "|"]
        for _, r in sub.iterrows():
            lines.append(f"| {r['design']} | " + " | ".join(f"{r[p]:.6g}" for p in study.parameters)
                         + f" | {r['volume_m3'] * 1e6:.0f} | {r['volume_err_m3'] * 1e6:.0f} | "
                         f"{r['largest_reach_m'] * 1e3:.1f} | {r['peak_stress_pa'] / 1e6:.0f} |"
                         + "".join(f" {format_measure(r[m], m)} |" for m in extra))
        lines += [*_versus_reference(study, ok, case, index), *_screening_note(study, ok, case, index, robot_file), ""]
    for u in summary.get("unranked", []):
        lines += [f"## No best under '{u['load_case']}' ({u['goal']} {u['measure']}, the first objective)", "",
                  f"No design is named best: {u['reason']}. Rank by a measure that differs between them (the "
                  "study's `[[objectives]]`, e.g. `largest_reach_m` or an `h_<name>_m`).", ""]
    goals = ", ".join(f"{o.goal} {o.measure} under '{study.objective_case(o)}'" for o in study.objectives)
    lines += [f"## Pareto front ({goals})", "", *_front_table(study, ok), ""]
    lines += [f"![{f}]({f})" for f in figures if f.endswith(".png")] + [""]
    failed = table[table["status"] == "failed"]
    if len(failed):
        lines += ["## Failed designs", ""] + [f"- design {r['design']}: {r['reason']}" for _, r in
                                              failed.drop_duplicates("design").iterrows()] + [""]
    return "\n".join(lines)


def _unranked(study: DesignStudy, table: Any) -> list[dict[str, Any]]:
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
        out.append({"load_case": case, "measure": measure, "goal": goal, "reason": reason})
    return out


def _write_best(out: Path, study: DesignStudy, robot: Robot, table: Any, records: dict[int, dict[str, Any]],
                skip: set[str]) -> list[tuple[str, int, str]]:
    """The robot file of the best design (by the first objective's measure and goal) under each load case but
    those in ``skip`` (where the measure ranks nothing), in ``best/``; returns (load case, design, file name)
    for each."""
    measure, goal = _ranked_by(study)
    ok = table[(table["status"] == "ok") & (table["design"] >= 0)].dropna(subset=[measure])
    best = []
    for case in dict.fromkeys(ok["load_case"]):
        if case in skip:
            continue
        _own_folder(out / "best")
        sub = ok[ok["load_case"] == case]
        k = int(sub.loc[sub[measure].idxmax() if goal == "max" else sub[measure].idxmin(), "design"])
        name = f"best/design_{k:06d}.toml"
        _clear(out / name)
        write_robot(apply_parameters(robot, records[k]["params"]).model_copy(
            update={"name": f"{study.name}-design-{k}"}), out / name)
        best.append((case, k, name))
    return best


#: the libraries whose versions a design study's summary records
_LIBRARIES = ("numpy", "scipy", "numba", "dask", "pymoo")


def _finish(out: Path, study: DesignStudy, robot: Robot, records: dict[int, dict[str, Any]],
            generation_of: dict[int, int], summary: dict[str, Any], figures: bool) -> Any:
    import pandas as pd

    table = _table(study, robot, records, generation_of)
    atomic_write(out / "designs.parquet", lambda tmp: table.to_parquet(tmp, index=False))
    atomic_write_text(out / "designs.csv", table.to_csv(index=False))
    timing = [{"design": k, **records[k]["timing"]} for k in sorted(records)]
    atomic_write_text(out / "timings.csv", pd.DataFrame(timing).to_csv(index=False))
    ok = (table["status"] == "ok") & (table["design"] >= 0)
    unranked = _unranked(study, table)
    summary["unranked"] = unranked
    skip = {u["load_case"] for u in unranked}
    best = _write_best(out, study, robot, table, records, skip) if ok.any() else []
    written = write_design_figures(out, study, robot, table, records) if figures and ok.any() else []
    summary["figures"] = written
    measure, goal = _ranked_by(study)
    err = _error_column(measure)
    summary["best"] = []
    for case, k, name in best:
        row = table[(table["design"] == k) & (table["load_case"] == case)].iloc[0]
        summary["best"].append({"load_case": case, "design": k, "robot_file": name, "measure": measure,
                                "goal": goal, "value": float(row[measure]),
                                "error": None if err is None else float(row[err])})
    oks = table[table["status"] == "ok"]
    summary["warnings"] = [f"{case}: " + " ".join(note).replace("**", "").strip() for case, k, name in best
                           if (note := _screening_note(study, oks, case, k, name))]
    write_json(out / "summary.json", summary)
    atomic_write_text(out / "report.md", _report(study, table, summary, best, written))
    return table


class _Runner:
    """Evaluates batches of designs into the folder: reuses a design's file when it is there, sends the rest to
    the executor (made when first needed), writes each record as it arrives, counts and reports progress."""

    def __init__(self, study: DesignStudy, robot: Robot, run: Any, total: int, options: DesignsRunOptions) -> None:
        self.study, self.robot, self.run, self.path = study, robot, run, run.path
        self.total = total + study.reference
        self.scheduler, self.workers, self.progress = options.scheduler, options.workers, options.progress
        self.records: dict[int, dict[str, Any]] = {}
        self.reused = self.computed = self.failed = 0
        self.executor: Any = None
        self._reference = study.reference
        self.shape = _RecordShape.of(study, robot)

    def saved(self) -> str:
        """How much is saved: "K of N designs" (and the base robot, when it is)."""
        k = sum(i >= 0 for i in self.records)
        return (f"saved {k} of {self.total - self.study.reference} designs"
                + (" and the base robot" if -1 in self.records else ""))

    def _report(self) -> None:
        self.run.interrupted_note = self.saved()
        if self.progress is not None:
            self.progress(len(self.records), self.failed, self.total)

    def _keep(self, generation: int, rec: dict[str, Any]) -> None:
        mark_saving()
        rec["generation"] = generation
        path = _design_file(self.path, rec["design"])
        _clear(path)  # a link, FIFO or folder put at its name: replaced, never written through
        atomic_write_text(path, dump_json(rec))  # strict JSON: a NaN measure is null, read back as NaN
        self.records[rec["design"]] = rec
        self.computed += rec["design"] >= 0
        self.failed += rec["status"] == "failed"
        self._report()

    def batch(self, generation: int, batch: list[tuple[int, dict[str, float]]]) -> dict[int, dict[str, Any]]:
        """Evaluate ``batch`` [(index, values)] (with the reference, index -1, the first time); returns the
        batch's records by index."""
        jobs = ([(-1, {})] if self._reference else []) + list(batch)
        self._reference = False
        todo = []
        for k, params in jobs:
            rec = _reuse(self.path, k, params, self.shape)
            if rec is None:
                todo.append((k, params))
                continue
            self.records[k] = rec
            self.reused += k >= 0
            self.failed += rec["status"] == "failed"
        self._report()
        if todo:
            if self.executor is None:
                self.executor = (_Dask(self.scheduler) if self.scheduler else
                                 _Local(min(self.workers or default_threads(), self.total)))
            study_data, robot_data = self.study.model_dump(mode="python"), self.robot.model_dump(mode="python")
            jobs_ = {self.executor.submit(study_data, robot_data, k, p): (k, p) for k, p in todo}
            _wait(self.executor, jobs_, lambda rec: self._keep(generation, rec))
        return {k: self.records[k] for k, _ in batch}


def run_digest(study: DesignStudy, robot: Robot) -> str:
    """What a folder's designs rest on: the study, the base robot's content (a robot file can change while the
    study file does not) and pytdcr's version. A folder is resumed only when this is unchanged."""
    text = json.dumps([study.digest(), robot.model_dump(mode="json"), __version__], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_designs(study: DesignStudy, robot: Robot, out: str | Path, *, study_text: str | None = None,
                options: DesignsRunOptions | None = None) -> DesignsRun:
    """Evaluate every design of ``study`` (base robot ``robot``) into the folder ``out``, resuming it.

    ``options`` (:class:`DesignsRunOptions`): a Dask scheduler to run on, or local processes (``workers``,
    default all cores); ``restart`` to start again; ``progress(done, failed, total)``, called as designs finish;
    ``figures``. ``study_text`` is kept as ``study.toml``. Ctrl-C stops at once, keeping every finished design
    (:class:`pytdcr.runs.RunInterrupted` says how many).
    Returns the table (also ``designs.parquet`` and ``designs.csv``) and the summary (``summary.json``).
    """
    check_capabilities(study, robot)  # every load case against the model, before the folder or any design
    how = options if options is not None else DesignsRunOptions()
    progress = how.progress
    t0 = time.perf_counter()
    designs = (None if study.designs.method == "optimize" else
               choose_designs(study.parameters, study.designs.method, study.designs.count, seed=study.seed))
    total = study.designs.total if designs is None else len(designs)
    inputs = {"study": study.model_dump(mode="json"), "designs": total, "robot": robot.model_dump(mode="json")}
    digest = run_digest(study, robot)
    with resumable_folder(out, "designs", inputs, digest, how.restart, LAYOUT) as run:
        _own_folder(run.path / "designs")
        for name in LAYOUT:  # the run's files: a link or anything but a file put there is replaced, never followed
            if name not in ("designs", "best"):
                _clear(run.path / name)
        if study_text is not None:
            atomic_write_text(run.path / "study.toml", study_text)
        runner = _Runner(study, robot, run, total, how)
        finished = False
        try:
            generation_of = design_batches(study, designs, runner.batch)
            finished = True
        except KeyboardInterrupt:
            raise RunInterrupted(f"{runner.saved()} in {run.path} (run the same command again to compute the "
                                 "rest)") from None
        except WorkersLost as err:
            raise WorkersLost(f"{err}; {runner.saved()} in {run.path}: run the same command again to compute the "
                              "rest (with fewer --workers if memory ran out)") from None
        finally:  # whatever stopped the run, no worker outlives it
            if runner.executor is not None:
                runner.executor.close(cancel=not finished)
        if progress is not None:  # the optimiser skips designs that come up again: its total was an upper bound
            progress(len(runner.records), runner.failed, len(runner.records))
        n = sum(k >= 0 for k in runner.records)
        summary = {"study": study.name, "digest": digest, "seed": study.seed, "designs": n,
                   "designs_reused": runner.reused, "designs_computed": runner.computed,
                   "designs_failed": sum(r["status"] == "failed" for k, r in runner.records.items() if k >= 0),
                   "reference": "off" if not study.reference else
                   ("failed" if runner.records[-1]["status"] == "failed" else "ok"),
                   "load_cases": list(study.load_cases(robot)),
                   "executor": runner.executor.name if runner.executor is not None else "none (every design reused)",
                   "seconds": time.perf_counter() - t0, "inputs": inputs["study"],
                   "versions": versions_record(_LIBRARIES),
                   "measures": measures_for(study.model)}
        table = _finish(run.path, study, robot, runner.records, generation_of, summary, how.figures)
    return DesignsRun(table, summary, run.path)

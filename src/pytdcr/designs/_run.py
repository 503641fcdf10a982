"""Running a design study where the compute is: local processes or a Dask cluster, resumable, never mixed.

Each design's result is written to ``designs/NNNNNN.json`` (atomically) as soon as it arrives; a run of the
same study into the same folder computes only the designs that have no file. The table is made from those
files at the end, sorted by design and load case, so it does not depend on where, in what order or how many
at a time the designs ran.
"""

from __future__ import annotations

import json
import multiprocessing
import platform
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..design import Robot
from ..io import write_robot
from ..statics import check_cancelled, mark_saving
from ..statics._batch import default_threads
from ..study._folder import RunInterrupted, atomic_write_text, resumable_folder
from ..study._output import write_json
from ._evaluate import MEASURES, evaluate_design
from ._space import apply_parameters, choose_designs
from ._spec import DesignStudy, StudyError

__all__ = ["DesignsRun", "run_designs"]

#: files and folders a study's folder holds
LAYOUT = ("study.toml", "designs", "designs.csv", "designs.parquet", "timings.csv", "summary.json", "report.md",
          "best")
#: how often the waiting loop looks for finished designs and for Ctrl-C [s]
POLL_S = 0.1


@dataclass(frozen=True)
class DesignsRun:
    """A finished study: the table (pandas DataFrame, one row per design and load case), the summary."""

    table: Any
    summary: dict[str, Any]
    path: Path


def _design_file(out: Path, index: int) -> Path:
    return out / "designs" / f"{index:06d}.json"


def _done(out: Path, designs: list[dict[str, float]]) -> dict[int, dict[str, Any]]:
    """The designs already in the folder (a file that does not parse, or holds other values, is redone)."""
    got = {}
    for k, params in enumerate(designs):
        f = _design_file(out, k)
        try:
            rec = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if rec.get("design") == k and rec.get("params") == params:
            got[k] = rec
    return got


class _Local:
    """Designs on local processes (spawned: a clean interpreter each, whatever the parent holds)."""

    def __init__(self, workers: int) -> None:
        self.name = f"{workers} local process{'es' * (workers != 1)}"
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))

    def submit(self, *args: Any) -> Any:
        return self.pool.submit(evaluate_design, *args)

    def close(self, cancel: bool) -> None:
        if cancel:
            procs = list(getattr(self.pool, "_processes", {}).values())
            self.pool.shutdown(wait=False, cancel_futures=True)
            for p in procs:  # a design in progress is lost either way: stop it now
                p.terminate()
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


def _wait(executor: Any, jobs: dict[Any, int], on_result: Callable[[dict[str, Any]], None]) -> None:
    """Hand each finished design to ``on_result`` as it comes; Ctrl-C (the run's cancel scope) stops at once."""
    pending = dict(jobs)
    while pending:
        check_cancelled()
        finished = [f for f in pending if f.done()]
        if not finished:
            time.sleep(POLL_S)
            continue
        for f in finished:
            pending.pop(f)
            on_result(f.result())


def _table(study: DesignStudy, designs: list[dict[str, float]], records: dict[int, dict[str, Any]]) -> Any:
    import pandas as pd

    names = list(study.parameters)
    measures = list(MEASURES) + [f"h_{k}_m" for k in study.measures.directions]
    rows = []
    for k in sorted(records):
        rec = records[k]
        base = {"design": k, **{n: designs[k][n] for n in names}, "status": rec["status"], "reason": rec["reason"]}
        if not rec["rows"]:
            rows.append({**base, "load_case": "", **{m: np.nan for m in measures}})
        for r in rec["rows"]:
            rows.append({**base, "load_case": r["load_case"], **{m: r.get(m, np.nan) for m in measures}})
    cols = ["design", "load_case", *names, "status", "reason", *measures]
    return pd.DataFrame(rows, columns=cols)


def _report(study: DesignStudy, table: Any, summary: dict[str, Any], best: list[tuple[str, int, str]]) -> str:
    lines = [f"# Design study '{study.name}'", "",
             f"{summary['designs']} designs ({study.designs.method}) of robot '{study.robot}', load cases "
             f"{', '.join(summary['load_cases'])}, tensions in [{study.bounds[0]:g}, {study.bounds[1]:g}] N, model "
             f"{study.model}, {study.budget.samples} samples and {study.budget.search} search solves per design "
             f"and load case; seed {study.seed}.", "",
             f"Computed {summary['designs_computed']}, reused {summary['designs_reused']}, failed "
             f"{summary['designs_failed']}; ran on {summary['executor']}.", ""]
    ok = table[table["status"] == "ok"]
    for case, index, robot_file in best:
        sub = ok[ok["load_case"] == case].sort_values("volume_m3", ascending=False).head(5)
        lines += [f"## Largest FSW under '{case}'", "", f"Best: design {index}, robot file `{robot_file}`.", "",
                  "| design | " + " | ".join(study.parameters) + " | FSW [cm³] | ± | reach [mm] | peak stress [MPa] |",
                  "|---" * (len(study.parameters) + 5) + "|"]
        for _, r in sub.iterrows():
            lines.append(f"| {r['design']} | " + " | ".join(f"{r[p]:.6g}" for p in study.parameters)
                         + f" | {r['volume_m3'] * 1e6:.0f} | {r['volume_err_m3'] * 1e6:.0f} | "
                         f"{r['largest_reach_m'] * 1e3:.1f} | {r['peak_stress_pa'] / 1e6:.0f} |")
        lines.append("")
    failed = table[table["status"] == "failed"]
    if len(failed):
        lines += ["## Failed designs", ""] + [f"- design {r['design']}: {r['reason']}" for _, r in
                                              failed.drop_duplicates("design").iterrows()] + [""]
    return "\n".join(lines)


def _write_best(out: Path, study: DesignStudy, robot: Robot, table: Any,
                designs: list[dict[str, float]]) -> list[tuple[str, int, str]]:
    """The robot file of the design with the largest FSW under each load case, in ``best/``."""
    (out / "best").mkdir(exist_ok=True)
    ok = table[table["status"] == "ok"]
    best = []
    for case in dict.fromkeys(ok["load_case"]):
        sub = ok[ok["load_case"] == case]
        k = int(sub.loc[sub["volume_m3"].idxmax(), "design"])
        name = f"best/design_{k:06d}.toml"
        write_robot(apply_parameters(robot, designs[k]).model_copy(update={"name": f"{study.name}-design-{k}"}),
                    out / name)
        best.append((case, k, name))
    return best


def _versions() -> dict[str, str]:
    import dask
    import numba
    import scipy

    return {"pytdcr": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__, "dask": dask.__version__}


def _finish(out: Path, study: DesignStudy, robot: Robot, designs: list[dict[str, float]],
            records: dict[int, dict[str, Any]], summary: dict[str, Any]) -> Any:
    table = _table(study, designs, records)
    tmp = out / ".designs.parquet.tmp"
    table.to_parquet(tmp, index=False)
    tmp.replace(out / "designs.parquet")
    atomic_write_text(out / "designs.csv", table.to_csv(index=False))
    timing = [{"design": k, **records[k]["timing"]} for k in sorted(records)]
    import pandas as pd

    atomic_write_text(out / "timings.csv", pd.DataFrame(timing).to_csv(index=False))
    best = _write_best(out, study, robot, table, designs) if (table["status"] == "ok").any() else []
    write_json(out / "summary.json", summary)
    atomic_write_text(out / "report.md", _report(study, table, summary, best))
    return table


def run_designs(study: DesignStudy, robot: Robot, out: str | Path, *, study_text: str | None = None,
                scheduler: str | None = None, workers: int | None = None, restart: bool = False,
                progress: Callable[[int, int, int], None] | None = None) -> DesignsRun:
    """Evaluate every design of ``study`` (base robot ``robot``) into the folder ``out``, resuming it.

    ``scheduler``: a Dask scheduler's address (``tcp://host:8786``) to run on; default local processes
    (``workers``, default all cores). ``progress(done, failed, total)`` is called as designs finish. Ctrl-C
    stops at once, keeping every finished design (:class:`pytdcr.study.RunInterrupted` says how many).
    Returns the table (also ``designs.parquet`` and ``designs.csv``) and the summary (``summary.json``).
    """
    t0 = time.perf_counter()
    designs = choose_designs(study.parameters, study.designs.method, study.designs.count, study.seed)
    inputs = {"study": study.model_dump(mode="json"), "designs": len(designs)}
    with resumable_folder(out, "designs", inputs, study.digest(), restart, LAYOUT) as run:
        path = run.path
        (path / "designs").mkdir(exist_ok=True)
        if study_text is not None:
            atomic_write_text(path / "study.toml", study_text)
        records = _done(path, designs)
        reused = len(records)
        todo = [k for k in range(len(designs)) if k not in records]
        failed = sum(r["status"] == "failed" for r in records.values())
        state = {"computed": 0, "failed": failed}
        if progress is not None:
            progress(len(records), failed, len(designs))

        def keep(rec: dict[str, Any]) -> None:
            mark_saving()
            atomic_write_text(_design_file(path, rec["design"]), json.dumps(rec, allow_nan=True))
            records[rec["design"]] = rec
            state["computed"] += 1
            state["failed"] += rec["status"] == "failed"
            run.interrupted_note = f"saved {len(records)} of {len(designs)} designs"
            if progress is not None:
                progress(len(records), state["failed"], len(designs))

        run.interrupted_note = f"saved {len(records)} of {len(designs)} designs"
        executor: Any = None
        try:
            if todo:
                executor = _Dask(scheduler) if scheduler else _Local(min(workers or default_threads(), len(todo)))
                study_data, robot_data = study.model_dump(mode="python"), robot.model_dump(mode="python")
                jobs = {executor.submit(study_data, robot_data, k, designs[k]): k for k in todo}
                _wait(executor, jobs, keep)
        except KeyboardInterrupt:
            if executor is not None:
                executor.close(cancel=True)
            raise RunInterrupted(f"saved {len(records)} of {len(designs)} designs in {path} (run the same command "
                                 "again to compute the rest)") from None
        if executor is not None:
            executor.close(cancel=False)
        summary = {"study": study.name, "digest": study.digest(), "seed": study.seed, "designs": len(designs),
                   "designs_reused": reused, "designs_computed": state["computed"],
                   "designs_failed": state["failed"], "load_cases": list(study.load_cases(robot)),
                   "executor": executor.name if executor is not None else "none (every design reused)",
                   "seconds": time.perf_counter() - t0, "inputs": inputs["study"], "versions": _versions(),
                   "measures": MEASURES}
        table = _finish(path, study, robot, designs, records, summary)
    return DesignsRun(table, summary, path)

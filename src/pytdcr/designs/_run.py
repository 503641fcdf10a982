"""Running a design study where the compute is: local processes or a Dask cluster, resumable, never mixed.

Each design's result is written to ``designs/NNNNNN.json`` (atomically) as soon as it arrives; a run of the
same study into the same folder computes only the designs that have no file it can trust (a file that is not a
regular one, or whose record is not exactly what this study writes for that design, is computed again; a link
is never followed). The records travel and are read back typed (:class:`~pytdcr.designs._records.DesignRecord`);
at the end :func:`pytdcr.designs._report.write_results` makes the table from them, sorted by design and load case
(so it does not depend on where, in what order or how many at a time the designs ran), and writes the summary,
the report, the best designs and the figures.
"""

from __future__ import annotations

import gc
import hashlib
import json
import signal
import time
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from .. import __version__
from ..robot import Robot
from ..runtime import (
    MAX_JSON_BYTES,
    OutputRun,
    RunInterrupted,
    atomic_write_text,
    default_threads,
    dump_json,
    process_pool,
    regular_file_bytes,
    resumable_folder,
    versions_record,
)
from ..statics import check_cancelled, mark_saving
from ..validate import check_count
from ._evaluate import check_capabilities, evaluate_design
from ._optimize import design_batches
from ._records import DesignRecord, DesignsSummary, RecordShape, Timing
from ._report import clear_name, own_folder, write_results
from ._space import choose_designs
from ._spec import DesignStudy, StudyError, measures_for

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DesignsRun", "DesignsRunOptions", "WorkersLost", "run_designs"]

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
    """A finished study.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per design and load case (:func:`~pytdcr.designs._report.build_table`; also ``designs.parquet``
        and ``designs.csv``).
    summary : DesignsSummary
        What ran and what was found (``summary.json``); read by attribute (``summary.best``).
    path : Path
        The study's folder.
    """

    table: pd.DataFrame
    summary: DesignsSummary
    path: Path


def _design_file(out: Path, index: int) -> Path:
    return out / "designs" / (f"{index:06d}.json" if index >= 0 else "reference.json")


#: failures that a resume tries again: what more memory, or workers that stay alive, can change
RETRIED_FAILURES = ("ResourceLimitError", "KilledWorker")


def _reuse(out: Path, index: int, params: dict[str, float], shape: RecordShape) -> DesignRecord | None:
    """Design ``index``'s record in the folder, if it is there for these values (else it is redone).

    The file is read as input another hand may have edited or replaced (:func:`~pytdcr.runtime._readback.
    regular_file_bytes`: a regular file, never through a link, a FIFO never waited on, of bounded size) and its
    record checked field by field (:meth:`DesignRecord.from_json`) and against the study
    (:meth:`RecordShape.mismatch`); a file that cannot be read or trusted, or a failure more memory or live
    workers may mend (:data:`RETRIED_FAILURES`), is computed again, never an error.
    """
    try:
        raw = json.loads(regular_file_bytes(_design_file(out, index), MAX_JSON_BYTES, follow=False).decode("utf-8"),
                         parse_constant=_no_constant)
        rec = DesignRecord.from_json(raw)  # a ValueError (a RecordKeyError among them) for a malformed record
    except (OSError, ValueError, RecursionError, UnicodeDecodeError):
        return None
    if shape.mismatch(rec, index, params) is not None or (rec.status == "failed"
                                                          and rec.reason.startswith(RETRIED_FAILURES)):
        return None
    return replace(rec, params=dict(params))  # the planned values themselves (equal, of the same JSON type)


def _no_constant(name: str) -> float:
    """JSON's ``NaN`` and ``Infinity`` are not strict JSON, and no record this run writes holds them."""
    raise ValueError(f"{name} is not strict JSON")


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

    def submit(self, *args: object) -> _Pending:
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
        self.futures: list[_Pending] = []

    def submit(self, *args: object) -> _Pending:
        fut = self.client.submit(evaluate_design, *args, pure=False)
        self.futures.append(fut)
        return fut

    def close(self, cancel: bool) -> None:
        if cancel:
            self.client.cancel(self.futures)
        self.client.close()


def _killed(index: int, params: dict[str, float], err: BaseException) -> DesignRecord:
    """The record of a design whose Dask workers died running it (the scheduler gave up on it): failed."""
    return DesignRecord(int(index), dict(params), "failed",
                        f"{type(err).__name__}: the workers running this design died (out of memory, or a crash "
                        f"in compiled code): {err}"[:500], (), Timing(float("nan"), "", -1))


class _Pending(Protocol):
    """A design handed to an executor: a local pool's future or a Dask one."""

    def done(self) -> bool: ...

    def result(self) -> DesignRecord: ...


def _wait(executor: _Local | _Dask | None, jobs: dict[_Pending, tuple[int, dict[str, float]]],
          on_result: Callable[[DesignRecord], None]) -> None:
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


class _Runner:
    """Evaluates batches of designs into the folder: reuses a design's file when it is there, sends the rest to
    the executor (made when first needed), writes each record as it arrives, counts and reports progress."""

    def __init__(self, study: DesignStudy, robot: Robot, run: OutputRun, total: int,
                 options: DesignsRunOptions) -> None:
        self.study, self.robot, self.run, self.path = study, robot, run, run.path
        self.total = total + study.reference
        self.scheduler, self.workers, self.progress = options.scheduler, options.workers, options.progress
        self.records: dict[int, DesignRecord] = {}
        self.reused = self.computed = self.failed = 0
        self.executor: _Local | _Dask | None = None
        self._reference = study.reference
        self.shape = RecordShape.of(study, robot)

    def saved(self) -> str:
        """How much is saved: "K of N designs" (and the base robot, when it is)."""
        k = sum(i >= 0 for i in self.records)
        return (f"saved {k} of {self.total - self.study.reference} designs"
                + (" and the base robot" if -1 in self.records else ""))

    def _report(self) -> None:
        self.run.interrupted_note = self.saved()
        if self.progress is not None:
            self.progress(len(self.records), self.failed, self.total)

    def _keep(self, generation: int, rec: DesignRecord) -> None:
        mark_saving()
        rec = replace(rec, generation=generation)
        path = _design_file(self.path, rec.design)
        clear_name(path)  # a link, FIFO or folder put at its name: replaced, never written through
        atomic_write_text(path, dump_json(rec.to_json()))  # strict JSON: a NaN measure is null, read back as NaN
        self.records[rec.design] = rec
        self.computed += rec.design >= 0
        self.failed += rec.status == "failed"
        self._report()

    def batch(self, generation: int, batch: list[tuple[int, dict[str, float]]]) -> dict[int, DesignRecord]:
        """Evaluate ``batch`` [(index, values)] (with the reference, index -1, the first time); returns the
        batch's records by index (what the optimiser reads: :mod:`pytdcr.designs._optimize`)."""
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
            self.failed += rec.status == "failed"
        self._report()
        if todo:
            if self.executor is None:
                self.executor = (_Dask(self.scheduler) if self.scheduler else
                                 _Local(min(self.workers or default_threads(), self.total)))
            study_data, robot_data = self.study.model_dump(mode="python"), self.robot.model_dump(mode="python")
            jobs_ = {self.executor.submit(study_data, robot_data, k, p): (k, p) for k, p in todo}
            _wait(self.executor, jobs_, lambda rec: self._keep(generation, rec))
        return {k: self.records[k] for k, _ in batch}


#: the libraries whose versions a design study's summary records
_LIBRARIES = ("numpy", "scipy", "numba", "dask", "pymoo")


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
    Returns the table (also ``designs.parquet`` and ``designs.csv``) and the summary (``summary.json``,
    :class:`~pytdcr.designs._records.DesignsSummary`); the report, the best designs and the figures are written
    by :func:`pytdcr.designs._report.write_results`.
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
        own_folder(run.path / "designs")
        for name in LAYOUT:  # the run's files: a link or anything but a file put there is replaced, never followed
            if name not in ("designs", "best"):
                clear_name(run.path / name)
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
        summary = DesignsSummary(
            study.name, digest, study.seed, n, runner.reused, runner.computed,
            sum(r.status == "failed" for k, r in runner.records.items() if k >= 0),
            "off" if not study.reference else runner.records[-1].status, tuple(study.load_cases(robot)),
            runner.executor.name if runner.executor is not None else "none (every design reused)",
            time.perf_counter() - t0, inputs["study"], versions_record(_LIBRARIES), measures_for(study.model))
        table, summary = write_results(run.path, study, robot, runner.records, generation_of, summary, how.figures)
    return DesignsRun(table, summary, run.path)

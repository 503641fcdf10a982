"""Progress on stderr, drawn from the first step (input refused before any work prints alone).

On a terminal every stage of a run is a row of one live block (rich), however many stages run at once on
threads: its name (the load case, the population, the model), a bar, the work done with its unit, the time
spent and left, and the quantity a person follows (the best reach in mm). A stage that ends early (a GA
stopped before its cap) ends full, its total set to the work done. When stderr is a file or a pipe: plain
timestamped lines, at most one every :func:`line_seconds` a stage and one at its end (no carriage returns in a
log). Nothing with ``--quiet`` (:func:`set_quiet`).
"""

from __future__ import annotations

import os
import sys
import threading
import time
from typing import TYPE_CHECKING

from ..runtime import duration, set_compile_notice

if TYPE_CHECKING:
    from rich.progress import Progress, ProgressColumn, Task

__all__ = ["LINE_SECONDS", "Bar", "Bars", "line_seconds", "quiet", "say", "set_quiet"]

#: the least time between two progress lines when stderr is not a terminal [s], unless
#: ``PYTDCR_PROGRESS_SECONDS`` says otherwise
LINE_SECONDS = 10.0
_QUIET = False


def line_seconds() -> float:
    """The least time between two progress lines [s]: ``PYTDCR_PROGRESS_SECONDS`` (a number >= 0; 0: a line a
    step), else :data:`LINE_SECONDS`."""
    text = os.environ.get("PYTDCR_PROGRESS_SECONDS", "")
    try:
        value = float(text)
    except ValueError:
        return LINE_SECONDS
    return value if value >= 0 and value == value else LINE_SECONDS


def set_quiet(quiet: bool) -> None:
    """Show no progress (``--quiet``) and no line saying kernels compile for first use; results and errors
    still print."""
    global _QUIET
    _QUIET = bool(quiet)
    set_compile_notice(not _QUIET)


def quiet() -> bool:
    """True with ``--quiet``."""
    return _QUIET


def say(text: str) -> None:
    """A line of progress news on stderr (an estimated time, a stage's start), timestamped when stderr is not a
    terminal; nothing with ``--quiet``."""
    if _QUIET:
        return
    stamp = "" if sys.stderr.isatty() else f"[{time.strftime('%H:%M:%S')}] "
    print(f"{stamp}{text}", file=sys.stderr, flush=True)


class _Lines:
    """A stage as timestamped lines on a stderr that is not a terminal."""

    def __init__(self, desc: str, total: int | None, unit: str) -> None:
        self.desc, self.total, self.unit, self.n, self.label = desc, total, unit, 0, ""
        self.t0 = self.last = time.monotonic()
        self.every = line_seconds()

    def update(self, k: int, label: str | None) -> None:
        self.n += k
        if label is not None:
            self.label = label
        if time.monotonic() - self.last >= self.every:
            self._line()

    def _line(self, end: str = "") -> None:
        self.last = time.monotonic()
        of = f"/{self.total}" if self.total else ""
        label = f", {self.label}" if self.label else ""
        print(f"[{time.strftime('%H:%M:%S')}] {self.desc}: {self.n}{of} {self.unit}{label}{end}", file=sys.stderr,
              flush=True)

    def close(self) -> None:
        self.total = self.n  # the total ends where the work ended
        self._line(f", done in {time.monotonic() - self.t0:.0f} s")


def _columns(width: int) -> tuple[ProgressColumn, ...]:
    """The live block's columns on a terminal ``width`` characters wide: the stage's name (given what the others
    leave, cut with an ellipsis), a bar (from 100 characters), the work done of its total, the time spent and
    left, the label (the best reach)."""
    from rich.progress import BarColumn, ProgressColumn, TextColumn
    from rich.table import Column
    from rich.text import Text

    class Count(ProgressColumn):
        def render(self, task: Task) -> Text:
            if task.finished and not task.completed:  # a stage of unknown length, ended
                return Text("done")
            of = f"/{task.total:.0f}" if task.total is not None else ""
            label = f", {task.fields['label']}" if task.fields.get("label") else ""
            return Text(f"{task.completed:.0f}{of} {task.fields.get('unit', '')}{label}")

    class Time(ProgressColumn):
        def render(self, task: Task) -> Text:
            spent = task.finished_time if task.finished else task.elapsed
            left = task.time_remaining
            more = f", ~{duration(left)} left" if left is not None and not task.finished and spent else ""
            return Text(f"{duration(spent or 0.0)}{more}", style="progress.elapsed")

    def natural() -> Column:
        return Column(no_wrap=True)

    name = TextColumn("{task.description}", table_column=Column(ratio=1, no_wrap=True, overflow="ellipsis"))
    bar = (BarColumn(bar_width=10, table_column=natural()),) if width >= 100 else ()
    return (name, *bar, Count(table_column=natural()), Time(table_column=natural()))


class _Live:
    """The one live block on a terminal: started with the first stage, stopped after the last ends (the rows
    stay on screen as the run's record)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.progress: Progress | None = None
        self.open = 0

    def add(self, desc: str, total: int | None, unit: str) -> int:
        with self.lock:
            if self.progress is None:
                from rich.console import Console
                from rich.progress import Progress

                console = Console(file=sys.stderr)
                self.progress = Progress(*_columns(console.width), console=console, refresh_per_second=8,
                                         expand=True)
                self.progress.start()
            self.open += 1
            return self.progress.add_task(desc, total=total, unit=unit, label="")

    def update(self, task: int, k: int, label: str | None) -> None:
        fields = {} if label is None else {"label": label}
        self.progress.update(task, advance=k, **fields)

    def finish(self, task: int) -> None:
        with self.lock:
            done = next(t.completed for t in self.progress.tasks if t.id == task)
            self.progress.update(task, total=done, completed=done)  # ends full where the work ended
            self.open -= 1
            if self.open == 0:
                self.progress.stop()
                self.progress = None


_LIVE = _Live()


class Bar:
    """One stage's progress on stderr (see the module), drawn from its first step."""

    def __init__(self, desc: str, total: int | None, unit: str) -> None:
        self.desc, self.total, self.unit = desc, total, unit
        self.task: int | None = None
        self.lines: _Lines | None = None
        self.closed = False
        self.done = 0

    def set_total(self, total: int | None) -> None:
        """A new total (an optimiser's total is an upper bound until it ends)."""
        self.total = total
        if self.task is not None:
            _LIVE.progress.update(self.task, total=total)
        elif self.lines is not None:
            self.lines.total = total

    def step(self, k: int = 1, label: str | None = None) -> None:
        """Advance by ``k``; ``label`` shows beside the bar."""
        if _QUIET or self.closed:
            return
        self.done += k
        if self.task is None and self.lines is None:
            if _LIVE.progress is not None or sys.stderr.isatty():  # the live block stands in for stderr meanwhile
                self.task = _LIVE.add(self.desc, self.total, self.unit)
            else:
                self.lines = _Lines(self.desc, self.total, self.unit)
        if self.task is not None:
            _LIVE.update(self.task, k, label)
        elif self.lines is not None:
            self.lines.update(k, label)

    def generation(self, _gen: int, best: float, _mean: float) -> None:
        """The GA's progress callback: ``best`` is the least cost, 1/reach [1/m], shown as the reach."""
        self.step(1, f"best reach {1e3 / best:.1f} mm" if best > 0 else f"best cost {best:.4g}")

    def close(self) -> None:
        """End the stage (its row stays, full); a second call does nothing."""
        if self.closed:
            return
        self.closed = True
        if self.task is not None:
            _LIVE.finish(self.task)
        elif self.lines is not None:
            self.lines.close()

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Steps:
    """A stage's ``step(k=1, label=None)`` that the run may end with ``close()``."""

    def __init__(self, bar: Bar) -> None:
        self.bar = bar

    def __call__(self, k: int = 1, label: str | None = None) -> None:
        self.bar.step(k, label)

    def close(self) -> None:
        self.bar.close()


class _Generations:
    """A GA's progress callback (:meth:`Bar.generation`) that the run ends with ``close()``."""

    def __init__(self, bar: Bar) -> None:
        self.bar = bar

    def __call__(self, gen: int, best: float, mean: float) -> None:
        self.bar.generation(gen, best, mean)

    def close(self) -> None:
        self.bar.close()


class Bars:
    """Progress for the stages of a long run, each a :class:`Bar` (a row of the live block). Stages from one
    thread follow each other: a thread's new stage closes its last one. :meth:`close` ends whatever is open."""

    def __init__(self, unit: str = "solve") -> None:
        self.unit = unit
        self.bars: dict[int, Bar] = {}
        self.lock = threading.Lock()

    def _open(self, stage: str, total: int | None, unit: str) -> Bar:
        with self.lock:
            last = self.bars.pop(threading.get_ident(), None)
            if last is not None:
                last.close()
            bar = self.bars[threading.get_ident()] = Bar(stage, total, unit)
        return bar

    def __call__(self, stage: str, total: int | None, unit: str | None = None) -> _Steps:
        """A stage of ``total`` steps (None: not known) of ``unit``: returns its ``step(k=1, label=None)``."""
        return _Steps(self._open(stage, total, unit or ("dir" if "h(d)" in stage else self.unit)))

    def generations(self, stage: str, total: int | None) -> _Generations:
        """A GA's stage: its callback shows the best reach in mm; the callback's ``close()`` ends the stage."""
        return _Generations(self._open(stage, total, "gen"))

    def close(self) -> None:
        """Close every open bar."""
        with self.lock:
            for bar in self.bars.values():
                bar.close()
            self.bars.clear()

    def __enter__(self) -> Bars:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

"""Progress on stderr, drawn from the first step (input refused before any work prints alone): a tqdm bar on a
terminal; plain timestamped lines, at most one every :func:`line_seconds` and one at the end, when stderr is a
file or a pipe (no carriage returns mixed into a log); nothing with ``--quiet`` (:func:`set_quiet`)."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

__all__ = ["LINE_SECONDS", "Bar", "Bars", "line_seconds", "set_quiet"]

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
    """Show no progress (``--quiet``); results and errors still print."""
    global _QUIET
    _QUIET = bool(quiet)


class _Lines:
    """tqdm's few calls, as timestamped lines on a stderr that is not a terminal."""

    def __init__(self, desc: str, total: int | None, unit: str) -> None:
        self.desc, self.total, self.unit, self.n, self.label = desc, total, unit, 0, ""
        self.t0 = self.last = time.monotonic()
        self.every = line_seconds()

    def set_postfix_str(self, label: str, refresh: bool = False) -> None:
        self.label = label

    def update(self, k: int) -> None:
        self.n += k
        if time.monotonic() - self.last >= self.every:
            self._line()

    def _line(self, end: str = "") -> None:
        self.last = time.monotonic()
        of = f"/{self.total}" if self.total else ""
        label = f", {self.label}" if self.label else ""
        print(f"[{time.strftime('%H:%M:%S')}] {self.desc}: {self.n}{of} {self.unit}{label}{end}", file=sys.stderr,
              flush=True)

    def close(self) -> None:
        self._line(f", {time.monotonic() - self.t0:.0f} s")


class Bar:
    """One stage's progress on stderr (see the module), drawn from its first step."""

    def __init__(self, desc: str, total: int, unit: str) -> None:
        self.desc, self.total, self.unit = desc, total, unit
        self.bar: Any = None

    def step(self, k: int = 1, label: str | None = None) -> None:
        """Advance by ``k``; ``label`` shows beside the bar."""
        if _QUIET:
            return
        if self.bar is None:
            if sys.stderr.isatty():
                from tqdm import tqdm

                self.bar = tqdm(total=self.total, desc=self.desc, unit=self.unit, leave=False, file=sys.stderr)
            else:
                self.bar = _Lines(self.desc, self.total, self.unit)
        if label is not None:
            self.bar.set_postfix_str(label, refresh=False)
        self.bar.update(k)

    def generation(self, _gen: int, best: float, _mean: float) -> None:
        """The GA's progress callback: ``best`` is the least cost, 1/reach [1/m], shown as the reach."""
        self.step(1, f"best reach {1e3 / best:.1f} mm" if best > 0 else f"best cost {best:.4g}")

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.close()


class Bars:
    """One progress bar per stage of a long run (``progress(stage, total)``), closed when the next opens."""

    def __init__(self) -> None:
        self.bar: Bar | None = None

    def __call__(self, stage: str, total: int | None) -> Any:
        self.close()
        self.bar = Bar(stage, total, "solve" if "h(d)" not in stage else "dir")  # type: ignore[arg-type]
        return self.bar.step

    def close(self) -> None:
        """Close the open bar, if any."""
        if self.bar is not None:
            self.bar.__exit__()
            self.bar = None

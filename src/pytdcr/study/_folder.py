"""The one output-folder rule, the same for every command, and atomic writes.

- A new or empty folder is used.
- A folder in use (a live lock) is refused with one line.
- A stale lock (its process gone) is taken over.
- A finished or interrupted run of any command is replaced as a whole: the new
  run writes aside, into a staging folder next to it, and the two are swapped
  when it ends; the folder never mixes two runs.
- A folder that holds anything but a tdcr run is refused, never replaced.

Each run's folder holds ``manifest.json``: the command, its inputs and seed,
the versions, the start and end, and ``status`` (``complete`` or
``interrupted``). An interrupted run that wrote results is swapped in with
status ``interrupted``; one that wrote none leaves the previous run in place.
(``tdcr designs`` alone resumes its own studies instead: issue 13.)
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import socket
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import __version__
from ..io import to_jsonable
from ..validate import show

__all__ = ["MANIFEST", "FolderError", "OutputRun", "RunInterrupted", "atomic_write_text", "output_folder"]

#: the name of every run's manifest
MANIFEST = "manifest.json"


class FolderError(ValueError):
    """An output folder that cannot be used (in use, holds other files, is a file)."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run that writes a folder; ``message`` says what was saved."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename: the file is whole or absent."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - another user's live process
        return True
    return True


def _lock_path(path: Path) -> Path:
    return path.parent / f".{path.name}.lock"


def _take_lock(path: Path, command: str) -> Path:
    """Create the lock beside ``path`` atomically; take over a stale one; refuse a live one."""
    lock = _lock_path(path)
    record = json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "command": command,
                         "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    for _ in range(3):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                other = json.loads(lock.read_text())
                pid, host = int(other["pid"]), str(other["host"])
            except (OSError, ValueError, KeyError, TypeError):
                other, pid, host = {}, -1, socket.gethostname()  # unreadable: a crash mid-write, stale
            who = show(other.get("command", "a tdcr run"))
            if host != socket.gethostname():
                raise FolderError(f"{show(str(path))}: in use by {who} on host {show(host)} (lock {show(str(lock))}; "
                                  "remove it if that run is gone)") from None
            if pid > 0 and pid != os.getpid() and _alive(pid):
                raise FolderError(f"{show(str(path))}: in use by process {pid} ({who}, started "
                                  f"{other.get('started', '?')}); wait for it or choose another --out") from None
            lock.unlink(missing_ok=True)  # stale: its process is gone
            continue
        with os.fdopen(fd, "w") as fh:
            fh.write(record)
        return lock
    raise FolderError(f"{show(str(path))}: cannot take the lock {show(str(lock))}")  # pragma: no cover


def _check_target(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise FolderError(f"--out {show(str(path))}: is a file, not a folder")
    if path.is_dir() and any(path.iterdir()) and not (path / MANIFEST).is_file():
        raise FolderError(f"--out {show(str(path))}: holds files that are not a tdcr run (no {MANIFEST}); "
                          "choose a new or empty folder")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise FolderError(f"--out {show(str(path))}: {show(str(parent))} is a file, not a folder")


@dataclass
class OutputRun:
    """A run being written: its staging folder, its manifest, what it saved."""

    path: Path
    staging: Path
    manifest: dict[str, Any]
    saved: list[str] = field(default_factory=list)
    interrupted_note: str = ""

    def file(self, name: str) -> Path:
        """Where to write the run's file ``name`` (in the staging folder)."""
        return self.staging / name


def _swap(run: OutputRun) -> None:
    """Put the staging folder in the target's place; the previous run, if any, goes as a whole."""
    old = run.path.parent / f".{run.path.name}.old-{os.getpid()}"
    if run.path.exists():
        os.replace(run.path, old)
    os.replace(run.staging, run.path)
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)


def _finish(run: OutputRun, status: str) -> None:
    run.manifest.update(status=status, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                        files=sorted(p.name for p in run.staging.iterdir() if not p.name.startswith(".")))
    if status == "interrupted" and run.interrupted_note:
        run.manifest["interrupted"] = run.interrupted_note
    atomic_write_text(run.staging / MANIFEST, json.dumps(to_jsonable(run.manifest), indent=2, allow_nan=False))
    _swap(run)


@contextmanager
def output_folder(path: str | Path, command: str, inputs: dict[str, Any] | None = None) -> Iterator[OutputRun]:
    """Run a command into ``path`` under the rule above; yields an :class:`OutputRun` to write into.

    On KeyboardInterrupt the run is saved with status ``interrupted`` if it wrote any file (``run.saved`` and
    ``run.interrupted_note`` say what), else discarded; the interrupt is raised again. On any other exception
    the staging folder is discarded and the previous run left as it was.
    """
    path = Path(path).absolute()
    _check_target(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = _take_lock(path, command)
    staging = path.parent / f".{path.name}.partial-{os.getpid()}"
    try:
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
        manifest = {"command": command, "argv": list(sys.argv), "pytdcr": __version__,
                    "python": platform.python_version(), "host": socket.gethostname(),
                    "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "status": "running", "inputs": inputs or {}}
        run = OutputRun(path, staging, manifest)
        try:
            yield run
        except KeyboardInterrupt:
            written = [p.name for p in staging.iterdir() if not p.name.startswith(".")]
            if written:
                _finish(run, "interrupted")
                what = run.interrupted_note or f"saved {len(written)} files"
                raise RunInterrupted(f"{what} in {path} (manifest status: interrupted)") from None
            where = "keeps the previous run" if path.exists() else "was not created"
            raise RunInterrupted(f"nothing saved; {path} {where}") from None
        _finish(run, "complete")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        lock.unlink(missing_ok=True)

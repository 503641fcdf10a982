"""The one output-folder rule, the same for every command, and atomic writes.

- A new or empty folder is used.
- A folder in use (a live lock) is refused with one line. The lock and the staging folder live beside the
  folder, so a mount point, the current folder (or one holding it) and a folder whose parent is not writable
  are refused before any work; a symbolic link is followed to the folder it names.
- A stale lock (its process gone) is taken over: the lock is a ``flock`` the
  kernel drops when the process ends, however it ends (POSIX systems).
- A finished or interrupted run of any command is replaced as a whole: the new
  run writes aside, into a staging folder next to it, and the two are swapped
  when it ends; the folder never mixes two runs. One exception keeps work: an
  interrupted run never replaces a complete one; it is saved beside it, in
  ``NAME.interrupted``.
- A folder that holds anything but a tdcr run, at any depth (a file or folder its manifest does not list, or a
  manifest that is not a tdcr run's), is refused, never replaced: a manifest lists every file a run wrote,
  sub-folders included.
- A design study's folder (resumable: its manifest has a ``digest``) is refused by every other command.
- A folder inside the folder of a live run (or inside its staging folder) is refused: that run's swap would
  delete it.

Each run's folder holds ``manifest.json``: the command, its inputs and seed,
the versions, the start and end, and ``status`` (``complete`` or
``interrupted``). An interrupted run that wrote results is swapped in with
status ``interrupted``; one that wrote none leaves the previous run in place.
(``tdcr designs`` alone resumes its own studies instead: issue 13.)
"""

from __future__ import annotations

import fcntl
import json
import os
import platform
import re
import shutil
import socket
import stat
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from .._version import __version__
from ..records import JsonDict, JsonObject
from ..validate import escape_controls, show, show_path
from ._cancel import mark_saving
from ._files import atomic_write_text, to_jsonable
from ._readback import MAX_JSON_BYTES, regular_file_bytes

__all__ = [
    "MANIFEST",
    "FolderError",
    "OutputRun",
    "RunInterrupted",
    "StudyChanged",
    "check_output_folder",
    "output_folder",
    "resumable_folder",
]

#: the name of every run's manifest
MANIFEST = "manifest.json"


class FolderError(ValueError):
    """An output folder that cannot be used (in use, holds other files, is a file)."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run that writes a folder; ``message`` says what was saved."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message




#: the libraries a run's numbers depend on (their versions go into every manifest and ``tdcr --version``)
RESULT_LIBRARIES = ("numpy", "scipy", "numba", "llvmlite", "pymoo")


def library_versions(libraries: tuple[str, ...] = RESULT_LIBRARIES) -> dict[str, str]:
    """The installed versions of ``libraries`` (default :data:`RESULT_LIBRARIES`), read from the packages'
    metadata (nothing imported); ``"not installed"`` for one that is not."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in libraries:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def versions_record(libraries: tuple[str, ...] = RESULT_LIBRARIES) -> dict[str, str]:
    """What a result file records of the software that made it: pytdcr's and Python's versions, then
    :func:`library_versions` of ``libraries``; the one version collector of every manifest and summary."""
    return {"pytdcr": __version__, "python": platform.python_version(), **library_versions(libraries)}


def _lock_path(path: Path) -> Path:
    return path.parent / f".{path.name}.lock"


def _staging_path(path: Path, pid: int) -> Path:
    return path.parent / f".{path.name}.partial-{pid}"


def _aside_path(path: Path, pid: int) -> Path:
    return path.parent / f".{path.name}.old-{pid}"


def _clean_after(path: Path, pid: int) -> None:
    """What a run killed outright (no Ctrl-C: SIGKILL, power) left beside ``path``: its staging folder goes;
    a previous run it had moved aside for the swap comes back."""
    if pid <= 0:
        return
    shutil.rmtree(_staging_path(path, pid), ignore_errors=True)
    aside = _aside_path(path, pid)
    if aside.is_dir() and not aside.is_symlink():  # only a folder a run moved aside comes back, never a link
        if path.exists():
            shutil.rmtree(aside, ignore_errors=True)
        else:
            os.replace(aside, path)


@dataclass
class _Lock:
    """A held lock: the open file whose ``flock`` the kernel keeps while this process lives."""

    path: Path
    fd: int

    def release(self) -> None:
        self.path.unlink(missing_ok=True)
        os.close(self.fd)


def _holder(fd: int) -> JsonObject:
    try:
        raw = os.pread(fd, 4096, 0)
        rec = json.loads(raw.decode("utf-8"))
        return rec if isinstance(rec, dict) else {}
    except (OSError, ValueError):
        return {}


def _in_use(path: Path, rec: JsonObject) -> FolderError:
    who = show(str(rec.get("command", "another run")))[1:-1]
    pid = rec["pid"] if isinstance(rec.get("pid"), int) else "?"  # the record is read back: shown, never trusted
    started = show(str(rec.get("started", "?")), 40)[1:-1]
    return FolderError(f"{show_path(path)}: in use by process {pid} (tdcr {who}, started {started}); "
                       "wait for it or choose another --out")


def _flock_retrying(fd: int, tries: int = 10) -> bool:
    """Take the exclusive lock, retrying briefly (another process's check holds a shared one for microseconds)."""
    for k in range(tries):
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if k < tries - 1:
                time.sleep(0.02)
    return False


#: how a lock file is opened: never through a link (its target would be truncated), never waiting on a FIFO
_LOCK_FLAGS = os.O_CREAT | os.O_RDWR | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
_PEEK_FLAGS = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def _open_lock(lock: Path, path: Path) -> int:
    """The lock file ``lock`` of ``path``, opened (made when missing) for this run: refused when it is a link or
    anything but a regular file (the lock is written: it is never written through a link)."""
    try:
        fd = os.open(lock, _LOCK_FLAGS, 0o644)
    except OSError as err:
        raise FolderError(f"{show_path(path)}: cannot use its lock {show_path(lock)} ({err.strerror or err}; a "
                          "link there is never followed): remove it or choose another --out") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise FolderError(f"{show_path(path)}: its lock {show_path(lock)} is not a regular file: remove it or "
                          "choose another --out")
    return fd


def _take_lock(path: Path, command: str) -> _Lock:
    """Lock ``path`` for this run (an exclusive ``flock`` on ``.<name>.lock`` beside it).

    The kernel drops the lock when its process ends however it ends, so a lock left by a run that is gone is
    free and is taken over (what that run left beside the folder is cleaned up); a live one is refused.
    """
    lock = _lock_path(path)
    for _ in range(10):
        fd = _open_lock(lock, path)
        if not _flock_retrying(fd):
            rec = _holder(fd)
            os.close(fd)
            raise _in_use(path, rec) from None
        try:  # the file may have been unlinked by the run that held it before we locked it: start again
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:
            os.close(fd)
            continue
        previous = _holder(fd)
        if previous.get("host") == socket.gethostname() and isinstance(previous.get("pid"), int):
            _clean_after(path, previous["pid"])
        record = json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "command": command,
                             "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}).encode()
        os.ftruncate(fd, 0)
        os.pwrite(fd, record, 0)
        return _Lock(lock, fd)
    raise FolderError(f"{show_path(path)}: cannot take the lock {show_path(lock)}")  # pragma: no cover


def _target(path: str | Path) -> Path:
    """The absolute folder a run writes: ``~`` expanded, symbolic links followed."""
    return Path(os.path.realpath(Path(path).expanduser()))


def check_output_folder(path: str | Path) -> None:
    """Refuse, before any work, an output folder the rule will not use: a file, a folder of other files, a
    mount point, the current folder, an unwritable parent, or one in use by a live run (:class:`FolderError`)."""
    path = _target(path)
    _check_target(path)
    lock = _lock_path(path)
    try:
        fd = os.open(lock, _PEEK_FLAGS)
    except OSError:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        raise _in_use(path, _holder(fd)) from None
    finally:
        os.close(fd)


def _read_manifest(path: Path) -> JsonObject | None:
    """The folder's manifest if it is a tdcr run's, else None: a regular file (never a link, a FIFO or a
    device; at most :data:`~pytdcr.runtime._readback.MAX_JSON_BYTES`) holding a JSON object whose ``command``,
    ``status`` and ``pytdcr`` are strings, whose ``files`` (and ``owned``, when there) are lists of relative
    paths, and whose ``digest`` (when there) is a string or null."""
    try:
        data = json.loads(regular_file_bytes(path / MANIFEST, MAX_JSON_BYTES, follow=False).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not (isinstance(data, dict) and all(isinstance(data.get(k), str) for k in ("command", "status", "pytdcr"))
            and _names(data.get("files")) and _names(data.get("owned", []))
            and isinstance(data.get("digest"), (str, type(None)))):
        return None
    return data


def _names(value: object) -> bool:
    """``value`` is a list of relative paths (strings, no absolute path, no ``..``)."""
    return isinstance(value, list) and all(
        isinstance(f, str) and f and not f.startswith("/") and ".." not in f.split("/") for f in value)


def _walk(path: Path) -> list[tuple[str, Path]]:
    """Every entry under ``path`` (relative POSIX path, path), folders before what they hold; links not followed."""
    out = []
    for p in sorted(path.iterdir()):
        out.append((p.name, p))
        if p.is_dir() and not p.is_symlink():
            out += [(f"{p.name}/{rel}", q) for rel, q in _walk(p)]
    return out


def run_files(path: Path) -> list[str]:
    """The files a run wrote in ``path``, at every depth, as relative POSIX paths (its temporary files, whose
    names start with a dot, and the manifest aside)."""
    return sorted(rel for rel, p in _walk(path) if not p.is_dir() or p.is_symlink()
                  if not any(part.startswith(".") for part in rel.split("/")) and rel != MANIFEST)


def _foreign(path: Path) -> list[str]:
    """Entries of ``path``, at any depth, that are not part of the tdcr run its manifest describes (all of them if
    none): a file its manifest does not list, or anything but a file or folder. Folders are the run's when
    every entry they hold is; what a resumable run owns whole (its manifest's ``owned`` names) is not looked
    into."""
    manifest = _read_manifest(path)
    if manifest is None:
        return sorted(p.name for p in path.iterdir())
    files = {MANIFEST, *map(str, manifest["files"])}
    names = {f for f in manifest.get("owned", []) if isinstance(f, str)}
    inside = tuple(f"{f}/" for f in names)
    out = []
    for rel, p in _walk(path):
        if rel in names or rel.startswith(inside):
            continue
        if p.is_dir() and not p.is_symlink():
            continue
        if rel not in files:
            out.append(rel)
    return out


def _live_lock(folder: Path) -> JsonObject | None:
    """The lock record of the live run writing ``folder``, or None (no lock, or its process is gone)."""
    try:
        fd = os.open(_lock_path(folder), _PEEK_FLAGS)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    except BlockingIOError:
        return _holder(fd) or {"command": "another run"}
    finally:
        os.close(fd)


def _check_not_inside_a_live_run(path: Path) -> None:
    """Refuse a folder inside a live run's folder or staging folder (its swap would delete it)."""
    for ancestor in path.parents:
        name = ancestor.name
        m = re.fullmatch(r"\.(.+)\.(?:partial|old)-\d+", name)
        owner = ancestor.with_name(m.group(1)) if m else ancestor
        rec = _live_lock(owner)
        if rec is not None:
            who = show(str(rec.get("command", "another run")))[1:-1]
            raise FolderError(f"--out {show_path(path)}: is inside {show_path(owner)}, the folder of a live run "
                              f"(process {rec.get('pid', '?')}, tdcr {who}), which replaces its folder as a whole "
                              "when it ends; give a folder outside it")


def _check_target(path: Path, resumable: bool = False) -> None:
    shown = show_path(path)
    _check_not_inside_a_live_run(path)
    cwd = Path(os.path.realpath(Path.cwd()))
    if path == cwd or path in cwd.parents:
        raise FolderError(f"--out {shown}: is the current folder or holds it; a run replaces its folder as a "
                          "whole, so give it a folder of its own")
    if path.exists() and not path.is_dir():
        raise FolderError(f"--out {shown}: is a file, not a folder")
    if path.is_dir():
        if os.path.ismount(path):
            raise FolderError(f"--out {shown}: is a mount point; a run is written beside its folder and swapped "
                              "in, so give a folder inside it")
        manifest = _read_manifest(path)
        if manifest is not None and manifest.get("digest") is not None and not resumable:
            raise FolderError(f"--out {shown}: holds a design study (tdcr {show(str(manifest.get('command')))[1:-1]},"
                              " resumable); other runs never replace it: give another folder")
        other = _foreign(path)
        if other:
            raise FolderError(f"--out {shown}: holds files that are not part of a tdcr run ({show(other[0])}"
                              f"{f' and {len(other) - 1} more' if len(other) > 1 else ''}); choose a new or "
                              "empty folder")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise FolderError(f"--out {shown}: {show_path(parent)} is a file, not a folder")
    if parent.is_dir() and not os.access(parent, os.W_OK | os.X_OK):
        raise FolderError(f"--out {shown}: cannot write in {show_path(parent)} (the run is written beside its "
                          "folder and swapped in)")


@dataclass
class OutputRun:
    """A run being written: its staging folder, its manifest, what it saved."""

    path: Path
    staging: Path
    manifest: JsonDict
    saved: list[str] = field(default_factory=list)
    interrupted_note: str = ""

    def file(self, name: str) -> Path:
        """Where to write the run's file ``name`` (in the staging folder)."""
        return self.staging / name


def _swap(staging: Path, target: Path) -> None:
    """Put ``staging`` in ``target``'s place; the previous run there, if any, goes as a whole."""
    old = _aside_path(target, os.getpid())
    if target.exists():
        os.chmod(staging, stat.S_IMODE(target.stat().st_mode))  # the folder keeps its permissions
        os.replace(target, old)
    os.replace(staging, target)
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)


def _finish(run: OutputRun, status: str) -> Path:
    """Write the manifest and swap the run in; returns where it went (an interrupted run never replaces a
    complete one: it goes to ``NAME.interrupted`` beside it)."""
    mark_saving()
    run.manifest.update(status=status, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"), files=run_files(run.staging))
    if status == "interrupted" and run.interrupted_note:
        run.manifest["interrupted"] = run.interrupted_note
    atomic_write_text(run.staging / MANIFEST, json.dumps(to_jsonable(run.manifest), indent=2, allow_nan=False))
    target = run.path
    if status == "interrupted" and (_read_manifest(target) or {}).get("status") == "complete":
        target = target.with_name(f"{target.name}.interrupted")
        if target.exists() and (not target.is_dir() or _foreign(target)):
            raise FolderError(f"{show_path(target)}: holds files that are not a tdcr run; the interrupted run "
                              "was not saved")
    _swap(run.staging, target)
    return target


@contextmanager
def output_folder(path: str | Path, command: str, inputs: JsonDict | None = None) -> Iterator[OutputRun]:
    """Run a command into ``path`` under the rule above; yields an :class:`OutputRun` to write into.

    On KeyboardInterrupt the run is saved with status ``interrupted`` if it wrote any file (``run.saved`` and
    ``run.interrupted_note`` say what), else discarded; the interrupt is raised again. On any other exception
    the staging folder is discarded and the previous run left as it was.
    """
    path = _target(path)
    _check_target(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = _take_lock(path, command)
    staging = _staging_path(path, os.getpid())
    try:
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
        manifest = {"command": command, "argv": list(sys.argv), "pytdcr": __version__,
                    "python": platform.python_version(), "versions": library_versions(), "host": socket.gethostname(),
                    "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "status": "running", "inputs": inputs or {}}
        run = OutputRun(path, staging, manifest)
        try:
            yield run
        except KeyboardInterrupt:
            mark_saving()
            written = [p.name for p in staging.iterdir() if not p.name.startswith(".")]
            if written:
                where = _finish(run, "interrupted")
                what = run.interrupted_note or f"saved {len(written)} files"
                kept = f"; the complete run in {escape_controls(str(path))} is kept" if where != path else ""
                raise RunInterrupted(f"{what} in {escape_controls(str(where))} (manifest status: interrupted)"
                                     f"{kept}") from None
            where = "keeps the previous run" if path.exists() else "was not created"
            raise RunInterrupted(f"nothing saved; {escape_controls(str(path))} {where}") from None
        _finish(run, "complete")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        lock.release()


class StudyChanged(FolderError):
    """A resumable folder was started by a study that differs from the one given now."""


@contextmanager
def resumable_folder(path: str | Path, command: str, inputs: JsonDict, digest: str,
                     restart: bool = False, layout: tuple[str, ...] = ()) -> Iterator[OutputRun]:
    """The one exception to the rule above (``tdcr designs``, ``tdcr calibrate``): a folder whose run stopped is
    resumed in place.

    A new or empty folder is started; a folder of the same study (its manifest's ``digest``) is resumed, its
    finished work kept; one of another study, or of another command, is refused (:class:`StudyChanged`) unless
    ``restart``, which empties it first. Files other than a tdcr run's are refused as always; a folder in use
    is refused. The run writes into the folder itself (``run.staging`` is ``run.path``), each file atomically;
    the manifest says ``running``, then ``complete`` or ``interrupted``; it lists the ``layout`` names (the files
    and sub-folders the run may write) from the start, so a run killed outright is still recognised as one.
    """
    path = _target(path)
    _check_target(path, resumable=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = _take_lock(path, command)
    try:
        old = _read_manifest(path) if path.is_dir() else None
        if old is not None and (old.get("command") != command or old.get("digest") != digest):
            what = (f"a run of 'tdcr {old.get('command')}'" if old.get("command") != command
                    else "a run of other inputs (its study file or data, its robot, its settings or pytdcr's version "
                    "changed since it was started)")
            if not restart:
                raise StudyChanged(f"--out {show_path(path)}: holds {what}; give a new folder, or --restart to "
                                   "discard it and start again")
        if restart and path.is_dir():
            for p in path.iterdir():
                shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
            old = None
        path.mkdir(exist_ok=True)
        manifest = {"command": command, "argv": list(sys.argv), "pytdcr": __version__,
                    "python": platform.python_version(), "versions": library_versions(), "host": socket.gethostname(),
                    "digest": digest,
                    "started": (old or {}).get("started", time.strftime("%Y-%m-%dT%H:%M:%S%z")),
                    "resumed": time.strftime("%Y-%m-%dT%H:%M:%S%z") if old else None,
                    "status": "running", "inputs": inputs, "files": (old or {}).get("files", [])}
        run = OutputRun(path, path, manifest)

        def close(status: str) -> None:
            mark_saving()
            # names the run owns whole: while it runs, every name of its layout (it may be killed outright at any
            # moment); once closed, its sub-folders (one file per design: written and resumed by it alone)
            owned = sorted(layout) if status == "running" else sorted(f for f in layout if (path / f).is_dir())
            inside = tuple(f"{d}/" for d in owned)
            here = [f for f in run_files(path) if not f.startswith(inside) and f not in owned]
            manifest.update(status=status, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"), owned=owned, files=here)
            if status == "interrupted" and run.interrupted_note:
                manifest["interrupted"] = run.interrupted_note
            atomic_write_text(path / MANIFEST, json.dumps(to_jsonable(manifest), indent=2, allow_nan=False))

        close("running")
        try:
            yield run
        except BaseException:  # Ctrl-C or an error: what was finished stays, for the next run to resume
            close("interrupted")
            raise
        close("complete")
    finally:
        lock.release()

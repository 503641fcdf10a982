"""Atomic file writes: every file pytdcr writes is whole or absent, never half-written, and never anything but a
regular file.

A file is written to a temporary name beside its target (``.NAME.tmp-PID``) and renamed over it; a failure
removes the temporary file. A symbolic link is followed to its target, which is written (the link stays); a
path that names anything but a regular file or nothing (a folder, a device such as ``/dev/null``, a FIFO, a
socket) is refused before anything is written (:class:`FileRefused`, a ValueError: the command line's exit 2).
JSON is strict (non-finite numbers become null) and NumPy values are converted.
"""

from __future__ import annotations

import csv
import io
import json
import os
import stat
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import overload

import numpy as np

from ..records import JsonDict
from ..validate import show_path

__all__ = ["FileRefused", "atomic_write", "atomic_write_text", "dump_json", "to_jsonable", "writable_file",
           "write_csv", "write_json"]

#: what a path that is not a regular file names, by its file type
_KINDS = {stat.S_IFDIR: "a folder", stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device",
          stat.S_IFIFO: "a FIFO (named pipe)", stat.S_IFSOCK: "a socket"}


class FileRefused(ValueError):
    """A path that pytdcr will not write a file to (a folder, a device, a FIFO, a socket, a missing folder)."""


def writable_file(path: str | Path, what: str = "") -> Path:
    """The regular file (existing or new) that writing ``path`` replaces: symbolic links followed to their target.

    Parameters
    ----------
    path : str or Path
        The file a user or a run names.
    what : str
        How messages name it (``--plot``, ``--out``); default: the path alone.

    Raises
    ------
    FileRefused
        When ``path`` (after following links) names anything but a regular file or nothing, or when its folder
        does not exist.
    """
    given = Path(path).expanduser()
    real = Path(os.path.realpath(given))
    label = f"{what} {show_path(given)}" if what else show_path(given)
    try:
        mode = os.stat(real).st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
        via = f" (a link to {show_path(real)})" if real != Path(os.path.abspath(given)) else ""
        raise FileRefused(f"{label}: is {kind}{via}; give the name of a regular file or of a new one")
    if not real.parent.is_dir():
        raise FileRefused(f"{label}: its folder {show_path(real.parent)} does not exist")
    return real


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` to write a temporary file beside ``path``, then rename it to ``path``.

    Parameters
    ----------
    path : str or Path
        The file to (re)place.
    write : callable
        Writes the whole file at the path it is given (``savefig``, ``export``, ``np.savez`` ...).

    Returns
    -------
    Path
        ``path`` as given; the file written (``path``, or the target of the link that ``path`` is) is whole: a
        reader never sees part of it, and if ``write`` raises it is left as it was. An existing file keeps its
        permissions.

    Raises
    ------
    FileRefused
        When ``path`` names anything but a regular file or nothing (:func:`writable_file`).
    """
    real = writable_file(path)
    tmp = real.with_name(f".{real.name}.tmp-{os.getpid()}")
    try:
        write(tmp)
        if real.exists():
            os.chmod(tmp, stat.S_IMODE(real.stat().st_mode))
        os.replace(tmp, real)
    finally:
        tmp.unlink(missing_ok=True)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`)."""
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


@overload
def to_jsonable(obj: dict[str, object]) -> JsonDict: ...
@overload
def to_jsonable(obj: object) -> object: ...


def to_jsonable(obj: object) -> object:
    """Convert NumPy values inside ``obj`` (any value: its type is checked) to JSON-ready Python values
    (non-finite floats become None); a dict becomes a dict with string keys."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        x = float(obj) + 0.0  # -0.0 is written 0.0
        return x if np.isfinite(x) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def dump_json(obj: object, indent: int | None = None) -> str:
    """Strict JSON text of ``obj`` (non-finite numbers become null)."""
    return json.dumps(to_jsonable(obj), indent=indent, allow_nan=False)


def write_json(path: str | Path, data: object) -> Path:
    """Strict JSON (non-finite numbers become null), indented, written atomically."""
    return atomic_write_text(path, dump_json(data, indent=2))


def write_csv(path: str | Path, header: list[str], rows: Iterable[Iterable[object]]) -> Path:
    """A CSV file with a header row, written atomically."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    return atomic_write_text(path, buf.getvalue())

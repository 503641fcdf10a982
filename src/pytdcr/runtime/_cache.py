"""The one on-disk cache: where it is, how an entry is read, how one is written.

A cache is a file we own in a folder others may write, so nothing found there is trusted:

- **The folder** (:func:`cache_dir`): ``PYTDCR_CACHE_DIR`` (set empty: no disk cache), else
  ``$XDG_CACHE_HOME/pytdcr`` or ``~/.cache/pytdcr``. It is made with mode 0700 and used only when it is a real
  folder (not a link to one), owned by this user and writable by no one else (neither its group nor everyone);
  it is opened once per read or write and every entry is reached through that open folder, so it cannot be
  swapped under us.
- **Reading an entry** (:func:`read_entry`, :func:`read_arrays`): only a regular file owned by this user, with one
  name (no hard link elsewhere), of bounded size, opened without following a link (``O_NOFOLLOW``) and without
  blocking (a FIFO never hangs); arrays are read by :func:`~pytdcr.runtime._readback.npz_arrays` (each header
  checked before its data is read: no pickle, no shape declaring more data than the entry holds) and their
  names, shapes, dtypes and finiteness checked. Anything else (a link, a FIFO, a device, a folder, another
  user's file, a truncated or garbage file) is "no entry": the caller computes it again.
- **Writing an entry** (:func:`write_entry`, :func:`write_arrays`): a new temporary file (``O_CREAT | O_EXCL |
  O_NOFOLLOW``, mode 0600) in the cache folder, renamed over the entry's name (a rename replaces a link there, it
  never writes through it); arrays that reading would refuse (a NaN, an infinity) are not written. Any failure
  means the entry is not kept: never an error, never a partial file.
- **Bounding the folder** (done by :func:`write_entry`): an entry's name is ``KIND-KEY[.EXT]`` (``inverse-pool-
  <digest>.npz``: its kind is ``inverse-pool``). After an entry is kept, the entries of its kind beyond the newest
  :data:`MAX_ENTRIES_PER_KIND` (by modification time) are removed, and so are its kind's temporary files left by a
  writer that died more than :data:`STALE_TEMP_S` ago: only regular files of this user's with one name, each
  removed by its name in the open folder (never through a link; a link, a folder or anything else there is left
  alone and not counted). A folder that cannot be listed, or an entry that cannot be removed, is only not pruned.
"""

from __future__ import annotations

import io
import logging
import os
import re
import secrets
import stat
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ._readback import npz_arrays, read_fd

__all__ = ["MAX_ENTRIES_PER_KIND", "MAX_ENTRY_BYTES", "STALE_TEMP_S", "cache_dir", "entry_kind", "read_arrays",
           "read_entry", "write_arrays", "write_entry"]

#: the largest cache entry read or written [bytes] (a file or an array's data beyond it is no entry)
MAX_ENTRY_BYTES = 256 * 2**20
#: the most entries of one kind kept in the cache folder (the newest; writing one more removes the oldest)
MAX_ENTRIES_PER_KIND = 64
#: the age after which a temporary file of a writer that never finished is removed [s]
STALE_TEMP_S = 3600.0

_log = logging.getLogger("pytdcr.cache")
#: an entry's name: one plain file name (no folder, no leading dot: those are the temporary files)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,200}")
#: a temporary file of :func:`write_entry`: ``.NAME.tmp-PID-HEX``
_TEMP = re.compile(r"\.(?P<name>.+)\.tmp-\d+-[0-9a-f]+")
_DIR_FLAGS = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
_READ_FLAGS = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
_NEW_FLAGS = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0))


def cache_dir() -> Path | None:
    """Where entries are kept between runs: ``PYTDCR_CACHE_DIR``, else ``$XDG_CACHE_HOME/pytdcr`` (an absolute
    ``XDG_CACHE_HOME`` only, as the XDG specification says) or ``~/.cache/pytdcr``; None (no cache on disk) when
    ``PYTDCR_CACHE_DIR`` is set empty or no home folder is known."""
    env = os.environ.get("PYTDCR_CACHE_DIR")
    if env is not None:
        return Path(env).expanduser() if env.strip() else None
    base = os.environ.get("XDG_CACHE_HOME") or ""
    if not os.path.isabs(base):
        try:
            base = str(Path.home() / ".cache")
        except (RuntimeError, KeyError, OSError):  # no home folder
            return None
    return Path(base) / "pytdcr"


def _ours(st: os.stat_result) -> bool:
    """``st`` belongs to this process's user (where the system has users)."""
    return not hasattr(os, "geteuid") or st.st_uid == os.geteuid()


def _open_folder(folder: Path, create: bool) -> int | None:
    """A descriptor of the cache ``folder`` (made with mode 0700 when ``create``), or None when it is missing,
    a link, not a folder, another user's, or writable by its group or by everyone."""
    if create:
        try:
            folder.parent.mkdir(parents=True, exist_ok=True)
            os.mkdir(folder, 0o700)
        except FileExistsError:
            pass
        except OSError as err:
            _log.debug("cache folder %s not made: %s", folder, err)
            return None
    try:
        fd = os.open(folder, _DIR_FLAGS)
    except OSError as err:  # missing, or a link (ELOOP), or not a folder
        if create:
            _log.debug("cache folder %s not used: %s", folder, err)
        return None
    st = os.fstat(fd)
    if not stat.S_ISDIR(st.st_mode) or not _ours(st) or st.st_mode & (stat.S_IWOTH | stat.S_IWGRP):
        _log.debug("cache folder %s not used: not a private folder of this user", folder)
        os.close(fd)
        return None
    return fd


def _where(folder: Path | None) -> Path | None:
    return cache_dir() if folder is None else Path(folder)


def read_entry(name: str, *, folder: Path | None = None, max_bytes: int = MAX_ENTRY_BYTES) -> bytes | None:
    """The bytes of the cache entry ``name`` (in ``folder``, default :func:`cache_dir`), or None when there is
    no entry to trust: none, or anything but a regular file of this user's with one name and at most
    ``max_bytes`` bytes."""
    where = _where(folder)
    if where is None or not _NAME.fullmatch(name):
        return None
    dfd = _open_folder(where, create=False)
    if dfd is None:
        return None
    try:
        st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
        if not stat.S_ISREG(st.st_mode):  # never opened: a FIFO would block, a device do anything
            return None
        fd = os.open(name, _READ_FLAGS, dir_fd=dfd)
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode) or not _ours(st) or st.st_nlink != 1 or st.st_size > max_bytes:
                return None
            data = read_fd(fd, max_bytes)
            return data if len(data) <= max_bytes else None
        finally:
            os.close(fd)
    except OSError:
        return None
    finally:
        os.close(dfd)


def write_entry(name: str, data: bytes, *, folder: Path | None = None) -> bool:
    """Keep ``data`` as the cache entry ``name`` (in ``folder``, default :func:`cache_dir`), whole or not at all;
    True when it was kept. Whatever sits at the name (a link, a file) is replaced, never written through; a
    folder that cannot be made or written means the entry is not kept (a debug note, never an error). Once kept,
    the oldest entries of its kind beyond :data:`MAX_ENTRIES_PER_KIND` are removed (:func:`entry_kind`)."""
    where = _where(folder)
    if where is None or not _NAME.fullmatch(name) or len(data) > MAX_ENTRY_BYTES:
        return False
    dfd = _open_folder(where, create=True)
    if dfd is None:
        return False
    try:
        kept = _replace(dfd, name, data)
        if kept:
            _prune(dfd, name)
        return kept
    finally:
        os.close(dfd)


def _replace(dfd: int, name: str, data: bytes) -> bool:
    """Write ``data`` to a new temporary file in the folder open as ``dfd`` and rename it to ``name``; True when
    done, False (the temporary file removed) on an OSError."""
    tmp = f".{name}.tmp-{os.getpid()}-{secrets.token_hex(4)}"
    try:
        fd = os.open(tmp, _NEW_FLAGS, 0o600, dir_fd=dfd)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
        finally:
            os.close(fd)
        os.replace(tmp, name, src_dir_fd=dfd, dst_dir_fd=dfd)
        return True
    except OSError as err:
        _log.debug("cache entry %s not kept: %s", name, err)
        _unlink(dfd, tmp)
        return False


def entry_kind(name: str) -> str:
    """The kind of the cache entry ``name`` (``KIND-KEY[.EXT]``): the name up to its last ``-`` with the
    extension after the key kept (``inverse-pool-3fa2.npz`` is of kind ``inverse-pool-*.npz``); a name without a
    ``-`` is a kind of its own."""
    stem, dash, rest = name.rpartition("-")
    if not dash:
        return name
    dot = rest.find(".")
    return f"{stem}-*{rest[dot:] if dot >= 0 else ''}"


def _prune(dfd: int, name: str) -> None:
    """Remove, in the cache folder open as ``dfd``, the entries of ``name``'s kind (:func:`entry_kind`) beyond
    the newest :data:`MAX_ENTRIES_PER_KIND` (``name``, just written, is always kept) and its kind's temporary files
    older than :data:`STALE_TEMP_S`. Only regular files of this user's with one name are counted and removed, by
    their name (unlink never follows a link); any OSError only leaves the folder as it is."""
    kind = entry_kind(name)
    try:
        names = os.listdir(dfd)
    except OSError as err:
        _log.debug("cache folder not pruned: %s", err)
        return
    now = time.time()
    entries: list[tuple[int, str]] = []
    for other in names:
        temp = _TEMP.fullmatch(other)
        if other == name or entry_kind(temp.group("name") if temp else other) != kind or not (
                temp or _NAME.fullmatch(other)):
            continue
        try:
            st = os.stat(other, dir_fd=dfd, follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISREG(st.st_mode) or not _ours(st) or st.st_nlink != 1:
            continue  # a link, a folder, a FIFO, another user's file, a second name: not an entry of ours
        if temp:
            if now - st.st_mtime > STALE_TEMP_S:
                _unlink(dfd, other)
        else:
            entries.append((st.st_mtime_ns, other))
    entries.sort(reverse=True)  # the newest first
    for _, other in entries[max(MAX_ENTRIES_PER_KIND - 1, 0):]:
        _unlink(dfd, other)


def _unlink(dfd: int, name: str) -> None:
    """Remove ``name`` from the folder open as ``dfd`` (a link itself, never its target); an OSError is only a
    file not removed."""
    try:
        os.unlink(name, dir_fd=dfd)
    except OSError as err:
        _log.debug("cache entry %s not removed: %s", name, err)


def _shapes_agree(arrays: Mapping[str, np.ndarray], shapes: Mapping[str, tuple[int | str, ...]],
                  dims: Mapping[str, int]) -> bool:
    """Every array has its shape: an int is that length, a name the same length wherever it appears and at most
    ``dims[name]`` (when given)."""
    seen: dict[str, int] = {}
    for key, shape in shapes.items():
        got = arrays[key].shape
        if len(got) != len(shape):
            return False
        for want, n in zip(shape, got, strict=True):
            if isinstance(want, int):
                if n != want:
                    return False
            elif seen.setdefault(want, n) != n or n > dims.get(want, n):
                return False
    return True


def read_arrays(name: str, shapes: Mapping[str, tuple[int | str, ...]], *, folder: Path | None = None,
                dims: Mapping[str, int] | None = None,
                max_bytes: int = MAX_ENTRY_BYTES) -> dict[str, np.ndarray] | None:
    """The float64 arrays of the ``.npz`` cache entry ``name`` (:func:`read_entry`), or None when there is none
    to trust.

    Parameters
    ----------
    name : str
        The entry's file name.
    shapes : mapping
        Each array's name and shape: an int is a fixed length, a string a length that must agree wherever it
        appears (``{"a": ("K", 3), "b": ("K",)}``).
    folder : Path, optional
        The cache folder (default :func:`cache_dir`).
    dims : mapping, optional
        The largest length of each named one.
    max_bytes : int
        The largest file and the most array data read [bytes].

    Returns
    -------
    dict or None
        The arrays, each float64 and finite; None when the entry is missing, not ours, not a whole ``.npz``
        file, lacks one of the arrays or holds other ones, or one has another dtype or shape or a non-finite
        value.
    """
    data = read_entry(name, folder=folder, max_bytes=max_bytes)
    if data is None:
        return None
    try:
        arrays = npz_arrays(data, max_bytes)
    except ValueError:  # not a whole .npz file, too large, or an array's header refused: no entry
        return None
    if set(arrays) != set(shapes):
        return None
    if any(a.dtype != np.float64 or not np.all(np.isfinite(a)) for a in arrays.values()):
        return None
    return arrays if _shapes_agree(arrays, shapes, dims or {}) else None


def write_arrays(name: str, arrays: Mapping[str, np.ndarray], *, folder: Path | None = None) -> bool:
    """Keep ``arrays`` (float64) as the ``.npz`` cache entry ``name`` (:func:`write_entry`); True when kept.

    Arrays :func:`read_arrays` would refuse are not kept (False, a debug note): one holding a NaN or an infinity
    would otherwise be written again by every run that found no entry it trusts."""
    values = {key: np.asarray(a, dtype=np.float64) for key, a in arrays.items()}
    bad = [key for key, a in values.items() if not np.all(np.isfinite(a))]
    if bad:
        _log.debug("cache entry %s not kept: %s not finite", name, ", ".join(bad))
        return False
    buf = io.BytesIO()
    np.savez(buf, **values)
    return write_entry(name, buf.getvalue(), folder=folder)

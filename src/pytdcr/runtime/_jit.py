"""Compiled kernels: where numba keeps them between runs, and the one line a first use prints while it compiles.

- **Where** (:func:`kernel_cache_dir`): ``<cache>/kernels/<version>-<digest>`` in the one cache folder
  (:func:`~pytdcr.runtime.cache_dir`: ``PYTDCR_CACHE_DIR``, else the user's cache folder), or
  ``$PYTDCR_KERNEL_CACHE_DIR/<version>-<digest>`` when that variable names a folder for the kernels alone (the
  tests keep the rest of the cache in a folder of their own, the kernels in the user's); never beside the
  installed sources, so a read-only ``site-packages`` works. The key names the package's version and a digest
  of every source a kernel is compiled from (:data:`KERNEL_SOURCES`) and of numba's version: a cache written by
  another version, or before a kernel (or a constant it reads) was edited, is never loaded, since numba itself
  checks only the stamp of the file a function is defined in, not the files whose functions it compiled in.
  The folder is used only when it is this user's private folder (mode 0700); else, or with ``PYTDCR_CACHE_DIR``
  set empty, numba's own places are used (``__pycache__`` beside the sources when writable). Key folders other
  than the newest :data:`KEPT_KEYS` are removed when a new one is made.
- **Saying so** (:func:`announce_compiling`, :func:`set_compile_notice`): the first time a model's kernels
  compile in a process (numba's compile event, which a cache hit does not raise), one line on stderr says what
  compiles and about how long it takes; never when the kernels load from the cache; silenced by the command
  line's ``--quiet``.

:func:`njit` is ``numba.njit`` with the cache folder chosen above, for every kernel of the package.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

from .._version import __version__
from ._cache import _open_folder, cache_dir
from ._flags import KERNEL_OPTIONS

__all__ = ["KEPT_KEYS", "KERNEL_SOURCES", "announce_compiling", "kernel_cache_dir", "kernel_key", "njit",
           "set_compile_notice"]

_F = TypeVar("_F", bound=Callable)
_log = logging.getLogger("pytdcr.cache")
_PACKAGE = Path(__file__).resolve().parents[1]
#: the sources kernels are compiled from, relative to the package (globs): the kernels themselves and every
#: module whose functions or constants they compile in (tests/test_kernel_cache.py checks the list is whole)
KERNEL_SOURCES = ("kinematics.py", "runtime/_flags.py", "statics/kernels/*.py", "statics/options.py")
#: key folders kept beside the one in use (the newest by modification time)
KEPT_KEYS = 2

_lock = threading.RLock()
_chosen: list[Path | None] = []  # the folder, once chosen (a list: set once per process)
_notice = {"on": True}
_said: set[str] = set()
#: per thread, what is being used, innermost last: (label, about how many seconds). numba compiles in the thread
#: that first calls a kernel, so a compile is said under that thread's label, never under another thread's
_local = threading.local()


def _current() -> list[tuple[str, float]]:
    """This thread's stack of labels."""
    stack = getattr(_local, "stack", None)
    if stack is None:
        stack = _local.stack = []
    return stack

_listening = {"on": False}


def kernel_key() -> str:
    """The cache key of this install's kernels: ``<version>-<16 hex digits>``, the digits a SHA-256 of numba's
    version, the Python version and the bytes of every file of :data:`KERNEL_SOURCES` (in sorted order, each
    with its path)."""
    import numba

    h = hashlib.sha256(f"{numba.__version__}|{sys.version_info[:2]}".encode())
    for pattern in KERNEL_SOURCES:
        for path in sorted(_PACKAGE.glob(pattern)):
            h.update(path.relative_to(_PACKAGE).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return f"{__version__}-{h.hexdigest()[:16]}"


def kernel_cache_dir() -> Path | None:
    """The folder the kernels are cached in (made, mode 0700, on the first call; older key folders beyond
    :data:`KEPT_KEYS` removed then), or None when the cache folder is off (``PYTDCR_CACHE_DIR``, or
    ``PYTDCR_KERNEL_CACHE_DIR`` when set, set empty) or not a private folder of this user's: numba's own places
    are used then."""
    with _lock:
        if not _chosen:
            _chosen.append(_choose())
        return _chosen[0]


def _choose() -> Path | None:
    explicit = os.environ.get("PYTDCR_KERNEL_CACHE_DIR")
    if explicit is not None:  # the kernels' own folder, apart from the rest of the cache
        if not explicit.strip():
            return None
        base = Path(explicit).expanduser()
        folders = [base, base / kernel_key()]
    else:
        root = cache_dir()
        if root is None:
            return None
        folders = [root, root / "kernels", root / "kernels" / kernel_key()]
    for folder in folders:
        fd = _open_folder(folder, create=True)
        if fd is None:
            return None
        os.close(fd)
    _prune(folders[-2], folders[-1])
    return folders[-1]


def _prune(kernels: Path, keep: Path) -> None:
    """Remove the key folders in ``kernels`` but ``keep`` and the newest :data:`KEPT_KEYS` others (a folder
    only, never through a link; anything that cannot be removed stays)."""
    try:
        others = [p for p in kernels.iterdir() if p != keep and p.is_dir() and not p.is_symlink()]
        others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in others[KEPT_KEYS:]:
        shutil.rmtree(old, ignore_errors=True)
        _log.debug("old kernel cache %s removed", old)


def njit(*args: object, **kwargs: object) -> Callable:
    """``numba.njit`` with the package's kernel options (``KERNEL_OPTIONS`` of ``runtime/_flags.py``: NumPy's error
    model, a division by zero gives inf or NaN), unless given, whose ``cache=True`` keeps the compiled code in
    :func:`kernel_cache_dir` (used like ``numba.njit``: bare or with keyword options)."""
    if args and callable(args[0]) and not kwargs:
        return njit()(args[0])
    kwargs = {**KERNEL_OPTIONS, **kwargs}

    def decorate(func: _F) -> _F:
        import numba
        from numba.core import config

        if not kwargs.get("cache"):
            return numba.njit(**kwargs)(func)
        folder = kernel_cache_dir()
        with _lock:  # the locator reads the folder once, when the function is decorated
            before = config.CACHE_DIR
            config.CACHE_DIR = str(folder) if folder is not None else before
            try:
                return numba.njit(**kwargs)(func)
            finally:
                config.CACHE_DIR = before

    return decorate


def set_compile_notice(on: bool) -> None:
    """Print (True, the default) or not the line saying kernels compile for first use (``--quiet``: not)."""
    _notice["on"] = bool(on)


@contextmanager
def announce_compiling(label: str, seconds: float) -> Iterator[None]:
    """Within this block, the first kernel compile of the process for ``label`` (e.g. ``"the pcc model's solver"``)
    prints ``pytdcr: compiling <label> for first use, about <seconds> s, once`` on stderr (once per label and
    process; nothing when every kernel loads from the cache)."""
    _listen()
    stack = _current()
    stack.append((label, seconds))
    try:
        yield
    finally:
        stack.pop()


def _say(label: str, seconds: float) -> None:
    with _lock:
        if not _notice["on"] or label in _said:
            return
        _said.add(label)
    about = f"about {max(round(seconds, -1), 5):.0f} s" if seconds <= 120 else f"about {seconds / 60:.0f} min"
    print(f"pytdcr: compiling {label} for first use, {about}, once", file=sys.stderr, flush=True)


def _listen() -> None:
    """Register, once per process, the listener of numba's compile events."""
    if _listening["on"]:
        return
    from numba.core import event

    class _Compiles(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            stack = _current()
            if stack:
                _say(*stack[-1])

        def on_end(self, ev: event.Event) -> None:
            pass

    with _lock:
        if not _listening["on"]:
            event.register("numba:compile", _Compiles())
            _listening["on"] = True

"""Processes we start end with us: every worker process pytdcr starts exits when the process that started it is
gone, even when that process was killed outright (SIGKILL, the out-of-memory killer), when no ``atexit``
handler, ``finally`` block or pool shutdown runs in it.

The one mechanism is :func:`hold_lifeline`, run first in each worker (the initializer of every pool made by
:func:`process_pool`): a daemon thread of the worker waits on its lifeline to the parent and calls
``os._exit`` when it breaks. The lifeline is the pipe whose write end only the parent holds, the one
:mod:`multiprocessing` hands every process it starts (``multiprocessing.parent_process()``; a process handle on
Windows): the kernel closes it when the parent process ends, however it ends, so the worker sees the end at
once, whether busy or idle. A worker that was not started by :mod:`multiprocessing` (or whose recorded parent is
another process) polls :func:`os.getppid` instead: a process whose parent ends is given another parent.

``prctl(PR_SET_PDEATHSIG)`` is not used: Linux sends that signal when the parent *thread* that started the
worker ends, and a :class:`~concurrent.futures.ProcessPoolExecutor` starts its workers in whichever thread
submits (a ``tdcr`` command's worker thread, a notebook's thread), so a worker would be killed when a thread
ends rather than when its parent does. The pipe belongs to the process, not to a thread.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

__all__ = ["LIFELINE_POLL_S", "PARENT_GONE_EXIT", "hold_lifeline", "process_pool"]

#: how often a worker without a lifeline pipe looks whether its parent is still there [s]
LIFELINE_POLL_S = 0.2
#: the exit status of a worker that ended because its parent did (nobody is left to read it)
PARENT_GONE_EXIT = 1


def _parent_gone() -> None:
    """End this process at once: no ``atexit``, no ``finally``, no flushing of queues to a reader who is gone."""
    os._exit(PARENT_GONE_EXIT)


def _poll_parent(parent_pid: int, poll_s: float) -> None:
    """Return once this process's parent is no longer ``parent_pid`` (it ended and this process was re-parented)."""
    while os.getppid() == parent_pid:
        time.sleep(poll_s)


def _watcher(parent_pid: int, poll_s: float) -> Callable[[], None] | None:
    """A call that returns once the parent ``parent_pid`` is gone, or None if it is gone already."""
    parent = multiprocessing.parent_process()
    if parent is not None and parent.pid == parent_pid:
        if not parent.is_alive():
            return None
        return parent.join  # the lifeline pipe's end: returns when the parent process ends, however it ends
    if os.getppid() != parent_pid:
        return None
    return lambda: _poll_parent(parent_pid, poll_s)


def hold_lifeline(parent_pid: int, poll_s: float = LIFELINE_POLL_S) -> None:
    """Make this (worker) process end as soon as the process ``parent_pid`` that started it ends.

    Run it first in every worker process pytdcr starts (:func:`process_pool` does). If the parent is already
    gone, the worker exits here; otherwise a daemon thread waits on the lifeline (see the module's notes) and
    ends the process with ``os._exit`` when it breaks, whatever the worker is doing.

    Parameters
    ----------
    parent_pid : int
        The pid of the process that starts the worker (``os.getpid()`` there, passed to the worker).
    poll_s : float
        How often to look at the parent's pid when there is no lifeline pipe [s].
    """
    wait = _watcher(int(parent_pid), float(poll_s))
    if wait is None:
        _parent_gone()

    def watch() -> None:
        wait()
        _parent_gone()

    threading.Thread(target=watch, name="pytdcr-lifeline", daemon=True).start()


def _start_worker(parent_pid: int, initializer: Callable[..., object] | None, initargs: tuple[object, ...]) -> None:
    """The initializer of every pool :func:`process_pool` makes: the lifeline, then the caller's initializer."""
    hold_lifeline(parent_pid)
    if initializer is not None:
        initializer(*initargs)


def process_pool(max_workers: int, initializer: Callable[..., object] | None = None,
                 initargs: tuple[object, ...] = ()) -> ProcessPoolExecutor:
    """A pool of worker processes that end with this process (:func:`hold_lifeline`), however it ends.

    The workers are spawned (a clean interpreter each, whatever this process holds). Shut the pool down as
    any :class:`~concurrent.futures.ProcessPoolExecutor`; if this process is killed instead, the workers
    notice and exit within a moment.

    Parameters
    ----------
    max_workers : int
        The most worker processes, >= 1.
    initializer, initargs
        Run in each worker after its lifeline is held, as ``initializer(*initargs)`` (picklable).

    Returns
    -------
    ProcessPoolExecutor
        The pool.
    """
    return ProcessPoolExecutor(max_workers=max_workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_start_worker, initargs=(os.getpid(), initializer, tuple(initargs)))

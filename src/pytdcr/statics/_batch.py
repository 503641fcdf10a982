"""Running a batch of independent solves in chunks over threads.

The compiled solvers release the GIL, so Python threads run them on all cores.
Each case is solved by the same compiled code whichever thread takes it, and
the chunks are disjoint: a batch's results do not depend on the number of
threads or on the order the chunks finish in.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from functools import cache
from typing import Any

from threadpoolctl import ThreadpoolController

__all__ = ["default_threads", "run_in_chunks", "single_threaded_blas"]

_lock = threading.Lock()
_depth = 0
_limiter: Any = None


@cache
def _controller() -> ThreadpoolController:
    """The BLAS thread pools of this process, found once."""
    return ThreadpoolController()


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """BLAS and LAPACK on one thread while the compiled solvers run (they call LAPACK from our own threads).

    Without it, LAPACK's threads on top of ours oversubscribe the cores (measured: a batch of subsegment
    Cosserat solves took 1.9x longer on 2 threads than on 1) and can change the last bits with the thread
    count. Overlapping uses from several threads share one limit; the last to leave restores the user's.
    """
    global _depth, _limiter
    with _lock:
        if _depth == 0:
            _limiter = _controller().limit(limits=1, user_api="blas")
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _limiter.restore_original_limits()
                _limiter = None


def default_threads() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def run_in_chunks(fn: Callable[[int, int], None], n: int, threads: int | None = None,
                  chunk: int | None = None) -> None:
    """Call ``fn(start, stop)`` over disjoint chunks covering ``range(n)``, on ``threads`` threads.

    ``chunk`` defaults to a size that gives each thread several chunks (solve
    times vary by two orders of magnitude across cases, so small chunks
    balance the load). BLAS runs single-threaded meanwhile
    (:func:`single_threaded_blas`). Exceptions propagate; a KeyboardInterrupt
    cancels the chunks not yet started.
    """
    if n <= 0:
        return
    workers = min(default_threads() if threads is None else int(threads), n)
    if workers < 1:
        raise ValueError(f"threads must be >= 1, got {threads}")
    if workers == 1:
        with single_threaded_blas():
            fn(0, n)
        return
    size = chunk or max(1, min(64, n // (8 * workers)))
    bounds = [(s, min(n, s + size)) for s in range(0, n, size)]
    with single_threaded_blas(), ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(fn, a, b) for a, b in bounds]
        try:
            for f in futures:
                f.result()
        except BaseException:
            for f in futures:
                f.cancel()
            raise

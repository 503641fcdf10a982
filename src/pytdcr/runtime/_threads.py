"""Running a batch of independent solves in chunks over threads, and BLAS kept on one thread meanwhile.

The compiled solvers release the GIL, so Python threads run them on all cores. Each case is solved by the same
compiled code whichever thread takes it, and the chunks are disjoint: a batch's results do not depend on the
number of threads or on the order the chunks finish in. Chunks are small (at most :data:`MAX_CHUNK` cases) and
each checks for cancellation (:mod:`pytdcr.runtime._cancel`) before it starts, so the work stops within a
fraction of a second.
"""

from __future__ import annotations

import contextvars
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from functools import cache
from typing import Any, ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

from ._cancel import cancellable, check_cancelled

__all__ = ["MAX_CHUNK", "default_threads", "run_in_chunks", "single_threaded_blas", "submit_in_context",
           "worker_pool"]

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: the largest chunk of cases run between two checks for cancellation
MAX_CHUNK = 16


def submit_in_context(pool: ThreadPoolExecutor, fn: Callable[_P, _R], *args: _P.args,
                      **kwargs: _P.kwargs) -> Future[_R]:
    """``pool.submit(fn, *args, **kwargs)`` run in a copy of this thread's context (so it sees the cancellation
    scope)."""
    return pool.submit(contextvars.copy_context().run, fn, *args, **kwargs)


@contextmanager
def worker_pool(max_workers: int) -> Iterator[Callable[..., Future]]:
    """Threads whose work stops with their caller: yields ``submit(fn, *args, **kwargs)``.

    The work runs in a cancellation scope of its own (inside the caller's): if the caller's block raises
    (Ctrl-C in a notebook, an error), the scope is cancelled and the futures not started are dropped, so the
    pool's shutdown waits only for the chunks already running.
    """
    with cancellable() as scope:
        pool = ThreadPoolExecutor(max_workers=max(1, int(max_workers)))
        futures: list[Future] = []

        def submit(fn: Callable[_P, _R], *args: _P.args, **kwargs: _P.kwargs) -> Future[_R]:
            fut = submit_in_context(pool, fn, *args, **kwargs)
            futures.append(fut)
            return fut

        try:
            yield submit
        except BaseException:
            scope.cancel()
            for f in futures:
                f.cancel()
            raise
        finally:
            pool.shutdown(wait=True)


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
                  chunk: int | None = None, max_chunk: int = MAX_CHUNK) -> None:
    """Call ``fn(start, stop)`` over disjoint chunks covering ``range(n)``, on ``threads`` threads.

    ``chunk`` defaults to a size that gives each thread several chunks (solve
    times vary by two orders of magnitude across cases, so small chunks
    balance the load), at most ``max_chunk`` (slow solves: fewer). BLAS runs single-threaded
    meanwhile (:func:`single_threaded_blas`). Exceptions propagate; a
    KeyboardInterrupt, or the cancellation of the enclosing
    :func:`cancellable` scope, stops the chunks not yet started.
    """
    if n <= 0:
        return
    workers = min(default_threads() if threads is None else int(threads), n)
    if workers < 1:
        raise ValueError(f"threads must be >= 1, got {threads}")
    size = int(chunk) if chunk else max(1, min(int(max_chunk), n // (8 * workers)))
    bounds = [(s, min(n, s + size)) for s in range(0, n, size)]

    def run(a: int, b: int) -> None:
        check_cancelled()
        fn(a, b)

    if workers == 1:
        with single_threaded_blas():
            for a, b in bounds:
                run(a, b)
        return
    with single_threaded_blas(), worker_pool(workers) as submit:
        futures = [submit(run, a, b) for a, b in bounds]
        for f in futures:
            f.result()

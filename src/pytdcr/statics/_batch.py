"""Running a batch of independent solves in chunks over threads.

The compiled solvers release the GIL, so Python threads run them on all cores.
Each case is solved by the same compiled code whichever thread takes it, and
the chunks are disjoint: a batch's results do not depend on the number of
threads or on the order the chunks finish in.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

__all__ = ["default_threads", "run_in_chunks"]


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
    balance the load). Exceptions propagate; a KeyboardInterrupt cancels the
    chunks not yet started.
    """
    if n <= 0:
        return
    workers = min(default_threads() if threads is None else int(threads), n)
    if workers < 1:
        raise ValueError(f"threads must be >= 1, got {threads}")
    if workers == 1:
        fn(0, n)
        return
    size = chunk or max(1, min(64, n // (8 * workers)))
    bounds = [(s, min(n, s + size)) for s in range(0, n, size)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(fn, a, b) for a, b in bounds]
        try:
            for f in futures:
                f.result()
        except BaseException:
            for f in futures:
                f.cancel()
            raise

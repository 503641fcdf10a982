"""The memory budget: work that would need more is refused before it allocates, with the estimate.

The budget is a setting: the environment variable ``PYTDCR_MEMORY_GB``
(gigabytes, a positive number), by default the smaller of 8 GB and half of this
machine's memory. Estimates are of the peak working memory, measured for each
model (``bench/models.py`` and ``docs/models.md`` give the figures); they are
rounded up, never down.
"""

from __future__ import annotations

import math
import os
from typing import NamedTuple

from .validate import parse_numbers, show

__all__ = ["MEMORY_ENV", "ResourceLimitError", "Resources", "check_memory", "human_bytes", "human_seconds",
           "memory_budget"]

#: the environment variable that sets the budget [GB]
MEMORY_ENV = "PYTDCR_MEMORY_GB"
#: the default budget's cap [bytes]
DEFAULT_CAP = 8e9
#: the largest budget that may be set [GB]
MAX_BUDGET_GB = 1e6


class ResourceLimitError(ValueError):
    """Work that would need more memory than the budget (:func:`memory_budget`) allows."""


class Resources(NamedTuple):
    """What one solve needs.

    Attributes
    ----------
    bytes : float
        Peak working memory [bytes].
    seconds : float
        Rough time of one solve from the straight robot on one core [s].
    unknowns : int
        The number of unknowns (the dense Jacobian has ``unknowns**2`` numbers).
    """

    bytes: float
    seconds: float
    unknowns: int


def _physical_memory() -> float | None:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return None


def memory_budget() -> float:
    """The memory a pytdcr computation may use [bytes] (``PYTDCR_MEMORY_GB``, else min(8 GB, RAM / 2))."""
    text = os.environ.get(MEMORY_ENV)
    if text is not None:
        try:
            gb = float(parse_numbers(text, MEMORY_ENV, count=1)[0])
        except ValueError:
            gb = math.nan
        if not 0 < gb <= MAX_BUDGET_GB:
            raise ValueError(f"{MEMORY_ENV}={show(text, 40)}: must be a positive number of gigabytes up to "
                             f"{MAX_BUDGET_GB:g} (a petabyte), e.g. 4 or 0.5")
        return gb * 1e9
    ram = _physical_memory()
    return min(DEFAULT_CAP, 0.5 * ram) if ram else DEFAULT_CAP


def human_bytes(n: float) -> str:
    """``n`` bytes as e.g. ``'36 GB'`` or ``'410 MB'``."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def human_seconds(s: float) -> str:
    """A duration for a message: seconds, minutes, hours or days."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= size:
            return f"{s / size:.2g} {unit}"
    return f"{s:.2g} s"


def check_memory(what: str, need: float, detail: str = "") -> None:
    """Refuse ``what`` if it needs more than the budget.

    Raises
    ------
    ResourceLimitError
        One line: what, the estimate, the budget and how to change it.
    """
    budget = memory_budget()
    if need > budget:
        raise ResourceLimitError(f"{what} needs about {human_bytes(need)}{f' ({detail})' if detail else ''}, "
                                 f"more than the memory budget of {human_bytes(budget)} (set {MEMORY_ENV} to "
                                 "change it)")

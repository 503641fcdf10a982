"""Checks of the options every solver shares."""

from __future__ import annotations

import numpy as np

from ._constants import LOAD_STEPPING

__all__ = ["MAX_ATOL", "MIN_ATOL", "check_common_options"]


#: the loosest convergence tolerance accepted [N m]: a looser one passes poses visibly out of balance
MAX_ATOL = 1e-4
#: the tightest [N m]: below it the rounding of the moment balance itself decides convergence
MIN_ATOL = 1e-14


def check_common_options(atol: float, load_stepping: str) -> None:
    """Validate the options every solver shares; ValueError naming the field and its range."""
    if isinstance(atol, bool) or not isinstance(atol, (int, float, np.floating)):
        raise TypeError(f"atol must be a real number, got {type(atol).__name__}")
    if not (np.isfinite(atol) and MIN_ATOL <= atol <= MAX_ATOL):
        raise ValueError(f"atol must be in [{MIN_ATOL:g}, {MAX_ATOL:g}] N m (a looser tolerance passes poses "
                         f"visibly out of balance; a tighter one is below the rounding of the balance), got {atol:g}")
    if load_stepping not in LOAD_STEPPING:
        raise ValueError(f"load_stepping must be one of {sorted(LOAD_STEPPING)}, got {load_stepping!r}")

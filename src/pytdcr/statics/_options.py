"""Checks of the options every solver shares."""

from __future__ import annotations

import numpy as np

from ._constants import LOAD_STEPPING

__all__ = ["check_common_options"]


def check_common_options(atol: float, load_stepping: str) -> None:
    """Validate the options every solver shares; ValueError naming the field and its range."""
    if not (np.isfinite(atol) and atol > 0):
        raise ValueError(f"atol must be finite and > 0, got {atol}")
    if load_stepping not in LOAD_STEPPING:
        raise ValueError(f"load_stepping must be one of {sorted(LOAD_STEPPING)}, got {load_stepping!r}")

"""What a run says about its samples' static stability: the one place its words and counts come from.

A sample's stability is one of three states: stable, unstable or untested (a model without the static stability
test, :attr:`pytdcr.statics.Capabilities.stability`), and a sample that did not converge has none. The region
(the paper's FSW) holds the converged samples that are not unstable: for a model that tests stability these are
the stable ones; for one that does not, every converged sample, whose stability is then *untested*, and every
text, count, table and file says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..statics import Model, get_model

__all__ = ["STABILITY_TESTS", "feasible_words", "stability_counts", "stability_test", "stability_words"]

#: whether a run tested its samples' stability (``workspace.json``'s ``stability_test``)
STABILITY_TESTS = ("run", "untested")


def stability_test(model: str | Model) -> str:
    """``"run"`` when ``model`` tests an equilibrium's static stability, else ``"untested"``."""
    return STABILITY_TESTS[0] if get_model(model).capabilities.stability else STABILITY_TESTS[1]


def stability_counts(converged: np.ndarray, stable: np.ndarray, test: str = "run") -> dict[str, int | None]:
    """The converged samples by stability state: ``stable`` (1.0), ``unstable`` (0.0) and ``untested`` (NaN),
    from the ``converged`` (M,) and ``stable`` (M,) arrays of a run's samples. For a run whose stability
    ``test`` is ``"untested"`` the stable and unstable counts are None (unknown), never 0."""
    ok = np.asarray(converged, dtype=bool)
    st = np.asarray(stable, dtype=float)
    untested = int(np.sum(ok & np.isnan(st)))
    if not _tested(test):
        return {"stable": None, "unstable": None, "untested": untested}
    return {"stable": int(np.sum(ok & (st == 1.0))), "unstable": int(np.sum(ok & (st == 0.0))),
            "untested": untested}


def feasible_words(test: str) -> str:
    """What a feasible sample (a point of the FSW) is, for a run whose stability ``test`` is ``"run"`` or
    ``"untested"``: "converged, stable" or "converged, stability untested"."""
    return "converged, stable" if _tested(test) else "converged, stability untested"


def stability_words(counts: dict[str, Any], test: str) -> str:
    """The converged samples' stability in words, from a run's counts (``unstable`` and ``stability_untested``
    or ``untested``): "3 unstable" for a tested run (with the untested ones when there are any), "stability
    untested (N samples)" for a run whose model has no stability test."""
    untested = int(counts.get("stability_untested", counts.get("untested", 0)) or 0)
    if not _tested(test):
        return f"stability untested ({untested} converged sample{'s' * (untested != 1)})"
    return f"{counts['unstable']} unstable" + (f", {untested} untested" if untested else "")


def _tested(test: str) -> bool:
    if test not in STABILITY_TESTS:
        raise ValueError(f"stability_test must be one of {', '.join(STABILITY_TESTS)}, got {test!r}")
    return test == STABILITY_TESTS[0]

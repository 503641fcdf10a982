"""The static (divergence) stability of an equilibrium, from the tangent stiffness (MODEL.md, appendix B).

For the PCC models, K = dr'/dq in physical units, unscaled, with each residual
paired to the variable it is conjugate to: per subsegment r' = (r_y, -r_x, r_z)
against (beta, gamma, eps) (in this order the bending block is EI times the
identity at the straight robot; the raw order rotates it by 90 degrees). For the
subsegment rod, whose unknowns are not coordinates of the configuration, K is the
stiffness of the disks' poses
(:func:`pytdcr.statics.kernels.sscr.tangent_stiffness`). The loads are not
conservative (friction; a moment fixed in space), so K is not symmetric and
neither its symmetric part nor the real parts of complex eigenvalues are a
static test. The static test: the equilibrium is unstable when K has a real
eigenvalue <= 0, which the loading path reaches by crossing a point where K is
singular (a fold or a bifurcation), whatever the coordinates, or where a complex
pair with a negative real part meets the real axis and splits into two negative
real eigenvalues (non-conservative loads; K stays regular). Complex pairs
with a negative real part are reported apart (possible flutter, which only a
dynamic model with the mass matrix can decide); they do not make the pose
unstable here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..results import Stability

if TYPE_CHECKING:
    from ..records import JsonObject
    from .base import Model

__all__ = ["STABILITY_TESTS", "Stability", "conjugate_stiffness", "feasible_words", "stability_counts",
           "stability_from_eigenvalues", "stability_of", "stability_test", "stability_words"]


def conjugate_stiffness(jacobian: np.ndarray) -> np.ndarray:
    """K from the PCC residual's Jacobian (..., 3N, 3N), one or a stack: rows reordered per subsegment to
    (r_y, -r_x, r_z)."""
    J = np.asarray(jacobian, dtype=float)
    K = np.empty_like(J)
    K[..., 0::3, :] = J[..., 1::3, :]
    K[..., 1::3, :] = -J[..., 0::3, :]
    K[..., 2::3, :] = J[..., 2::3, :]
    return K


#: a conjugate pair whose imaginary part is below this fraction of the largest |eigenvalue| is a (near-double)
#: real eigenvalue split by rounding
_REAL_TOL = 1e-10


def stability_of(K: np.ndarray) -> Stability:
    """The test on a tangent stiffness K (m, m).

    LAPACK's real eigenvalue routine returns real eigenvalues as exact reals and complex ones in exact
    conjugate pairs; a pair with an imaginary part at rounding level (a double real eigenvalue, as at the
    symmetric buckling of a straight rod) counts as two real eigenvalues.
    """
    return stability_from_eigenvalues(np.linalg.eigvals(np.asarray(K, dtype=float)))


def stability_from_eigenvalues(ev: np.ndarray) -> Stability:
    """The test on the eigenvalues (m,) of a tangent stiffness, as LAPACK's real routine returns them (real or
    complex dtype): :func:`stability_of` without the eigenvalue problem (for batches solved as one stack)."""
    ev = np.asarray(ev)
    tiny = _REAL_TOL * max(float(np.max(np.abs(ev))), 1e-300)
    is_real = np.abs(ev.imag) <= tiny
    real = ev[is_real].real
    pairs = ev[~is_real & (ev.imag > 0.0) & (ev.real < 0.0)]
    nonpos = int(np.sum(real <= 0.0))
    least = complex(pairs[np.argmin(pairs.real)]) if pairs.size else None
    return Stability(stable=nonpos == 0, min_real_eigenvalue=float(real.min()) if real.size else float("nan"),
                     n_real_nonpositive=nonpos, flutter_pairs=int(pairs.size), least_damped=least)


# What a run says about its samples' static stability: the one place its words and counts come from. A sample's
# stability is one of three states: stable, unstable or untested (a model without the static stability test,
# :attr:`pytdcr.statics.Capabilities.stability`), and a sample that did not converge has none. The feasible
# static workspace holds the converged samples that are not unstable: for a model that tests stability these are
# the stable ones; for one that does not, every converged sample, whose stability is then *untested*, and every
# text, count, table and file says so.

#: whether a run tested its samples' stability (``workspace.json``'s ``stability_test``)
STABILITY_TESTS = ("run", "untested")


def stability_test(model: str | Model) -> str:
    """``"run"`` when ``model`` tests an equilibrium's static stability, else ``"untested"``."""
    from .registry import get_model  # the registry imports the models, which import this module

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


def stability_words(counts: JsonObject, test: str) -> str:
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

"""The static (divergence) stability of an equilibrium, from the tangent stiffness (MODEL.md, appendix B).

K = dr'/dq in physical units, unscaled, with each residual paired to the
variable it is conjugate to: per subsegment r' = (r_y, -r_x, r_z) against
(beta, gamma, eps) (in this order the bending block is EI times the identity at
the straight robot; the raw order rotates it by 90 degrees). The loads are not
conservative (friction; a moment fixed in space), so K is not symmetric and
neither its symmetric part nor the real parts of complex eigenvalues are a
static test. The static test: the equilibrium is unstable when K has a real
eigenvalue <= 0, which the loading path reaches only by crossing a point where
K is singular (a fold or a bifurcation), whatever the coordinates. Complex pairs
with a negative real part are reported apart (possible flutter, which only a
dynamic model with the mass matrix can decide); they do not make the pose
unstable here.
"""

from __future__ import annotations

import numpy as np

from ..results import Stability

__all__ = ["Stability", "conjugate_stiffness", "stability_from_eigenvalues", "stability_of"]


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

"""The tip's exact derivative by the tensions at PCC equilibria, compiled (the GIL released).

Implicit function theorem at an equilibrium q of r(q, T) = 0: dq/dT = -J^-1 dr/dT, with J the exact Jacobian
of :func:`pytdcr.statics.kernels.pcc.evaluate` and dr/dT_c = r(q, T + e_c) - r(q, T) exactly (the residual is
affine in the actuator tensions at fixed q); the tip's derivative is the exact
:func:`pytdcr.kinematics.tip_jacobian` times dq/dT. The same arithmetic as
:func:`pytdcr.statics.compiled._tip_derivative` (the reference the tests hold it to), without a Python call per
residual: one batch runs in threads.
"""

from __future__ import annotations

import numpy as np

from ...kinematics import tip_jacobian
from ...runtime import njit
from .pcc import evaluate, make_work, with_tension

__all__ = ["tip_gradient_range"]


@njit(cache=True, nogil=True)
def tip_gradient_range(q, model, tensions, start, stop, out):
    """Rows ``start <= b < stop``: the tip's derivative (3, nt) [m/N] at the equilibrium ``q[b]`` (B, 3N) of
    ``model`` (a packed PCC model) at the actuator tensions ``tensions[b]`` (B, nt) [N], into ``out[b]``
    (B, 3, nt). Rows whose ``q[b]`` is not finite are left as they are."""
    nq = q.shape[1]
    nt = tensions.shape[1]
    work = make_work(model.sub.shape[0], model.holes.shape[0])
    r0 = np.empty(nq)
    r1 = np.empty(nq)
    J = np.empty((nq, nq))
    none = np.empty((1, 1))
    dr = np.empty((nq, nt))
    for b in range(start, stop):
        qb = q[b]
        if not np.all(np.isfinite(qb)):
            continue
        evaluate(qb, 1.0, with_tension(model, tensions[b].copy()), True, r0, J, work)
        for c in range(nt):
            t = tensions[b].copy()
            t[c] += 1.0
            evaluate(qb, 1.0, with_tension(model, t), False, r1, none, work)
            for u in range(nq):
                dr[u, c] = r1[u] - r0[u]
        dq = np.linalg.solve(J, dr)
        g = tip_jacobian(qb, model.sub) @ dq
        for u in range(3):
            for c in range(nt):
                out[b, u, c] = -g[u, c]

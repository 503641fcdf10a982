"""The tangent stiffness of many equilibria, compiled (the GIL released), for the static stability test; and
their residuals, to check that a batch to continue holds equilibria.

K = dr'/dq with each residual paired to its conjugate variable (rows reordered per three to (r_y, -r_x, r_z):
:func:`pytdcr.statics.stability.conjugate_stiffness`), from the exact Jacobian of any packed model the compiled
solver takes (:func:`pytdcr.statics.kernels.solver.model_evaluate`): the same numbers as the model's Python
``evaluate``, without a Python call per row.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .solver import model_evaluate, model_with_tension, model_work

__all__ = ["largest_residuals", "stiffness_range"]


@njit(cache=True, nogil=True)
def stiffness_range(q, model, tensions, rows, start, stop, out):
    """For k in ``start <= k < stop``: the conjugate tangent stiffness (m, m) at the equilibrium ``q[rows[k]]``
    (B, m) of ``model`` at the actuator tensions ``tensions[rows[k]]`` (B, nt) [N], at full load, into
    ``out[k - start]`` (stop - start, m, m)."""
    nq = q.shape[1]
    work = model_work(model)
    r = np.empty(nq)
    J = np.empty((nq, nq))
    for k in range(start, stop):
        b = rows[k]
        model_evaluate(q[b], 1.0, model_with_tension(model, tensions[b].copy()), True, r, J, work)
        K = out[k - start]
        for i in range(0, nq, 3):
            for j in range(nq):
                K[i, j] = J[i + 1, j]
                K[i + 1, j] = -J[i, j]
                K[i + 2, j] = J[i + 2, j]


@njit(cache=True, nogil=True)
def largest_residuals(q, model, tensions, rows, out):
    """For each k: max |residual| [N m] at ``q[rows[k]]`` (B, m) of ``model`` at the actuator tensions
    ``tensions[rows[k]]`` (B, nt) [N], at full load, into ``out[k]`` (whether a batch's rows are equilibria)."""
    nq = q.shape[1]
    work = model_work(model)
    r = np.empty(nq)
    none = np.empty((1, 1))
    for k in range(rows.shape[0]):
        b = rows[k]
        model_evaluate(q[b], 1.0, model_with_tension(model, tensions[b].copy()), False, r, none, work)
        big = 0.0
        for u in range(nq):
            a = abs(r[u])
            if a != a:  # NaN: not an equilibrium, whatever else
                big = a
                break
            big = max(big, a)
        out[k] = big

"""The exact Jacobians of many equilibria, compiled (the GIL released), for the static stability test; and
their residuals, to check that a batch to continue holds equilibria. Both for any packed model the compiled
solver takes (:func:`pytdcr.statics.kernels.loading_path.model_evaluate`): the same numbers as the model's Python
``evaluate``, without a Python call per row.
"""

from __future__ import annotations

import numpy as np

from ...runtime import njit
from .loading_path import model_evaluate, model_with_tension, model_work

__all__ = ["jacobian_range", "largest_residuals"]


@njit(cache=True, nogil=True)
def jacobian_range(q, model, tensions, rows, start, stop, out):
    """For k in ``start <= k < stop``: the residual's exact Jacobian (m, m) at the equilibrium ``q[rows[k]]``
    (B, m) of ``model`` at the actuator tensions ``tensions[rows[k]]`` (B, nt) [N], at full load, into
    ``out[k - start]`` (stop - start, m, m)."""
    nq = q.shape[1]
    work = model_work(model)
    r = np.empty(nq)
    for k in range(start, stop):
        b = rows[k]
        model_evaluate(q[b], 1.0, model_with_tension(model, tensions[b].copy()), True, r, out[k - start], work)


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

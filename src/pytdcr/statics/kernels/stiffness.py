"""The exact Jacobians of many equilibria, compiled (the GIL released), for the static stability test; their
residuals, to check that a batch to continue holds equilibria; and the unknowns' derivative by the tensions, for
the tip gradients. All for any packed model the compiled solver takes
(:func:`pytdcr.statics.kernels.loading_path.model_evaluate`): the same numbers as the model's Python ``evaluate``,
without a Python call per row.
"""

from __future__ import annotations

import numpy as np

from ...runtime import njit
from .loading_path import model_evaluate, model_tip_jacobian, model_with_tension, model_work

__all__ = ["jacobian_range", "largest_residuals", "tip_gradient_range", "unknowns_by_tensions"]


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


@njit(cache=True)
def unknowns_by_tensions(q, model, tension, J, r0, r1, dr, work):
    """J^-1 dr/dT (m, nt) at the equilibrium ``q`` (m,) of ``model`` at the actuator tensions ``tension`` (nt,) [N]:
    minus the unknowns' derivative by the tensions (implicit function theorem, dq/dT = -J^-1 dr/dT).

    ``J`` (m, m) receives the exact Jacobian, ``r0``, ``r1`` (m,) and ``dr`` (m, nt) are scratch; dr/dT_c =
    r(q, T + e_c) - r(q, T) exactly (the residual is affine in the actuator tensions at fixed q). ``work`` holds
    the evaluation with the Jacobian at ``(q, tension)`` afterwards (the later residual-only evaluations leave its
    sensitivities as they are).
    """
    nq = q.shape[0]
    none = np.empty((1, 1))
    model_evaluate(q, 1.0, model_with_tension(model, tension.copy()), True, r0, J, work)
    for c in range(tension.shape[0]):
        t = tension.copy()
        t[c] += 1.0
        model_evaluate(q, 1.0, model_with_tension(model, t), False, r1, none, work)
        for u in range(nq):
            dr[u, c] = r1[u] - r0[u]
    return np.linalg.solve(J, dr)


@njit(cache=True, nogil=True)
def tip_gradient_range(q, model, tensions, start, stop, out):
    """Rows ``start <= b < stop``: the tip's exact derivative by the tensions (3, nt) [m/N] at the equilibrium
    ``q[b]`` (B, m) of ``model`` at the actuator tensions ``tensions[b]`` (B, nt) [N], into ``out[b]``
    (B, 3, nt); rows whose ``q[b]`` is not finite are left as they are.

    The tip's derivative by the unknowns (the model's ``tip_jacobian_of``) times dq/dT
    (:func:`unknowns_by_tensions`). The same arithmetic as :func:`pytdcr.statics.compiled._tip_derivative` (the
    reference the tests hold it to), without a Python call per residual: one batch runs in threads.
    """
    nq = q.shape[1]
    nt = tensions.shape[1]
    work = model_work(model)
    r0 = np.empty(nq)
    r1 = np.empty(nq)
    J = np.empty((nq, nq))
    dr = np.empty((nq, nt))
    for b in range(start, stop):
        qb = q[b]
        if not np.all(np.isfinite(qb)):
            continue
        dq = unknowns_by_tensions(qb, model, tensions[b], J, r0, r1, dr, work)
        g = model_tip_jacobian(qb, model, work) @ dq
        for u in range(3):
            for c in range(nt):
                out[b, u, c] = -g[u, c]

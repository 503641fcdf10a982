"""The boundary search's tension step inside the bounds, compiled: a damped least-squares problem with box
constraints in at most a few dozen unknowns, solved by a primal active-set method.

scipy's ``lsq_linear(method="bvls")`` solves the same problem; on the search's problems (3 rows, 8 unknowns)
its set-up costs about 0.5 ms a call, against a few microseconds here.
"""

from __future__ import annotations

import numpy as np

from ..runtime import njit

__all__ = ["box_least_squares"]

#: active-set iterations at most, per unknown (each adds or drops one bound; the method ends far sooner)
_ITER_PER_UNKNOWN = 8


@njit(cache=True)
def _free_solve(Q, c, x, fixed):
    """The minimiser of 1/2 x'Qx + c'x over the unknowns not ``fixed`` (the fixed ones held at ``x``)."""
    k = x.shape[0]
    idx = np.empty(k, dtype=np.int64)
    nf = 0
    for i in range(k):
        if not fixed[i]:
            idx[nf] = i
            nf += 1
    out = x.copy()
    if nf == 0:
        return out
    Qf = np.empty((nf, nf))
    rhs = np.empty(nf)
    for a in range(nf):
        s = -c[idx[a]]
        for j in range(k):
            if fixed[j]:
                s -= Q[idx[a], j] * x[j]
        rhs[a] = s
        for b in range(nf):
            Qf[a, b] = Q[idx[a], idx[b]]
    sol = np.linalg.solve(Qf, rhs)
    for a in range(nf):
        out[idx[a]] = sol[a]
    return out


@njit(cache=True)
def box_least_squares(A, y, damp, lower, upper):
    """``x`` (k,) minimising ``|A x - y|^2 + damp^2 |x|^2`` with ``lower <= x <= upper`` (``lower <= 0 <= upper``,
    so that x = 0 is feasible); ``A`` (m, k), ``damp`` > 0 (the problem is strictly convex: one minimiser).

    The primal active-set method from x = 0: solve on the unknowns not held at a bound, step as far towards
    that solution as the bounds allow (holding the bound that stops it), and where the step is complete
    release the held bound whose multiplier has the wrong sign, until none has.
    """
    k = A.shape[1]
    Q = A.T @ A
    for i in range(k):
        Q[i, i] += damp * damp
    c = -(A.T @ y)
    x = np.zeros(k)
    fixed = np.zeros(k, dtype=np.bool_)
    scale = 0.0
    for i in range(k):
        scale = max(scale, upper[i] - lower[i])
    eps = 1e-14 * max(scale, 1e-300)
    for _ in range(_ITER_PER_UNKNOWN * k + 8):
        z = _free_solve(Q, c, x, fixed)
        alpha = 1.0
        block = -1
        for i in range(k):
            if fixed[i]:
                continue
            p = z[i] - x[i]
            if p > 0.0 and x[i] + p > upper[i]:
                a = (upper[i] - x[i]) / p
                if a < alpha:
                    alpha, block = a, i
            elif p < 0.0 and x[i] + p < lower[i]:
                a = (lower[i] - x[i]) / p
                if a < alpha:
                    alpha, block = a, i
        if block >= 0:
            for i in range(k):
                if not fixed[i]:
                    x[i] += alpha * (z[i] - x[i])
            x[block] = upper[block] if z[block] > x[block] else lower[block]
            fixed[block] = True
            continue
        x[:] = z
        g = Q @ x + c
        worst = -1
        worst_val = 0.0
        for i in range(k):
            if not fixed[i]:
                continue
            # the multiplier of a held bound: the gradient must push into it
            m = g[i] if abs(x[i] - lower[i]) <= eps else -g[i]
            if m < worst_val:
                worst, worst_val = i, m
        if worst < 0:
            return x
        fixed[worst] = False
    return x

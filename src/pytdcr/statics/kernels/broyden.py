"""The quasi-Newton's inverse Jacobian without an explicit inverse: an LU factorisation of the last exact Jacobian
and Broyden's rank-one updates kept as vector pairs.

Broyden's ("good") update of the inverse, H+ = H + (s - H y) s^T H / (s^T H y), applied k times to
H_0 = J_0^-1 gives H_k = J_0^-1 + sum_j c_j d_j^T with c_j = (s_j - H_j y_j) / (s_j^T H_j y_j) and
d_j = H_j^T s_j. So ``H_k b`` is one LU solve and k dot products, ``H_k^T b`` one transposed LU solve and k more:
the same arithmetic as the dense update of an explicit inverse, without forming the inverse (an LU
factorisation is a third of an inversion's work). The LU is partial pivoting in plain loops, the same bits on
every thread and process.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = ["InverseJacobian", "apply", "apply_t", "factor", "make_inverse", "push", "set_zero"]

#: rank-one updates kept before the operator stops taking more (a fresh Jacobian clears them)
MAX_UPDATES = 64


class InverseJacobian(NamedTuple):
    """H = (LU)^-1 + C[:k]^T D[:k] for an (n, n) Jacobian: ``LU`` (n, n) packed factors of P J, ``piv`` (n,) the
    row swaps, ``C``, ``D`` (MAX_UPDATES, n) the update pairs, ``k`` (1,) how many (-1: the zero operator, where
    the Jacobian was singular)."""

    LU: np.ndarray
    piv: np.ndarray
    C: np.ndarray
    D: np.ndarray
    k: np.ndarray


@njit(cache=True)
def make_inverse(n):
    """An empty operator for n unknowns (the zero operator until :func:`factor`)."""
    return InverseJacobian(np.zeros((n, n)), np.zeros(n, dtype=np.int64), np.zeros((MAX_UPDATES, n)),
                           np.zeros((MAX_UPDATES, n)), np.full(1, -1, dtype=np.int64))


@njit(cache=True)
def set_zero(H):
    """Make ``H`` the zero operator (a singular Jacobian: the quasi-Newton then falls back on its other steps)."""
    H.k[0] = -1


@njit(cache=True)
def factor(H, J):
    """H = J^-1 (no updates): LU with partial pivoting of ``J`` (n, n). False (H the zero operator) when J is
    singular or not finite."""
    LU, piv = H.LU, H.piv
    n = J.shape[0]
    LU[:, :] = J
    for c in range(n):
        p = c
        big = abs(LU[c, c])
        for i in range(c + 1, n):
            v = abs(LU[i, c])
            if v > big:
                big = v
                p = i
        piv[c] = p
        if not (big > 0.0 and big < np.inf):
            H.k[0] = -1
            return False
        if p != c:
            for j in range(n):
                t = LU[c, j]
                LU[c, j] = LU[p, j]
                LU[p, j] = t
        inv = 1.0 / LU[c, c]
        for i in range(c + 1, n):
            f = LU[i, c] * inv
            LU[i, c] = f
            if f != 0.0:
                for j in range(c + 1, n):
                    LU[i, j] -= f * LU[c, j]
    H.k[0] = 0
    return True


@njit(cache=True)
def apply(H, b, out):
    """out = H b, shape (n,)."""
    n = b.shape[0]
    k = H.k[0]
    if k < 0:
        out[:] = 0.0
        return
    LU, piv = H.LU, H.piv
    out[:] = b
    for c in range(n):
        p = piv[c]
        if p != c:
            t = out[c]
            out[c] = out[p]
            out[p] = t
    for i in range(n):
        s = out[i]
        for j in range(i):
            s -= LU[i, j] * out[j]
        out[i] = s
    for i in range(n - 1, -1, -1):
        s = out[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * out[j]
        out[i] = s / LU[i, i]
    for u in range(k):
        w = 0.0
        for j in range(n):
            w += H.D[u, j] * b[j]
        for j in range(n):
            out[j] += w * H.C[u, j]


@njit(cache=True)
def apply_t(H, b, out):
    """out = H^T b, shape (n,)."""
    n = b.shape[0]
    k = H.k[0]
    if k < 0:
        out[:] = 0.0
        return
    LU, piv = H.LU, H.piv
    out[:] = b
    for i in range(n):  # U^T z = b
        s = out[i]
        for j in range(i):
            s -= LU[j, i] * out[j]
        out[i] = s / LU[i, i]
    for i in range(n - 1, -1, -1):  # L^T w = z (unit diagonal)
        s = out[i]
        for j in range(i + 1, n):
            s -= LU[j, i] * out[j]
        out[i] = s
    for c in range(n - 1, -1, -1):  # x = P^T w
        p = piv[c]
        if p != c:
            t = out[c]
            out[c] = out[p]
            out[p] = t
    for u in range(k):
        w = 0.0
        for j in range(n):
            w += H.C[u, j] * b[j]
        for j in range(n):
            out[j] += w * H.D[u, j]


@njit(cache=True)
def push(H, s, Hy, d):
    """Broyden's update with the step ``s``, ``Hy`` = H y and ``d`` = H^T s (all (n,), computed before the update).
    False (H unchanged) when s^T H y vanishes, H is the zero operator or holds MAX_UPDATES updates."""
    k = H.k[0]
    n = s.shape[0]
    sHy = 0.0
    for j in range(n):
        sHy += s[j] * Hy[j]
    if k < 0 or k >= MAX_UPDATES or not abs(sHy) > 1e-300:
        return False
    for j in range(n):
        H.C[k, j] = (s[j] - Hy[j]) / sHy
        H.D[k, j] = d[j]
    H.k[0] = k + 1
    return True

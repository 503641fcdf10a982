"""Kinematics of piecewise-constant-curvature subsegments (MODEL.md, paper Eqs. 1-4, 27-28).

Frame naming: ``R`` and ``d`` of subsegment i give frame i in frame i-1
(``x_{i-1} = R x_i + d``). ``frames`` chains them into base-frame poses.
Everything is written through (beta, gamma) and functions of theta^2, so it is
smooth and exact at zero curvature (no division by the curvature).

The compiled functions here (``subsegment``, ``frames``, ``subsegment_derivatives``,
``tip_jacobian``) are the numba kernels' building blocks; the Python functions
(:func:`subsegment_transform`, :func:`forward_kinematics`, :func:`backbone_curve`)
call their twins in the compiled core (``pytdcr._core``, ``src/cpp/kinematics.hpp``:
the same bits), so that they compile nothing at first use.
"""

from __future__ import annotations

import numpy as np

from ._core import frames as _core_frames
from ._core import subsegment as _core_subsegment
from .runtime import njit

__all__ = ["backbone_curve", "forward_kinematics", "frames", "subsegment", "subsegment_derivatives",
           "subsegment_transform", "tip_jacobian"]

_SERIES_T2 = 1e-2  # use series for theta^2 below this


@njit(cache=True, inline="always")
def _abc(t2):
    """A = sin(th)/th, B = (1-cos th)/th^2, C = (1-A)/th^2 as functions of th^2."""
    if t2.real < _SERIES_T2:
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)))
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0 * (1.0 - t2 / 90.0)))
        c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)))
    else:
        th = np.sqrt(t2)
        a = np.sin(th) / th
        b = (1.0 - np.cos(th)) / t2
        c = (1.0 - a) / t2
    return a, b, c


@njit(cache=True)
def subsegment(beta, gamma, eps, l, R, d, pg):
    """Transform of one subsegment (frame i in frame i-1) and its centroid.

    Works for real and complex inputs (complex step). ``R`` (3, 3), ``d`` (3,),
    ``pg`` (3,) are written in place. Exact and smooth at zero curvature.
    """
    wx = -gamma * l
    wy = beta * l
    t2 = wx * wx + wy * wy
    a, b, c = _abc(t2)
    # E = I + A K + B K^2, K = [w]x with w = (wx, wy, 0)
    e00 = 1.0 - b * wy * wy
    e01 = b * wx * wy
    e02 = a * wy
    e10 = b * wx * wy
    e11 = 1.0 - b * wx * wx
    e12 = -a * wx
    e20 = -a * wy
    e21 = a * wx
    e22 = 1.0 - b * t2
    ce = np.cos(eps)
    se = np.sin(eps)
    R[0, 0] = e00 * ce + e01 * se
    R[0, 1] = -e00 * se + e01 * ce
    R[0, 2] = e02
    R[1, 0] = e10 * ce + e11 * se
    R[1, 1] = -e10 * se + e11 * ce
    R[1, 2] = e12
    R[2, 0] = e20 * ce + e21 * se
    R[2, 1] = -e20 * se + e21 * ce
    R[2, 2] = e22
    ll = l * l
    d[0] = ll * b * beta
    d[1] = ll * b * gamma
    d[2] = l * a
    pg[0] = ll * c * beta
    pg[1] = ll * c * gamma
    pg[2] = l * b


@njit(cache=True)
def frames(q, sub, pos, rot):
    """Disk frames in the base frame: ``pos`` (N+1, 3) [m], ``rot`` (N+1, 3, 3)."""
    n = sub.shape[0]
    R = np.empty((3, 3))
    d = np.empty(3)
    pg = np.empty(3)
    pos[0, :] = 0.0
    rot[0, :, :] = np.eye(3)
    for i in range(1, n + 1):
        k = 3 * (i - 1)
        subsegment(q[k], q[k + 1], q[k + 2], sub[i - 1, 0], R, d, pg)
        P = rot[i - 1]
        for u in range(3):
            pos[i, u] = pos[i - 1, u] + P[u, 0] * d[0] + P[u, 1] * d[1] + P[u, 2] * d[2]
            for v in range(3):
                rot[i, u, v] = P[u, 0] * R[0, v] + P[u, 1] * R[1, v] + P[u, 2] * R[2, v]



def subsegment_transform(beta: float, gamma: float, eps: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and translation (3,) [m] of frame i in frame i-1.

    Parameters
    ----------
    beta, gamma : float
        Curvature components bending towards +x and +y of frame i-1 [1/m].
    eps : float
        Twist of the subsegment [rad].
    length : float
        Arc length [m].
    """
    R, d, _ = _core_subsegment(float(beta), float(gamma), float(eps), float(length))
    return R, d


@njit(cache=True, inline="always")
def _abc_slopes(t2):
    """Derivatives by theta^2 of A = sin(th)/th and B = (1-cos th)/th^2 (series near 0; no cancellation)."""
    a, b, c = _abc(t2)
    da = 0.5 * (c - b)
    if t2 < _SERIES_T2:
        db = -1.0 / 24.0 + t2 * (2.0 / 720.0 - t2 * (3.0 / 40320.0 - t2 * (4.0 / 3628800.0 - t2 * 5.0 / 479001600.0)))
    else:
        db = (a - 2.0 * b) / (2.0 * t2)
    return a, b, c, da, db


@njit(cache=True)
def subsegment_derivatives(beta, gamma, eps, l, dR, dd):
    """Derivatives of one subsegment's transform by (beta, gamma, eps), in closed form.

    Writes ``dR`` (3, 3, 3): ``dR[a]`` = d R / d q_a, and ``dd`` (3, 3): ``dd[a]``
    = d d / d q_a, for q = (beta [1/m], gamma [1/m], eps [rad]). With
    R = E(w) Rz(eps), E = I + A K + B K^2, K = [w]x, w = l (-gamma, beta, 0) and
    A, B functions of t2 = |w|^2; exact and smooth at zero curvature.
    """
    wx = -gamma * l
    wy = beta * l
    t2 = wx * wx + wy * wy
    a, b, _c, da, db = _abc_slopes(t2)
    K = np.zeros((3, 3))
    K[0, 2] = wy
    K[1, 2] = -wx
    K[2, 0] = -wy
    K[2, 1] = wx
    K2 = K @ K
    E = np.eye(3) + a * K + b * K2
    ce = np.cos(eps)
    se = np.sin(eps)
    Rz = np.array([[ce, -se, 0.0], [se, ce, 0.0], [0.0, 0.0, 1.0]])
    dRz = np.array([[-se, -ce, 0.0], [ce, -se, 0.0], [0.0, 0.0, 0.0]])
    ll = l * l
    for j in range(2):  # j = 0: by w_x, j = 1: by w_y
        wj = wx if j == 0 else wy
        Kj = np.zeros((3, 3))
        if j == 0:
            Kj[1, 2] = -1.0
            Kj[2, 1] = 1.0
        else:
            Kj[0, 2] = 1.0
            Kj[2, 0] = -1.0
        dE = (2.0 * wj * da) * K + a * Kj + (2.0 * wj * db) * K2 + b * (Kj @ K + K @ Kj)
        dEz = dE @ Rz
        # beta moves w_y by l; gamma moves w_x by -l
        lane = 0 if j == 1 else 1
        sgn = l if j == 1 else -l
        for u in range(3):
            for v in range(3):
                dR[lane, u, v] = sgn * dEz[u, v]
    ER = E @ dRz
    for u in range(3):
        for v in range(3):
            dR[2, u, v] = ER[u, v]
    # d = (l^2 B beta, l^2 B gamma, l A), t2 = l^2 (beta^2 + gamma^2)
    dt_db = 2.0 * ll * beta
    dt_dg = 2.0 * ll * gamma
    dd[0, 0] = ll * (b + beta * db * dt_db)
    dd[0, 1] = ll * gamma * db * dt_db
    dd[0, 2] = l * da * dt_db
    dd[1, 0] = ll * beta * db * dt_dg
    dd[1, 1] = ll * (b + gamma * db * dt_dg)
    dd[1, 2] = l * da * dt_dg
    dd[2, 0] = 0.0
    dd[2, 1] = 0.0
    dd[2, 2] = 0.0


@njit(cache=True)
def tip_jacobian(q, sub):
    """Exact derivative of the tip position by the unknowns q (3N,), shape (3, 3N) [m per unit of q].

    Moving subsegment i moves everything beyond it rigidly: d tip / d q_(i,a) =
    R_(0,i-1) (dd_i/dq_a + dR_i/dq_a x_i), with x_i the tip in frame i and the
    subsegment derivatives in closed form (:func:`subsegment_derivatives`).
    ``sub`` (N, >=1) holds the subsegment lengths [m] in its first column.
    """
    n = sub.shape[0]
    pos = np.empty((n + 1, 3))
    rot = np.empty((n + 1, 3, 3))
    frames(q, sub, pos, rot)
    out = np.empty((3, 3 * n))
    dR = np.empty((3, 3, 3))
    dd = np.empty((3, 3))
    x = np.empty(3)
    v = np.empty(3)
    for i in range(1, n + 1):
        k = 3 * (i - 1)
        subsegment_derivatives(q[k], q[k + 1], q[k + 2], sub[i - 1, 0], dR, dd)
        for u in range(3):
            x[u] = 0.0
            for w in range(3):
                x[u] += rot[i, w, u] * (pos[n, w] - pos[i, w])
        P = rot[i - 1]
        for a in range(3):
            for u in range(3):
                v[u] = dd[a, u] + dR[a, u, 0] * x[0] + dR[a, u, 1] * x[1] + dR[a, u, 2] * x[2]
            for u in range(3):
                out[u, k + a] = P[u, 0] * v[0] + P[u, 1] * v[1] + P[u, 2] * v[2]
    return out


def forward_kinematics(q: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Disk poses in the base frame.

    Parameters
    ----------
    q : array-like, shape (N, 3)
        (beta, gamma, eps) per subsegment.
    lengths : array-like, shape (N,)
        Subsegment arc lengths [m].

    Returns
    -------
    positions : ndarray, shape (N+1, 3)
        Disk centres [m]; row 0 is the base.
    rotations : ndarray, shape (N+1, 3, 3)
        Disk orientations (base from disk).
    """
    q = np.ascontiguousarray(q, dtype=float).reshape(-1)
    lengths = np.asarray(lengths, dtype=float)
    n = lengths.shape[0]
    if q.shape != (3 * n,):
        raise ValueError(f"q must have shape ({n}, 3), got {q.size} values")
    sub = np.zeros((n, 5))
    sub[:, 0] = lengths
    return _core_frames(q, sub)


def backbone_curve(q: np.ndarray, lengths: np.ndarray, points_per_subsegment: int = 8) -> np.ndarray:
    """Points along the backbone's arcs, shape (N * points_per_subsegment + 1, 3) [m]."""
    pos, rot = forward_kinematics(q, lengths)
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    pts = [pos[0]]
    for i, ell in enumerate(np.asarray(lengths, dtype=float)):
        for s in np.linspace(0.0, ell, points_per_subsegment + 1)[1:]:
            d = _core_subsegment(float(q[i, 0]), float(q[i, 1]), 0.0, float(s))[1]
            pts.append(pos[i] + rot[i] @ d)
    return np.array(pts)

"""Compiled kernels of the Cosserat-rod model (Rucker & Webster 2011).

Formulation. Cut the robot (rod and tendons together) at arc length s. The
loads on everything beyond the cut are external only: gravity, the disks'
point wrenches, the tip wrench (the tendons' pull on their anchor disks and on
the rod are internal to rod + tendons). So the total internal force ``N`` and
moment ``M`` (base frame, about the backbone point p(s)) obey

    N' = -rho A g,     M' = -p' x N          (jumps -F_j, -M_j at disk j),

with N known in closed form from the base and only M(0) unknown (3 unknowns,
not the 6 of a rod-only shooting). The rod's own wrench is the total minus the
tendons' share: in the body frame,

    R^T M = Kbt u + sum_c tau_c r_c x t_c,     R^T N = Kse (v - e3) + sum_c tau_c t_c,

t_c = (v + u x r_c)/|v + u x r_c| the tendon's unit tangent (straight routing:
r_c constant in the body frame), the sum over the tendons that run past s.
These are solved for (u, v) at every evaluation (Newton, from the last value);
inextensible and unshearable means v = e3 and only the moment equation.
Then p' = R v and R' = R hat(u). A tendon ends where its segment does, so u
jumps there while N and M do not. The shooting residual is M just past the
tip, which must vanish.

Integration is fixed-step classical Runge-Kutta, ``nsub`` steps per
subsegment, so every disk lies on a step boundary (the point loads are exact
jumps); its error is checked against SciPy's DOP853 in the tests.

State ``y`` (18,): p (3), R row-major (9), M (3), N (3); base frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...runtime import njit

__all__ = ["Rod", "constitutive", "rhs", "shoot"]


class Rod(NamedTuple):
    """The packed rod and its loads, as :func:`shoot` takes them (the PCC kernels' ``Packed`` plays this part
    for the PCC family)."""

    lengths: np.ndarray  # (N,) subsegment lengths [m]
    stiff: np.ndarray  # (4,) EI, GJ [N m^2], GA, EA [N]
    mpl: float  # backbone mass per length [kg/m]
    dmass: np.ndarray  # (N,) disk masses [kg]
    holes: np.ndarray  # (nt, 3) tendon holes in the body frame [m]
    anchor: np.ndarray  # (nt,) 1-based anchor disk
    tension: np.ndarray  # (nt,) actuator tensions [N]
    grav: np.ndarray  # (3,) gravity, base frame [m/s^2]
    pforce: np.ndarray  # (N, 3) point force on each disk, base frame [N]
    pmoment: np.ndarray  # (N, 3) point moment on each disk, base frame [N m]
    ext: bool  # shear and extension on
    nsub: int  # RK4 steps per subsegment

_NEWTON_TOL = 1e-13
_NEWTON_MAX = 30


@njit(cache=True)
def _gauss_solve(A, b, n):
    """Solve A[:n, :n] x = b[:n] in place (b becomes x) by partial pivoting; False if singular."""
    for k in range(n):
        piv = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                piv = i
        if big == 0.0 or not np.isfinite(big):
            return False
        if piv != k:
            for j in range(n):
                A[k, j], A[piv, j] = A[piv, j], A[k, j]
            b[k], b[piv] = b[piv], b[k]
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            for j in range(k, n):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for j in range(k + 1, n):
            acc -= A[k, j] * b[j]
        b[k] = acc / A[k, k]
    return True


@njit(cache=True)
def constitutive(mb, nb, holes, tau, active, stiff, ext, x, A, F):
    """Solve the body-frame balance for x = (u, v) in place, from its current value.

    Parameters
    ----------
    mb, nb : (3,) total moment and force in the body frame [N m, N].
    holes : (nt, 3) tendon routing r_c in the body frame [m].
    tau : (nt,) tendon tensions [N]; ``active`` (nt,) bool: tendon runs past s.
    stiff : (4,) EI, GJ, GA, EA [N m^2, N m^2, N, N].
    ext : bool, solve for v too (shear and extension) or keep v = e3.
    x : (6,) u [1/m] then v [-]; A (6, 6), F (6,) scratch.

    Returns True when the Newton iteration converged to a physical strain (with extension: v3 > 0, an
    axial strain above -1).
    """
    n = 6 if ext else 3
    EI, GJ, GA, EA = stiff[0], stiff[1], stiff[2], stiff[3]
    if not ext:
        x[3] = 0.0
        x[4] = 0.0
        x[5] = 1.0
    for _ in range(_NEWTON_MAX):
        u0, u1, u2, v0, v1, v2 = x[0], x[1], x[2], x[3], x[4], x[5]
        for i in range(6):
            F[i] = 0.0
            for j in range(6):
                A[i, j] = 0.0
        F[0] = EI * u0 - mb[0]
        F[1] = EI * u1 - mb[1]
        F[2] = GJ * u2 - mb[2]
        A[0, 0] = EI
        A[1, 1] = EI
        A[2, 2] = GJ
        if ext:
            F[3] = GA * v0 - nb[0]
            F[4] = GA * v1 - nb[1]
            F[5] = EA * (v2 - 1.0) - nb[2]
            A[3, 3] = GA
            A[4, 4] = GA
            A[5, 5] = EA
        for c in range(holes.shape[0]):
            tc = tau[c]
            if not active[c] or tc == 0.0:
                continue
            r0, r1, r2 = holes[c, 0], holes[c, 1], holes[c, 2]
            # w = v + u x r
            w0 = v0 + u1 * r2 - u2 * r1
            w1 = v1 + u2 * r0 - u0 * r2
            w2 = v2 + u0 * r1 - u1 * r0
            nw = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
            t0, t1, t2 = w0 / nw, w1 / nw, w2 / nw
            # r x t
            F[0] += tc * (r1 * t2 - r2 * t1)
            F[1] += tc * (r2 * t0 - r0 * t2)
            F[2] += tc * (r0 * t1 - r1 * t0)
            if ext:
                F[3] += tc * t0
                F[4] += tc * t1
                F[5] += tc * t2
            # dt/dw = P = (I - t t^T)/|w|, dw/du = -hat(r), dw/dv = I, c = r x t:
            # d(r x t)/du = -hat(r) P hat(r) = -(r r^T - |r|^2 I + c c^T)/|w|
            # d(r x t)/dv = hat(r) P = (hat(r) - c t^T)/|w|
            # dt/du = -P hat(r) = -(hat(r) + t c^T)/|w|,  dt/dv = P
            c0 = r1 * t2 - r2 * t1
            c1 = r2 * t0 - r0 * t2
            c2 = r0 * t1 - r1 * t0
            rv = (r0, r1, r2)
            tv = (t0, t1, t2)
            cv = (c0, c1, c2)
            rr = r0 * r0 + r1 * r1 + r2 * r2
            s = tc / nw
            for i in range(3):
                for j in range(3):
                    dij = 1.0 if i == j else 0.0
                    A[i, j] -= s * (rv[i] * rv[j] - rr * dij + cv[i] * cv[j])
            if ext:
                # hat(r)[i, j] = -eps_ijk r_k
                hr = ((0.0, -r2, r1), (r2, 0.0, -r0), (-r1, r0, 0.0))
                for i in range(3):
                    for j in range(3):
                        dij = 1.0 if i == j else 0.0
                        A[i, 3 + j] += s * (hr[i][j] - cv[i] * tv[j])
                        A[3 + i, j] -= s * (hr[i][j] + tv[i] * cv[j])
                        A[3 + i, 3 + j] += s * (dij - tv[i] * tv[j])
        big = 0.0
        for i in range(n):
            F[i] = -F[i]
        if not _gauss_solve(A, F, n):
            return False
        for i in range(n):
            x[i] += F[i]
            big = max(big, abs(F[i]) / (1.0 + abs(x[i])))
        if not np.isfinite(big):
            return False
        if big <= _NEWTON_TOL:
            # an axial strain of -1 or less (v3 <= 0) crushes the rod through itself: no equilibrium of
            # this rod law, so the integration (and the solve) fails rather than report it
            return not (ext and x[5] <= 0.0)
    return False


@njit(cache=True)
def rhs(y, holes, tau, active, stiff, ext, fw, x, A, F, dy):
    """Derivative ``dy`` (18,) of the state ``y`` at a point of a subsegment.

    ``fw`` (3,) is N', minus the distributed weight per length [N/m].
    ``x`` (6,) carries (u, v) from the last call (warm start) and receives the
    new one. Returns False if the balance could not be solved.
    """
    mb = np.empty(3)
    nb = np.empty(3)
    for i in range(3):
        mb[i] = y[3 + 0 * 3 + i] * y[12] + y[3 + 1 * 3 + i] * y[13] + y[3 + 2 * 3 + i] * y[14]
        nb[i] = y[3 + 0 * 3 + i] * y[15] + y[3 + 1 * 3 + i] * y[16] + y[3 + 2 * 3 + i] * y[17]
    if not constitutive(mb, nb, holes, tau, active, stiff, ext, x, A, F):
        return False
    u0, u1, u2, v0, v1, v2 = x[0], x[1], x[2], x[3], x[4], x[5]
    # p' = R v
    for i in range(3):
        dy[i] = y[3 + 3 * i] * v0 + y[4 + 3 * i] * v1 + y[5 + 3 * i] * v2
    # R' = R hat(u): row i of R times hat(u)
    for i in range(3):
        a, b, c = y[3 + 3 * i], y[4 + 3 * i], y[5 + 3 * i]
        dy[3 + 3 * i] = b * u2 - c * u1
        dy[4 + 3 * i] = -a * u2 + c * u0
        dy[5 + 3 * i] = a * u1 - b * u0
    # M' = -p' x N; N' = -rho A g
    n0, n1, n2 = y[15], y[16], y[17]
    dy[12] = -(dy[1] * n2 - dy[2] * n1)
    dy[13] = -(dy[2] * n0 - dy[0] * n2)
    dy[14] = -(dy[0] * n1 - dy[1] * n0)
    dy[15] = fw[0]
    dy[16] = fw[1]
    dy[17] = fw[2]
    return True


@njit(cache=True)
def _reorthonormalize(y):
    """Pull R = y[3:12] back onto SO(3): one Newton-Schulz step R <- R (3 I - R^T R) / 2.

    RK4 drifts off the rotation group by O(h^5) per step; this removes the
    drift to second order without changing the order of the integration.
    """
    R = y[3:12].reshape(3, 3)
    S = R.T @ R
    for i in range(3):
        for j in range(3):
            S[i, j] = (3.0 if i == j else 0.0) - S[i, j]
    Rn = R @ S
    for i in range(3):
        for j in range(3):
            y[3 + 3 * i + j] = 0.5 * Rn[i, j]


@njit(cache=True, nogil=True)
def shoot(m0, lam, rod, record, pos, rot, curve, res):
    """Integrate from the base with M(0) = ``m0`` and every load scaled by ``lam``.

    Parameters
    ----------
    m0 : (3,) total moment at the base, base frame [N m].
    rod : :class:`Rod`, the rod and its loads.
    record : fill ``pos`` (N+1, 3), ``rot`` (N+1, 3, 3) at the disks and ``curve`` (N nsub + 1, 3).
    res : (6,) receives M just past the tip [N m] (the shooting residual), then the tip position [m].

    Returns True if the integration could be carried out (NaN residual otherwise).
    """
    lengths, stiff, mpl, dmass, holes, anchor = rod.lengths, rod.stiff, rod.mpl, rod.dmass, rod.holes, rod.anchor
    tension, grav, pforce, pmoment, ext, nsub = rod.tension, rod.grav, rod.pforce, rod.pmoment, rod.ext, rod.nsub
    n = lengths.shape[0]
    nt = holes.shape[0]
    y = np.zeros(18)
    y[3] = 1.0
    y[7] = 1.0
    y[11] = 1.0
    # total force at the base: every external force, all of it beyond s = 0+
    total_len = 0.0
    for i in range(n):
        total_len += lengths[i]
    for k in range(3):
        acc = mpl * total_len * grav[k]
        for i in range(n):
            acc += pforce[i, k] + dmass[i] * grav[k]
        y[12 + k] = m0[k]
        y[15 + k] = lam * acc
    tau = np.empty(nt)
    for c in range(nt):
        tau[c] = lam * tension[c]
    active = np.empty(nt, dtype=np.bool_)
    x = np.zeros(6)
    x[5] = 1.0
    A = np.empty((6, 6))
    F = np.empty(6)
    K = np.empty((4, 18))
    yt = np.empty(18)
    fw = np.empty(3)
    for k in range(3):
        fw[k] = -lam * mpl * grav[k]  # N' from the backbone's weight
    if record:
        pos[0, :] = 0.0
        for a in range(3):
            for b in range(3):
                rot[0, a, b] = 1.0 if a == b else 0.0
        curve[0, :] = 0.0
    ic = 1
    for i in range(n):
        for c in range(nt):
            active[c] = anchor[c] >= i + 1
        h = lengths[i] / nsub
        for _ in range(nsub):
            for st in range(4):  # classical Runge-Kutta stages
                if not rhs(y if st == 0 else yt, holes, tau, active, stiff, ext, fw, x, A, F, K[st]):
                    res[:] = np.nan
                    return False
                if st < 3:
                    c = h if st == 2 else 0.5 * h
                    for k in range(18):
                        yt[k] = y[k] + c * K[st, k]
            for k in range(18):
                y[k] += h / 6.0 * (K[0, k] + 2.0 * K[1, k] + 2.0 * K[2, k] + K[3, k])
            _reorthonormalize(y)
            if record:
                curve[ic, 0] = y[0]
                curve[ic, 1] = y[1]
                curve[ic, 2] = y[2]
                ic += 1
        # disk i+1: its weight and point wrench act here (jump of N and M)
        for k in range(3):
            y[15 + k] -= lam * (pforce[i, k] + dmass[i] * grav[k])
            y[12 + k] -= lam * pmoment[i, k]
        if record:
            for k in range(3):
                pos[i + 1, k] = y[k]
            for a in range(3):
                for b in range(3):
                    rot[i + 1, a, b] = y[3 + 3 * a + b]
    for k in range(3):
        res[k] = y[12 + k]
        res[3 + k] = y[k]
    return bool(np.isfinite(res[0]) and np.isfinite(res[1]) and np.isfinite(res[2]))

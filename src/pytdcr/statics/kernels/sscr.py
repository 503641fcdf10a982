"""Compiled kernels of the subsegment Cosserat rod (``sscr``).

The backbone between neighbouring disks is a Cosserat rod carrying only its
own weight; the disks are rigid bodies on it. Each disk receives the tendon
forces through its holes along the actual chords to the neighbouring disks
(the PCC model's pull rule, anchor and friction laws: the tendon kernel of
:mod:`pytdcr.statics.kernels.pcc` is reused on the relative transforms of the
disks), its weight and any point wrench.

Unknowns ``x`` (6N,): per subsegment i (from disk i-1 to disk i), the internal
force n_i and moment m_i at its base (just past disk i-1), in the frame of disk
i-1, as (l_i n_i, m_i) [N m] so that every unknown is a moment (multiple
shooting). Local frames keep the equations nearly invariant to rotations of
the robot upstream, as the PCC model's local curvatures do. Integrating subsegment i from the pose of disk i-1 (the
poses are chained from the base) gives the pose of disk i and the internal
wrench just before it, (n_i^e, m_i^e). Residual, per disk i, the balance of
disk i, about its centre, written in the frame of disk i:

    r_i = R_i^T ( l_i (n_i^e - n_{i+1} - F_i),  m_i^e - m_{i+1} - M_i ),   n_{N+1} = m_{N+1} = 0

with (F_i, M_i) the loads on disk i (world) and the force rows scaled by l_i,
so that every residual is a moment [N m]. The rod (world frame, internal force n and moment
m about the rod's point):

    p' = R v,  R' = R [u]x,  n' = -rho A g,  m' = -p' x n,
    u = K_bt^-1 R^T m,  v = e3 (+ K_se^-1 R^T n with shear and extension),

integrated by classical Runge-Kutta, ``nsub`` steps per subsegment, R pulled
back onto SO(3) after each step.

The Jacobian is exact for the discrete scheme: the tangent of every Runge-Kutta
step (forward mode, nine directions: the start rotation, force and moment) gives
each subsegment's state-transition matrix; these are chained along the robot;
the tendon loads' derivatives by the poses of the three disks they touch come
from the PCC tendon kernel's tangent lanes.

Layout of the packed model: as :class:`pytdcr.statics.kernels.pcc.Packed` (``sub``,
``holes``, ``anchor``, ``fric``, ``tension``, ``grav``, ``pforce``,
``pmoment``) plus ``rod`` (5,): GA [N], EA [N], mass per length [kg/m], shear
and extension (1) or not (0), Runge-Kutta steps per subsegment.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...runtime import njit
from .pcc import tendon_unit_load_jvp

__all__ = ["SSCRPacked", "SSCRWork", "blend", "evaluate", "largest_angle", "make_model_work", "record_shape",
           "stiffness_range", "tangent_stiffness", "tip_jacobian_of", "with_tension"]

#: lanes of one disk's tendon loads: (dp, dtheta) of the disks before it, itself and after it
_LANES = 18
# NumPy scalars where a constant is passed to a compiled function: numba types a Python int or bool argument as
# a literal and compiles the callee once per value (tests/test_kernel_signatures.py)
_NO = np.bool_(False)
_YES = np.bool_(True)
_ROW0 = np.int64(0)


class SSCRPacked(NamedTuple):
    """The packed subsegment Cosserat rod (see the module docstring)."""

    sub: np.ndarray
    holes: np.ndarray
    anchor: np.ndarray
    fric: np.ndarray
    tension: np.ndarray
    grav: np.ndarray
    pforce: np.ndarray
    pmoment: np.ndarray
    rod: np.ndarray


class SSCRWork(NamedTuple):
    """Scratch arrays of :func:`evaluate` (N disks, nt tendons, m = 6N unknowns)."""

    pos: np.ndarray  # (N+2, 3) disk centres, world; 0 the base; N+1 padding
    rot: np.ndarray  # (N+2, 3, 3) disk frames, world
    wend: np.ndarray  # (N+1, 6) internal wrench at the end of subsegment i, world
    phi: np.ndarray  # (N+1, 12, 12) d(pose_i, wend_i) / d(pose_{i-1}, x_i); pose = (dp, dtheta), world
    S: np.ndarray  # (N+2, 6, m) d pose_i / d x
    E: np.ndarray  # (N+1, 6, m) d wend_i / d x
    Rrel: np.ndarray  # (N+2, 3, 3) frame of disk i in frame of disk i-1
    drel: np.ndarray  # (N+2, 3)
    T: np.ndarray  # (N+2, nt) tension in piece i of each tendon [N]
    dT: np.ndarray  # (N+2, nt, m)
    W: np.ndarray  # (N+1, nt, 7) unit load (frame i-1, about its origin) and tension ratio at disk i
    dW: np.ndarray  # (N+1, nt, 7, 18) its derivative by the 18 pose lanes
    dD: np.ndarray  # (6, m) scratch: derivative of one disk's load


@njit(cache=True)
def make_model_work(model):
    """Scratch arrays for ``model``."""
    n = model.sub.shape[0]
    nt = model.holes.shape[0]
    m = 6 * n
    rot = np.zeros((n + 2, 3, 3))
    Rrel = np.zeros((n + 2, 3, 3))
    for i in range(n + 2):
        for a in range(3):
            rot[i, a, a] = 1.0
            Rrel[i, a, a] = 1.0
    return SSCRWork(np.zeros((n + 2, 3)), rot, np.zeros((n + 1, 6)), np.zeros((n + 1, 12, 12)),
                    np.zeros((n + 2, 6, m)), np.zeros((n + 1, 6, m)), Rrel, np.zeros((n + 2, 3)),
                    np.zeros((n + 2, nt)), np.zeros((n + 2, nt, m)), np.zeros((n + 1, nt, 7)),
                    np.zeros((n + 1, nt, 7, _LANES)), np.zeros((6, m)))


@njit(cache=True)
def with_tension(m, tension):
    """The packed model with other actuator tensions (nt,) [N]."""
    return SSCRPacked(m.sub, m.holes, m.anchor, m.fric, tension, m.grav, m.pforce, m.pmoment, m.rod)


@njit(cache=True)
def blend(ma, mb, s):
    """The packed rod ``mb`` under the loads ``(1 - s) ma + s mb`` (see :func:`pytdcr.statics.kernels.pcc.blend`)."""
    if s == 1.0:
        return mb
    if s == 0.0:
        return ma
    return SSCRPacked(mb.sub, mb.holes, mb.anchor, mb.fric, ma.tension + s * (mb.tension - ma.tension),
                      ma.grav + s * (mb.grav - ma.grav), ma.pforce + s * (mb.pforce - ma.pforce),
                      ma.pmoment + s * (mb.pmoment - ma.pmoment), mb.rod)


@njit(cache=True)
def largest_angle(dq, model):
    """How far a change ``dq`` (6N,) of the base wrenches bends or twists a subsegment [rad]: l |dm| / min(EI, GJ).

    A change of the base force bends the subsegment only through its moment along the subsegment, which the
    base moments of the neighbouring subsegments carry; an axial force does not bend it at all.
    """
    sub = model.sub
    big = 0.0
    for i in range(sub.shape[0]):
        k = 6 * i
        dm = np.sqrt(dq[k + 3] ** 2 + dq[k + 4] ** 2 + dq[k + 5] ** 2)
        big = max(big, sub[i, 0] * dm / min(sub[i, 1], sub[i, 2]))
    return big


# ------------------------------------------------------------------------------------ the rod between two disks
@njit(cache=True, inline="always")
def _rhs(y, kinv, ext, fw, dy, uv):
    """d/ds of the state y (18,): p, R (row-major), n, m. ``uv`` (6,) receives u, v."""
    for b in range(3):
        rtm = y[3 + b] * y[15] + y[6 + b] * y[16] + y[9 + b] * y[17]
        uv[b] = kinv[b] * rtm
        uv[3 + b] = 0.0
    uv[5] = 1.0
    if ext:
        for b in range(3):
            rtn = y[3 + b] * y[12] + y[6 + b] * y[13] + y[9 + b] * y[14]
            uv[3 + b] += kinv[3 + b] * rtn
        if uv[5] <= 0.0:  # axial strain <= -1: the rod crushed through itself; no equilibrium (NaN residual)
            uv[5] = np.nan
    u0, u1, u2, v0, v1, v2 = uv[0], uv[1], uv[2], uv[3], uv[4], uv[5]
    for a in range(3):
        r0, r1, r2 = y[3 + 3 * a], y[4 + 3 * a], y[5 + 3 * a]
        dy[a] = r0 * v0 + r1 * v1 + r2 * v2
        dy[3 + 3 * a] = r1 * u2 - r2 * u1
        dy[4 + 3 * a] = -r0 * u2 + r2 * u0
        dy[5 + 3 * a] = r0 * u1 - r1 * u0
    for a in range(3):
        dy[12 + a] = fw[a]
    n0, n1, n2 = y[12], y[13], y[14]
    dy[15] = -(dy[1] * n2 - dy[2] * n1)
    dy[16] = -(dy[2] * n0 - dy[0] * n2)
    dy[17] = -(dy[0] * n1 - dy[1] * n0)


@njit(cache=True, inline="always")
def _rhs_tangent(y, Y, kinv, ext, dy, uv, dY):
    """Tangent of :func:`_rhs` along each column of Y (18, nc); ``dy`` and ``uv`` from :func:`_rhs` at y."""
    u0, u1, u2, v0, v1, v2 = uv[0], uv[1], uv[2], uv[3], uv[4], uv[5]
    n0, n1, n2 = y[12], y[13], y[14]
    m0, m1, m2 = y[15], y[16], y[17]
    for c in range(Y.shape[1]):
        dn0, dn1, dn2 = Y[12, c], Y[13, c], Y[14, c]
        dm0, dm1, dm2 = Y[15, c], Y[16, c], Y[17, c]
        du0 = kinv[0] * (Y[3, c] * m0 + Y[6, c] * m1 + Y[9, c] * m2 + y[3] * dm0 + y[6] * dm1 + y[9] * dm2)
        du1 = kinv[1] * (Y[4, c] * m0 + Y[7, c] * m1 + Y[10, c] * m2 + y[4] * dm0 + y[7] * dm1 + y[10] * dm2)
        du2 = kinv[2] * (Y[5, c] * m0 + Y[8, c] * m1 + Y[11, c] * m2 + y[5] * dm0 + y[8] * dm1 + y[11] * dm2)
        dv0 = dv1 = dv2 = 0.0
        if ext:
            dv0 = kinv[3] * (Y[3, c] * n0 + Y[6, c] * n1 + Y[9, c] * n2 + y[3] * dn0 + y[6] * dn1 + y[9] * dn2)
            dv1 = kinv[4] * (Y[4, c] * n0 + Y[7, c] * n1 + Y[10, c] * n2 + y[4] * dn0 + y[7] * dn1 + y[10] * dn2)
            dv2 = kinv[5] * (Y[5, c] * n0 + Y[8, c] * n1 + Y[11, c] * n2 + y[5] * dn0 + y[8] * dn1 + y[11] * dn2)
        for a in range(3):
            dr0, dr1, dr2 = Y[3 + 3 * a, c], Y[4 + 3 * a, c], Y[5 + 3 * a, c]
            r0, r1, r2 = y[3 + 3 * a], y[4 + 3 * a], y[5 + 3 * a]
            dY[a, c] = dr0 * v0 + dr1 * v1 + dr2 * v2 + r0 * dv0 + r1 * dv1 + r2 * dv2
            dY[3 + 3 * a, c] = dr1 * u2 - dr2 * u1 + r1 * du2 - r2 * du1
            dY[4 + 3 * a, c] = -dr0 * u2 + dr2 * u0 - r0 * du2 + r2 * du0
            dY[5 + 3 * a, c] = dr0 * u1 - dr1 * u0 + r0 * du1 - r1 * du0
            dY[12 + a, c] = 0.0
        dp0, dp1, dp2 = dY[0, c], dY[1, c], dY[2, c]
        dY[15, c] = -(dp1 * n2 - dp2 * n1 + dy[1] * dn2 - dy[2] * dn1)
        dY[16, c] = -(dp2 * n0 - dp0 * n2 + dy[2] * dn0 - dy[0] * dn2)
        dY[17, c] = -(dp0 * n1 - dp1 * n0 + dy[0] * dn1 - dy[1] * dn0)


@njit(cache=True)
def _reorthonormalize(y, Y, tangent, S, R):
    """R <- R (3 I - R^T R) / 2 (one Newton-Schulz step back onto SO(3)), with its tangent.

    ``S`` and ``R`` (3, 3) are scratch.
    """
    for a in range(3):
        for b in range(3):
            R[a, b] = y[3 + 3 * a + b]
    for a in range(3):
        for b in range(3):
            S[a, b] = (3.0 if a == b else 0.0) - (R[0, a] * R[0, b] + R[1, a] * R[1, b] + R[2, a] * R[2, b])
    if tangent:
        dS = np.empty((3, 3))
        dRn = np.empty((3, 3))
        for c in range(Y.shape[1]):
            # dRn = (dR S + R dS) / 2, dS = -(dR^T R + R^T dR)
            for e in range(3):
                for b in range(3):
                    acc = 0.0
                    for f in range(3):
                        acc -= Y[3 + 3 * f + e, c] * R[f, b] + R[f, e] * Y[3 + 3 * f + b, c]
                    dS[e, b] = acc
            for a in range(3):
                for b in range(3):
                    acc = 0.0
                    for e in range(3):
                        acc += Y[3 + 3 * a + e, c] * S[e, b] + R[a, e] * dS[e, b]
                    dRn[a, b] = 0.5 * acc
            for a in range(3):
                for b in range(3):
                    Y[3 + 3 * a + b, c] = dRn[a, b]
    for a in range(3):
        for b in range(3):
            y[3 + 3 * a + b] = 0.5 * (R[a, 0] * S[0, b] + R[a, 1] * S[1, b] + R[a, 2] * S[2, b])


@njit(cache=True)
def integrate(y, ell, nsub, kinv, ext, fw, tangent, Y, curve, ic):
    """Integrate one subsegment of length ``ell`` from the state ``y`` (18,), in place.

    With ``tangent``, ``Y`` (18, 9) is carried along (forward mode of the discrete scheme). If ``curve``
    has room, the points after each step are written from row ``ic``; returns the next free row.
    """
    h = ell / nsub
    k = np.empty((4, 18))
    yt = np.empty(18)
    uv = np.empty(6)
    Sbuf = np.empty((3, 3))
    Rbuf = np.empty((3, 3))
    nc = Y.shape[1]
    K = np.empty((4, 18, nc))
    Yt = np.empty((18, nc))
    for _ in range(nsub):
        for st in range(4):
            src = y if st == 0 else yt
            _rhs(src, kinv, ext, fw, k[st], uv)
            if tangent:
                _rhs_tangent(src, Y if st == 0 else Yt, kinv, ext, k[st], uv, K[st])
            if st < 3:
                c = h if st == 2 else 0.5 * h
                for a in range(18):
                    yt[a] = y[a] + c * k[st, a]
                if tangent:
                    for a in range(18):
                        for b in range(nc):
                            Yt[a, b] = Y[a, b] + c * K[st, a, b]
        for a in range(18):
            y[a] += h / 6.0 * (k[0, a] + 2.0 * k[1, a] + 2.0 * k[2, a] + k[3, a])
        if tangent:
            for a in range(18):
                for b in range(nc):
                    Y[a, b] += h / 6.0 * (K[0, a, b] + 2.0 * K[1, a, b] + 2.0 * K[2, a, b] + K[3, a, b])
        _reorthonormalize(y, Y, tangent, Sbuf, Rbuf)
        if ic < curve.shape[0]:
            curve[ic, 0] = y[0]
            curve[ic, 1] = y[1]
            curve[ic, 2] = y[2]
            ic += 1
    return ic


@njit(cache=True)
def _stiffness_inverse(model, i):
    kinv = np.empty(6)
    EI = model.sub[i, 1]
    GJ = model.sub[i, 2]
    kinv[0] = 1.0 / EI
    kinv[1] = 1.0 / EI
    kinv[2] = 1.0 / GJ
    kinv[3] = 1.0 / model.rod[0]
    kinv[4] = 1.0 / model.rod[0]
    kinv[5] = 1.0 / model.rod[1]
    return kinv


@njit(cache=True)
def _transition(y0, y, Y, phi):
    """The 12x12 state-transition matrix of one subsegment from the tangents Y (18, 9) at its end state y.

    Columns: start (dp, dtheta, dn, dm); rows: end (dp, dtheta, dn, dm); rotations as world-frame angles.
    """
    for a in range(12):
        for b in range(12):
            phi[a, b] = 0.0
    for a in range(3):
        phi[a, a] = 1.0  # moving the start moves the end alike; nothing else depends on it
    R = y[3:12].reshape(3, 3)
    for c in range(9):
        col = 3 + c
        for a in range(3):
            phi[a, col] = Y[a, c]
            phi[6 + a, col] = Y[12 + a, c]
            phi[9 + a, col] = Y[15 + a, c]
        dR = Y[3:12, c].copy().reshape(3, 3)
        A = dR @ R.T
        phi[3, col] = 0.5 * (A[2, 1] - A[1, 2])
        phi[4, col] = 0.5 * (A[0, 2] - A[2, 0])
        phi[5, col] = 0.5 * (A[1, 0] - A[0, 1])


@njit(cache=True)
def _start_state(q, model, i, pos, rot, y):
    """The state at the base of subsegment i: pose of disk i-1, wrench R_{i-1} (x_n / l_i, x_m), world."""
    k = 6 * (i - 1)
    ell = model.sub[i - 1, 0]
    for a in range(3):
        y[a] = pos[i - 1, a]
        y[12 + a] = (rot[i - 1, a, 0] * q[k] + rot[i - 1, a, 1] * q[k + 1] + rot[i - 1, a, 2] * q[k + 2]) / ell
        y[15 + a] = rot[i - 1, a, 0] * q[k + 3] + rot[i - 1, a, 1] * q[k + 4] + rot[i - 1, a, 2] * q[k + 5]
        for b in range(3):
            y[3 + 3 * a + b] = rot[i - 1, a, b]


@njit(cache=True)
def _local_columns(y0, Rp, ell, phi):
    """Rewrite the wrench columns of ``phi`` for the local unknowns (l n, m) in the frame of disk i-1.

    The world start wrench is R_{i-1} (x_n / l, x_m): turning disk i-1 by dtheta turns it by dtheta x, and
    the unknowns enter through R_{i-1} / l and R_{i-1}.
    """
    col = np.empty((12, 6))
    for a in range(12):
        for b in range(6):
            col[a, b] = phi[a, 6 + b]
    n0, n1, n2 = y0[12], y0[13], y0[14]
    m0, m1, m2 = y0[15], y0[16], y0[17]
    for a in range(12):
        # d(start n) = dtheta x n = -[n]x dtheta; likewise m
        c0, c1, c2 = col[a, 0], col[a, 1], col[a, 2]
        d0, d1, d2 = col[a, 3], col[a, 4], col[a, 5]
        # row vector (c) times -[n]x: (c . (e x n)) = e . (n x c)
        phi[a, 3] += (n1 * c2 - n2 * c1) + (m1 * d2 - m2 * d1)
        phi[a, 4] += (n2 * c0 - n0 * c2) + (m2 * d0 - m0 * d2)
        phi[a, 5] += (n0 * c1 - n1 * c0) + (m0 * d1 - m1 * d0)
        for j in range(3):
            phi[a, 6 + j] = (c0 * Rp[0, j] + c1 * Rp[1, j] + c2 * Rp[2, j]) / ell
            phi[a, 9 + j] = d0 * Rp[0, j] + d1 * Rp[1, j] + d2 * Rp[2, j]


@njit(cache=True)
def _chain(q, lam, model, want_jac, work):
    """Integrate every subsegment from the base; poses, end wrenches and (with want_jac) their sensitivities."""
    sub = model.sub
    n = sub.shape[0]
    nsub = int(model.rod[4])
    ext = model.rod[3] > 0.5
    fw = np.empty(3)
    for a in range(3):
        fw[a] = -lam * model.rod[2] * model.grav[a]
    y = np.empty(18)
    Y = np.zeros((18, 9))
    y0 = np.empty(18)
    nocurve = np.empty((0, 3))
    pos, rot = work.pos, work.rot
    for i in range(1, n + 1):
        _start_state(q, model, i, pos, rot, y)
        y0[:] = y
        if want_jac:
            Y[:, :] = 0.0
            for e in range(3):  # rotation of the start by e: dR = [e_x] R
                for a in range(3):
                    for b in range(3):
                        acc = 0.0
                        if a == 0:
                            acc = (-rot[i - 1, 1, b] if e == 2 else 0.0) + (rot[i - 1, 2, b] if e == 1 else 0.0)
                        elif a == 1:
                            acc = (rot[i - 1, 0, b] if e == 2 else 0.0) - (rot[i - 1, 2, b] if e == 0 else 0.0)
                        else:
                            acc = (-rot[i - 1, 0, b] if e == 1 else 0.0) + (rot[i - 1, 1, b] if e == 0 else 0.0)
                        Y[3 + 3 * a + b, e] = acc
                Y[12 + e, 3 + e] = 1.0
                Y[15 + e, 6 + e] = 1.0
        integrate(y, sub[i - 1, 0], nsub, _stiffness_inverse(model, i - 1), ext, fw, want_jac, Y, nocurve, _ROW0)
        for a in range(3):
            pos[i, a] = y[a]
            work.wend[i, a] = y[12 + a]
            work.wend[i, 3 + a] = y[15 + a]
            for b in range(3):
                rot[i, a, b] = y[3 + 3 * a + b]
        if want_jac:
            _transition(y0, y, Y, work.phi[i])
            _local_columns(y0, rot[i - 1], sub[i - 1, 0], work.phi[i])
        Rp = rot[i - 1]
        for a in range(3):
            acc = 0.0
            for b in range(3):
                work.Rrel[i, a, b] = Rp[0, a] * rot[i, 0, b] + Rp[1, a] * rot[i, 1, b] + Rp[2, a] * rot[i, 2, b]
                acc += Rp[b, a] * (pos[i, b] - pos[i - 1, b])
            work.drel[i, a] = acc


@njit(cache=True)
def _sensitivities(model, work):
    """S_i = d pose_i / d x and E_i = d wend_i / d x, chained from the base."""
    n = model.sub.shape[0]
    S, E, phi = work.S, work.E, work.phi
    S[0, :, :] = 0.0
    S[n + 1, :, :] = 0.0
    m = 6 * n
    for i in range(1, n + 1):
        k = 6 * (i - 1)
        P = phi[i]
        for a in range(6):
            for j in range(k):
                accS = 0.0
                accE = 0.0
                for b in range(6):
                    accS += P[a, b] * S[i - 1, b, j]
                    accE += P[6 + a, b] * S[i - 1, b, j]
                S[i, a, j] = accS
                E[i, a, j] = accE
            for j in range(6):
                S[i, a, k + j] = P[a, 6 + j]
                E[i, a, k + j] = P[6 + a, 6 + j]
            for j in range(k + 6, m):
                S[i, a, j] = 0.0
                E[i, a, j] = 0.0


@njit(cache=True, inline="always")
def _cross_into(a0, a1, a2, b0, b1, b2, out, o):
    out[o] = a1 * b2 - a2 * b1
    out[o + 1] = a2 * b0 - a0 * b2
    out[o + 2] = a0 * b1 - a1 * b0


@njit(cache=True)
def _pose_lanes(work, i, lR, ld):
    """Tangent lanes of the transform of subsegment i by the 18 pose lanes (disks i-1, i, i+1)."""
    Rp = work.rot[i - 1]
    Ri = work.rot[i]
    lR[:, :, :] = 0.0
    ld[:, :] = 0.0
    dp = work.pos[i] - work.pos[i - 1]
    for e in range(3):
        # [e_x] Ri, then Rp^T of it: dRrel = Rp^T [dtheta_i - dtheta_{i-1}]x Ri
        Ex = np.zeros((3, 3))
        if e == 0:
            Ex[1, 2] = -1.0
            Ex[2, 1] = 1.0
        elif e == 1:
            Ex[0, 2] = 1.0
            Ex[2, 0] = -1.0
        else:
            Ex[0, 1] = -1.0
            Ex[1, 0] = 1.0
        G = Rp.T @ Ex @ Ri
        ex = np.zeros(3)
        ex[e] = 1.0
        cr = np.empty(3)
        _cross_into(ex[0], ex[1], ex[2], dp[0], dp[1], dp[2], cr, 0)
        for a in range(3):
            for b in range(3):
                lR[3 + e, a, b] = -G[a, b]
                lR[9 + e, a, b] = G[a, b]
            ld[e, a] = -Rp[e, a]
            ld[6 + e, a] = Rp[e, a]
            ld[3 + e, a] = -(Rp[0, a] * cr[0] + Rp[1, a] * cr[1] + Rp[2, a] * cr[2])


@njit(cache=True)
def _hole_lanes(work, i, px, py, lh):
    """Tangent lanes of the next hole (on disk i+1, in frame i) by the 18 pose lanes."""
    Ri = work.rot[i]
    Rn = work.rot[i + 1]
    lh[:, :] = 0.0
    hw = np.empty(3)  # R_{i+1} r, world
    w = np.empty(3)  # p_{i+1} + R_{i+1} r - p_i, world
    for a in range(3):
        hw[a] = Rn[a, 0] * px + Rn[a, 1] * py
        w[a] = work.pos[i + 1, a] + hw[a] - work.pos[i, a]
    cr = np.empty(3)
    for e in range(3):
        ex = np.zeros(3)
        ex[e] = 1.0
        for a in range(3):
            lh[6 + e, a] = -Ri[e, a]
            lh[12 + e, a] = Ri[e, a]
        _cross_into(ex[0], ex[1], ex[2], hw[0], hw[1], hw[2], cr, 0)
        for a in range(3):
            lh[15 + e, a] = Ri[0, a] * cr[0] + Ri[1, a] * cr[1] + Ri[2, a] * cr[2]
        _cross_into(ex[0], ex[1], ex[2], w[0], w[1], w[2], cr, 0)
        for a in range(3):
            lh[9 + e, a] = -(Ri[0, a] * cr[0] + Ri[1, a] * cr[1] + Ri[2, a] * cr[2])


@njit(cache=True)
def _tendons(lam, model, want_jac, work):
    """Tensions piece by piece (friction from the base on) and every tendon's unit load at every disk."""
    n = model.sub.shape[0]
    nt = model.holes.shape[0]
    m = 6 * n
    T, dT, W, dW, S = work.T, work.dT, work.W, work.dW, work.S
    lR = np.zeros((_LANES, 3, 3))
    ld = np.zeros((_LANES, 3))
    lh = np.zeros((_LANES, 3))
    hn = np.zeros(3)
    out = np.empty(7)
    for c in range(nt):
        T[1, c] = lam * model.tension[c]
        if want_jac:
            dT[1, c, :] = 0.0
    for i in range(1, n + 1):
        if want_jac:
            _pose_lanes(work, i, lR, ld)
        for c in range(nt):
            if i > model.anchor[c]:
                W[i, c, :] = 0.0
                T[i + 1, c] = 0.0
                if want_jac:
                    dT[i + 1, c, :] = 0.0
                continue
            is_anchor = i == model.anchor[c]
            px = model.holes[c, 0]
            py = model.holes[c, 1]
            if not is_anchor:
                Rn = work.Rrel[i + 1]
                for a in range(3):
                    hn[a] = Rn[a, 0] * px + Rn[a, 1] * py + work.drel[i + 1, a]
                if want_jac:
                    _hole_lanes(work, i, px, py, lh)
            nl = _LANES if want_jac else 0
            tendon_unit_load_jvp(work.Rrel[i], work.drel[i], hn, lR, ld, lh, nl, px, py, is_anchor, model.fric,
                                 out, dW[i, c])
            for u in range(7):
                W[i, c, u] = out[u]
            rho = out[6]
            T[i + 1, c] = rho * T[i, c] if not is_anchor else 0.0
            if want_jac:
                if is_anchor:
                    dT[i + 1, c, :] = 0.0
                else:
                    Ti = T[i, c]
                    for j in range(m):
                        acc = rho * dT[i, c, j]
                        for L in range(6):
                            acc += Ti * (dW[i, c, 6, L] * S[i - 1, L, j] + dW[i, c, 6, 6 + L] * S[i, L, j]
                                         + dW[i, c, 6, 12 + L] * S[i + 1, L, j])
                        dT[i + 1, c, j] = acc


@njit(cache=True)
def _disk_load(i, lam, model, want_jac, work, load, A):
    """The load on disk i (world, about its centre): ``load`` (6,); with want_jac, its local derivative A (6, 18)
    by the pose lanes (tendon geometry) and, in ``work.dD`` (6, m), the part through the tensions."""
    nt = model.holes.shape[0]
    Rp = work.rot[i - 1]
    d = work.drel[i]
    md = model.sub[i - 1, 3]
    for a in range(3):
        load[a] = lam * (md * model.grav[a] + model.pforce[i - 1, a])
        load[3 + a] = lam * model.pmoment[i - 1, a]
    if want_jac:
        A[:, :] = 0.0
        work.dD[:, :] = 0.0
    Fl = np.empty(3)
    Ml = np.empty(3)
    Fw = np.empty(3)
    Mw = np.empty(3)
    for c in range(nt):
        if i > model.anchor[c]:
            continue
        Tc = work.T[i, c]
        Wc = work.W[i, c]
        # the unit load in frame i-1 about disk i's centre, then in the world frame
        for a in range(3):
            Fl[a] = Wc[a]
        Ml[0] = Wc[3] - (d[1] * Wc[2] - d[2] * Wc[1])
        Ml[1] = Wc[4] - (d[2] * Wc[0] - d[0] * Wc[2])
        Ml[2] = Wc[5] - (d[0] * Wc[1] - d[1] * Wc[0])
        for a in range(3):
            Fw[a] = Rp[a, 0] * Fl[0] + Rp[a, 1] * Fl[1] + Rp[a, 2] * Fl[2]
            Mw[a] = Rp[a, 0] * Ml[0] + Rp[a, 1] * Ml[1] + Rp[a, 2] * Ml[2]
            load[a] += Tc * Fw[a]
            load[3 + a] += Tc * Mw[a]
        if not want_jac:
            continue
        dTc = work.dT[i, c]
        for j in range(dTc.shape[0]):
            g = dTc[j]
            if g != 0.0:
                for a in range(3):
                    work.dD[a, j] += Fw[a] * g
                    work.dD[3 + a, j] += Mw[a] * g
        dWc = work.dW[i, c]
        for L in range(_LANES):
            # the local change of the unit load in frame i-1 (about disk i), rotated to the world
            dfl0, dfl1, dfl2 = dWc[0, L], dWc[1, L], dWc[2, L]
            dd0, dd1, dd2 = 0.0, 0.0, 0.0
            if L < 12:
                dd0, dd1, dd2 = _ddrel(work, i, L)
            dml0 = dWc[3, L] - (dd1 * Fl[2] - dd2 * Fl[1]) - (d[1] * dfl2 - d[2] * dfl1)
            dml1 = dWc[4, L] - (dd2 * Fl[0] - dd0 * Fl[2]) - (d[2] * dfl0 - d[0] * dfl2)
            dml2 = dWc[5, L] - (dd0 * Fl[1] - dd1 * Fl[0]) - (d[0] * dfl1 - d[1] * dfl0)
            for a in range(3):
                dfw = Rp[a, 0] * dfl0 + Rp[a, 1] * dfl1 + Rp[a, 2] * dfl2
                dmw = Rp[a, 0] * dml0 + Rp[a, 1] * dml1 + Rp[a, 2] * dml2
                A[a, L] += Tc * dfw
                A[3 + a, L] += Tc * dmw
            if 3 <= L < 6:  # rotating disk i-1 rotates the frame the load was written in
                e = L - 3
                ex = np.zeros(3)
                ex[e] = 1.0
                cr = np.empty(3)
                _cross_into(ex[0], ex[1], ex[2], Fw[0], Fw[1], Fw[2], cr, 0)
                for a in range(3):
                    A[a, L] += Tc * cr[a]
                _cross_into(ex[0], ex[1], ex[2], Mw[0], Mw[1], Mw[2], cr, 0)
                for a in range(3):
                    A[3 + a, L] += Tc * cr[a]


@njit(cache=True, inline="always")
def _ddrel(work, i, L):
    """The change of d_rel (frame i-1) along pose lane L < 12 (disks i-1 and i)."""
    Rp = work.rot[i - 1]
    if L < 3:
        return -Rp[L, 0], -Rp[L, 1], -Rp[L, 2]
    if L < 6:
        e = L - 3
        dp0 = work.pos[i, 0] - work.pos[i - 1, 0]
        dp1 = work.pos[i, 1] - work.pos[i - 1, 1]
        dp2 = work.pos[i, 2] - work.pos[i - 1, 2]
        if e == 0:
            c0, c1, c2 = 0.0, -dp2, dp1
        elif e == 1:
            c0, c1, c2 = dp2, 0.0, -dp0
        else:
            c0, c1, c2 = -dp1, dp0, 0.0
        return (-(Rp[0, 0] * c0 + Rp[1, 0] * c1 + Rp[2, 0] * c2), -(Rp[0, 1] * c0 + Rp[1, 1] * c1 + Rp[2, 1] * c2),
                -(Rp[0, 2] * c0 + Rp[1, 2] * c1 + Rp[2, 2] * c2))
    if L < 9:
        e = L - 6
        return Rp[e, 0], Rp[e, 1], Rp[e, 2]
    return 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def evaluate(q, lam, model, want_jac, r, J, work):
    """Residual ``r`` (6N,) [N m] and, if ``want_jac``, its Jacobian ``J`` (6N, 6N); every load scaled by ``lam``."""
    sub = model.sub
    n = sub.shape[0]
    m = 6 * n
    _chain(q, lam, model, want_jac, work)
    if want_jac:
        _sensitivities(model, work)
    _tendons(lam, model, want_jac, work)
    load = np.empty(6)
    u = np.empty(6)
    A = np.zeros((6, _LANES))
    G = np.empty((6, m))
    S, E = work.S, work.E
    for i in range(1, n + 1):
        k = 6 * (i - 1)
        ell = sub[i - 1, 0]
        Ri = work.rot[i]
        _disk_load(i, lam, model, want_jac, work, load, A)
        for a in range(6):
            u[a] = work.wend[i, a] - load[a]  # what disk i leaves for the next subsegment, world
        for a in range(3):
            for h in range(2):
                o = 3 * h
                val = Ri[0, a] * u[o] + Ri[1, a] * u[o + 1] + Ri[2, a] * u[o + 2]
                if i < n:
                    val -= q[k + 6 + o + a] / sub[i, 0] if h == 0 else q[k + 6 + o + a]
                r[k + o + a] = ell * val if h == 0 else val
        if not want_jac:
            continue
        # G = d u / d x (world), then rows R_i^T (G + u x dtheta_i)
        for a in range(6):
            for j in range(m):
                acc = E[i, a, j] - work.dD[a, j]
                for L in range(6):
                    acc -= A[a, L] * S[i - 1, L, j] + A[a, 6 + L] * S[i, L, j] + A[a, 12 + L] * S[i + 1, L, j]
                G[a, j] = acc
        for h in range(2):
            o = 3 * h
            u0, u1, u2 = u[o], u[o + 1], u[o + 2]
            scale = ell if h == 0 else 1.0
            for j in range(m):
                t0, t1, t2 = S[i, 3, j], S[i, 4, j], S[i, 5, j]
                g0 = G[o, j] + u1 * t2 - u2 * t1
                g1 = G[o + 1, j] + u2 * t0 - u0 * t2
                g2 = G[o + 2, j] + u0 * t1 - u1 * t0
                for a in range(3):
                    J[k + o + a, j] = scale * (Ri[0, a] * g0 + Ri[1, a] * g1 + Ri[2, a] * g2)
            if i < n:
                for a in range(3):
                    J[k + o + a, k + 6 + o + a] -= scale / sub[i, 0] if h == 0 else scale


@njit(cache=True)
def record_shape(q, model, pos, rot, curve):
    """Disk poses ``pos`` (N+1, 3), ``rot`` (N+1, 3, 3) and backbone points ``curve`` (N nsub + 1, 3) at ``q``."""
    work = make_model_work(model)
    _chain(q, 1.0, model, _NO, work)
    n = model.sub.shape[0]
    nsub = int(model.rod[4])
    ext = model.rod[3] > 0.5
    fw = np.empty(3)
    for a in range(3):
        fw[a] = -model.rod[2] * model.grav[a]
    y = np.empty(18)
    Y = np.zeros((18, 1))
    curve[0, :] = 0.0
    ic = np.int64(1)
    for i in range(1, n + 1):
        _start_state(q, model, i, work.pos, work.rot, y)
        ic = integrate(y, model.sub[i - 1, 0], nsub, _stiffness_inverse(model, i - 1), ext, fw, _NO, Y, curve, ic)
    for i in range(n + 1):
        pos[i, :] = work.pos[i]
        rot[i, :, :] = work.rot[i]



@njit(cache=True)
def wrenches_from_poses(pos, rot, model, q):
    """Base wrenches ``q`` (6N,) that balance every disk at the given poses (N+1, 3), (N+1, 3, 3).

    Each disk's load follows from the poses (tendon chords, friction, weights, point wrenches); the internal
    wrench at the base of subsegment i is then everything beyond it, the backbone's weight taken at the
    chords' midpoints. Exact for the poses of an ``sscr`` equilibrium up to that weight's lever arm; a good
    start from the poses of another model (``pcc2``) of the same robot.
    """
    n = model.sub.shape[0]
    work = make_model_work(model)
    for i in range(n + 1):
        work.pos[i, :] = pos[i]
        work.rot[i, :, :] = rot[i]
    for i in range(1, n + 1):
        Rp = rot[i - 1]
        for a in range(3):
            for b in range(3):
                work.Rrel[i, a, b] = Rp[0, a] * rot[i, 0, b] + Rp[1, a] * rot[i, 1, b] + Rp[2, a] * rot[i, 2, b]
            work.drel[i, a] = (Rp[0, a] * (pos[i, 0] - pos[i - 1, 0]) + Rp[1, a] * (pos[i, 1] - pos[i - 1, 1])
                               + Rp[2, a] * (pos[i, 2] - pos[i - 1, 2]))
    _tendons(1.0, model, _NO, work)
    loads = np.empty((n + 1, 6))
    A = np.zeros((6, _LANES))
    for i in range(1, n + 1):
        _disk_load(i, 1.0, model, _NO, work, loads[i], A)
    F = np.zeros(3)
    M = np.zeros(3)  # about the current point, world
    for i in range(n, 0, -1):
        # move the moment from p_i to p_{i-1}: M <- M + (p_i - p_{i-1}) x F, after adding disk i's load
        for a in range(3):
            F[a] += loads[i, a]
            M[a] += loads[i, 3 + a]
        d0 = pos[i, 0] - pos[i - 1, 0]
        d1 = pos[i, 1] - pos[i - 1, 1]
        d2 = pos[i, 2] - pos[i - 1, 2]
        wb = model.sub[i - 1, 4] * model.grav  # the backbone piece's weight, at the chord's midpoint
        M[0] += d1 * F[2] - d2 * F[1] + 0.5 * (d1 * wb[2] - d2 * wb[1])
        M[1] += d2 * F[0] - d0 * F[2] + 0.5 * (d2 * wb[0] - d0 * wb[2])
        M[2] += d0 * F[1] - d1 * F[0] + 0.5 * (d0 * wb[1] - d1 * wb[0])
        for a in range(3):
            F[a] += wb[a]
        k = 6 * (i - 1)
        ell = model.sub[i - 1, 0]
        Rp = rot[i - 1]
        for a in range(3):
            q[k + a] = ell * (Rp[0, a] * F[0] + Rp[1, a] * F[1] + Rp[2, a] * F[2])
            q[k + 3 + a] = Rp[0, a] * M[0] + Rp[1, a] * M[1] + Rp[2, a] * M[2]


# ------------------------------------------------------------------ stability test and tip gradient, compiled
@njit(cache=True)
def tangent_stiffness(q, model, work, K):
    """The tangent stiffness K (6N, 6N) [N m] of the disks' poses at the equilibrium ``q`` (6N,), into ``K``.

    K = B P^-1 with B = dr/dx the residual's Jacobian, each disk's rows turned to the world (R_i r_i: the
    disk's out-of-balance wrench, force times l_i, moment about its centre, the restoring sign) and P = d pose / dx
    the disks' poses by the unknowns (world; positions divided by l_i, rotation angles): K maps a change of the
    disks' poses (l_i-scaled displacement, rotation) to the restoring wrench it meets, every entry in N m, a
    congruence of the physical stiffness by the positive diagonal of the l_i (which keeps its inertia).

    An inextensible, unshearable rod leaves a straight subsegment's chord unable to change (its axial force a
    Lagrange multiplier, P singular), so the rod is evaluated here with its real axial and shear stiffness
    (EA, GA; ``model.rod``): the poses are then coordinates, and as EA, GA grow the eigenvalues of K split into
    stiff ones of order EA l (positive: the chords) and those of the constrained rod, to which the rest converge
    (MODEL.md, appendix B). With ``shear_extension`` the rod is already so and K is its own.
    """
    n = model.sub.shape[0]
    m = 6 * n
    rod = model.rod.copy()
    rod[3] = 1.0
    ext = SSCRPacked(model.sub, model.holes, model.anchor, model.fric, model.tension, model.grav, model.pforce,
                     model.pmoment, rod)
    r = np.empty(m)
    J = np.empty((m, m))
    evaluate(q, 1.0, ext, _YES, r, J, work)
    B = np.empty((m, m))
    P = np.empty((m, m))
    for i in range(1, n + 1):
        k = 6 * (i - 1)
        Ri = work.rot[i]
        ell = model.sub[i - 1, 0]
        for h in range(2):
            o = k + 3 * h
            for a in range(3):
                for j in range(m):
                    B[o + a, j] = Ri[a, 0] * J[o, j] + Ri[a, 1] * J[o + 1, j] + Ri[a, 2] * J[o + 2, j]
        for a in range(6):
            for j in range(m):
                P[k + a, j] = work.S[i, a, j] / ell if a < 3 else work.S[i, a, j]
    # K P = B  <=>  P^T K^T = B^T
    Kt = np.linalg.solve(P.T.copy(), B.T.copy())
    for a in range(m):
        for j in range(m):
            K[a, j] = Kt[j, a]


@njit(cache=True, nogil=True)
def stiffness_range(q, model, tensions, rows, start, stop, out):
    """For k in ``start <= k < stop``: :func:`tangent_stiffness` at the equilibrium ``q[rows[k]]`` (B, 6N) of
    ``model`` at the actuator tensions ``tensions[rows[k]]`` (B, nt) [N], into ``out[k - start]``."""
    work = make_model_work(model)
    for k in range(start, stop):
        b = rows[k]
        tangent_stiffness(q[b], with_tension(model, tensions[b].copy()), work, out[k - start])


@njit(cache=True)
def tip_jacobian_of(q, model, work):
    """The tip's exact derivative by the unknowns (3, 6N): the chained sensitivity ``work.S[N, :3]`` of the
    evaluation with the Jacobian at ``q`` that ``work`` holds."""
    return np.ascontiguousarray(work.S[model.sub.shape[0], :3, :])

"""Compiled kernels of the PCC kineto-static model (MODEL.md).

Layout of the packed model (built by :class:`pytdcr.statics.pcc.PCCEquations`):

- ``sub``   (N, 5)  per subsegment i: l_i [m], EI [N m^2], GJ [N m^2],
                    disk mass [kg], backbone mass of the piece [kg]
- ``holes`` (nt, 2) tendon hole (x, y) in its disk's frame [m]
- ``anchor`` (nt,)  1-based anchor disk of each tendon
- ``fric``  (4,)    law code (0 none, 1 constant, 2 exponential), mu0,
                    decay [1/rad], mode (+1 pull, -1 release)
- ``tension`` (nt,) actuator tensions [N]
- ``grav``  (3,)    gravity in the base frame [m/s^2]
- ``pforce``, ``pmoment`` (N, 3) point wrench on disk i in the base frame [N, N m]

Unknowns ``q`` (3N,) = (beta_i, gamma_i, eps_i) for i = 1..N.
The residual is written in frame i-1 for subsegment i.

The Jacobian is exact: local derivatives come from the complex step for one
subsegment's transform (no truncation or cancellation error) and from a
hand-derived tangent (forward-mode) kernel for one tendon's load at one disk;
they are chained across disks analytically
(tensions forward, wrenches backward, base-fixed loads through the angular
velocities of the frames), which costs O(N^2) instead of the O(N^2 * tendons)
of a dense forward-mode pass.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...kinematics import frames, subsegment, tip_jacobian
from ...runtime import njit

# No fast-math here (nor in any kernel): numba links a private, separately optimised copy of every kernel these
# call into each cached entry point (pcc's and sscr's solvers, the evaluate kernels), as ELF weak symbols, and a
# process runs whichever copy it loaded first. With fast-math ('contract', 'reassoc') the copies rounded
# differently (other FMA contractions), so a result depended on what the process had solved before; IEEE
# arithmetic makes every copy compute the same bits (tests/test_repeatable.py).

__all__ = ["BALANCE_BASE", "BALANCE_MIDPOINT", "Packed", "Work", "blend", "evaluate", "frames", "largest_angle",
           "make_model_work", "make_work", "subsegment", "tendon_unit_load_jvp", "tip_jacobian_of", "with_tension"]


class Packed(NamedTuple):
    """The packed model (see the module docstring for each array's layout)."""

    sub: np.ndarray
    holes: np.ndarray
    anchor: np.ndarray
    fric: np.ndarray
    tension: np.ndarray
    grav: np.ndarray
    pforce: np.ndarray
    pmoment: np.ndarray
    balance: int  # where each subsegment's moment balance is taken: BALANCE_BASE or BALANCE_MIDPOINT


class Work(NamedTuple):
    """Scratch arrays of :func:`evaluate` (N disks, nt tendons, m = 3N unknowns): O(N nt + m) numbers; the
    Jacobian itself is the caller's (m, m)."""

    R: np.ndarray  # (N+2, 3, 3) subsegment rotations R[i] (index 1..N; N+1 = padding)
    d: np.ndarray  # (N+2, 3) subsegment translations
    pg: np.ndarray  # (N+2, 3) backbone piece centroids
    dR: np.ndarray  # (N+2, 3, 3, 3) dR[i, a]: derivative by q[3(i-1) + a]
    dd: np.ndarray  # (N+2, 3, 3)
    dpg: np.ndarray  # (N+2, 3, 3)
    G: np.ndarray  # (N+1, 3, 3) G[i] = R_{0,i}^T
    omega: np.ndarray  # (3, m) body angular velocity of one frame per unknown (swept base to tip and back)
    T: np.ndarray  # (N+2, nt) tension in piece i of each tendon [N]
    dTl: np.ndarray  # (m,) one tendon's tension in one piece, by every unknown
    W: np.ndarray  # (N+1, nt, 7) unit load (force, moment) and tension ratio at disk i
    dW: np.ndarray  # (N+1, nt, 7, 6) its local derivative
    dF: np.ndarray  # (3, m)
    dM: np.ndarray  # (3, m)
    dL: np.ndarray  # (6, m)


_H = 1e-30  # complex-step size

#: the paper's balance, about each subsegment's base (MODEL.md; first order in the disk spacing)
BALANCE_BASE = 0
#: about the subsegment's midpoint, in the midpoint's cross-section frame (MODEL.md, appendix A; second order)
BALANCE_MIDPOINT = 1


@njit(cache=True, inline="always")
def tendon_unit_load_jvp(R, d, hn, dR, dd, dh, nl, px, py, is_anchor, fric, out, dout):
    """Load of one tendon of unit tension on disk i, in frame i-1, and its derivatives.

    ``R``, ``d``: transform of subsegment i; ``hn``: the hole at disk i+1 in
    frame i (unused at the anchor). Writes ``out[0:3]`` force, ``out[3:6]``
    moment about the origin of frame i-1 and ``out[6]`` the tension ratio
    T_{i+1}/T_i across the disk (0 at the anchor); the deflection angle of the
    paper's friction law is ``atan2(|u_prev x u_next|, -u_prev . u_next)``.

    Lane ``a`` (of ``nl``, 0 for the load alone) moves the subsegment transform by ``dR[a]`` (3, 3), ``dd[a]`` (3,)
    and the next hole by ``dh[a]`` (3,). Writes ``dout[u, a]`` (7, nl). At the
    non-smooth points of the friction law (a straight tendon: zero deflection,
    zero normal force) the derivative of the norm is taken as 0.
    """
    bx = R[0, 0] * px + R[0, 1] * py + d[0]
    by = R[1, 0] * px + R[1, 1] * py + d[1]
    bz = R[2, 0] * px + R[2, 1] * py + d[2]
    v1x = px - bx
    v1y = py - by
    v1z = -bz
    n1 = np.sqrt(v1x * v1x + v1y * v1y + v1z * v1z)
    if not n1 > 0.0:  # two holes at one point (a subsegment folded onto itself): no tendon direction, no answer
        n1 = np.nan
    u1x = v1x / n1
    u1y = v1y / n1
    u1z = v1z / n1
    law = int(fric[0])
    fr = not is_anchor and law != 0 and fric[1] != 0.0
    # primal
    ex = ey = ez = n2 = u2x = u2y = u2z = 0.0
    zx = R[0, 2]
    zy = R[1, 2]
    zz = R[2, 2]
    cs = sn = crx = cry = crz = 0.0
    mu = 0.0
    yx = yy = yz = zy_ = nx = ny = nz = hm = 0.0
    rho = 0.0
    clipped = False
    xx = xy = xz = zx_ = tx = ty = tz = tn = w = 0.0
    if is_anchor:
        fx = u1x
        fy = u1y
        fz = u1z
    else:
        ex = R[0, 0] * hn[0] + R[0, 1] * hn[1] + R[0, 2] * hn[2] + d[0]
        ey = R[1, 0] * hn[0] + R[1, 1] * hn[1] + R[1, 2] * hn[2] + d[1]
        ez = R[2, 0] * hn[0] + R[2, 1] * hn[1] + R[2, 2] * hn[2] + d[2]
        v2x = ex - bx
        v2y = ey - by
        v2z = ez - bz
        n2 = np.sqrt(v2x * v2x + v2y * v2y + v2z * v2z)
        if not n2 > 0.0:
            n2 = np.nan
        u2x = v2x / n2
        u2y = v2y / n2
        u2z = v2z / n2
        yx = u1x + u2x
        yy = u1y + u2y
        yz = u1z + u2z
        zy_ = zx * yx + zy * yy + zz * yz
        if not fr:
            rho = 1.0
            fx = yx - zx * zy_
            fy = yy - zy * zy_
            fz = yz - zz * zy_
        else:
            if law == 1:
                mu = fric[1]
            else:
                cs = -(u1x * u2x + u1y * u2y + u1z * u2z)
                crx = u1y * u2z - u1z * u2y
                cry = u1z * u2x - u1x * u2z
                crz = u1x * u2y - u1y * u2x
                sn = np.sqrt(crx * crx + cry * cry + crz * crz)
                mu = fric[1] * np.exp(-fric[2] * np.arctan2(sn, cs))
            nx = yx - zx * zy_
            ny = yy - zy * zy_
            nz = yz - zz * zy_
            hm = np.sqrt(nx * nx + ny * ny + nz * nz)
            rho = 1.0 - fric[3] * mu * hm
            if rho < 0.0:
                rho = 0.0
                clipped = True
            xx = u1x + rho * u2x
            xy = u1y + rho * u2y
            xz = u1z + rho * u2z
            zx_ = zx * xx + zy * xy + zz * xz
            tx = u1x - u2x
            ty = u1y - u2y
            tz = u1z - u2z
            tn = np.sqrt(tx * tx + ty * ty + tz * tz)
            if not tn * tn > 0.0:  # the tendon turned back on itself: no normal direction, no answer
                tn = np.nan
            w = (1.0 - rho) / tn
            fx = xx - zx * zx_ + w * tx
            fy = xy - zy * zx_ + w * ty
            fz = xz - zz * zx_ + w * tz
    out[0] = fx
    out[1] = fy
    out[2] = fz
    out[3] = by * fz - bz * fy
    out[4] = bz * fx - bx * fz
    out[5] = bx * fy - by * fx
    out[6] = rho
    # tangents
    for a in range(nl):
        A = dR[a]
        dbx = A[0, 0] * px + A[0, 1] * py + dd[a, 0]
        dby = A[1, 0] * px + A[1, 1] * py + dd[a, 1]
        dbz = A[2, 0] * px + A[2, 1] * py + dd[a, 2]
        p1 = (u1x * dbx + u1y * dby + u1z * dbz)
        du1x = (-dbx + u1x * p1) / n1
        du1y = (-dby + u1y * p1) / n1
        du1z = (-dbz + u1z * p1) / n1
        drho = 0.0
        if is_anchor:
            dfx = du1x
            dfy = du1y
            dfz = du1z
        else:
            dex = A[0, 0] * hn[0] + A[0, 1] * hn[1] + A[0, 2] * hn[2] + dd[a, 0]
            dey = A[1, 0] * hn[0] + A[1, 1] * hn[1] + A[1, 2] * hn[2] + dd[a, 1]
            dez = A[2, 0] * hn[0] + A[2, 1] * hn[1] + A[2, 2] * hn[2] + dd[a, 2]
            dex += R[0, 0] * dh[a, 0] + R[0, 1] * dh[a, 1] + R[0, 2] * dh[a, 2]
            dey += R[1, 0] * dh[a, 0] + R[1, 1] * dh[a, 1] + R[1, 2] * dh[a, 2]
            dez += R[2, 0] * dh[a, 0] + R[2, 1] * dh[a, 1] + R[2, 2] * dh[a, 2]
            dvx = dex - dbx
            dvy = dey - dby
            dvz = dez - dbz
            p2 = u2x * dvx + u2y * dvy + u2z * dvz
            du2x = (dvx - u2x * p2) / n2
            du2y = (dvy - u2y * p2) / n2
            du2z = (dvz - u2z * p2) / n2
            dzx = A[0, 2]
            dzy = A[1, 2]
            dzz = A[2, 2]
            dyx = du1x + du2x
            dyy = du1y + du2y
            dyz = du1z + du2z
            dzy_ = dzx * yx + dzy * yy + dzz * yz + zx * dyx + zy * dyy + zz * dyz
            if not fr:
                dfx = dyx - dzx * zy_ - zx * dzy_
                dfy = dyy - dzy * zy_ - zy * dzy_
                dfz = dyz - dzz * zy_ - zz * dzy_
            else:
                dmu = 0.0
                if law == 2:
                    dcs = -(du1x * u2x + du1y * u2y + du1z * u2z + u1x * du2x + u1y * du2y + u1z * du2z)
                    dcrx = du1y * u2z - du1z * u2y + u1y * du2z - u1z * du2y
                    dcry = du1z * u2x - du1x * u2z + u1z * du2x - u1x * du2z
                    dcrz = du1x * u2y - du1y * u2x + u1x * du2y - u1y * du2x
                    dsn = (crx * dcrx + cry * dcry + crz * dcrz) / sn if sn > 0.0 else 0.0
                    dsig = (cs * dsn - sn * dcs) / (cs * cs + sn * sn)
                    dmu = -fric[2] * mu * dsig
                dnx = dyx - dzx * zy_ - zx * dzy_
                dny = dyy - dzy * zy_ - zy * dzy_
                dnz = dyz - dzz * zy_ - zz * dzy_
                dhm = (nx * dnx + ny * dny + nz * dnz) / hm if hm > 0.0 else 0.0
                drho = 0.0 if clipped else -fric[3] * (dmu * hm + mu * dhm)
                dxx = du1x + drho * u2x + rho * du2x
                dxy = du1y + drho * u2y + rho * du2y
                dxz = du1z + drho * u2z + rho * du2z
                dzx_ = dzx * xx + dzy * xy + dzz * xz + zx * dxx + zy * dxy + zz * dxz
                dtx = du1x - du2x
                dty = du1y - du2y
                dtz = du1z - du2z
                dtn = (tx * dtx + ty * dty + tz * dtz) / tn
                dw = (-drho * tn - (1.0 - rho) * dtn) / (tn * tn)
                dfx = dxx - dzx * zx_ - zx * dzx_ + dw * tx + w * dtx
                dfy = dxy - dzy * zx_ - zy * dzx_ + dw * ty + w * dty
                dfz = dxz - dzz * zx_ - zz * dzx_ + dw * tz + w * dtz
        dout[0, a] = dfx
        dout[1, a] = dfy
        dout[2, a] = dfz
        dout[3, a] = dby * fz - dbz * fy + by * dfz - bz * dfy
        dout[4, a] = dbz * fx - dbx * fz + bz * dfx - bx * dfz
        dout[5, a] = dbx * fy - dby * fx + bx * dfy - by * dfx
        dout[6, a] = drho


@njit(cache=True)
def make_work(n, nt):
    """Allocate the scratch arrays of :func:`evaluate` for N = n disks, nt tendons."""
    m = 3 * n
    return Work(
        np.zeros((n + 2, 3, 3)), np.zeros((n + 2, 3)), np.zeros((n + 2, 3)), np.zeros((n + 2, 3, 3, 3)),
        np.zeros((n + 2, 3, 3)), np.zeros((n + 2, 3, 3)), np.zeros((n + 1, 3, 3)), np.zeros((3, m)),
        np.zeros((n + 2, nt)), np.zeros(m), np.zeros((n + 1, nt, 7)), np.zeros((n + 1, nt, 7, 6)),
        np.zeros((3, m)), np.zeros((3, m)), np.zeros((6, m)),
    )


@njit(cache=True, inline="always")
def _tension_lanes(dW, W, c, i, Ti, out):
    """d T_{i,c} / d q for the lanes of subsegments 1..i, into ``out`` (3i,): T_i times the sum of the
    log-derivatives of the tension ratios upstream.

    T_i = T_1 prod_{k<i} rho_k, and rho_k depends on the lanes of subsegments k and k+1 only (``dW[k, c, 6]``),
    so each lane collects at most two terms. A ratio clipped to zero has no derivative and leaves no tension
    beyond it (then T_i = 0 and the caller skips this).
    """
    for s in range(1, i + 1):
        base = 3 * (s - 1)
        for a in range(3):
            acc = 0.0
            if s - 1 >= 1:  # disk s-1's ratio through its next subsegment's lanes
                rho = W[s - 1, c, 6]
                if rho > 0.0:
                    acc += dW[s - 1, c, 6, 3 + a] / rho
            if s < i:  # disk s's ratio through its own lanes
                rho = W[s, c, 6]
                if rho > 0.0:
                    acc += dW[s, c, 6, a] / rho
            out[base + a] = Ti * acc


@njit(cache=True)
def _midpoint_rows(q, k, ell, EI, GJ, nFx, nFy, nFz, nMx, nMy, nMz, dF, dM, want_jac, r, J):
    """Residual rows of one subsegment, balanced about its midpoint (MODEL.md, appendix A), and their Jacobian.

    The distal wrench (nF, nM: frame i-1, about the subsegment's base) is moved to the midpoint of the arc,
    p_m = d(beta, gamma; l/2), and written in the midpoint's cross-section frame
    R_m = Exp((l/2)[-gamma, beta, 0]) Rz(eps/2) (half the bend, half the twist), where the bending moment is
    EI Rz(-eps/2) [-gamma, beta, 0] and the torsion GJ eps/l:

        r = EI Rz(-eps/2) [-gamma, beta, 0] + [0, 0, GJ eps / l] - R_m^T (nM - p_m x nF)

    ``dF``, ``dM`` (3, 3N) hold the derivatives of nF and nM by every unknown; the local derivatives of R_m
    and p_m come from the complex step, like the subsegment's own.
    """
    beta = q[k]
    gamma = q[k + 1]
    eps = q[k + 2]
    Rm = np.empty((3, 3))
    pm = np.empty(3)
    pg = np.empty(3)
    subsegment(beta, gamma, 0.5 * eps, 0.5 * ell, Rm, pm, pg)
    # mu = nM - pm x nF, about the midpoint, frame i-1
    mux = nMx - (pm[1] * nFz - pm[2] * nFy)
    muy = nMy - (pm[2] * nFx - pm[0] * nFz)
    muz = nMz - (pm[0] * nFy - pm[1] * nFx)
    c = np.cos(0.5 * eps)
    s = np.sin(0.5 * eps)
    b0 = EI * (-c * gamma + s * beta)
    b1 = EI * (s * gamma + c * beta)
    tz = GJ * eps / ell
    r[k] = b0 - (Rm[0, 0] * mux + Rm[1, 0] * muy + Rm[2, 0] * muz)
    r[k + 1] = b1 - (Rm[0, 1] * mux + Rm[1, 1] * muy + Rm[2, 1] * muz)
    r[k + 2] = tz - (Rm[0, 2] * mux + Rm[1, 2] * muy + Rm[2, 2] * muz)
    if not want_jac:
        return
    m = dF.shape[1]
    # d(mu)/dq_j through the distal wrench (every lane), then R_m^T of it
    for j in range(m):
        dmx = dM[0, j] - (pm[1] * dF[2, j] - pm[2] * dF[1, j])
        dmy = dM[1, j] - (pm[2] * dF[0, j] - pm[0] * dF[2, j])
        dmz = dM[2, j] - (pm[0] * dF[1, j] - pm[1] * dF[0, j])
        J[k, j] = -(Rm[0, 0] * dmx + Rm[1, 0] * dmy + Rm[2, 0] * dmz)
        J[k + 1, j] = -(Rm[0, 1] * dmx + Rm[1, 1] * dmy + Rm[2, 1] * dmz)
        J[k + 2, j] = -(Rm[0, 2] * dmx + Rm[1, 2] * dmy + Rm[2, 2] * dmz)
    # local lanes: R_m and p_m move with the subsegment's own unknowns (complex step)
    Rc = np.empty((3, 3), dtype=np.complex128)
    pc = np.empty(3, dtype=np.complex128)
    gc = np.empty(3, dtype=np.complex128)
    h = _H
    for a in range(3):
        qb = beta + 0j
        qg = gamma + 0j
        qe = eps + 0j
        if a == 0:
            qb += 1j * h
        elif a == 1:
            qg += 1j * h
        else:
            qe += 1j * h
        subsegment(qb, qg, 0.5 * qe, 0.5 * ell + 0j, Rc, pc, gc)
        dpx = pc[0].imag / h
        dpy = pc[1].imag / h
        dpz = pc[2].imag / h
        # d(mu) from the moving midpoint
        dmx = -(dpy * nFz - dpz * nFy)
        dmy = -(dpz * nFx - dpx * nFz)
        dmz = -(dpx * nFy - dpy * nFx)
        for u in range(3):
            acc = Rm[0, u] * dmx + Rm[1, u] * dmy + Rm[2, u] * dmz
            acc += (Rc[0, u].imag * mux + Rc[1, u].imag * muy + Rc[2, u].imag * muz) / h
            J[k + u, k + a] -= acc
    # the bending and torsion terms
    J[k, k] += EI * s
    J[k, k + 1] += -EI * c
    J[k + 1, k] += EI * c
    J[k + 1, k + 1] += EI * s
    J[k, k + 2] += 0.5 * EI * (s * gamma + c * beta)
    J[k + 1, k + 2] += 0.5 * EI * (c * gamma - s * beta)
    J[k + 2, k + 2] += GJ / ell


@njit(cache=True, nogil=True)
def evaluate(q, lam, model, want_jac, r, J, work):
    """Residual ``r`` (3N,) and, if ``want_jac``, its Jacobian ``J`` (3N, 3N).

    ``lam`` scales every load (tensions, gravity, point wrenches): load stepping.
    """
    sub, holes, anchor, fric = model.sub, model.holes, model.anchor, model.fric
    tension, grav, pforce, pmoment = model.tension, model.grav, model.pforce, model.pmoment
    n = sub.shape[0]
    nt = holes.shape[0]
    m = 3 * n
    Rs, ds, pgs, dRs, dds, dpgs, G, Om = work.R, work.d, work.pg, work.dR, work.dd, work.dpg, work.G, work.omega
    T, W, dW, dF, dM, dL, dTl = work.T, work.W, work.dW, work.dF, work.dM, work.dL, work.dTl
    Rc = np.empty((3, 3), dtype=np.complex128)
    dc = np.empty(3, dtype=np.complex128)
    pgc = np.empty(3, dtype=np.complex128)
    lR = np.zeros((6, 3, 3))
    ld = np.zeros((6, 3))
    lh = np.zeros((6, 3))
    hn = np.zeros(3)
    out = np.empty(7)
    h = _H

    # ---- subsegment transforms (and their derivatives by complex step)
    for i in range(1, n + 1):
        k = 3 * (i - 1)
        subsegment(q[k], q[k + 1], q[k + 2], sub[i - 1, 0], Rs[i], ds[i], pgs[i])
        if want_jac:
            for a in range(3):
                qc0 = q[k] + 0j
                qc1 = q[k + 1] + 0j
                qc2 = q[k + 2] + 0j
                if a == 0:
                    qc0 += 1j * h
                elif a == 1:
                    qc1 += 1j * h
                else:
                    qc2 += 1j * h
                subsegment(qc0, qc1, qc2, sub[i - 1, 0] + 0j, Rc, dc, pgc)
                for u in range(3):
                    for v in range(3):
                        dRs[i, a, u, v] = Rc[u, v].imag / h
                    dds[i, a, u] = dc[u].imag / h
                    dpgs[i, a, u] = pgc[u].imag / h

    # ---- base-to-frame rotations and angular velocities per lane
    for u in range(3):
        for v in range(3):
            G[0, u, v] = 1.0 if u == v else 0.0
    for i in range(1, n + 1):
        R = Rs[i]
        for u in range(3):
            for v in range(3):
                G[i, u, v] = R[0, u] * G[i - 1, 0, v] + R[1, u] * G[i - 1, 1, v] + R[2, u] * G[i - 1, 2, v]
        if want_jac:  # Om holds frame i-1's angular velocities per lane; it becomes frame i's
            k = 3 * (i - 1)
            for j in range(k):
                o0 = Om[0, j]
                o1 = Om[1, j]
                o2 = Om[2, j]
                Om[0, j] = R[0, 0] * o0 + R[1, 0] * o1 + R[2, 0] * o2
                Om[1, j] = R[0, 1] * o0 + R[1, 1] * o1 + R[2, 1] * o2
                Om[2, j] = R[0, 2] * o0 + R[1, 2] * o1 + R[2, 2] * o2
            for a in range(3):
                # vee(R^T dR)
                dRa = dRs[i, a]
                s21 = R[0, 2] * dRa[0, 1] + R[1, 2] * dRa[1, 1] + R[2, 2] * dRa[2, 1]
                s02 = R[0, 0] * dRa[0, 2] + R[1, 0] * dRa[1, 2] + R[2, 0] * dRa[2, 2]
                s10 = R[0, 1] * dRa[0, 0] + R[1, 1] * dRa[1, 0] + R[2, 1] * dRa[2, 0]
                Om[0, k + a] = s21
                Om[1, k + a] = s02
                Om[2, k + a] = s10
            for j in range(k + 3, m):
                Om[0, j] = 0.0
                Om[1, j] = 0.0
                Om[2, j] = 0.0

    # ---- tendons, base to tip: unit loads, tension ratios, tensions
    for c in range(nt):
        T[1, c] = lam * tension[c]
    for i in range(1, n + 1):
        k = 3 * (i - 1)
        if want_jac:  # tangent lanes 0-2 move subsegment i, lanes 3-5 the hole on disk i+1
            for a in range(3):
                for u in range(3):
                    for v in range(3):
                        lR[a, u, v] = dRs[i, a, u, v]
                    ld[a, u] = dds[i, a, u]
        for c in range(nt):
            anc = anchor[c]
            if i > anc:
                W[i, c, :] = 0.0
                T[i + 1, c] = 0.0
                if want_jac:
                    dW[i, c, :, :] = 0.0
                continue
            is_anchor = i == anc
            px = holes[c, 0]
            py = holes[c, 1]
            if not is_anchor:
                Rn = Rs[i + 1]
                dn = ds[i + 1]
                for u in range(3):
                    hn[u] = Rn[u, 0] * px + Rn[u, 1] * py + dn[u]
            if want_jac:
                nl = 3 if is_anchor else 6
                if not is_anchor:
                    for a in range(3):
                        for u in range(3):
                            lh[a + 3, u] = dRs[i + 1, a, u, 0] * px + dRs[i + 1, a, u, 1] * py + dds[i + 1, a, u]
                tendon_unit_load_jvp(Rs[i], ds[i], hn, lR, ld, lh, nl, px, py, is_anchor, fric, out, dW[i, c])
                for a in range(nl, 6):
                    for u in range(7):
                        dW[i, c, u, a] = 0.0
            else:  # the same kernel with no tangent lanes: the load alone
                tendon_unit_load_jvp(Rs[i], ds[i], hn, lR, ld, lh, 0, px, py, is_anchor, fric, out, dW[i, c])
            for u in range(7):
                W[i, c, u] = out[u]
            rho = out[6]
            T[i + 1, c] = rho * T[i, c] if not is_anchor else 0.0

    # ---- wrenches, tip to base
    Fx = 0.0
    Fy = 0.0
    Fz = 0.0
    Mx = 0.0
    My = 0.0
    Mz = 0.0
    if want_jac:
        dF[:, :] = 0.0
        dM[:, :] = 0.0
    for i in range(n, 0, -1):
        k = 3 * (i - 1)
        R = Rs[i]
        d = ds[i]
        pg = pgs[i]
        ell = sub[i - 1, 0]
        md = sub[i - 1, 3]
        mb = sub[i - 1, 4]
        Gp = G[i - 1]
        # base-fixed loads in frame i-1
        glx = lam * (Gp[0, 0] * grav[0] + Gp[0, 1] * grav[1] + Gp[0, 2] * grav[2])
        gly = lam * (Gp[1, 0] * grav[0] + Gp[1, 1] * grav[1] + Gp[1, 2] * grav[2])
        glz = lam * (Gp[2, 0] * grav[0] + Gp[2, 1] * grav[1] + Gp[2, 2] * grav[2])
        pfx = lam * (Gp[0, 0] * pforce[i - 1, 0] + Gp[0, 1] * pforce[i - 1, 1] + Gp[0, 2] * pforce[i - 1, 2])
        pfy = lam * (Gp[1, 0] * pforce[i - 1, 0] + Gp[1, 1] * pforce[i - 1, 1] + Gp[1, 2] * pforce[i - 1, 2])
        pfz = lam * (Gp[2, 0] * pforce[i - 1, 0] + Gp[2, 1] * pforce[i - 1, 1] + Gp[2, 2] * pforce[i - 1, 2])
        pmx = lam * (Gp[0, 0] * pmoment[i - 1, 0] + Gp[0, 1] * pmoment[i - 1, 1] + Gp[0, 2] * pmoment[i - 1, 2])
        pmy = lam * (Gp[1, 0] * pmoment[i - 1, 0] + Gp[1, 1] * pmoment[i - 1, 1] + Gp[1, 2] * pmoment[i - 1, 2])
        pmz = lam * (Gp[2, 0] * pmoment[i - 1, 0] + Gp[2, 1] * pmoment[i - 1, 1] + Gp[2, 2] * pmoment[i - 1, 2])
        mass = md + mb
        cmx = md * d[0] + mb * pg[0]
        cmy = md * d[1] + mb * pg[1]
        cmz = md * d[2] + mb * pg[2]
        LFx = mass * glx + pfx
        LFy = mass * gly + pfy
        LFz = mass * glz + pfz
        LMx = cmy * glz - cmz * gly + d[1] * pfz - d[2] * pfy + pmx
        LMy = cmz * glx - cmx * glz + d[2] * pfx - d[0] * pfz + pmy
        LMz = cmx * gly - cmy * glx + d[0] * pfy - d[1] * pfx + pmz
        for c in range(nt):
            if i <= anchor[c]:
                Tc = T[i, c]
                LFx += Tc * W[i, c, 0]
                LFy += Tc * W[i, c, 1]
                LFz += Tc * W[i, c, 2]
                LMx += Tc * W[i, c, 3]
                LMy += Tc * W[i, c, 4]
                LMz += Tc * W[i, c, 5]
        # propagate F_{i+1}, M_{i+1} (frame i) into frame i-1
        RFx = R[0, 0] * Fx + R[0, 1] * Fy + R[0, 2] * Fz
        RFy = R[1, 0] * Fx + R[1, 1] * Fy + R[1, 2] * Fz
        RFz = R[2, 0] * Fx + R[2, 1] * Fy + R[2, 2] * Fz
        RMx = R[0, 0] * Mx + R[0, 1] * My + R[0, 2] * Mz
        RMy = R[1, 0] * Mx + R[1, 1] * My + R[1, 2] * Mz
        RMz = R[2, 0] * Mx + R[2, 1] * My + R[2, 2] * Mz
        nFx = LFx + RFx
        nFy = LFy + RFy
        nFz = LFz + RFz
        nMx = LMx + RMx + d[1] * RFz - d[2] * RFy
        nMy = LMy + RMy + d[2] * RFx - d[0] * RFz
        nMz = LMz + RMz + d[0] * RFy - d[1] * RFx
        # residual
        EI = sub[i - 1, 1]
        tau = sub[i - 1, 2] * q[k + 2] / ell
        if model.balance == BALANCE_BASE:
            r[k] = -EI * q[k + 1] + R[0, 2] * tau - nMx
            r[k + 1] = EI * q[k] + R[1, 2] * tau - nMy
            r[k + 2] = R[2, 2] * tau - nMz

        if want_jac:
            dL[:, :] = 0.0
            # Om: frame i's angular velocities per lane -> frame i-1's (lanes of subsegment i drop out)
            for j in range(k):
                o0 = Om[0, j]
                o1 = Om[1, j]
                o2 = Om[2, j]
                Om[0, j] = R[0, 0] * o0 + R[0, 1] * o1 + R[0, 2] * o2
                Om[1, j] = R[1, 0] * o0 + R[1, 1] * o1 + R[1, 2] * o2
                Om[2, j] = R[2, 0] * o0 + R[2, 1] * o1 + R[2, 2] * o2
            for j in range(k, k + 3):
                Om[0, j] = 0.0
                Om[1, j] = 0.0
                Om[2, j] = 0.0
            # tendons: through tensions (all upstream lanes) and local geometry
            for c in range(nt):
                if i <= anchor[c]:
                    Tc = T[i, c]
                    if Tc != 0.0:
                        _tension_lanes(dW, W, c, i, Tc, dTl)
                        for u in range(6):
                            wu = W[i, c, u]
                            for j in range(k + 3):
                                dL[u, j] += wu * dTl[j]
                    la = 6 if k + 6 <= m else 3
                    for a in range(la):
                        for u in range(6):
                            dL[u, k + a] += Tc * dW[i, c, u, a]
            # base-fixed loads: upstream lanes rotate them, local lanes move the points
            for j in range(k):
                ox = Om[0, j]
                oy = Om[1, j]
                oz = Om[2, j]
                # d(v) = v x omega for each base-fixed vector v in frame i-1
                dgx = gly * oz - glz * oy
                dgy = glz * ox - glx * oz
                dgz = glx * oy - gly * ox
                dfx = pfy * oz - pfz * oy
                dfy = pfz * ox - pfx * oz
                dfz = pfx * oy - pfy * ox
                dmx = pmy * oz - pmz * oy
                dmy = pmz * ox - pmx * oz
                dmz = pmx * oy - pmy * ox
                dL[0, j] += mass * dgx + dfx
                dL[1, j] += mass * dgy + dfy
                dL[2, j] += mass * dgz + dfz
                dL[3, j] += cmy * dgz - cmz * dgy + d[1] * dfz - d[2] * dfy + dmx
                dL[4, j] += cmz * dgx - cmx * dgz + d[2] * dfx - d[0] * dfz + dmy
                dL[5, j] += cmx * dgy - cmy * dgx + d[0] * dfy - d[1] * dfx + dmz
            for a in range(3):
                ddx = dds[i, a, 0]
                ddy = dds[i, a, 1]
                ddz = dds[i, a, 2]
                dcx = md * ddx + mb * dpgs[i, a, 0]
                dcy = md * ddy + mb * dpgs[i, a, 1]
                dcz = md * ddz + mb * dpgs[i, a, 2]
                dL[3, k + a] += dcy * glz - dcz * gly + ddy * pfz - ddz * pfy
                dL[4, k + a] += dcz * glx - dcx * glz + ddz * pfx - ddx * pfz
                dL[5, k + a] += dcx * gly - dcy * glx + ddx * pfy - ddy * pfx
            # dF_i, dM_i from dF_{i+1}, dM_{i+1} (in place, lane by lane)
            for j in range(m):
                ax = dF[0, j]
                ay = dF[1, j]
                az = dF[2, j]
                bx_ = dM[0, j]
                by_ = dM[1, j]
                bz_ = dM[2, j]
                rfx = R[0, 0] * ax + R[0, 1] * ay + R[0, 2] * az
                rfy = R[1, 0] * ax + R[1, 1] * ay + R[1, 2] * az
                rfz = R[2, 0] * ax + R[2, 1] * ay + R[2, 2] * az
                rmx = R[0, 0] * bx_ + R[0, 1] * by_ + R[0, 2] * bz_
                rmy = R[1, 0] * bx_ + R[1, 1] * by_ + R[1, 2] * bz_
                rmz = R[2, 0] * bx_ + R[2, 1] * by_ + R[2, 2] * bz_
                dF[0, j] = dL[0, j] + rfx
                dF[1, j] = dL[1, j] + rfy
                dF[2, j] = dL[2, j] + rfz
                dM[0, j] = dL[3, j] + rmx + d[1] * rfz - d[2] * rfy
                dM[1, j] = dL[4, j] + rmy + d[2] * rfx - d[0] * rfz
                dM[2, j] = dL[5, j] + rmz + d[0] * rfy - d[1] * rfx
            for a in range(3):
                dRa = dRs[i, a]
                ddx = dds[i, a, 0]
                ddy = dds[i, a, 1]
                ddz = dds[i, a, 2]
                gfx = dRa[0, 0] * Fx + dRa[0, 1] * Fy + dRa[0, 2] * Fz
                gfy = dRa[1, 0] * Fx + dRa[1, 1] * Fy + dRa[1, 2] * Fz
                gfz = dRa[2, 0] * Fx + dRa[2, 1] * Fy + dRa[2, 2] * Fz
                gmx = dRa[0, 0] * Mx + dRa[0, 1] * My + dRa[0, 2] * Mz
                gmy = dRa[1, 0] * Mx + dRa[1, 1] * My + dRa[1, 2] * Mz
                gmz = dRa[2, 0] * Mx + dRa[2, 1] * My + dRa[2, 2] * Mz
                dF[0, k + a] += gfx
                dF[1, k + a] += gfy
                dF[2, k + a] += gfz
                dM[0, k + a] += gmx + ddy * RFz - ddz * RFy + d[1] * gfz - d[2] * gfy
                dM[1, k + a] += gmy + ddz * RFx - ddx * RFz + d[2] * gfx - d[0] * gfz
                dM[2, k + a] += gmz + ddx * RFy - ddy * RFx + d[0] * gfy - d[1] * gfx
            if model.balance == BALANCE_BASE:
                # Jacobian rows of subsegment i
                for j in range(m):
                    J[k, j] = -dM[0, j]
                    J[k + 1, j] = -dM[1, j]
                    J[k + 2, j] = -dM[2, j]
                GJl = sub[i - 1, 2] / ell
                for a in range(3):
                    for u in range(3):
                        J[k + u, k + a] += dRs[i, a, u, 2] * tau
                J[k, k + 1] += -EI
                J[k + 1, k] += EI
                for u in range(3):
                    J[k + u, k + 2] += R[u, 2] * GJl
        if model.balance == BALANCE_MIDPOINT:
            _midpoint_rows(q, k, ell, EI, sub[i - 1, 2], nFx, nFy, nFz, nMx, nMy, nMz, dF, dM, want_jac, r, J)
        Fx = nFx
        Fy = nFy
        Fz = nFz
        Mx = nMx
        My = nMy
        Mz = nMz




@njit(cache=True)
def make_model_work(model):
    """Scratch arrays for ``model``."""
    return make_work(model.sub.shape[0], model.holes.shape[0])


@njit(cache=True)
def tip_jacobian_of(q, model, work):
    """The tip's exact derivative by the unknowns (3, 3N) at ``q`` (:func:`pytdcr.kinematics.tip_jacobian`)."""
    return tip_jacobian(q, model.sub)


@njit(cache=True)
def largest_angle(dq, model):
    """Largest change of bend angle or twist of one subsegment for a change ``dq`` (3N,) of the unknowns [rad]."""
    sub = model.sub
    big = 0.0
    for i in range(sub.shape[0]):
        dth = np.sqrt(dq[3 * i] ** 2 + dq[3 * i + 1] ** 2) * sub[i, 0]
        big = max(big, dth, abs(dq[3 * i + 2]))
    return big


@njit(cache=True)
def with_tension(m, tension):
    """The packed model with other actuator tensions (nt,) [N]."""
    return Packed(m.sub, m.holes, m.anchor, m.fric, tension, m.grav, m.pforce, m.pmoment, m.balance)


@njit(cache=True)
def blend(ma, mb, s):
    """The packed model ``mb`` under the loads ``(1 - s) ma + s mb``: actuator tensions, gravity and point wrenches
    (both the same robot). Exactly ``ma`` at s = 0 and ``mb`` at s = 1; the equations are affine in the loads,
    so the residual is too."""
    if s == 1.0:
        return mb
    if s == 0.0:
        return ma
    return Packed(mb.sub, mb.holes, mb.anchor, mb.fric, ma.tension + s * (mb.tension - ma.tension),
                  ma.grav + s * (mb.grav - ma.grav), ma.pforce + s * (mb.pforce - ma.pforce),
                  ma.pmoment + s * (mb.pmoment - ma.pmoment), mb.balance)

"""The solver every PCC-family model shares, compiled once per packed-model type.

Quasi-Newton with an exact Jacobian along the loading path (:func:`solve_one`),
for any packed model for which the four functions below are overloaded:
``model_evaluate`` (residual and Jacobian), ``model_work`` (scratch arrays),
``model_angle`` (how far a change of the unknowns bends or twists a
subsegment, for step control) and ``model_with_tension``. The solver always
takes the path of the loads, a :class:`Homotopy` of two packed models, so that
numba compiles one specialisation of it per packed type (the PCC models'
``Packed``, the subsegment Cosserat rod's ``SSCRPacked``) for a solve and a
continuation alike; the model's branch is chosen when compiling, not when
running.

Unknowns ``q`` and residual ``r`` have the model's own layout.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.extending import overload

from ...runtime import njit
from ..options import (
    FOLD_ARCLENGTH,
    FOLD_RELAX,
    FOLD_STOP,
    PATH_CONTINUED,
    PATH_DIRECT,
    PATH_FALLBACK,
    PATH_FOLD,
    PATH_LOADING,
    PATH_SNAP,
    STEP_CONTINUE,
)

__all__ = ["FOLD_ARCLENGTH", "FOLD_RELAX", "FOLD_STOP", "Homotopy", "Outcome", "Settings", "arclength",
           "model_angle", "model_evaluate", "model_with_tension", "model_work", "newton", "relax",
           "snap_through", "solve_one", "solve_range"]

_STALL = 15  # Newton gives up after this many iterations without halving the residual
_MAX_DLAM = 0.25  # largest load step
_STEP_TARGET = 0.05  # [rad] bend/twist change of a subsegment that a load step aims at
_MAX_STEP_CHANGE = 0.1  # [rad] largest bend/twist change of a subsegment in one load step (else: a branch jump)
_ARC_STEPS = 300  # pseudo-arclength steps allowed through a fold
# NumPy scalars where a constant is passed to a compiled function: numba types a Python int or bool argument as
# a literal and compiles the callee once per value (tests/test_kernel_signatures.py)
_STEP_JACOBIANS = np.int64(2)  # exact Jacobians a load step may take before it is halved instead (a fold is near)
_UNLIMITED = np.int64(1 << 30)
_FRESH = np.bool_(False)  # newton's ``reuse``: start from the exact Jacobian
_WALKS = 3  # loading paths walked at most, each with load steps four times finer than the last
_RAMP = np.bool_(True)  # Homotopy.ramp of a solve
_BLEND = np.bool_(False)  # Homotopy.ramp of a continuation



class Settings(NamedTuple):
    """Solver settings: tolerance [N m], Newton iterations, step limit [rad], load-stepping code, iterations per
    load step, what to do at a fold, tolerance of intermediate load steps [N m] (they only track the branch).

    :func:`solve_range` replaces both tolerances by each case's own (:mod:`pytdcr.statics.tolerance`)."""

    atol: float
    max_iter: int
    max_dtheta: float
    stepping: int
    step_iter: int  # Newton iterations allowed per load step
    fold: int  # at a fold of the loading path: FOLD_RELAX, FOLD_ARCLENGTH or FOLD_STOP
    step_atol: float
    step_scale: float  # scales the loading path's step target and largest step




class Outcome(NamedTuple):
    """What :func:`solve_one` returns."""

    q: np.ndarray  # (3N,) the unknowns reached
    converged: bool
    residual: float  # max |residual| [N m]
    iterations: int  # Newton iterations in all
    jacobians: int  # exact Jacobian evaluations
    load_steps: int
    path: int  # a PATH_* code




class Homotopy(NamedTuple):
    """The path of the loads the solver follows as its load factor ``lam`` goes from 0 to 1; the one type its
    compiled code is specialised for, so that a solve and a continuation share one compiled solver.

    With ``ramp`` (a solve: ``start`` is ``end``), every load of ``end`` is scaled by ``lam``: the loading path from
    the unloaded robot. Without (a continuation), ``start`` (lam = 0) and ``end`` (lam = 1) are two packed models of
    one robot under two sets of loads, and the loads move along the straight path between them (the kernel
    module's ``blend``): continuation from an equilibrium of ``start`` follows its branch to ``end``."""

    start: object
    end: object
    ramp: bool


# ------------------------------------------------------------------ dispatch on the packed model's type
#: packed-model type -> the kernel module that implements it; filled by the registry
#: (:func:`pytdcr.statics.registry.register`) from each compiled model's ``kernels``
KERNELS: dict = {}


def register_kernels(packed_type, module) -> None:
    """Let the solver solve models packed as ``packed_type`` with ``module``'s ``evaluate``, ``make_model_work``,
    ``largest_angle`` and ``with_tension`` (and differentiate their tips with ``tip_jacobian_of``)."""
    KERNELS[packed_type] = module


def _module_for(model):
    cls = getattr(model, "instance_class", None)
    return KERNELS.get(cls)


def _homotopy_module(model):
    """The kernel module of a :class:`Homotopy`'s packed models (None for any other type)."""
    if getattr(model, "instance_class", None) is not Homotopy:
        return None
    return _module_for(model.types[1])


def model_evaluate(q, lam, model, want_jac, r, J, work):  # pragma: no cover - compiled code only
    """Residual ``r`` and, if ``want_jac``, its Jacobian ``J`` at load factor ``lam``."""
    raise NotImplementedError


def model_work(model):  # pragma: no cover - compiled code only
    """Scratch arrays of ``model_evaluate``."""
    raise NotImplementedError


def model_angle(dq, model):  # pragma: no cover - compiled code only
    """Largest bend or twist of a subsegment that the change ``dq`` of the unknowns makes [rad]."""
    raise NotImplementedError


def model_with_tension(model, tension):  # pragma: no cover - compiled code only
    """The packed model with other actuator tensions."""
    raise NotImplementedError


def model_tip_jacobian(q, model, work):  # pragma: no cover - compiled code only
    """The tip position's exact derivative by the unknowns (3, m) at ``q``, ``work`` holding the evaluation with
    the Jacobian there."""
    raise NotImplementedError


def model_rest(model):  # pragma: no cover - compiled code only
    """A packed model whose evaluation at load factor 0 is the unloaded robot (a :class:`Homotopy`'s start)."""
    raise NotImplementedError


@overload(model_evaluate)
def _evaluate_impl(q, lam, model, want_jac, r, J, work):
    mod = _module_for(model)
    if mod is not None:
        kernel = mod.evaluate
        return lambda q, lam, model, want_jac, r, J, work: kernel(q, lam, model, want_jac, r, J, work)
    mod = _homotopy_module(model)
    if mod is not None:
        kernel, blend = mod.evaluate, mod.blend

        def impl(q, lam, model, want_jac, r, J, work):
            if model.ramp:  # every load scaled by lam
                kernel(q, lam, model.end, want_jac, r, J, work)
            else:  # every load at its blend: the load factor moves along the path, not from zero
                kernel(q, 1.0, blend(model.start, model.end, lam), want_jac, r, J, work)

        return impl
    return None


@overload(model_work)
def _work_impl(model):
    mod = _module_for(model)
    if mod is not None:
        kernel = mod.make_model_work
        return lambda model: kernel(model)
    mod = _homotopy_module(model)
    if mod is not None:
        kernel = mod.make_model_work
        return lambda model: kernel(model.end)
    return None


@overload(model_angle)
def _angle_impl(dq, model):
    mod = _module_for(model)
    if mod is not None:
        kernel = mod.largest_angle
        return lambda dq, model: kernel(dq, model)
    mod = _homotopy_module(model)
    if mod is not None:
        kernel = mod.largest_angle
        return lambda dq, model: kernel(dq, model.end)
    return None


@overload(model_with_tension)
def _tension_impl(model, tension):
    mod = _module_for(model)
    if mod is not None:
        kernel = mod.with_tension
        return lambda model, tension: kernel(model, tension)
    return None


@overload(model_tip_jacobian)
def _tip_jacobian_impl(q, model, work):
    mod = _module_for(model)
    if mod is not None:
        kernel = mod.tip_jacobian_of
        return lambda q, model, work: kernel(q, model, work)
    return None


@overload(model_rest)
def _rest_impl(model):
    if _module_for(model) is not None:
        return lambda model: model
    if _homotopy_module(model) is not None:
        return lambda model: model.start
    return None


@njit(cache=True, inline="always")
def _maxabs(r):
    s = 0.0
    for x in r:
        ax = abs(x)
        if not ax <= s:  # also catches NaN
            s = ax if ax == ax else np.inf
    return s


@njit(cache=True, inline="always")
def _sumsq(r):
    s = 0.0
    for x in r:
        s += x * x
    return s


@njit(cache=True)
def _step_scale(dx, m, max_dtheta):
    """Largest factor <= 1 keeping every subsegment's bend and twist change <= max_dtheta."""
    big = model_angle(dx, m)
    if big > max_dtheta:
        return max_dtheta / big
    return 1.0


@njit(cache=True, inline="always")
def _matvec(A, x, out):
    """``out = A @ x`` (in place; no temporaries)."""
    n = x.shape[0]
    for u in range(A.shape[0]):
        acc = 0.0
        for v in range(n):
            acc += A[u, v] * x[v]
        out[u] = acc


@njit(cache=True, inline="always")
def _broyden(H, q, qt, rt, hr, hrt, hy, sh, s):
    """Broyden's ("good") rank-one update of the inverse Jacobian ``H`` (in place) for the step from ``q`` to
    ``qt`` whose residual is ``rt``, with ``hr`` = H r at ``q`` on entry; on return ``hr`` = H rt for the updated H
    (the next step's direction, without another product). ``hrt``, ``hy``, ``sh``, ``s``: scratch (m,)."""
    nq = q.shape[0]
    _matvec(H, rt, hrt)
    shy = 0.0
    for u in range(nq):
        s[u] = qt[u] - q[u]
        hy[u] = hrt[u] - hr[u]  # H y, y = rt - r
        shy += s[u] * hy[u]
    if not abs(shy) > 1e-300:
        hr[:] = hrt
        return
    for v in range(nq):
        sh[v] = 0.0
    for u in range(nq):
        su = s[u]
        for v in range(nq):
            sh[v] += su * H[u, v]
    c = 0.0
    for v in range(nq):
        c += sh[v] * rt[v]
    for u in range(nq):
        w = (s[u] - hy[u]) / shy
        for v in range(nq):
            H[u, v] += w * sh[v]
        hr[u] = hrt[u] + w * c


@njit(cache=True)
def newton(q, lam, m, atol, max_iter, max_dtheta, work, H, reuse, max_jac):
    """Quasi-Newton iteration from ``q`` (modified in place) at load factor ``lam``.

    ``H`` (3N, 3N) holds the inverse Jacobian: computed from the exact
    Jacobian unless ``reuse`` (then the caller's ``H``, e.g. from the last load
    step, is the start), and left updated on return. Later steps update the inverse with
    Broyden's rank-one formula and the exact Jacobian is recomputed only when a
    step stops making good progress. Steps are scaled so that no subsegment's
    bend angle or twist changes by more than ``max_dtheta`` [rad] and
    backtracked on ||r||^2. Where the Newton direction fails on a fresh
    Jacobian (near a fold), Levenberg-Marquardt steps take over. A load step
    passes a small ``max_jac``: where it would need more exact Jacobians than
    that (a fold is near, and Newton crawls), it fails and the caller halves
    the step, instead of forcing its way through many more.
    Returns ``(converged, max|r|, iterations, jacobian evaluations)``.
    """
    nq = q.shape[0]
    r = np.empty(nq)
    rt = np.empty(nq)
    J = np.empty((nq, nq))
    qt = np.empty(nq)
    hr = np.empty(nq)  # H r for the current r (kept up to date through each Broyden update)
    hrt = np.empty(nq)
    hy = np.empty(nq)
    sh = np.empty(nq)
    s = np.empty(nq)
    dx = np.empty(nq)
    have_hr = False
    if reuse:
        model_evaluate(q, lam, m, False, r, J, work)
        njac = 0
        fresh = False
    else:
        model_evaluate(q, lam, m, True, r, J, work)
        njac = 1
        fresh = True
        try:
            H[:, :] = np.linalg.inv(J)
        except Exception:
            H[:, :] = 0.0
    res = _maxabs(r)
    it = 0
    best = res
    since = 0
    while it < max_iter:
        if res <= atol:
            return True, res, it, njac
        if not np.isfinite(res):
            return False, res, it, njac
        # give up on stagnation: no halving of the residual in _STALL iterations
        if res < 0.5 * best:
            best = res
            since = 0
        else:
            since += 1
            if since > _STALL:
                return False, res, it, njac
        it += 1
        if not have_hr:
            _matvec(H, r, hr)
            have_hr = True
        for u in range(nq):
            dx[u] = -hr[u]
        alpha = _step_scale(dx, m, max_dtheta)
        f0 = _sumsq(r)
        accepted = False
        nls = 8 if not fresh else 12
        for _ls in range(nls):
            for u in range(nq):
                qt[u] = q[u] + alpha * dx[u]
            model_evaluate(qt, lam, m, False, rt, J, work)
            f1 = _sumsq(rt)
            if f1 <= (1.0 - 1e-4 * alpha) * f0:
                accepted = True
                break
            alpha *= 0.5
        if not accepted and fresh:
            # Levenberg-Marquardt on the exact Jacobian (robust where J is near singular)
            A = J.T @ J
            g = J.T @ r
            mu = 1e-5
            dmax = 0.0
            for u in range(nq):
                if A[u, u] > dmax:
                    dmax = A[u, u]
            for _lm in range(8):
                B = A.copy()
                for u in range(nq):
                    B[u, u] += mu * dmax
                try:
                    dx[:] = -np.linalg.solve(B, g)
                except Exception:
                    mu *= 10.0
                    continue
                alpha = _step_scale(dx, m, max_dtheta)
                for u in range(nq):
                    qt[u] = q[u] + alpha * dx[u]
                model_evaluate(qt, lam, m, False, rt, J, work)
                f1 = _sumsq(rt)
                if f1 < f0:
                    accepted = True
                    break
                mu *= 10.0
            if not accepted:
                return False, res, it, njac
        if not accepted:
            # stale Broyden inverse: recompute the exact Jacobian here and retry
            if njac >= max_jac:
                return False, res, it, njac
            model_evaluate(q, lam, m, True, r, J, work)
            njac += 1
            fresh = True
            have_hr = False
            try:
                H[:, :] = np.linalg.inv(J)
            except Exception:
                H[:, :] = 0.0
            continue
        _broyden(H, q, qt, rt, hr, hrt, hy, sh, s)
        for u in range(nq):
            q[u] = qt[u]
            r[u] = rt[u]
        res = _maxabs(r)
        fresh = False
        if f1 > 0.25 * f0 and res > atol:
            if njac >= max_jac:
                return False, res, it, njac
            model_evaluate(q, lam, m, True, r, J, work)
            njac += 1
            fresh = True
            have_hr = False
            try:
                H[:, :] = np.linalg.inv(J)
            except Exception:
                H[:, :] = 0.0
    return res <= atol, res, it, njac


@njit(cache=True)
def relax(q, lam, m, atol, max_iter, max_dtheta, work):
    """Pseudo-transient continuation from ``q`` (in place): implicit Euler on dq/dt = -D^-1 r.

    Used where Newton fails at a fold: the pseudo-time flow follows the
    snap-through to a neighbouring stable equilibrium; the time step grows as
    the residual falls (switched evolution relaxation), ending in Newton steps.
    Returns ``(converged, max|r|, iterations, jacobian evaluations)``.
    """
    nq = q.shape[0]
    r = np.empty(nq)
    J = np.empty((nq, nq))
    D = np.empty(nq)
    model_evaluate(q, lam, m, True, r, J, work)
    for u in range(nq):
        D[u] = abs(J[u, u]) + 1e-12
    r0 = np.sqrt(_sumsq(r))
    rprev = r0
    dt = 0.05
    res = _maxabs(r)
    for it in range(max_iter):
        if res <= atol:
            return True, res, it, it + 1
        A = J.copy()
        for u in range(nq):
            A[u, u] += D[u] / dt
        try:
            dx = -np.linalg.solve(A, r)
        except Exception:
            return False, res, it, it + 1
        alpha = _step_scale(dx, m, max_dtheta)
        for u in range(nq):
            q[u] += alpha * dx[u]
        model_evaluate(q, lam, m, True, r, J, work)
        res = _maxabs(r)
        if not np.isfinite(res):
            return False, res, it + 1, it + 2
        rn = np.sqrt(_sumsq(r))
        grow = dt * 2.0 if rn < rprev else dt * 0.5
        dt = min(1e12, max(grow, 0.05 * r0 / max(rn, 1e-300)))
        rprev = rn
    return res <= atol, res, max_iter, max_iter + 1


@njit(cache=True)
def _change(qa, qb, m):
    """Largest change of bend angle or twist of one subsegment between ``qa`` and ``qb`` [rad]."""
    return model_angle(qa - qb, m)



@njit(cache=True)
def _dr_dlam(q, lam, m, work, r0, r1, dr):
    """d r / d lam at (q, lam) by central differences (the residual's dependence on the load factor)."""
    J = np.empty((1, 1))
    h = 1e-6
    model_evaluate(q, lam + h, m, False, r0, J, work)
    model_evaluate(q, lam - h, m, False, r1, J, work)
    for u in range(q.shape[0]):
        dr[u] = (r0[u] - r1[u]) / (2.0 * h)


@njit(cache=True)
def arclength(q, lam, m, atol, max_iter, max_dtheta, work):
    """Pseudo-arclength continuation of the equilibrium curve from (q, lam) until lam = 1; q in place.

    The tangent t of the curve r(q, lam) = 0 in (q, lam) comes from J dq = -dr/dlam; each step predicts along
    it and corrects with Newton on the bordered system [J, dr/dlam; t^T] (the step's length fixed). Where a
    step would pass lam = 1, or its corrector carries lam past 1, it corrects at lam = 1 instead. Returns
    ``(converged, max|r|, iterations, jacobian evaluations, steps, turned)``, ``turned`` when lam decreased
    somewhere (a turning point was passed: the branch reached at full load is not the one the loading path
    started on).
    """
    nq = q.shape[0]
    r = np.empty(nq)
    r0 = np.empty(nq)
    r1 = np.empty(nq)
    dl = np.empty(nq)
    J = np.empty((nq, nq))
    A = np.empty((nq + 1, nq + 1))
    b = np.empty(nq + 1)
    t = np.zeros(nq + 1)
    tprev = np.zeros(nq + 1)
    tprev[nq] = 1.0  # the loading path goes towards larger loads
    z = np.empty(nq + 1)
    zs = np.empty(nq + 1)
    ds = 0.05
    iters = 0
    njac = 0
    turned = False
    res = np.inf
    for step in range(_ARC_STEPS):
        model_evaluate(q, lam, m, True, r, J, work)
        njac += 1
        _dr_dlam(q, lam, m, work, r0, r1, dl)
        try:
            dq = np.linalg.solve(J, -dl)
        except Exception:
            return False, res, iters, njac, step, turned
        for u in range(nq):
            t[u] = dq[u]
        t[nq] = 1.0
        nt = np.sqrt(np.sum(t * t))
        sgn = 1.0 if np.sum(t * tprev) >= 0.0 else -1.0
        for u in range(nq + 1):
            t[u] = sgn * t[u] / nt
        accepted = False
        while ds > 1e-7 and not accepted:
            at_end = lam + ds * t[nq] >= 1.0
            h = (1.0 - lam) / t[nq] if at_end else ds
            for u in range(nq):
                zs[u] = q[u] + h * t[u]
            zs[nq] = 1.0 if at_end else lam + h * t[nq]
            for _it in range(max_iter):
                iters += 1
                model_evaluate(zs[:nq], zs[nq], m, True, r, J, work)
                njac += 1
                res = _maxabs(r)
                # on the last step lam is held at 1: Newton in q alone; else the arclength is held
                g = 0.0
                if not at_end:
                    for u in range(nq + 1):
                        z[u] = zs[u] - (q[u] if u < nq else lam)
                    g = np.sum(t * z) - h
                if res <= atol and abs(g) <= 1e-12:
                    accepted = True
                    break
                if not np.isfinite(res):
                    break
                A[:nq, :nq] = J
                if at_end:
                    A[:nq, nq] = 0.0
                    A[nq, :] = 0.0
                    A[nq, nq] = 1.0
                else:
                    _dr_dlam(zs[:nq], zs[nq], m, work, r0, r1, dl)
                    A[:nq, nq] = dl
                    A[nq, :] = t
                b[:nq] = -r
                b[nq] = -g
                try:
                    dz = np.linalg.solve(A, b)
                except Exception:
                    break
                alpha = _step_scale(dz[:nq], m, max_dtheta)
                for u in range(nq + 1):
                    zs[u] += alpha * dz[u]
                if not at_end and zs[nq] > 1.0:
                    # the corrector carried lam past full load: hold it at 1 and finish in q alone (an
                    # equilibrium at lam > 1 is not one at full load)
                    zs[nq] = 1.0
                    at_end = True
            if not accepted:
                ds *= 0.5
        if not accepted:
            return False, res, iters, njac, step, turned
        if zs[nq] < lam:
            turned = True
        for u in range(nq):
            q[u] = zs[u]
        lam = zs[nq]
        for u in range(nq + 1):
            tprev[u] = t[u]
        if lam >= 1.0:
            return True, res, iters, njac, step + 1, turned
        ds = min(2.0 * ds, 0.25)
        if lam < -0.5:
            break
    return False, res, iters, njac, _ARC_STEPS, turned


# ------------------------------------------------------------------ through a fold: follow, snap, follow on
_SNAP_DLAM = 1.0 / 128.0  # how far past a fold's load factor the snap-through is relaxed
_FOLD_H = 1e-4  # a load step this small that still fails: the branch ends (a fold) here (the snap is relaxed
# _SNAP_DLAM past it: locating the fold more finely changes nothing but the cost)
_FOLLOW_THETA = 0.5  # a follower's step whose first Newton contraction is above this is too long: halved
_FOLLOW_STEPS = 200  # load steps allowed to the follower between two folds
_MAX_FOLDS = 6  # snap-throughs allowed on the way to full load
_FLOW_STEPS = 300  # implicit Euler steps of one snap-through (at most 6 max_iter: the user's cap holds here too)
_FLOW_CAP = 1.0  # largest pseudo-time step while the flow's residual grows (the snap itself)


@njit(cache=True)
def _inverse(J, H):
    """``H`` = J^-1 in place; False (H zero) where J is singular."""
    try:
        H[:, :] = np.linalg.inv(J)
    except Exception:
        H[:, :] = 0.0
        return False
    return np.all(np.isfinite(H))


@njit(cache=True)
def _det_sign(J):
    """The sign of det J (0 where singular or not finite)."""
    if not np.all(np.isfinite(J)):
        return 0.0
    s, ld = np.linalg.slogdet(J)
    return s if np.isfinite(ld) else 0.0


@njit(cache=True)
def _correct(q, lam, m, tol, max_iter, max_dtheta, work, max_theta):
    """Newton from ``q`` (in place) at load factor ``lam`` with the exact Jacobian every iteration, damped by
    Deuflhard's natural monotonicity test: a step of length a along the Newton correction dx is accepted when the
    simplified correction J^-1 r(q + a dx) at the new point is shorter than (1 - a/4) |dx|.

    Affine invariant, unlike a test on |r|: where the Jacobian is ill-conditioned and far from symmetric (no
    friction, near a fold) a full Newton step that converges can raise |r| on the way, and a line search on |r|
    rejects it. Returns ``(converged, max|r|, iterations, jacobian evaluations, theta)``, theta the first
    iteration's contraction |simplified correction| / |dx| (small: the start was well inside the basin); a first
    contraction above ``max_theta`` ends the iteration at once (not converged: the start is too far out)."""
    nq = q.shape[0]
    r = np.empty(nq)
    rt = np.empty(nq)
    qt = np.empty(nq)
    J = np.empty((nq, nq))
    H = np.empty((nq, nq))
    a = 1.0
    theta = 0.0  # a start already in balance contracts at once
    njac = 0
    for it in range(max_iter):
        model_evaluate(q, lam, m, True, r, J, work)
        njac += 1
        res = _maxabs(r)
        if res <= tol:
            return True, res, it, njac, theta
        if not np.isfinite(res) or not _inverse(J, H):
            return False, res, it, njac, theta
        dx = -(H @ r)
        ndx = np.sqrt(_sumsq(dx))
        a = min(1.0, 2.0 * a, _step_scale(dx, m, max_dtheta))
        while True:
            for u in range(nq):
                qt[u] = q[u] + a * dx[u]
            model_evaluate(qt, lam, m, False, rt, J, work)
            th = np.sqrt(_sumsq(H @ rt)) / ndx
            if it == 0:
                theta = th
                if th > max_theta:
                    return False, res, it + 1, njac, theta
            if th <= 1.0 - 0.25 * a or _maxabs(rt) <= tol:
                break
            a *= 0.5
            if a < 1e-4:
                return False, res, it + 1, njac, theta
        q[:] = qt
        rn = _maxabs(rt)
        if rn <= tol:  # in balance at the new point: no Jacobian to confirm it
            return True, rn, it + 1, njac, theta
    model_evaluate(q, lam, m, False, r, J, work)
    res = _maxabs(r)
    return res <= tol, res, max_iter, njac, theta


@njit(cache=True)
def _follow(q, lam, m, atol, step_atol, max_iter, max_dtheta, work, target):
    """Follow the branch of the equilibrium ``q`` (in place) at load factor ``lam`` towards lam = 1 in small load
    steps: the tangent dq/dlam as predictor, :func:`_correct` as corrector, steps aimed at ``target`` [rad] per
    subsegment and halved on a failed, slowly contracting or jumping step. Stops at lam = 1 or where a step of
    :data:`_FOLD_H` fails (a fold: the branch turns back; ``q`` the last equilibrium before it).
    Returns ``(reached, lam, max|r|, iterations, jacobian evaluations, steps)``."""
    nq = q.shape[0]
    J = np.empty((nq, nq))
    r0 = np.empty(nq)
    r1 = np.empty(nq)
    dl = np.empty(nq)
    qs = np.empty(nq)
    iters = 0
    njac = 0
    h = _MAX_DLAM
    res = np.inf
    for step in range(_FOLLOW_STEPS):
        if lam >= 1.0:
            return True, lam, res, iters, njac, step
        model_evaluate(q, lam, m, True, r0, J, work)
        njac += 1
        _dr_dlam(q, lam, m, work, r0, r1, dl)
        try:
            tan = -np.linalg.solve(J, dl)
        except Exception:
            return False, lam, res, iters, njac, step
        rate = model_angle(tan, m)
        if rate > 0.0 and np.isfinite(rate):
            h = min(h, target / rate)
        while True:
            h = min(h, 1.0 - lam)
            lt = lam + h
            for u in range(nq):
                qs[u] = q[u] + h * tan[u]
            tol = atol if lt >= 1.0 else max(atol, step_atol)
            ok, res, it, ne, theta = _correct(qs, lt, m, tol, min(12, max_iter), max_dtheta, work, _FOLLOW_THETA)
            iters += it
            njac += ne
            if ok and theta < _FOLLOW_THETA and _change(qs, q, m) <= max(_MAX_STEP_CHANGE, 2.0 * h * rate):
                q[:] = qs
                lam = 1.0 if lt >= 1.0 else lt
                h = min(2.0 * h, _MAX_DLAM)
                break
            h *= 0.5
            if h < _FOLD_H:
                return False, lam, res, iters, njac, step + 1
    return lam >= 1.0, lam, res, iters, njac, _FOLLOW_STEPS


@njit(cache=True)
def _flow(q, lam, m, tol, max_iter, max_dtheta, work, J0, H0, sign0):
    """The snap-through: implicit Euler (in place) on the pseudo-time flow dq/dt = -J0^-1 r(q) at load factor
    ``lam``, ``J0`` the unloaded, straight robot's Jacobian (``H0`` its inverse).

    J0^-1 pairs each residual with the unknown it is conjugate to (the raw residual of the PCC models is the
    bending moment rotated by 90 degrees against (beta, gamma): a flow dq/dt = -D^-1 r with a diagonal D turns
    about the equilibrium instead of falling towards it) and weighs it by the unloaded robot's stiffness: a
    damped, stiffness-proportional flow. The time step keeps each step's bend and twist near 0.1 rad, grows
    towards Newton's as the residual falls, and stays at most :data:`_FLOW_CAP` while the residual grows
    (the snap). Where the flow circles instead of settling (an equilibrium with a pair of complex eigenvalues of
    the wrong sign: no first-order flow settles there), Newton (:func:`_correct`) is tried from each point where
    |J0^-1 r| had a local minimum. Converged only on an equilibrium whose det J has the sign ``sign0`` of the
    stable start (an odd count of real negative eigenvalues is a saddle).
    Returns ``(converged, max|r|, iterations, jacobian evaluations)``."""
    nq = q.shape[0]
    r = np.empty(nq)
    J = np.empty((nq, nq))
    A = np.empty((nq, nq))
    qlow = q.copy()
    qtry = np.empty(nq)
    model_evaluate(q, lam, m, True, r, J, work)
    njac = 1
    iters = 0
    z = np.sqrt(_sumsq(H0 @ r))
    falling = False
    dt = 1.0
    res = _maxabs(r)
    for _ in range(min(_FLOW_STEPS, 6 * max_iter)):
        if res <= tol:
            if _det_sign(J) == sign0:
                return True, res, iters, njac
            break
        iters += 1
        for u in range(nq):
            for v in range(nq):
                A[u, v] = J[u, v] + J0[u, v] / dt
        try:
            dx = -np.linalg.solve(A, r)
        except Exception:
            break
        step = model_angle(dx, m)
        if not np.isfinite(step):
            break
        if step > 0.2:  # too far for one step of the flow: a shorter time step
            dt *= 0.05 / step
            if not dt > 1e-300:  # no time step short enough: the flow cannot go on
                break
            continue
        qlow[:] = q
        for u in range(nq):
            q[u] += dx[u]
        model_evaluate(q, lam, m, True, r, J, work)
        njac += 1
        res = _maxabs(r)
        zn = np.sqrt(_sumsq(H0 @ r))
        dt = min(1e12, dt * min(4.0, 0.1 / max(step, 1e-300)))
        if zn > z:
            dt = min(dt, _FLOW_CAP)
            if falling and res > tol:  # |J0^-1 r| had a local minimum at the last point: Newton from there
                qtry[:] = qlow
                ok, rt, it, ne, _th = _correct(qtry, lam, m, tol, min(8, max_iter), max_dtheta, work, np.inf)
                iters += it
                njac += ne
                if ok:
                    model_evaluate(qtry, lam, m, True, r, J, work)
                    njac += 1
                    if _det_sign(J) == sign0:
                        q[:] = qtry
                        return True, rt, iters, njac
                    model_evaluate(q, lam, m, True, r, J, work)
                    njac += 1
        falling = zn < z
        z = zn
    return False, res, iters, njac


@njit(cache=True)
def snap_through(q, lam, m, atol, step_atol, max_iter, max_dtheta, work, target):
    """From the last equilibrium ``q`` (in place) of a loading path that stalled at load factor ``lam``, reach
    full load: follow the branch in small steps (:func:`_follow`, which also carries on where the stall was no
    fold but a Newton failure), and at each fold relax :data:`_SNAP_DLAM` past it (:func:`_flow`; the robot
    snaps through to a neighbouring stable equilibrium) and follow on from there; where that relaxation fails,
    relax at full load. The unloaded, straight robot's Jacobian (its elastic stiffness) weighs the flow, on a
    continuation too: there the Jacobian at the start of the path carries the start's loads, and a flow weighed
    by it can fail to settle where the elastic one settles at once.
    Returns ``(converged, max|r|, iterations, jacobian evaluations, steps, snapped)``."""
    nq = q.shape[0]
    r = np.empty(nq)
    J0 = np.empty((nq, nq))
    H0 = np.empty((nq, nq))
    model_evaluate(np.zeros(nq), 0.0, model_rest(m), True, r, J0, work)
    iters = 0
    njac = 1
    steps = 0
    snapped = False
    res = np.inf
    if not _inverse(J0, H0):
        return False, res, iters, njac, steps, snapped
    sign0 = _det_sign(J0)
    qs = np.empty(nq)
    for _fold in range(_MAX_FOLDS + 1):
        ok, lam, res, it, ne, st = _follow(q, lam, m, atol, step_atol, max_iter, max_dtheta, work, target)
        iters += it
        njac += ne
        steps += st
        if ok or _fold == _MAX_FOLDS:
            return ok, res, iters, njac, steps, snapped
        # a fold at lam: the robot snaps through to another equilibrium just past it
        lt = min(1.0, lam + _SNAP_DLAM)
        qs[:] = q
        tol = atol if lt >= 1.0 else max(atol, step_atol)
        ok, res, it, ne = _flow(qs, lt, m, tol, max_iter, max_dtheta, work, J0, H0, sign0)
        iters += it
        njac += ne
        steps += 1
        if not ok and lt < 1.0:  # no settling near the fold: relax at full load
            lt = 1.0
            qs[:] = q
            ok, res, it, ne = _flow(qs, lt, m, atol, max_iter, max_dtheta, work, J0, H0, sign0)
            iters += it
            njac += ne
            steps += 1
        if not ok:
            return False, res, iters, njac, steps, snapped
        q[:] = qs
        lam = lt
        snapped = True
        if lam >= 1.0:
            return True, res, iters, njac, steps, snapped
    return False, res, iters, njac, steps, snapped


@njit(cache=True)
def _tangent(q, r1, m, work, H, tan):
    """The path's tangent ``tan`` = dq/dlam (in place) at ``q``, an equilibrium at lam = 0 whose residual at lam = 1
    is ``r1``: ``-J^-1 dr/dlam`` with the exact Jacobian, whose inverse is left in ``H``. The residual is affine in
    lam (every load is), so dr/dlam = r(q, 1) - r(q, 0) exactly. Returns (False where J is singular, then ``tan``
    is zero; the sign of det J there)."""
    nq = q.shape[0]
    r0 = np.empty(nq)
    J = np.empty((nq, nq))
    model_evaluate(q, 0.0, m, True, r0, J, work)
    sign = _det_sign(J)
    try:
        H[:, :] = np.linalg.inv(J)
    except Exception:
        tan[:] = 0.0
        return False, sign
    tan[:] = -(H @ (r1 - r0))
    return np.all(np.isfinite(tan)), sign


@njit(cache=True, nogil=True)
def solve_one(q0, m, settings, work):
    """Solve at full load.

    ``m`` is a :class:`Homotopy`: with ``ramp`` for stepping 0 to 2, without for 3.
    ``stepping``: 0 Newton from ``q0`` only; 1 Newton from ``q0``, then the
    loading path if that fails; 2 the loading path from the unloaded,
    straight robot; ``STEP_CONTINUE`` (3) continuation: ``q0`` is an
    equilibrium at lam = 0 followed to lam = 1,
    the first step predicted along the path's tangent (path code
    ``PATH_CONTINUED``). The loading path ramps every load by a factor lam from 0
    to 1 (secant predictor, adaptive steps): the branch quasi-static loading
    follows. Where it stalls at a fold it relaxes at full load from the last
    equilibrium (the snap-through); if that fails too, Newton at full load
    from the last equilibrium and then from ``q0`` gives another equilibrium
    (path code 3). A loading path or continuation that reaches full load
    with the sign of det J changed from its start's has stepped over a fold
    pair onto another branch (an odd number of real eigenvalues crossed zero:
    the robot could not have got there quasi-statically); it is walked again
    with load steps four times finer, and once more if that one ends on the
    other sign too (at most :data:`_WALKS` walks); a first walk that found no
    way to full load is walked again once.
    ``settings`` (:class:`Settings`) carries ``stepping`` and the tolerances. Returns an :class:`Outcome`.
    """
    atol, max_iter, max_dtheta, stepping = settings.atol, settings.max_iter, settings.max_dtheta, settings.stepping
    nq = q0.shape[0]
    q = q0.copy()
    H = np.zeros((nq, nq))
    iters = 0
    nj = 0
    cont = stepping == STEP_CONTINUE
    r_full = np.empty(nq)  # the start's residual at full load
    if stepping != 2:  # a start already in balance at full load is the answer: no Jacobian for it
        model_evaluate(q, 1.0, m, False, r_full, np.empty((1, 1)), work)
        res = _maxabs(r_full)
        if res <= atol:
            return Outcome(q, True, res, 0, 0, 0, PATH_CONTINUED if cont else PATH_DIRECT)
    if stepping != 2 and not cont:
        ok, res, it, ne = newton(q, 1.0, m, atol, max_iter, max_dtheta, work, H, _FRESH, _UNLIMITED)
        iters += it
        nj += ne
        if ok or stepping == 0:
            return Outcome(q, ok, res, iters, nj, 0, PATH_DIRECT)
    if not cont:
        q[:] = 0.0
        model_evaluate(q, 1.0, m, False, r_full, np.empty((1, 1)), work)
    start = q.copy()
    scale = settings.step_scale
    steps = 0
    kept = np.empty(nq)  # the last answer that reached full load on the other sign of det J
    kept_res = np.inf
    kept_path = PATH_LOADING
    for attempt in range(_WALKS):
        q[:] = start
        ok, lam, res, it, ne, st, path, sign0 = _walk(q, m, settings, work, H, scale, cont, r_full)
        iters += it
        nj += ne
        steps += st
        if lam >= 1.0:
            if path == PATH_SNAP or sign0 == 0.0 or attempt == _WALKS - 1:
                break
            # the branch reached must be the one the path started on: det J keeps its sign along it
            J = np.empty((nq, nq))
            r = np.empty(nq)
            model_evaluate(q, 1.0, m, True, r, J, work)
            nj += 1
            if _det_sign(J) == sign0:
                break
            kept[:] = q
            kept_res = res
            kept_path = path
        elif path == PATH_FOLD:  # the path ends at a fold (one that a coarser walk stepped over, if any)
            break
        elif attempt > 0:  # a finer walk found no way: the answer a coarser one reached (if any) stands
            if kept_res <= atol:
                q[:] = kept
                ok, lam, res, path = True, 1.0, kept_res, kept_path
            break
        scale *= 0.25  # stepped over a fold pair, or stalled with no way on: walk again in finer steps
    if lam < 1.0:
        # last resort: any equilibrium at full load, from the last equilibrium, then from q0 (none where the
        # path was to stop at a fold)
        qs = np.empty(nq)
        for which in range(0 if path == PATH_FOLD else 2):
            if which == 0:
                qs[:] = q
            else:
                qs[:] = q0
            ok, res, it, ne = newton(qs, 1.0, m, atol, max_iter, max_dtheta, work, H, _FRESH, _UNLIMITED)
            iters += it
            nj += ne
            if ok:
                return Outcome(qs, True, res, iters, nj, steps, PATH_FALLBACK)
        r = np.empty(nq)
        J = np.empty((1, 1))
        model_evaluate(q, 1.0, m, False, r, J, work)
        return Outcome(q, False, _maxabs(r), iters, nj, steps, path)
    return Outcome(q, ok, res, iters, nj, steps, path)


@njit(cache=True)
def _walk(q, m, settings, work, H, scale, cont, r_full):
    """The loading path (or a continuation, ``cont``) from ``q`` at lam = 0 (in place) towards lam = 1, load steps
    scaled by ``scale``; ``r_full`` is the residual of ``q`` at lam = 1. See :func:`solve_one`.
    Returns ``(converged, lam reached, max|r|, iterations, jacobians, steps, path code, sign of det J at the
    start)``."""
    atol, max_iter, max_dtheta = settings.atol, settings.max_iter, settings.max_dtheta
    nq = q.shape[0]
    iters = 0
    nj = 0
    path = PATH_CONTINUED if cont else PATH_LOADING
    qprev = np.zeros(nq)
    lprev = 0.0
    qs = np.zeros(nq)
    lam = 0.0
    target = _STEP_TARGET * scale
    # a continuation may cross its whole path in one step; the loading path from rest takes at least four
    max_dlam = 1.0 if cont else _MAX_DLAM * scale
    dlam = max_dlam
    tan = np.zeros(nq)
    # the first step is predicted along the path's tangent (there is no secant yet) and sized by it
    use_tan, sign0 = _tangent(q, r_full, m, work, H, tan)
    nj += 1
    rate = model_angle(tan, m)
    if use_tan and rate > 0.0:
        dlam = min(max_dlam, target / rate)
    steps = 0
    ok = False
    res = np.inf
    step_iter = min(max_iter, settings.step_iter)
    have_h = use_tan  # an inverse Jacobian from the last converged load step (or the start's, for the tangent)
    while lam < 1.0 and steps < 400:
        lt = min(1.0, lam + dlam)
        if not lt > lam:  # a step below the load factor's resolution (a huge secant rate): the path cannot go on
            ok = False
            break
        # secant predictor from the last two equilibria
        if lam > lprev:
            w = (lt - lam) / (lam - lprev)
            for u in range(nq):
                qs[u] = q[u] + w * (q[u] - qprev[u])
        elif use_tan:
            for u in range(nq):
                qs[u] = q[u] + (lt - lam) * tan[u]
        else:
            qs[:] = q
        tol = atol if lt >= 1.0 else max(atol, settings.step_atol)
        # a step whose corrector fails is halved (from a fresh Jacobian at the shorter step's predictor); correcting
        # again from the last equilibrium without a predictor succeeded on 2 % of the failed steps and cost a fifth
        # of all Jacobians (sscr, paper load) and is not tried
        ok, res, it, ne = newton(qs, lt, m, tol, step_iter, max_dtheta, work, H, have_h, _STEP_JACOBIANS)
        iters += it
        nj += ne
        steps += 1
        if ok and dlam >= 1.0 / 64.0 and _change(qs, q, m) > _MAX_STEP_CHANGE:
            ok = False  # a converged step that moved far has jumped to another branch: take a smaller step
        have_h = ok
        if ok:
            qprev[:] = q
            lprev = lam
            q[:] = qs
            lam = lt
            # next step from the secant rate of change: aim at _STEP_TARGET per subsegment
            rate = _change(q, qprev, m) / (lam - lprev)
            dlam = min(2.0 * dlam, max_dlam, target / rate if rate > 0.0 else max_dlam)
        else:
            dlam *= 0.5
            if dlam < 1.0 / 128.0:
                if settings.fold == FOLD_STOP:  # no way on: the path ends at a fold, and so does the solve
                    path = PATH_FOLD
                    break
                qs[:] = q
                if settings.fold == FOLD_ARCLENGTH:
                    # follow the equilibrium curve through the fold, in (q, lam)
                    ok, res, it, ne, st, turned = arclength(qs, lam, m, atol, max_iter, max_dtheta, work)
                    steps += st
                else:
                    # a stall: follow the branch on in small steps to its fold, snap through, follow on
                    ok, res, it, ne, st, turned = snap_through(qs, lam, m, atol, settings.step_atol, max_iter,
                                                               max_dtheta, work, target)
                    steps += st
                    if not ok:  # relax at full load from the last equilibrium of the loading path
                        iters += it
                        nj += ne
                        qs[:] = q
                        ok, res, it, ne = relax(qs, 1.0, m, atol, 4 * max_iter, max_dtheta, work)
                        steps += 1
                        turned = True
                iters += it
                nj += ne
                if ok:
                    q[:] = qs
                    lam = 1.0
                    path = PATH_SNAP if turned else path
                break
    return ok, lam, res, iters, nj, steps, path, sign0


@njit(cache=True, nogil=True)
def solve_range(q0, ma, mb, t_start, t_end, settings, tols, start, stop, out_q, out_ok, out_res, out_it, out_steps,
                out_path):
    """Solve, or continue, the cases ``start <= b < stop`` of a batch, one after the other (the GIL released).

    The one compiled entry of the solver, for solves and continuations alike (each entry compiles the solver's
    code again). ``t_end`` (B, nt) holds each case's actuator tensions [N]; ``mb`` gives every other load.
    Solve (``settings.stepping`` 0 to 2): case b from ``q0[b]`` (B, m) as :func:`solve_one` does (``ma`` and
    ``t_start`` unused; pass ``mb`` and ``t_end``). Continue (``STEP_CONTINUE``): ``q0[b]`` is an equilibrium
    of ``ma`` at the tensions ``t_start[b]`` (B, nt) [N], followed along the straight path of the loads to
    ``mb`` at ``t_end[b]``. ``tols`` (B, 2): each case's tolerance and load-step tolerance [N m], in place of
    ``settings``'. Writes ``out_q`` (B, m), ``out_ok``, ``out_res``, ``out_it``, ``out_steps`` and ``out_path``
    (B,) for those cases. Callers run disjoint ranges in threads: each case is solved by the same compiled
    code whatever the thread, so a batch's results do not depend on how it is split.
    """
    work = model_work(mb)
    blend = settings.stepping == STEP_CONTINUE
    for b in range(start, stop):
        end = model_with_tension(mb, t_end[b])
        if blend:
            h = Homotopy(model_with_tension(ma, t_start[b]), end, _BLEND)
        else:
            h = Homotopy(end, end, _RAMP)
        o = solve_one(q0[b], h, _case_settings(settings, tols, b), work)
        _store(o, b, out_q, out_ok, out_res, out_it, out_steps, out_path)


@njit(cache=True, inline="always")
def _case_settings(settings, tols, b):
    """``settings`` with case b's tolerance and load-step tolerance from ``tols`` (B, 2) [N m]."""
    return Settings(tols[b, 0], settings.max_iter, settings.max_dtheta, settings.stepping, settings.step_iter,
                    settings.fold, tols[b, 1], settings.step_scale)


@njit(cache=True, inline="always")
def _store(o, b, out_q, out_ok, out_res, out_it, out_steps, out_path):
    """Write the :class:`Outcome` ``o`` into row b of the outputs."""
    out_q[b, :] = o.q
    out_ok[b] = o.converged
    out_res[b] = o.residual
    out_it[b] = o.iterations
    out_steps[b] = o.load_steps
    out_path[b] = o.path

"""The inverse statics' search (:func:`pytdcr.optimize.inverse_statics` says what it does and why): evaluated
tension vectors, the trust-region steps on their exact Jacobians, and the pool of sample equilibria it starts
from."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.optimize import linprog, lsq_linear
from scipy.stats import qmc

from .._version import __version__
from ..bounds import TensionBounds
from ..io import robot_to_dict
from ..loads import Loads
from ..results import StaticSolution
from ..robot import Robot
from ..runtime import cache_dir, read_arrays, write_arrays
from ..statics import Model, ModelOptions, equilibrium_jacobians, solve, solve_batch

__all__ = ["NEAREST", "POOL_SAMPLES", "Point", "Pool", "Search", "Target", "cache_dir", "choose_step", "is_optimal",
           "objective_value",
           "ranked_starts", "sample_pool"]

#: Sobol samples solved once per robot, load, bounds and model for the starts
POOL_SAMPLES = 256
#: how many of the samples nearest the target are ranked as starts
NEAREST = 8
_POOLS: dict[str, Pool] = {}
_POOLS_KEPT = 16


@dataclass(frozen=True, eq=False)
class Pool:
    """Equilibria to start from: tensions (K, n_tendons) [N], tips (K, 3) [m] and, when known, the tips'
    Jacobians by the tensions (K, 3, n_tendons) [m/N]."""

    tensions: np.ndarray
    tips: np.ndarray
    jacobians: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Point:
    """An evaluated tension vector: its equilibrium, its miss (3,) or (6,) and the miss's Jacobian."""

    tensions: np.ndarray
    solution: StaticSolution | None
    miss: np.ndarray
    jacobian: np.ndarray

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.miss))


class Target:
    """The target, the optional direction, and how equilibria are evaluated against them."""

    def __init__(self, robot: Robot, loads: Loads, m: Model, opts: ModelOptions, target: np.ndarray,
                 direction: np.ndarray | None, budget: int) -> None:
        self.robot, self.loads, self.m, self.opts = robot, loads, m, opts
        self.target, self.direction, self.scale = target, direction, robot.length
        self.count, self.budget = 0, budget
        # warm steps: Newton alone from the last equilibrium (a step that loses its way is refused, not ramped)
        self.warm_opts = replace(opts, load_stepping="never") if hasattr(opts, "load_stepping") else opts

    def aim(self, target: np.ndarray, budget: int) -> None:
        """Aim at another ``target`` (3,) [m] (same direction), with ``budget`` more solves."""
        self.target, self.budget = target, self.count + budget

    @property
    def exhausted(self) -> bool:
        """The solve budget is spent."""
        return self.count >= self.budget

    def evaluate(self, t: np.ndarray, base: Point | None) -> Point | None:
        """The equilibrium at ``t`` solved by Newton from ``base``'s (from rest when None); None if it did not
        converge or the budget is spent."""
        if self.exhausted:
            return None
        loads = self.loads.with_tensions(t)
        sol = solve(self.robot, loads, model=self.m, options=self.opts if base is None else self.warm_opts,
                    q0=None if base is None else base.solution.q)
        self.count += 1
        if not sol.converged:
            return None
        return self.measure(t, sol)

    def measure(self, t: np.ndarray, sol: StaticSolution) -> Point:
        """The miss of the converged ``sol`` at ``t`` and its Jacobian by the tensions."""
        loads = self.loads.with_tensions(t)
        r = sol.tip_position - self.target
        if self.direction is None:
            _, g = self.m.tip_gradient(self.robot, loads, sol, self.opts)
            return Point(t, sol, r, g)
        jac = equilibrium_jacobians(self.robot, loads, sol, model=self.m, options=self.opts)
        axis = sol.disk_rotations[-1][:, 2]
        return Point(t, sol, np.concatenate([r, self.scale * (axis - self.direction)]),
                     np.vstack([jac.tip_position, self.scale * jac.tip_axis]))


def objective_value(t: np.ndarray, objective: str) -> float:
    """The objective at tensions ``t`` (n,) [N]: sum of squares [N^2], the largest [N] or the total [N]."""
    if objective == "least-squares":
        return float(t @ t)
    return float(np.max(t)) if objective == "least-max" else float(np.sum(t))


def _box(p: Point, bounds: TensionBounds, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The bounds intersected with the trust region ``|T - p.tensions|_inf <= radius`` [N]."""
    return (np.maximum(bounds.lower, p.tensions - radius), np.minimum(bounds.upper, p.tensions + radius))


def _reach_step(p: Point, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Gauss-Newton: tensions in [lo, hi] minimising |G dT + r|^2 + eps^2 |dT|^2 (the least step among those
    cancelling the linearised miss), eps a millionth of G's scale."""
    g, r, n = p.jacobian, p.miss, p.tensions.size
    eps = 1e-6 * max(float(np.linalg.norm(g)), 1e-12)
    a = np.vstack([g, eps * np.eye(n)])
    b = np.concatenate([-r, np.zeros(n)])
    step = lsq_linear(a, b, bounds=(lo - p.tensions, hi - p.tensions + 1e-300), method="bvls").x
    return np.clip(p.tensions + step, lo, hi)


def choose_step(p: Point, lo: np.ndarray, hi: np.ndarray, objective: str,
                 hessian: np.ndarray | None) -> np.ndarray:
    """Tensions in [lo, hi] lowering the objective with the linearised miss ``G dT + r`` held at zero (a heavy
    penalty on it): for ``least-squares`` the bounded least-squares form of the quadratic model with the
    Lagrangian's Hessian ``hessian`` (n, n) (BFGS; 2 I at first), for the others an exact L1 penalty in a
    linear programme."""
    g, r, t = p.jacobian, p.miss, p.tensions
    m, n = g.shape
    w = 1e4 * max(float(np.sqrt(np.sum(t * t) + 1.0)), 1.0) / max(float(np.linalg.norm(g)), 1e-12)
    if objective == "least-squares":
        try:
            chol = np.linalg.cholesky(2.0 * np.eye(n) if hessian is None else 0.5 * (hessian + hessian.T))
        except np.linalg.LinAlgError:  # rounding lost the update's definiteness: start it again
            chol = np.sqrt(2.0) * np.eye(n)
        a = np.vstack([w * g, chol.T])
        b = np.concatenate([-w * r, -np.linalg.solve(chol, 2.0 * t)])
        step = lsq_linear(a, b, bounds=(lo - t, hi - t + 1e-300), method="bvls").x
        return np.clip(t + step, lo, hi)
    # variables: T (n), e+ (m), e- (m) [, s]; G T - e+ + e- = G t - r
    k = 2 * m + n + (1 if objective == "least-max" else 0)
    c = np.zeros(k)
    c[n:n + 2 * m] = w
    a_eq = np.hstack([g, -np.eye(m), np.eye(m), np.zeros((m, k - n - 2 * m))])
    bnds = [*zip(lo, hi, strict=True), *[(0.0, None)] * (2 * m)]
    a_ub = b_ub = None
    if objective == "least-total":
        c[:n] = 1.0
    else:
        c[-1] = 1.0
        bnds.append((0.0, None))
        a_ub = np.hstack([np.eye(n), np.zeros((n, 2 * m)), -np.ones((n, 1))])
        b_ub = np.zeros(n)
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=g @ t - r, bounds=bnds, method="highs")
    return np.clip(res.x[:n], lo, hi) if res.status == 0 else t.copy()


def is_optimal(p: Point, bounds: TensionBounds, objective: str) -> bool:
    """First-order optimality at the reaching ``p``: no step of 1 mN per tension inside the bounds lowers the
    objective's model (miss held) by more than a thousandth of what the objective's gradient could."""
    step = 1e-3
    y = choose_step(p, *_box(p, bounds, step), objective, None)
    t = p.tensions
    slope = 2.0 * float(np.sum(np.abs(t))) if objective == "least-squares" else float(t.size)
    return objective_value(t, objective) - objective_value(y, objective) <= 1e-3 * step * max(slope, 1.0)


def _multipliers(p: Point, bounds: TensionBounds) -> np.ndarray:
    """Least-squares estimate of the miss's multipliers at ``p`` for the sum of squares: 2 T = G^T lambda on
    the tensions off their bounds."""
    t = p.tensions
    free = (t > bounds.lower + 1e-9) & (t < bounds.upper - 1e-9)
    if not np.any(free):
        return np.zeros(p.miss.size)
    return np.linalg.lstsq(p.jacobian[:, free].T, 2.0 * t[free], rcond=None)[0]


def _bfgs(hessian: np.ndarray | None, p: Point, q: Point, bounds: TensionBounds) -> np.ndarray:
    """The Lagrangian's Hessian updated by the step from ``p`` to ``q`` (damped BFGS, Powell: kept positive
    definite)."""
    n = p.tensions.size
    h = 2.0 * np.eye(n) if hessian is None else hessian
    lam = _multipliers(q, bounds)
    s = q.tensions - p.tensions
    y = 2.0 * s - (q.jacobian - p.jacobian).T @ lam
    hs = h @ s
    shs = float(s @ hs)
    if shs <= 1e-300:
        return h
    sy = float(s @ y)
    theta = 1.0 if sy >= 0.2 * shs else 0.8 * shs / (shs - sy)
    y = theta * y + (1.0 - theta) * hs
    return h - np.outer(hs, hs) / shs + np.outer(y, y) / float(s @ y)


class Search:
    """The trust-region search from one start (see the module)."""

    def __init__(self, tg: Target, bounds: TensionBounds, objective: str, tol: float, cold: bool) -> None:
        self.tg, self.bounds, self.objective, self.tol, self.cold = tg, bounds, objective, tol, cold
        self.radius = 0.25 * float(np.max(bounds.span))

    def _eval(self, t: np.ndarray, base: Point) -> Point | None:
        return self.tg.evaluate(t, None if self.cold else base)

    def reach(self, p: Point, max_steps: int = 60, radius: float | None = None,
              tol: float | None = None) -> Point:
        """Gauss-Newton steps from ``p`` until the miss is within ``tol`` [m] (the search's by default) or no
        step shortens it."""
        rad = self.radius if radius is None else radius
        tol = self.tol if tol is None else tol
        floor = 1e-9 * float(np.max(self.bounds.span))
        for _ in range(max_steps):
            if p.distance <= tol or rad < floor or self.tg.exhausted:
                break
            lo, hi = _box(p, self.bounds, rad)
            y = _reach_step(p, lo, hi)
            pred = p.distance - float(np.linalg.norm(p.jacobian @ (y - p.tensions) + p.miss))
            if pred <= 1e-15:
                break
            q = self._eval(y, p)
            if q is None or p.distance - q.distance < 0.1 * pred:
                rad = 0.25 * min(rad, float(np.max(np.abs(y - p.tensions))))
                continue
            if p.distance - q.distance > 0.75 * pred:
                rad = min(2.0 * rad, float(np.max(self.bounds.span)))
            p = q
        if radius is None:
            self.radius = rad
        return p

    def choose(self, p: Point, max_steps: int = 40) -> Point:
        """Objective steps from the reaching ``p``, each brought back near the target (within a ten-thousandth
        of the robot's length) and kept when the objective fell; then a few more held within ``tol`` (the
        objective compared at the target itself); the last kept point, or ``p``."""
        first = p
        loose = max(self.tol, 1e-4 * self.tg.scale)
        p, hessian, rad = self._improve(p, loose, max_steps, None, self.radius)
        if p.distance > self.tol:
            p = self.reach(p, max_steps=6, radius=1e-3 * float(np.max(self.bounds.span)))
        if p.distance > self.tol:
            return first
        p, _, _ = self._improve(p, self.tol, 10, hessian, max(rad, 1e-3 * float(np.max(self.bounds.span))))
        return p

    def _improve(self, p: Point, near: float, max_steps: int, hessian: np.ndarray | None,
                 rad: float) -> tuple[Point, np.ndarray | None, float]:
        """Up to ``max_steps`` objective steps from ``p``, each kept when, brought back within ``near`` [m] of
        the target, the objective fell; the last kept point, the Hessian and the trust radius [N]."""
        floor = 1e-7 * float(np.max(self.bounds.span))
        f = objective_value(p.tensions, self.objective)
        for _ in range(max_steps):
            if rad < floor or self.tg.exhausted:
                break
            lo, hi = _box(p, self.bounds, rad)
            y = choose_step(p, lo, hi, self.objective, hessian)
            pred = f - objective_value(y, self.objective)
            if pred <= 1e-10 * (1.0 + abs(f)):
                break
            q = self._eval(y, p)
            if q is not None and q.distance > near:
                q = self.reach(q, max_steps=4, radius=max(rad, 1e-3), tol=near)
            fq = objective_value(q.tensions, self.objective) if q is not None else np.inf
            if q is None or q.distance > near or fq >= f:
                rad = 0.25 * min(rad, float(np.max(np.abs(y - p.tensions))))
                continue
            if f - fq > 0.5 * pred:
                rad = min(2.0 * rad, float(np.max(self.bounds.span)))
            if self.objective == "least-squares":
                hessian = _bfgs(hessian, p, q, self.bounds)
            p, f = q, fq
        return p, hessian, rad


def _read_pool(path: Path, n_tendons: int) -> Pool | None:
    """The pool kept as the cache entry ``path`` (:func:`pytdcr.runtime.read_arrays`: a regular file of this
    user's, whole, of the shapes of at most :data:`POOL_SAMPLES` equilibria of ``n_tendons`` tendons, every value
    finite), or None where there is none to trust (it is made again)."""
    arrays = read_arrays(path.name, {"tensions": ("K", n_tendons), "tips": ("K", 3),
                                     "jacobians": ("K", 3, n_tendons)},
                         folder=path.parent, dims={"K": POOL_SAMPLES})
    return None if arrays is None else Pool(arrays["tensions"], arrays["tips"], arrays["jacobians"])


def _keep_pool(path: Path, pool: Pool) -> None:
    """Keep ``pool`` as the cache entry ``path`` (:func:`pytdcr.runtime.write_arrays`: whole or not at all, never
    through a link; a cache that cannot be written is only not kept)."""
    write_arrays(path.name, {"tensions": pool.tensions, "tips": pool.tips, "jacobians": pool.jacobians},
                 folder=path.parent)


def sample_pool(tg: Target, bounds: TensionBounds, *, seed: int = 0) -> Pool:
    """The equilibria of :data:`POOL_SAMPLES` scrambled Sobol tension vectors in the bounds, without their
    co-contraction, solved from rest, that converged and were not found unstable (for a model without a stability
    test they are untested, and kept), with their tips' Jacobians: once per robot, external loads, bounds, model,
    options, seed and pytdcr version (the last few kept in the process, and the newest of them in
    :func:`cache_dir`, :func:`pytdcr.runtime.write_arrays`)."""
    robot, loads = tg.robot, tg.loads.with_tensions(np.zeros(tg.robot.n_tendons))
    what = {"pytdcr": __version__, "robot": robot_to_dict(robot), "tip_force": loads.tip_force.tolist(),
            "tip_moment": loads.tip_moment.tolist(), "release": loads.release,
            "point_loads": [[p.disk, p.force.tolist(), p.moment.tolist()] for p in loads.point_loads],
            "bounds": [bounds.lower.tolist(), bounds.upper.tolist()], "model": tg.m.name, "options": repr(tg.opts),
            "seed": seed, "samples": POOL_SAMPLES}
    key = hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()
    if key in _POOLS:
        return _POOLS[key]
    where = cache_dir()
    path = None if where is None else where / f"inverse-pool-{key[:32]}.npz"
    pool = None if path is None else _read_pool(path, robot.n_tendons)
    if pool is None:
        u = qmc.Sobol(robot.n_tendons, scramble=True, seed=seed).random(POOL_SAMPLES)
        t = _relaxed(robot, bounds, bounds.lower + u * (bounds.upper - bounds.lower))
        b = solve_batch(robot, t, loads, model=tg.m, options=tg.opts)
        ok = b.converged & (b.stable != 0.0)  # stable (1) or untested (NaN): only those found unstable go
        pool = Pool(t[ok], b.tip_position[ok], tg.m.tip_gradients(robot, t[ok], loads, b.q[ok], tg.opts))
        if path is not None:
            _keep_pool(path, pool)
    if len(_POOLS) >= _POOLS_KEPT:
        _POOLS.pop(next(iter(_POOLS)))
    _POOLS[key] = pool
    return pool


def ranked_starts(tg: Target, pool: Pool, bounds: TensionBounds, objective: str, count: int) -> list[Point]:
    """Of the :data:`NEAREST` pool equilibria whose tips lie nearest the target, the ``count`` whose linearised
    best step (the objective with the miss cancelled, inside the bounds) predicts the lowest objective (those
    whose step cannot cancel the miss last, by their predicted miss; by their distance when none can), the
    nearest always among them. Points of a pool without Jacobians are solved from rest here."""
    near = np.argsort(np.linalg.norm(pool.tips - tg.target, axis=1))[:NEAREST]
    points: list[Point] = []
    for k in near:
        if pool.jacobians is not None:
            miss = pool.tips[k] - tg.target
            points.append(Point(pool.tensions[k], None, miss, pool.jacobians[k]))  # solved when chosen
        else:
            p = tg.evaluate(pool.tensions[k], None)
            if p is not None:
                points.append(Point(p.tensions, p.solution, p.miss[:3], p.jacobian[:3]))
    scores = []
    for p in points:
        y = choose_step(p, bounds.lower, bounds.upper, objective, None)
        miss = float(np.linalg.norm(p.jacobian @ (y - p.tensions) + p.miss))
        scores.append((round(miss / (1e-3 * tg.scale)), objective_value(y, objective)))
    if all(sc[0] > 0 for sc in scores):  # no start's linear step reaches: the target may lie outside, the nearest
        scores = [(0, p.distance) for p in points]
    order = sorted(range(len(points)), key=lambda i: scores[i])[:max(1, count)]
    if points and 0 not in order:  # the nearest is always tried: the answer is never farther than the pool's tips
        order[-1] = 0
    return [points[i] for i in order]


def _relaxed(robot: Robot, bounds: TensionBounds, t: np.ndarray) -> np.ndarray:
    """Tensions (K, n_tendons) [N] without their co-contraction: each segment's tendons lowered together until
    the least of them sits at its lower bound (pulling every tendon of a segment alike mostly compresses it)."""
    out = t - bounds.lower
    seg = np.array([td.segment for td in robot.tendons])
    for s in np.unique(seg):
        cols = seg == s
        out[:, cols] -= out[:, cols].min(axis=1, keepdims=True)
    return bounds.lower + out



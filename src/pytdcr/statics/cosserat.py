"""The Cosserat-rod model of the same robot, and its shooting solver.

The backbone is a Kirchhoff rod (bending EI, torsion GJ; inextensible and
unshearable by default, with shear GA and extension EA as an option), each
tendon runs along it at its routing radius and angle (Rucker & Webster 2011,
straight routing) and ends at its anchor disk. Disk weights and point
wrenches act at the disks, the backbone's weight along it, the tip wrench at
the tip: the loads, the routing and the packing are those of the PCC model
(:class:`~pytdcr.statics.pcc.PCCEquations`); only the backbone's mechanics
differ. See :mod:`pytdcr.statics.kernels.cosserat` for the equations.

The boundary-value problem has three unknowns, the total moment at the base
(the total force there is known), found by SciPy's MINPACK hybrid root finder
on the tip residual; a cold start that fails is retried by load continuation.
The model has no tendon friction (its capabilities say so, and the registry
refuses a robot with a friction law).

:class:`CosseratShooting` is the shooting problem of one robot under its
loads; :class:`CosseratModel` is the registry's entry that solves it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from functools import cached_property
from typing import NamedTuple

import numpy as np
from scipy.optimize import root

from .. import _core
from ..contact import contact_failure
from ..limits import Resources
from ..loads import Loads
from ..results import BatchSolution, StaticSolution
from ..robot import Robot
from ..runtime import check_cancelled, run_in_chunks
from .base import Capabilities
from .kernels.pcc import Packed
from .options import CosseratOptions, SolvePath
from .pcc import PCCEquations
from .tolerance import RELATIVE, tolerances

__all__ = ["COSSERAT", "CosseratModel", "CosseratOptions", "CosseratShooting"]

_MIN_DLAM = 1.0 / 1024.0


class Shot(NamedTuple):
    """One integration from the base: the moment just past the tip [N m], the tip [m], and the shape if recorded."""

    residual: np.ndarray  # (3,) the shooting residual: total moment just past the tip
    tip_position: np.ndarray  # (3,) [m]
    positions: np.ndarray | None  # (N+1, 3) disk centres [m]
    rotations: np.ndarray | None  # (N+1, 3, 3)
    curve: np.ndarray | None  # (N nsub + 1, 3) backbone points [m]


@dataclass(frozen=True, eq=False)
class CosseratShooting:
    """The shooting problem of ``robot`` under ``loads`` (three unknowns: the base moment).

    Attributes
    ----------
    robot : Robot
    packed : pytdcr.statics.kernels.pcc.Packed
        The loads and routing, packed exactly as for the PCC model.
    stiff : ndarray, shape (4,)
        EI, GJ [N m^2], GA, EA [N].
    holes : ndarray, shape (n_tendons, 3)
        Routing r_c in the body frame [m].
    mpl : float
        Backbone mass per length [kg/m].
    shear_extension : bool
    nsub : int
        Runge-Kutta steps per subsegment.
    """

    robot: Robot
    packed: Packed
    stiff: np.ndarray
    holes: np.ndarray
    mpl: float
    shear_extension: bool
    nsub: int

    @classmethod
    def build(cls, robot: Robot, loads: Loads, options: CosseratOptions | None = None) -> CosseratShooting:
        """Pack ``robot`` and ``loads`` (any friction law of the robot is ignored: the rod has none)."""
        opts = options or CosseratOptions()
        packed = PCCEquations.build(robot, loads).packed
        bb = robot.backbone
        area = math.pi * (bb.outer_radius**2 - bb.inner_radius**2)
        stiff = np.array([bb.bending_stiffness, bb.torsional_stiffness, bb.shear * area, bb.youngs_modulus * area])
        return cls(robot=robot, packed=packed, stiff=stiff, holes=np.array(robot.tendon_holes),
                   mpl=bb.mass_per_length, shear_extension=bool(opts.shear_extension),
                   nsub=int(opts.steps_per_subsegment))

    def with_tensions(self, tensions: np.ndarray) -> CosseratShooting:
        """The same problem with other actuator tensions [N], shape (n_tendons,)."""
        return replace(self, packed=self.packed._replace(tension=np.asarray(tensions, dtype=float)))

    def shoot(self, m0: np.ndarray, load_factor: float = 1.0, record: bool = False) -> Shot:
        """Integrate from the base with total base moment ``m0`` (3,) [N m], every load scaled by ``load_factor``."""
        p = self.packed
        _, res, *out = _core.cosserat_shoot(
            np.ascontiguousarray(m0, dtype=float), float(load_factor), *self._core_rod[:6],
            np.ascontiguousarray(p.tension, dtype=float), *self._core_rod[6:], bool(self.shear_extension),
            int(self.nsub), record)
        return Shot(res[:3], res[3:], *(out if record else (None, None, None)))

    @cached_property
    def _core_rod(self) -> tuple:
        """The rod's arrays as the compiled core's ``cosserat_shoot`` takes them, but the tensions (C-ordered):
        lengths, stiff, mass per length, disk masses, holes, anchor disks (int64); gravity, point forces and
        moments."""
        p = self.packed
        c = np.ascontiguousarray
        return (c(p.sub[:, 0], dtype=float), c(self.stiff, dtype=float), float(self.mpl), c(p.sub[:, 3], dtype=float),
                c(self.holes, dtype=float), c(p.anchor, dtype=np.int64), c(p.grav, dtype=float),
                c(p.pforce, dtype=float), c(p.pmoment, dtype=float))

    def residual(self, m0: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Total moment just past the tip [N m], shape (3,), for base moment ``m0`` (3,) [N m].

        Zero at an equilibrium; NaN where the rod's balance has no solution.
        """
        m0 = np.asarray(m0, dtype=float)
        if m0.shape != (3,) or not np.all(np.isfinite(m0)):
            raise ValueError(f"m0 must be 3 finite numbers [N m], got {m0!r}")
        return self.shoot(m0, load_factor).residual

    def tip_gradient(self, m0: np.ndarray, rel_step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (3,) [m] at the equilibrium ``m0`` and its derivative by the tensions (3, n_tendons) [m/N].

        Implicit function theorem on the shooting residual r(m0, T) = 0:
        dm0/dT = -(dr/dm0)^-1 dr/dT, every partial by central differences of
        the integration (relative step ``rel_step``).
        """
        m0 = np.asarray(m0, dtype=float)
        tension = self.packed.tension

        def run(m: np.ndarray, t: np.ndarray) -> np.ndarray:
            shot = self.with_tensions(t).shoot(m)
            return np.concatenate([shot.residual, shot.tip_position])

        base = run(m0, tension)
        nt = tension.size
        d_m = np.empty((6, 3))
        hm = rel_step * max(1e-4, float(np.max(np.abs(m0))))
        for j in range(3):
            e = np.zeros(3)
            e[j] = hm
            d_m[:, j] = (run(m0 + e, tension) - run(m0 - e, tension)) / (2.0 * hm)
        d_t = np.empty((6, nt))
        ht = rel_step * max(1.0, float(np.max(tension)))
        for c in range(nt):
            e = np.zeros(nt)
            e[c] = ht
            d_t[:, c] = (run(m0, tension + e) - run(m0, tension - e)) / (2.0 * ht)
        dm_dt = -np.linalg.solve(d_m[:3], d_t[:3])
        return base[3:].copy(), d_t[3:] + d_m[3:] @ dm_dt

    def straight_guess(self, load_factor: float = 1.0) -> np.ndarray:
        """Base moment [N m] of the loads on the straight robot: the cold start, shape (3,)."""
        return load_factor * self._straight_moment

    @cached_property
    def _straight_moment(self) -> np.ndarray:
        # every load scales with the load factor: computed once per model (each root solve asks for it)
        p = self.packed
        s = np.cumsum(p.sub[:, 0])
        force = p.pforce + p.sub[:, 3:4] * p.grav
        arm = np.zeros((s.size, 3))
        arm[:, 2] = s
        m = np.cross(arm, force).sum(axis=0) + p.pmoment.sum(axis=0)
        length = s[-1]
        m += np.cross([0.0, 0.0, length / 2.0], self.mpl * length * p.grav)
        return m

    def root(self, load_factor: float, x0: np.ndarray, atol: float, max_eval: int,
             xtol: float = 1e-13) -> tuple[np.ndarray, float, int]:
        """One root solve at ``load_factor`` from ``x0`` (3,) [N m]; returns (m0, max |residual|, integrations)."""
        lam = load_factor
        scale = max(1e-6, float(np.max(np.abs(x0))), float(np.max(np.abs(self.straight_guess(lam)))))
        count = 0

        def fun(z: np.ndarray) -> np.ndarray:
            nonlocal count
            count += 1
            r = self.shoot(z * scale, lam).residual
            return r / scale if np.all(np.isfinite(r)) else np.full(3, 1e6)

        r0 = self.shoot(x0, lam).residual
        count += 1
        if np.all(np.isfinite(r0)) and np.max(np.abs(r0)) <= atol:
            return x0, float(np.max(np.abs(r0))), count
        sol = root(fun, x0 / scale, method="hybr", options={"xtol": xtol, "maxfev": max_eval})
        m0 = sol.x * scale
        r = self.shoot(m0, lam).residual
        count += 1
        res = float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else math.inf
        return m0, res, count


class _Ramp(NamedTuple):
    m0: np.ndarray
    residual: float
    integrations: int
    steps: int
    load_factor: float  # the last load factor reached


def _ramp(problem: CosseratShooting, opts: CosseratOptions, tol: float, step_atol: float) -> _Ramp:
    """Follow the loading path from load factor 0, to ``tol`` at full load and ``step_atol`` before [N m]."""
    lam = 0.0
    x = np.zeros(3)
    x_prev, lam_prev = None, None
    dlam = 0.25
    count = steps = 0
    res = 0.0
    while lam < 1.0:
        target = min(1.0, lam + dlam)
        guess = x if x_prev is None else x + (x - x_prev) * (target - lam) / (lam - lam_prev)
        this_tol = tol if target == 1.0 else step_atol
        # intermediate steps only track the branch: a looser step tolerance
        m0, res, c = problem.root(target, guess, this_tol, opts.max_eval, 1e-13 if target == 1.0 else 1e-7)
        count += c
        steps += 1
        if res <= this_tol:
            x_prev, lam_prev = x, lam
            x, lam = m0, target
            dlam = min(0.5, dlam * 1.5)
        else:
            dlam /= 2.0
            if dlam < _MIN_DLAM:
                return _Ramp(x, math.inf, count, steps, lam)
    return _Ramp(x, res, count, steps, lam)


def _solve_shooting(problem: CosseratShooting, m0: np.ndarray | None, opts: CosseratOptions,
                    loads: Loads) -> StaticSolution:
    """Solve the shooting problem (``loads``: its loads) to the tolerance of :mod:`pytdcr.statics.tolerance`; the
    result has the same type as the PCC solver's.

    ``q`` is the base moment (3,) [N m]; ``iterations`` counts shooting
    integrations. ``path`` as for the PCC solver, except that at a fold
    (``"snap"``) the root finder jumps to full load from the last equilibrium
    instead of relaxing.
    """
    t0 = time.perf_counter()
    count = steps = 0
    path = SolvePath.DIRECT
    warm = m0 is not None
    if warm:
        x0 = np.asarray(m0, dtype=float).reshape(-1)
        if x0.shape != (3,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"q0 must be 3 finite numbers (the base moment [N m]) for the cosserat model, "
                             f"got shape {np.shape(m0)}")
    else:
        x0 = problem.straight_guess()
    tols, steps_tol = tolerances(problem.robot, loads, problem.packed.tension[None, :], opts.atol, RELATIVE)
    tol = float(tols[0])
    x, res = x0, math.inf
    if opts.load_stepping in ("auto", "never") or warm:
        x, res, count = problem.root(1.0, x0, tol, opts.max_eval)
    if res > tol and opts.load_stepping != "never":
        ramp = _ramp(problem, opts, tol, float(steps_tol[0]))
        x, res, steps = ramp.m0, ramp.residual, ramp.steps
        count += ramp.integrations
        path = SolvePath.LOADING
        if res > tol and ramp.load_factor > 0.0:  # a fold of the loading path: jump to full load from there
            x, res, c = problem.root(1.0, x, tol, opts.max_eval)
            count += c
            path = SolvePath.SNAP
        if res > tol:
            x, res, c = problem.root(1.0, x0, tol, opts.max_eval)
            count += c
            path = SolvePath.FALLBACK
    converged = bool(res <= tol and np.all(np.isfinite(x)))
    shot = problem.shoot(x, record=True)
    failure = ""
    if converged and shot.curve is not None:
        failure = contact_failure(shot.curve, problem.robot.backbone.outer_radius)
    name = SolvePath.SELF_CONTACT if failure else path
    seconds = time.perf_counter() - t0
    p = problem.packed
    pieces = np.arange(1, p.sub.shape[0] + 1)
    tensions = np.where(pieces[None, :] <= p.anchor[:, None], p.tension[:, None], 0.0)
    return StaticSolution(
        converged=converged and not failure, residual=float(res), iterations=int(count), load_steps=int(steps),
        path=name, q=np.array(x, dtype=float), tensions=tensions, seconds=seconds, atol=tol,
        _positions=shot.positions, _rotations=shot.rotations, model=COSSERAT.name, _curve=shot.curve,
        failure=failure,
    )


class CosseratModel:
    """The registry's entry for the Cosserat rod with smeared tendons (see the module docstring)."""

    name = "cosserat"
    description = "Cosserat rod, tendons along it at their routing (Rucker & Webster 2011); no friction"
    options_type = CosseratOptions
    capabilities = Capabilities(friction=False, point_wrenches=True, gradient="finite differences")
    unknowns = "q: (3,), the total moment at the base [N m], base frame"
    iteration_unit = "integrations"

    def resources(self, robot: Robot, options: CosseratOptions) -> Resources:
        """Peak memory and rough time of one solve: linear in the disks (three unknowns; measured 11 ms for
        20 disks)."""
        return Resources(8.0 * robot.n_disks * (2000.0 + 100.0 * robot.n_tendons), 5e-4 * robot.n_disks, 3)

    def default_options(self) -> CosseratOptions:
        """Default options."""
        return CosseratOptions()

    def solve(self, robot: Robot, loads: Loads, q0: np.ndarray | None, options: CosseratOptions) -> StaticSolution:
        """One equilibrium; see :func:`pytdcr.solve`."""
        check_cancelled()
        return _solve_shooting(CosseratShooting.build(robot, loads, options), q0, options, loads)

    def solve_batch(self, robot: Robot, tensions: np.ndarray, loads: Loads, q0: np.ndarray | None,
                    options: CosseratOptions, threads: int | None = None) -> BatchSolution:
        """Every row of ``tensions`` (B, n_tendons) [N]; ``q0`` is (3,) or (B, 3)."""
        nb = tensions.shape[0]
        if q0 is not None:
            Q0 = np.asarray(q0, dtype=float)
            if Q0.size not in (3, 3 * nb):
                raise ValueError(f"q0 must have shape (3,) or ({nb}, 3) for the cosserat model, got {Q0.shape}")
            Q0 = np.broadcast_to(Q0.reshape(1, 3), (nb, 3)) if Q0.size == 3 else Q0.reshape(nb, 3)
        problem = CosseratShooting.build(robot, loads.with_tensions(np.zeros(robot.n_tendons)), options)
        sols: list[StaticSolution | None] = [None] * nb

        def chunk(start: int, stop: int) -> None:
            for b in range(start, stop):
                check_cancelled()
                sols[b] = _solve_shooting(problem.with_tensions(tensions[b]), None if q0 is None else Q0[b], options,
                                          loads)

        t0 = time.perf_counter()
        run_in_chunks(chunk, nb, threads)
        seconds = time.perf_counter() - t0
        return BatchSolution.from_solutions(tensions, sols, seconds, self.name)

    def equilibrium_residual(self, robot: Robot, loads: Loads, q: np.ndarray, options: CosseratOptions) -> float:
        """max |tip moment residual| [N m] of ``robot`` under ``loads`` at the base moment ``q`` (3,) [N m]."""
        return float(np.max(np.abs(CosseratShooting.build(robot, loads, options).residual(q))))

    def tip_gradient(self, robot: Robot, loads: Loads, solution: StaticSolution,
                     options: CosseratOptions) -> tuple[np.ndarray, np.ndarray]:
        """Tip (3,) [m] and its derivative by the tensions (3, n_tendons) [m/N], by central differences of the
        shooting map (implicit function theorem)."""
        return CosseratShooting.build(robot, loads, options).tip_gradient(solution.q)

    def tip_gradients(self, robot: Robot, tensions: np.ndarray, loads: Loads, q: np.ndarray,
                      options: CosseratOptions, threads: int | None = None) -> np.ndarray:
        """Derivatives of the tip by the tensions at many equilibria ``q`` (B, 3) at ``tensions``
        (B, n_tendons) [N], shape (B, 3, n_tendons) [m/N]; NaN rows where ``q[b]`` is not finite."""
        tensions = np.asarray(tensions, dtype=float)
        q = np.asarray(q, dtype=float).reshape(tensions.shape[0], -1)
        out = np.full((tensions.shape[0], 3, robot.n_tendons), np.nan)

        def chunk(start: int, stop: int) -> None:
            for b in range(start, stop):
                if np.all(np.isfinite(q[b])):
                    shot = CosseratShooting.build(robot, loads.with_tensions(tensions[b]), options)
                    out[b] = shot.tip_gradient(q[b])[1]

        run_in_chunks(chunk, tensions.shape[0], threads)
        return out


#: the registry's instance
COSSERAT = CosseratModel()

"""The Cosserat-rod model of the same robot, and its shooting solver.

The backbone is a Kirchhoff rod (bending EI, torsion GJ; inextensible and
unshearable by default, with shear GA and extension EA as an option), each
tendon runs along it at its routing radius and angle (Rucker & Webster 2011,
straight routing) and ends at its anchor disk. Disk weights and point
wrenches act at the disks, the backbone's weight along it, the tip wrench at
the tip: the loads, the routing and the packing are those of the PCC model
(:class:`~pytdcr.statics.model.StaticModel`); only the backbone's mechanics
differ. See :mod:`pytdcr.statics._cosserat_kernels` for the equations.

The boundary-value problem has three unknowns, the total moment at the base
(the total force there is known), found by SciPy's MINPACK hybrid root finder
on the tip residual; a cold start that fails is retried by load continuation.
The model has no tendon friction: a robot with a friction law is refused.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from scipy.optimize import root

from ..design import ConstantFriction, NoFriction, Robot
from ..loads import Loads
from ..results import StaticSolution
from . import _cosserat_kernels as CK
from .model import StaticModel

__all__ = ["CosseratModel", "CosseratOptions", "solve_cosserat"]

_PATHS = ("direct", "loading", "snap", "fallback")
_MIN_DLAM = 1.0 / 1024.0


@dataclass(frozen=True)
class CosseratOptions:
    """Options of the Cosserat model and its solver.

    Parameters
    ----------
    atol : float
        Converged when max |tip moment residual| <= atol [N m].
    max_eval : int
        Shooting integrations allowed per root solve.
    steps_per_subsegment : int
        Classical Runge-Kutta steps between neighbouring disks.
    shear_extension : bool
        Model shear (GA) and extension (EA) of the backbone; default inextensible.
    load_stepping : {'always', 'auto', 'never'}
        'always' (default) follows the loading path from the unloaded robot, as
        the PCC solver does; 'auto' solves at full load first; 'never' only that.
    """

    atol: float = 1e-9
    max_eval: int = 200
    steps_per_subsegment: int = 4
    shear_extension: bool = False
    load_stepping: Literal["always", "auto", "never"] = "always"

    def __post_init__(self) -> None:
        check_common_options(self.atol, self.load_stepping)
        if self.max_eval < 4:
            raise ValueError(f"max_eval must be >= 4, got {self.max_eval}")
        if not 1 <= self.steps_per_subsegment <= 1000:
            raise ValueError(f"steps_per_subsegment must be in [1, 1000], got {self.steps_per_subsegment}")


def check_common_options(atol: float, load_stepping: str) -> None:
    """Validate the options every solver shares; ValueError naming the field and its range."""
    if not (np.isfinite(atol) and atol > 0):
        raise ValueError(f"atol must be finite and > 0, got {atol}")
    if load_stepping not in ("always", "auto", "never"):
        raise ValueError(f"load_stepping must be one of ['always', 'auto', 'never'], got {load_stepping!r}")


@dataclass(frozen=True, eq=False)
class CosseratModel:
    """The shooting problem of ``robot`` under ``loads`` (three unknowns: the base moment).

    Attributes
    ----------
    packed : StaticModel
        The loads and routing, packed exactly as for the PCC model.
    stiff : ndarray, shape (4,)
        EI, GJ [N m^2], GA, EA [N].
    holes : ndarray, shape (n_tendons, 3)
        Routing r_c in the body frame [m].
    mpl : float
        Backbone mass per length [kg/m].
    """

    packed: StaticModel
    stiff: np.ndarray
    holes: np.ndarray
    mpl: float
    shear_extension: bool
    nsub: int

    @classmethod
    def build(cls, robot: Robot, loads: Loads, options: CosseratOptions | None = None) -> CosseratModel:
        """Pack ``robot`` and ``loads``; ValueError if the robot has friction."""
        opts = options or CosseratOptions()
        law = robot.friction
        if not (isinstance(law, NoFriction) or (isinstance(law, ConstantFriction) and law.mu0 == 0.0)):
            raise ValueError(
                f"robot.friction: the cosserat model has no tendon friction; use friction 'none' "
                f"(robot '{robot.name}' has law '{law.law}')"
            )
        packed = StaticModel.build(robot, loads)
        bb = robot.backbone
        area = math.pi * (bb.outer_radius**2 - bb.inner_radius**2)
        stiff = np.array([bb.bending_stiffness, bb.torsional_stiffness, bb.shear * area, bb.youngs_modulus * area])
        return cls(packed=packed, stiff=stiff, holes=np.ascontiguousarray(robot.tendon_holes), mpl=bb.mass_per_length,
                   shear_extension=bool(opts.shear_extension), nsub=int(opts.steps_per_subsegment))

    @property
    def robot(self) -> Robot:
        """The robot this model was built from."""
        return self.packed.robot

    def _shoot(self, m0: np.ndarray, lam: float, record: bool = False) -> tuple[np.ndarray, bool, tuple]:
        p = self.packed
        n = p.sub.shape[0]
        if record:
            out = (np.empty((n + 1, 3)), np.empty((n + 1, 3, 3)), np.empty((n * self.nsub + 1, 3)))
        else:
            out = (np.empty((1, 3)), np.empty((1, 3, 3)), np.empty((1, 3)))
        res = np.empty(6)
        ok = CK.shoot(np.ascontiguousarray(m0, dtype=float), float(lam), p.sub[:, 0], self.stiff, self.mpl,
                      p.sub[:, 3], self.holes, p.anchor, p.tension, p.grav, p.pforce, p.pmoment,
                      self.shear_extension, self.nsub, record, *out, res)
        return res[:3], bool(ok), out

    def residual(self, m0: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Total moment just past the tip [N m], shape (3,), for base moment ``m0`` (3,) [N m].

        Zero at an equilibrium; NaN where the rod's balance has no solution.
        """
        m0 = np.asarray(m0, dtype=float)
        if m0.shape != (3,) or not np.all(np.isfinite(m0)):
            raise ValueError(f"m0 must be 3 finite numbers [N m], got {m0!r}")
        return self._shoot(m0, load_factor)[0]

    def shape(self, m0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Disk positions (N+1, 3) [m], disk rotations (N+1, 3, 3) and backbone points (N nsub + 1, 3)."""
        return self._shoot(np.asarray(m0, dtype=float), 1.0, record=True)[2]

    def tip_and_gradient(self, m0: np.ndarray, rel_step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (3,) [m] at the equilibrium ``m0`` and its derivative by the tensions (3, n_tendons) [m/N].

        Implicit function theorem on the shooting residual r(m0, T) = 0:
        dm0/dT = -(dr/dm0)^-1 dr/dT, every partial by central differences of
        the integration (relative step ``rel_step``).
        """
        p = self.packed
        m0 = np.asarray(m0, dtype=float)

        def run(m: np.ndarray, tension: np.ndarray) -> np.ndarray:
            out = (np.empty((1, 3)), np.empty((1, 3, 3)), np.empty((1, 3)))
            res = np.empty(6)
            CK.shoot(m, 1.0, p.sub[:, 0], self.stiff, self.mpl, p.sub[:, 3], self.holes, p.anchor, tension,
                     p.grav, p.pforce, p.pmoment, self.shear_extension, self.nsub, False, *out, res)
            return res

        base = run(m0, p.tension)
        nt = p.tension.size
        d_m = np.empty((6, 3))
        hm = rel_step * max(1e-4, float(np.max(np.abs(m0))))
        for j in range(3):
            e = np.zeros(3)
            e[j] = hm
            d_m[:, j] = (run(m0 + e, p.tension) - run(m0 - e, p.tension)) / (2.0 * hm)
        d_t = np.empty((6, nt))
        ht = rel_step * max(1.0, float(np.max(p.tension)))
        for c in range(nt):
            e = np.zeros(nt)
            e[c] = ht
            d_t[:, c] = (run(m0, p.tension + e) - run(m0, p.tension - e)) / (2.0 * ht)
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


def _root(model: CosseratModel, lam: float, x0: np.ndarray, atol: float,
          max_eval: int, xtol: float = 1e-13) -> tuple[np.ndarray, float, int]:
    """One root solve at load factor ``lam``; returns (m0, max |residual|, integrations)."""
    scale = max(1e-6, float(np.max(np.abs(x0))), float(np.max(np.abs(model.straight_guess(lam)))))
    count = 0

    def fun(z: np.ndarray) -> np.ndarray:
        nonlocal count
        count += 1
        r = model._shoot(z * scale, lam)[0]
        return r / scale if np.all(np.isfinite(r)) else np.full(3, 1e6)

    r0 = model._shoot(x0, lam)[0]
    count += 1
    if np.all(np.isfinite(r0)) and np.max(np.abs(r0)) <= atol:
        return x0, float(np.max(np.abs(r0))), count
    sol = root(fun, x0 / scale, method="hybr", options={"xtol": xtol, "maxfev": max_eval})
    m0 = sol.x * scale
    r = model._shoot(m0, lam)[0]
    count += 1
    res = float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else math.inf
    return m0, res, count


def _ramp(model: CosseratModel, opts: CosseratOptions) -> tuple[np.ndarray, float, int, int, float]:
    """Follow the loading path from lam = 0; returns (m0, residual, integrations, steps, last lam reached)."""
    lam = 0.0
    x = np.zeros(3)
    x_prev, lam_prev = None, None
    dlam = 0.25
    count = steps = 0
    step_atol = max(opts.atol, 1e-8)
    res = 0.0
    while lam < 1.0:
        target = min(1.0, lam + dlam)
        guess = x if x_prev is None else x + (x - x_prev) * (target - lam) / (lam - lam_prev)
        tol = opts.atol if target == 1.0 else step_atol
        # intermediate steps only track the branch: a looser step tolerance
        m0, res, c = _root(model, target, guess, tol, opts.max_eval, 1e-13 if target == 1.0 else 1e-7)
        count += c
        steps += 1
        if res <= tol:
            x_prev, lam_prev = x, lam
            x, lam = m0, target
            dlam = min(0.5, dlam * 1.5)
        else:
            dlam /= 2.0
            if dlam < _MIN_DLAM:
                return x, math.inf, count, steps, lam
    return x, res, count, steps, lam


def solve_cosserat(model: CosseratModel, m0: np.ndarray | None = None,
                   options: CosseratOptions | None = None) -> StaticSolution:
    """Solve the Cosserat model; the result has the same type as the PCC solver's.

    Parameters
    ----------
    model : CosseratModel
    m0 : array-like, shape (3,), optional
        Warm start: the base moment [N m] of a nearby solution (``solution.q``).
    options : CosseratOptions, optional
        Must match the ones the model was built with (steps, shear/extension).

    Returns
    -------
    StaticSolution
        ``model == "cosserat"``; ``q`` is the base moment (3,) [N m];
        ``iterations`` counts shooting integrations. ``path`` as for the PCC
        solver, except that at a fold (``"snap"``) the root finder jumps to
        full load from the last equilibrium instead of relaxing.
    """
    opts = options or CosseratOptions()
    t0 = time.perf_counter()
    count = steps = 0
    path = 0
    warm = m0 is not None
    if warm:
        x0 = np.asarray(m0, dtype=float).reshape(-1)
        if x0.shape != (3,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"m0 must be 3 finite numbers [N m], got {m0!r}")
    else:
        x0 = model.straight_guess()
    x, res = x0, math.inf
    if opts.load_stepping in ("auto", "never") or warm:
        x, res, count = _root(model, 1.0, x0, opts.atol, opts.max_eval)
    if res > opts.atol and opts.load_stepping != "never":
        x, res, c, steps, lam = _ramp(model, opts)
        count += c
        path = 1
        if res > opts.atol and lam > 0.0:  # a fold of the loading path: jump to full load from there
            x, res, c = _root(model, 1.0, x, opts.atol, opts.max_eval)
            count += c
            path = 2
        if res > opts.atol:
            x, res, c = _root(model, 1.0, x0, opts.atol, opts.max_eval)
            count += c
            path = 3
    converged = bool(res <= opts.atol and np.all(np.isfinite(x)))
    pos, rot, curve = model.shape(x)
    seconds = time.perf_counter() - t0
    p = model.packed
    n = p.sub.shape[0]
    pieces = np.arange(1, n + 1)
    tensions = np.where(pieces[None, :] <= p.anchor[:, None], p.tension[:, None], 0.0)
    return StaticSolution(
        converged=converged, residual=float(res), iterations=int(count), load_steps=int(steps),
        path=_PATHS[path], q=np.array(x, dtype=float), tensions=tensions, seconds=seconds, atol=opts.atol,
        _positions=pos, _rotations=rot, model="cosserat", _curve=curve,
    )

"""The equilibrium equations of the PCC model, packed for the compiled kernels.

The model knows nothing of how it is solved (see :mod:`pytdcr.statics.solve`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import ConstantFriction, ExponentialFriction, NoFriction, Robot
from ..loads import Loads
from . import _kernels as K

__all__ = ["StaticModel", "friction_params"]


def friction_params(robot: Robot, release: bool) -> np.ndarray:
    """Kernel parameters of the robot's friction law: (code, mu0, decay [1/rad], mode)."""
    law = robot.friction
    mode = -1.0 if release else 1.0
    if isinstance(law, NoFriction):
        return np.array([0.0, 0.0, 0.0, mode])
    if isinstance(law, ConstantFriction):
        return np.array([1.0, law.mu0, 0.0, mode])
    if isinstance(law, ExponentialFriction):
        return np.array([2.0, law.mu0, law.decay_per_deg * 180.0 / np.pi, mode])
    raise TypeError(f"unsupported friction law {type(law).__name__}")  # pragma: no cover


@dataclass(frozen=True, eq=False)
class StaticModel:
    """The 3N equilibrium equations of ``robot`` under ``loads``.

    Attributes
    ----------
    robot : Robot
    loads : Loads
    sub : ndarray, shape (N, 5)
        Per subsegment: length [m], EI [N m^2], GJ [N m^2], disk mass [kg],
        backbone piece mass [kg].
    holes : ndarray, shape (n_tendons, 2)
        Hole (x, y) of each tendon in its disk frame [m].
    anchor : ndarray of int64, shape (n_tendons,)
        1-based anchor disk of each tendon.
    fric : ndarray, shape (4,)
        Friction law parameters for the kernels.
    tension : ndarray, shape (n_tendons,)
        Actuator tensions [N].
    grav : ndarray, shape (3,)
        Gravity in the base frame [m/s^2].
    pforce, pmoment : ndarray, shape (N, 3)
        External force [N] and moment [N m] on each disk, base frame.
    """

    robot: Robot
    loads: Loads
    sub: np.ndarray
    holes: np.ndarray
    anchor: np.ndarray
    fric: np.ndarray
    tension: np.ndarray
    grav: np.ndarray
    pforce: np.ndarray
    pmoment: np.ndarray

    @classmethod
    def build(cls, robot: Robot, loads: Loads) -> StaticModel:
        """Pack ``robot`` and ``loads``; raises ValueError on a mismatch between them."""
        n = robot.n_disks
        if loads.tensions.shape != (robot.n_tendons,):
            raise ValueError(
                f"tensions must have {robot.n_tendons} entries (one per tendon of robot "
                f"'{robot.name}'), got {loads.tensions.shape[0]}"
            )
        lengths = robot.subsegment_lengths
        bb = robot.backbone
        sub = np.empty((n, 5))
        sub[:, 0] = lengths
        sub[:, 1] = bb.bending_stiffness
        sub[:, 2] = bb.torsional_stiffness
        sub[:, 3] = robot.disk_masses
        sub[:, 4] = bb.mass_per_length * lengths
        pforce = np.zeros((n, 3))
        pmoment = np.zeros((n, 3))
        pforce[n - 1] += loads.tip_force
        pmoment[n - 1] += loads.tip_moment
        for p in loads.point_loads:
            if p.disk > n:
                raise ValueError(f"point load disk must be between 1 and {n}, got {p.disk}")
            pforce[p.disk - 1] += p.force
            pmoment[p.disk - 1] += p.moment
        return cls(
            robot=robot,
            loads=loads,
            sub=sub,
            holes=np.ascontiguousarray(robot.tendon_holes[:, :2]),
            anchor=robot.anchor_disks,
            fric=friction_params(robot, loads.release),
            tension=np.array(loads.tensions, dtype=float),
            grav=np.array(robot.gravity, dtype=float),
            pforce=pforce,
            pmoment=pmoment,
        )

    @property
    def n_unknowns(self) -> int:
        """3N."""
        return 3 * self.sub.shape[0]

    def _args(self) -> tuple:
        return (self.sub, self.holes, self.anchor, self.fric, self.tension, self.grav, self.pforce, self.pmoment)

    def _check_q(self, q: np.ndarray) -> np.ndarray:
        q = np.ascontiguousarray(q, dtype=float).reshape(-1)
        if q.shape != (self.n_unknowns,):
            raise ValueError(f"q must have {self.n_unknowns} entries (N x 3), got {q.size}")
        return q

    def _evaluate(self, q: np.ndarray, load_factor: float, want_jac: bool) -> tuple[np.ndarray, np.ndarray, tuple]:
        """Run the kernel once: residual (3N,), Jacobian (3N, 3N) or a dummy, and the work arrays."""
        q = self._check_q(q)
        m = self.n_unknowns
        r = np.empty(m)
        J = np.empty((m, m)) if want_jac else np.empty((1, 1))
        work = K.make_work(self.sub.shape[0], self.holes.shape[0])
        K.evaluate(q, float(load_factor), *self._args(), want_jac, r, J, work)
        return r, J, work

    def residual(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Equilibrium residual [N m], shape (N, 3): row i in frame i-1.

        Parameters
        ----------
        q : array-like, shape (N, 3) or (3N,)
            (beta, gamma, eps) per subsegment [1/m, 1/m, rad].
        load_factor : float
            Scale on every load (1: the full loads).
        """
        return self._evaluate(q, load_factor, False)[0].reshape(-1, 3)

    def jacobian(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Exact Jacobian of the flattened residual, shape (3N, 3N) [N m per unit of q]."""
        return self._evaluate(q, load_factor, True)[1]

    def tensions(self, q: np.ndarray) -> np.ndarray:
        """Tension in every tendon piece [N], shape (n_tendons, N); 0 past the anchor."""
        T = self._evaluate(q, 1.0, False)[2][8]
        return np.ascontiguousarray(T[1 : self.sub.shape[0] + 1].T)

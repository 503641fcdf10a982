"""The paper's piecewise-constant-curvature model (MODEL.md) and its solver.

:class:`PCCEquations` packs a robot and its loads into the 3N equilibrium
equations and evaluates them (residual, exact Jacobian, tendon tensions); it
knows nothing of how they are solved. :class:`PCCModel` is the registry's
entry: it solves them (quasi-Newton with an exact Jacobian along the loading
path, see :func:`pytdcr.statics.kernels.loading_path.solve_one`) for one tension vector
or a batch, and differentiates an equilibrium's tip by the tensions.

Both run in the compiled core, ``pytdcr._core`` (C++ built at install: ``src/cpp/pcc.hpp``,
``loading_path.hpp``, ``stiffness.hpp``), the twin of the numba kernels of
:mod:`pytdcr.statics.kernels.pcc` and :mod:`~pytdcr.statics.kernels.loading_path`
(the same residual and Jacobian to the bit; the solver's linear algebra is our
own, LU factors with Broyden's updates in product form where numba keeps an
explicit inverse, so a solve agrees with numba's to round-off): nothing compiles
at first use.

Which equilibrium? A robot under large loads can have several. By default
(``load_stepping="always"``) the solver follows the loading path: every load
(tensions, gravity, external wrenches) is ramped from zero, where the straight
robot is exact, to its full value in adaptive steps, which is the branch that
quasi-static loading reaches. At a fold of that path (a snap-through) it
relaxes to the equilibrium the robot snaps to. Only if that fails does it
settle for any equilibrium at full load (path ``"fallback"``). ``"auto"``
tries Newton at full load first (faster, but the branch it lands on is
whichever Newton reaches); a warm start ``q0`` is always followed directly
first.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import _core
from ..loads import Loads
from ..robot import ConstantFriction, ExponentialFriction, NoFriction, Robot
from .base import Capabilities
from .compiled import CompiledModel, Evaluation, Kernels, PackedEquations
from .kernels import pcc as K
from .options import SolverOptions

__all__ = ["CORE_KERNELS", "PCC", "PCCEquations", "PCCModel", "friction_params"]

#: the compiled core's solver and stiffness kernels for the PCC family (``pytdcr._core``; C++ built at install)
CORE_KERNELS = Kernels(_core.solve_range_pcc, _core.jacobian_range_pcc, _core.largest_residuals_pcc,
                       _core.tip_gradient_range_pcc)


def friction_params(robot: Robot, release: bool) -> np.ndarray:
    """Kernel parameters of the robot's friction law, shape (4,): (code, mu at sigma = 0, decay [1/rad], mode)."""
    law = robot.friction
    mode = -1.0 if release else 1.0
    if isinstance(law, NoFriction):
        return np.array([0.0, 0.0, 0.0, mode])
    if isinstance(law, ConstantFriction):
        return np.array([1.0, law.mu, 0.0, mode])
    if isinstance(law, ExponentialFriction):
        return np.array([2.0, law.mu0, law.decay_per_deg * 180.0 / np.pi, mode])
    raise TypeError(f"unsupported friction law {type(law).__name__}")  # pragma: no cover


@dataclass(frozen=True, eq=False)
class PCCEquations(PackedEquations):
    """The 3N equilibrium equations of ``robot`` under ``loads`` (MODEL.md).

    Attributes
    ----------
    robot : Robot
    loads : Loads
    packed : pytdcr.statics.kernels.pcc.Packed
        The arrays the kernels take: ``sub`` (N, 5) per subsegment: length [m],
        EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg];
        ``holes`` (n_tendons, 2) hole (x, y) in the disk frame [m]; ``anchor``
        (n_tendons,) 1-based anchor disk; ``fric`` (4,) friction law;
        ``tension`` (n_tendons,) [N]; ``grav`` (3,) [m/s^2]; ``pforce``,
        ``pmoment`` (N, 3) wrench on each disk, base frame [N, N m]; ``balance``
        where each subsegment's moment balance is taken.
    """

    per_subsegment = 3
    robot: Robot
    loads: Loads
    packed: K.Packed
    kernels = CORE_KERNELS

    @cached_property
    def kernel_model(self) -> _core.PccModel:
        """The packed equations as the compiled core takes them (a copy of :attr:`packed`, made once)."""
        return _core.PccModel.from_packed(self.packed)

    @classmethod
    def build(cls, robot: Robot, loads: Loads, balance: int = K.BALANCE_BASE) -> PCCEquations:
        """Pack ``robot`` and ``loads``; raises ValueError on a mismatch between them.

        ``balance`` says where each subsegment's moment balance is taken: about its base (the paper's,
        MODEL.md) or about its midpoint (``pcc2``, MODEL.md appendix A).
        """
        n = robot.n_disks
        tensions = loads.tensions_for(robot.n_tendons)  # none given: every tendon slack
        if tensions.shape != (robot.n_tendons,):
            raise ValueError(
                f"tensions must have {robot.n_tendons} entries (one per tendon of robot "
                f"'{robot.name}'), got {tensions.shape[0]}"
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
        packed = K.Packed(sub, np.array(robot.tendon_holes[:, :2]), robot.anchor_disks.copy(),
                          friction_params(robot, loads.release), np.array(tensions, dtype=float),
                          np.array(robot.gravity, dtype=float), pforce, pmoment, int(balance))
        return cls(robot=robot, loads=loads, packed=packed)

    def evaluate(self, q: np.ndarray, load_factor: float = 1.0, jacobian: bool = False) -> Evaluation:
        """Residual, optionally the exact Jacobian, and the tendon tensions at ``q`` (3N,) or (N, 3)."""
        r, J, T = self.kernel_model.evaluate(self.check_q(q), float(load_factor), bool(jacobian))
        return Evaluation(r, J, np.ascontiguousarray(T[1 : self.n_disks + 1].T))

    def residual(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Equilibrium residual [N m], shape (N, 3): row i in frame i-1.

        Parameters
        ----------
        q : array-like, shape (N, 3) or (3N,)
            (beta, gamma, eps) per subsegment [1/m, 1/m, rad].
        load_factor : float
            Scale on every load (1: the full loads).
        """
        return self.evaluate(q, load_factor).residual.reshape(-1, 3)

    def jacobian(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Exact Jacobian of the flattened residual, shape (3N, 3N) [N m per unit of q]."""
        return self.evaluate(q, load_factor, jacobian=True).jacobian

    def tensions(self, q: np.ndarray) -> np.ndarray:
        """Tension in every tendon piece [N], shape (n_tendons, N); 0 past the anchor."""
        return self.evaluate(q).tensions

    def shape(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, None]:
        """Disk positions (N+1, 3) [m] and rotations (N+1, 3, 3); the backbone is drawn from q's arcs."""
        pos, rot = _core.frames(np.ascontiguousarray(q, dtype=float).reshape(-1), self.packed.sub)
        return pos, rot, None

    def tip_jacobian(self, q: np.ndarray) -> np.ndarray:
        """Exact derivative of the tip by the unknowns, shape (3, 3N) (:func:`pytdcr.kinematics.tip_jacobian`)."""
        return self.kernel_model.tip_jacobian(self.check_q(q))

    def pose_jacobians(self, q: np.ndarray) -> np.ndarray:
        """Exact derivatives of every disk's pose by the unknowns, shape (N+1, 6, 3N): rows 0-2 the position
        [m per unit of q], rows 3-5 the rotation (the angular change w, base frame, dR = [w]x R) [rad per unit].

        Moving subsegment i moves every disk j >= i rigidly: d p_j = R_(i-1) (dd + dR x_j), x_j the disk in
        frame i, and turns it by R_(i-1) vee(dR Rloc_i^T) (the closed-form subsegment derivatives,
        :func:`pytdcr.kinematics.subsegment_derivatives`); disks before i do not move."""
        q = self.check_q(q)
        n = self.n_disks
        pos, rot, _ = self.shape(q)
        out = np.zeros((n + 1, 6, 3 * n))
        for i in range(1, n + 1):
            k = 3 * (i - 1)
            dR, dd = _core.subsegment_derivatives(q[k], q[k + 1], q[k + 2], self.packed.sub[i - 1, 0])
            P = rot[i - 1]
            local = P.T @ rot[i]  # the subsegment's own rotation
            x = (pos[i:] - pos[i]) @ rot[i]  # disks i..N in frame i, (N+1-i, 3)
            for a in range(3):
                out[i:, :3, k + a] = (dd[a] + x @ dR[a].T) @ P.T
                W = dR[a] @ local.T
                out[i:, 3:, k + a] = P @ np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2
        return out


class PCCModel(CompiledModel):
    """The registry's entry for the paper's PCC model (see the module docstring)."""

    kernels = K
    packed_type = K.Packed
    name = "pcc"
    description = "the paper's piecewise constant curvature model (balance about each subsegment's base, MODEL.md)"
    balance = K.BALANCE_BASE
    options_type = SolverOptions
    capabilities = Capabilities(friction=True, point_wrenches=True, gradient="exact", stability=True,
                                continuation=True)
    unknowns = "q: (N, 3), (beta [1/m], gamma [1/m], eps [rad]) per subsegment"

    def equations(self, robot: Robot, loads: Loads, options: SolverOptions | None = None) -> PCCEquations:
        """The packed equations of ``robot`` under ``loads``."""
        return PCCEquations.build(robot, loads, self.balance)


#: the registry's instance
PCC = PCCModel()

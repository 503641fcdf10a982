"""``sscr``: the subsegment Cosserat rod, the reference model of disk-type TDCRs.

The backbone between neighbouring disks is a Cosserat rod (Kirchhoff by
default: inextensible and unshearable; shear and extension as an option); each
disk is a rigid body on the rod that receives the tendon forces through its
holes along the actual chords to the neighbouring disks (MODEL.md's pull rule,
the full pull at the anchor disk), the tendon-disk friction laws of the PCC
model (none, constant, the paper's; pull and release), the disk's weight and
any external wrench. The backbone's own weight acts along the rod.

Solved by multiple shooting: one unknown base wrench per subsegment (6N
unknowns), the disks' balances as the residual, the exact Jacobian of the
discrete scheme (forward mode through every Runge-Kutta step), and the PCC
solver's loading path from the unloaded robot. Equations and Jacobian:
:mod:`pytdcr.statics.kernels.sscr`.

Runs in the compiled core, ``pytdcr._core`` (C++ built at install:
``src/cpp/sscr.hpp``, ``loading_path.hpp``, ``stiffness.hpp``), the twin of the
numba kernels of :mod:`pytdcr.statics.kernels.sscr` and
:mod:`~pytdcr.statics.kernels.loading_path` (the same residual and Jacobian to
the bit; the solver's linear algebra is our own (LU factors with Broyden's
updates in product form where numba keeps an explicit inverse), so a solve
agrees with numba's to round-off): nothing compiles at first
use.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import _core
from ..loads import Loads
from ..robot import Robot
from .base import Capabilities
from .compiled import CompiledModel, Evaluation, Kernels, PackedEquations
from .kernels import sscr as SK
from .options import SSCROptions
from .pcc import PCCEquations

__all__ = ["SSCR", "SSCR_CORE_KERNELS", "SSCREquations", "SSCRModel", "SSCROptions"]

#: the compiled core's solver and stiffness kernels for the subsegment Cosserat rod (``pytdcr._core``; C++ built
#: at install)
SSCR_CORE_KERNELS = Kernels(_core.solve_range_sscr, _core.jacobian_range_sscr, _core.largest_residuals_sscr,
                            _core.tip_gradient_range_sscr)


@dataclass(frozen=True, eq=False)
class SSCREquations(PackedEquations):
    """The 6N disk balances of ``robot`` under ``loads`` (see :mod:`pytdcr.statics.kernels.sscr`), evaluated and
    solved in the compiled core (:attr:`kernels`, :attr:`kernel_model`).

    Attributes
    ----------
    robot : Robot
    loads : Loads
    packed : pytdcr.statics.kernels.sscr.SSCRPacked
        The PCC model's packed loads and routing, plus the rod's shear and
        axial stiffness, mass per length, extensibility and integration steps.
    """

    per_subsegment = 6
    robot: Robot
    loads: Loads
    packed: SK.SSCRPacked
    kernels = SSCR_CORE_KERNELS

    @cached_property
    def kernel_model(self) -> _core.SscrModel:
        """The packed equations as the compiled core takes them (a copy of :attr:`packed`, made once)."""
        return _core.SscrModel.from_packed(self.packed)

    @classmethod
    def build(cls, robot: Robot, loads: Loads, options: SSCROptions | None = None) -> SSCREquations:
        """Pack ``robot`` and ``loads`` with the rod's options."""
        opts = options or SSCROptions()
        p = PCCEquations.build(robot, loads).packed
        bb = robot.backbone
        area = np.pi * (bb.outer_radius**2 - bb.inner_radius**2)
        rod = np.array([bb.shear * area, bb.youngs_modulus * area, bb.mass_per_length,
                        1.0 if opts.shear_extension else 0.0, float(opts.steps_per_subsegment)])
        packed = SK.SSCRPacked(p.sub, p.holes, p.anchor, p.fric, p.tension, p.grav, p.pforce, p.pmoment, rod)
        return cls(robot=robot, loads=loads, packed=packed)

    def evaluate(self, q: np.ndarray, load_factor: float = 1.0, jacobian: bool = False) -> Evaluation:
        """Residual (6N,) [N m], optionally its exact Jacobian (6N, 6N), and the tendon tensions (nt, N) [N]."""
        r, J, T = self.kernel_model.evaluate(self.check_q(q), float(load_factor), bool(jacobian))
        return Evaluation(r, J, np.ascontiguousarray(T[1 : self.n_disks + 1].T))

    def residual(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """The disk balances, shape (N, 6): l_i times the force balance [N m], then the moment balance [N m]."""
        return self.evaluate(q, load_factor).residual.reshape(-1, 6)

    def jacobian(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Exact Jacobian of the flattened residual, shape (6N, 6N)."""
        return self.evaluate(q, load_factor, jacobian=True).jacobian

    def shape(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Disk positions (N+1, 3) [m], rotations (N+1, 3, 3) and backbone points (N steps + 1, 3) [m]."""
        return self.kernel_model.record_shape(np.ascontiguousarray(q, dtype=float).reshape(-1))

    def tip_jacobian(self, q: np.ndarray) -> np.ndarray:
        """Exact derivative of the tip position by the unknowns, shape (3, 6N) (the chained sensitivities)."""
        return self.kernel_model.tip_jacobian(self.check_q(q))

    def pose_jacobians(self, q: np.ndarray) -> np.ndarray:
        """Exact derivatives of every disk's pose by the unknowns, shape (N+1, 6, 6N): position [m per unit of
        q], then rotation (the angular change w, base frame, dR = [w]x R) (the chained sensitivities)."""
        return self.kernel_model.pose_jacobians(self.check_q(q))


class SSCRModel(CompiledModel):
    """The registry's entry for the subsegment Cosserat rod (see the module docstring): solved, differentiated and
    tested for stability in the compiled core."""

    kernels = SK
    packed_type = SK.SSCRPacked
    checks_self_contact = True
    name = "sscr"
    description = ("subsegment Cosserat rod: a rod between each pair of disks, tendons as chords, friction "
                   "(the reference)")
    options_type = SSCROptions
    capabilities = Capabilities(friction=True, point_wrenches=True, gradient="exact", stability=True,
                                continuation=True)
    unknowns = ("q: (N, 6), per subsegment the internal force times the subsegment's length and the internal "
                "moment at its base, world frame [N m]")
    unknowns_per_disk = 6
    #: measured: 7.3 dense matrices in all at 200-400 disks, of which (N + 2)(6 + n_tendons) rows of
    #: sensitivities (:meth:`extra_words`)
    peak_matrices = 5.5
    #: measured: 400 disks 2.5 s
    seconds_per_cubed_unknown = 1.8e-10

    def tangent_stiffnesses(self, eq: SSCREquations, q: np.ndarray, tensions: np.ndarray, rows: np.ndarray,
                            start: int, stop: int, out: np.ndarray) -> None:
        """For k in ``start <= k < stop``: the tangent stiffness of the disks' poses (6N, 6N) [N m] at the
        equilibrium ``q[rows[k]]`` (B, 6N) at the tensions ``tensions[rows[k]]`` (B, nt) [N], into
        ``out[k - start]`` (the compiled core's twin of :func:`pytdcr.statics.kernels.sscr.tangent_stiffness`, the GIL
        released)."""
        _core.stiffness_range_sscr(q, eq.kernel_model, tensions, rows, start, stop, out)

    def extra_words(self, robot: Robot, nq: int) -> float:
        """The sensitivities carried along the rod, (N + 2)(6 + n_tendons) x 6N, and the per-disk work."""
        return (robot.n_disks + 2.0) * (6 + robot.n_tendons) * nq + robot.n_disks * (500.0 + 80.0 * robot.n_tendons)

    def equations(self, robot: Robot, loads: Loads, options: SSCROptions | None = None) -> SSCREquations:
        """The packed equations of ``robot`` under ``loads``."""
        return SSCREquations.build(robot, loads, options)


#: the registry's instance
SSCR = SSCRModel()

"""Exact derivatives of an equilibrium: how its shape moves with the tensions, and how its tip yields to a
wrench (the compliance and the stiffness).

At an equilibrium ``r(q; T, w) = 0`` of the unknowns q under the actuator tensions T and the tip wrench w, the
implicit function theorem gives ``dq = -J^-1 (dr/dT dT + dr/dw dw)`` with J the residual's exact Jacobian. The
residual is affine in T and in w at fixed q (a tension and a wrench enter every balance linearly once the shape
is fixed), so ``dr/dT`` and ``dr/dw`` are differences of residuals, exact. Every disk's pose by q is exact too
(each model's ``pose_jacobians``). Only models with an exact gradient have them (``pcc``, ``pcc2``, ``sscr``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from ..loads import Loads
from ..records import JsonDict
from ..results import StaticSolution
from ..robot import Robot
from .base import Model
from .equilibrium import check_solution
from .options import ModelOptions
from .registry import resolve

if TYPE_CHECKING:
    from .pcc import PCCEquations
    from .sscr import SSCREquations

__all__ = ["Jacobians", "TipCompliance", "equilibrium_jacobians", "tip_compliance"]


@dataclass(frozen=True, eq=False)
class Jacobians:
    """How an equilibrium's shape moves with the actuator tensions, tip wrench held fixed (exact).

    Attributes
    ----------
    tip_position : ndarray, shape (3, n_tendons)
        d tip / d T [m/N], base frame.
    tip_rotation : ndarray, shape (3, n_tendons)
        The tip frame's turn by T (angular change w, dR = [w]x R, base frame) [rad/N].
    tip_axis : ndarray, shape (3, n_tendons)
        d z_tip / d T [1/N]: the tip's unit axis (the disk normal, R[:, 2]), ``w x z``.
    disk_positions : ndarray, shape (N+1, 3, n_tendons)
        d p_k / d T of every disk [m/N] (row 0 the base, fixed: zero).
    """

    tip_position: np.ndarray
    tip_rotation: np.ndarray
    tip_axis: np.ndarray
    disk_positions: np.ndarray

    @property
    def tip_pose(self) -> np.ndarray:
        """The tip's position and axis by T, shape (6, n_tendons): rows [m/N] then [1/N]."""
        return np.vstack([self.tip_position, self.tip_axis])

    def to_dict(self) -> JsonDict:
        """JSON-ready form (nested lists)."""
        return {"tip_position": self.tip_position.tolist(), "tip_rotation": self.tip_rotation.tolist(),
                "tip_axis": self.tip_axis.tolist(), "disk_positions": self.disk_positions.tolist()}


@dataclass(frozen=True, eq=False)
class TipCompliance:
    """The tip's compliance at an equilibrium, tensions held fixed, linearised (exact derivatives).

    Attributes
    ----------
    matrix : ndarray, shape (6, 6)
        Rows (displacement [m]; rotation [rad]) of the tip, columns (force [N]; moment [N m]) applied at the
        tip, all in the base frame: ``matrix[:3, :3]`` is d tip / d force [m/N], ``matrix[3:, 3:]`` the turn
        by a moment [rad/(N m)].
    """

    matrix: np.ndarray

    @property
    def stiffness(self) -> np.ndarray:
        """The inverse, shape (6, 6): the tip wrench (force [N]; moment [N m]) per unit displacement and
        rotation; LinAlgError where the compliance is singular."""
        return np.linalg.inv(self.matrix)

    @property
    def translational_stiffness(self) -> np.ndarray:
        """The stiffness of the tip's position alone (moment held zero), shape (3, 3) [N/m]:
        ``inv(matrix[:3, :3])`` (not symmetric where friction or a fixed moment makes the loads
        non-conservative)."""
        return np.linalg.inv(self.matrix[:3, :3])

    def stiffness_range(self) -> tuple[float, float, np.ndarray, np.ndarray]:
        """The softest and stiffest the tip is to a force [N/m], and those forces' directions (unit, (3,)): the
        inverse of the largest and smallest singular values of ``matrix[:3, :3]`` (a unit force along the
        softest direction moves the tip farthest, 1/softest m)."""
        _, sv, vt = np.linalg.svd(self.matrix[:3, :3])
        soft, stiff = (1.0 / float(s) if s > 0.0 else math.inf for s in (sv[0], sv[-1]))  # a rigid direction: inf
        return soft, stiff, vt[0], vt[-1]

    def to_dict(self) -> JsonDict:
        """JSON-ready form: the compliance, its position block's stiffness (None where the tip cannot move in some
        direction: infinitely stiff there), and the softest and stiffest directions (:meth:`stiffness_range`;
        an infinite stiffness written as null)."""
        lo, hi, soft, stiff = self.stiffness_range()
        try:
            k = self.translational_stiffness.tolist()
        except np.linalg.LinAlgError:  # a direction the tip cannot move in (a straight inextensible backbone,
            k = None                   # along its axis): infinitely stiff there, no finite matrix
        return {"compliance": self.matrix.tolist(), "translational_stiffness_N_per_m": k,
                "translational_stiffness_range_N_per_m": [lo, hi], "softest_direction": soft.tolist(),
                "stiffest_direction": stiff.tolist()}


def _linearised(m: Model, robot: Robot, loads: Loads, solution: StaticSolution, options: ModelOptions
                ) -> tuple[PCCEquations | SSCREquations, np.ndarray, tuple[np.ndarray, np.ndarray], np.ndarray]:
    """The equations, the unknowns, the LU factors of the Jacobian and every disk's pose Jacobian (N+1, 6, m)."""
    if m.capabilities.gradient != "exact" or not hasattr(m, "equations"):
        raise ValueError(f"model '{m.name}' has no exact pose derivatives: use pcc, pcc2 or sscr")
    check_solution(m, robot, loads, solution, options)
    eq = m.equations(robot, loads, options)
    q = eq.check_q(solution.q)
    J = eq.evaluate(q, jacobian=True).jacobian
    return eq, q, lu_factor(J), eq.pose_jacobians(q)


def _rotated_axes(rot_tip: np.ndarray, w: np.ndarray) -> np.ndarray:
    """d z / d x for the tip axis z = R[:, 2] turned by w (3, K): w x z, shape (3, K)."""
    return np.cross(w.T, rot_tip[:, 2]).T


def equilibrium_jacobians(robot: Robot, loads: Loads, solution: StaticSolution, *, model: str | Model = "pcc",
                          options: ModelOptions | None = None) -> Jacobians:
    """Every disk's position and the tip's position, turn and axis by the actuator tensions at the converged
    ``solution`` of ``robot`` under ``loads`` (:class:`Jacobians`; exact, see the module).

    Raises ValueError for a model without exact derivatives, or a solution not of this robot, model and
    loads; NotConvergedError for one that did not converge."""
    m, opts = resolve(model, robot, loads, options, gradient=True)
    eq, q, lu, P = _linearised(m, robot, loads, solution, opts)
    r0 = eq.evaluate(q).residual
    nt = robot.n_tendons
    dr = np.empty((q.size, nt))
    for c in range(nt):
        t = eq.packed.tension.copy()
        t[c] += 1.0
        dr[:, c] = eq.with_tensions(t).evaluate(q).residual - r0
    dq = -lu_solve(lu, dr)
    moved = P @ dq  # (N+1, 6, nt)
    rot_tip = solution.disk_rotations[-1]
    return Jacobians(tip_position=moved[-1, :3], tip_rotation=moved[-1, 3:],
                     tip_axis=_rotated_axes(rot_tip, moved[-1, 3:]), disk_positions=moved[:, :3])


def tip_compliance(robot: Robot, loads: Loads, solution: StaticSolution, *, model: str | Model = "pcc",
                   options: ModelOptions | None = None) -> TipCompliance:
    """The 6x6 compliance of the tip at the converged ``solution`` of ``robot`` under ``loads``, tensions held
    fixed (:class:`TipCompliance`; its ``stiffness`` is the inverse): the tip's displacement and turn per unit
    force and moment added at the tip, all in the base frame, linearised with the exact derivatives.

    Raises as :func:`equilibrium_jacobians`."""
    m, opts = resolve(model, robot, loads, options, gradient=True)
    eq, q, lu, P = _linearised(m, robot, loads, solution, opts)
    r0 = eq.evaluate(q).residual
    dr = np.empty((q.size, 6))
    for c in range(6):
        field, k = ("pforce", c) if c < 3 else ("pmoment", c - 3)
        arr = getattr(eq.packed, field).copy()
        arr[-1, k] += 1.0
        dr[:, c] = replace(eq, packed=eq.packed._replace(**{field: arr})).evaluate(q).residual - r0
    return TipCompliance(matrix=P[-1] @ -lu_solve(lu, dr))

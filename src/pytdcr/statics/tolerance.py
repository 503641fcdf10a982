"""When an equilibrium counts as converged: the residual judged against the problem's own moment scale.

Every model's residual is a moment balance [N m] (the subsegment rod's force balances are multiplied by their
subsegment's length). An absolute test alone (max |residual| <= ``atol``) means nothing on its own: a very soft
backbone under a small tension is out of balance by less than 1e-9 N m while still straight, and a stiff one
under large loads cannot reach 1e-9 N m in float64. So each solve is judged by

    tol = clip(atol, FLOOR * S, RELATIVE * S)

where ``S`` [N m] is the moment scale of that robot under that load (:func:`moment_scale`): the moment every
applied load could exert about the base, plus the elastic moment of bending the whole backbone by a radian. The
user's ``atol`` holds wherever it is between a part in 10^12 of the scale (what float64 resolves in a balance of
that size, with room for thousands of disks) and a part in 10^8 (looser passes poses that are visibly out of
balance relative to their loads). A start point (the straight robot included) is accepted only by this test.

Intermediate load steps of the loading path (they only track the branch) are solved to
``max(tol, STEP_RELATIVE * S)``.
"""

from __future__ import annotations

import numpy as np

from ..loads import Loads
from ..robot import Robot

__all__ = ["FLOOR", "RELATIVE", "STEP_RELATIVE", "moment_scale", "tolerances"]

#: the loosest tolerance, relative to the moment scale
RELATIVE = 1e-8
#: the tightest tolerance, relative to the moment scale (float64's reach, with margin)
FLOOR = 1e-12
#: the tolerance of the loading path's intermediate steps, relative to the moment scale
STEP_RELATIVE = 1e-6


def moment_scale(robot: Robot, loads: Loads, tensions: np.ndarray) -> np.ndarray:
    """The moment scale S [N m] of ``robot`` under ``loads`` with each row of ``tensions`` (B, n_tendons) [N].

    S = sum_j T_j r_j (each tendon's tension times its routing radius) + L (|F_tip| + sum_k |F_k| + W)
    + |M_tip| + sum_k |M_k| + EI / L, with L the backbone's length [m], F_k, M_k the point loads, W the robot's
    weight [N] and EI / L the elastic moment of bending the whole backbone by one radian. Shape (B,).
    """
    T = np.asarray(tensions, dtype=float)
    T = T.reshape(T.shape[0] if T.ndim == 2 else 1, robot.n_tendons)
    radii = np.array([t.radius for t in robot.tendons], dtype=float)
    length = robot.length
    g = float(np.linalg.norm(robot.gravity))
    weight = g * (robot.backbone.mass_per_length * length + float(np.sum(robot.disk_masses)))
    forces = np.linalg.norm(loads.tip_force) + sum(float(np.linalg.norm(p.force)) for p in loads.point_loads)
    moments = np.linalg.norm(loads.tip_moment) + sum(float(np.linalg.norm(p.moment)) for p in loads.point_loads)
    fixed = length * (forces + weight) + moments + robot.backbone.bending_stiffness / length
    return T @ radii + fixed


def tolerances(robot: Robot, loads: Loads, tensions: np.ndarray, atol: float,
               step_relative: float = STEP_RELATIVE) -> tuple[np.ndarray, np.ndarray]:
    """Each case's convergence tolerance and load-step tolerance [N m], shapes (B,), for the rows of ``tensions``
    (B, n_tendons) [N] and the user's ``atol`` [N m] (the rule in this module's docstring; a solver whose load
    steps need more than :data:`STEP_RELATIVE` gives its own ``step_relative``)."""
    scale = moment_scale(robot, loads, tensions)
    tol = np.clip(float(atol), FLOOR * scale, RELATIVE * scale)
    return tol, np.maximum(tol, step_relative * scale)

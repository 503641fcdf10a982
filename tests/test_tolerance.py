"""Convergence is judged against the problem's own moment scale (issue 25): a robot whose stiffness and loads are
all scaled by the same factor takes the same shape, however small or large the factor, and a start point (the
straight robot) is never accepted only because everything is small."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import Loads, solve, solve_batch
from pytdcr.paper import paper_loads, paper_robot
from pytdcr.robot import NoFriction, Robot
from pytdcr.statics.tolerance import FLOOR, RELATIVE, moment_scale, tolerances

TENSIONS = np.array([5.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
MODELS = ("pcc", "pcc2", "sscr", "cosserat")


def scaled_robot(k: float, robot: Robot | None = None, outer_radius: float | None = None) -> Robot:
    """``robot`` (default the paper's) with its Young's modulus and every mass times ``k`` (and, given, another
    backbone radius)."""
    r = robot or paper_robot()
    bb = r.backbone
    update = {"youngs_modulus": bb.youngs_modulus * k, "mass_per_length": bb.mass_per_length * k}
    if outer_radius is not None:
        update["outer_radius"] = outer_radius
    segments = tuple(s.model_copy(update={"disk_mass": s.disk_mass * k}) for s in r.segments)
    return r.model_copy(update={"backbone": bb.model_copy(update=update), "segments": segments})


def robot_for(model: str) -> Robot:
    """The paper robot, without friction for the model that has none."""
    robot = paper_robot()
    return robot.with_friction(NoFriction()) if model == "cosserat" else robot


@pytest.mark.parametrize("model", MODELS)
def test_scaling_stiffness_and_every_load_keeps_the_shape(model: str) -> None:
    """E, masses (so gravity), tensions and the tip wrench all times k, for k from 1e-6 to 30 (E at most 2e12 Pa):
    the equilibrium is the same; the old absolute test accepted a pose 1e-6 out of scale as converged."""
    base = robot_for(model)
    wrench = paper_loads(TENSIONS)
    tips, tols = {}, {}
    for k in (1e-6, 1e-3, 1.0, 30.0):
        loads = Loads(TENSIONS * k, wrench.tip_force * k, wrench.tip_moment * k)
        robot = scaled_robot(k, base)
        sol = solve(robot, loads, model=model)
        assert sol.converged, (k, sol.residual, sol.atol)
        assert sol.iterations > 0
        tips[k], tols[k] = sol.tip_position, sol.atol
        assert sol.residual <= sol.atol
        assert sol.atol <= RELATIVE * moment_scale(robot, loads, TENSIONS)[0] * (1 + 1e-12)
    for k, tip in tips.items():
        np.testing.assert_allclose(tip, tips[1.0], atol=1e-7, err_msg=f"scale {k:g}")
    assert tols[1e-6] < 1e-14  # a millionth of the scale: judged a millionth as loosely


@pytest.mark.parametrize("model", ["pcc", "cosserat"])
def test_a_million_times_stiffer_under_a_million_times_the_wrench(model: str) -> None:
    """The stiff end, by the backbone's radius (E 2e12 Pa, EI a million times the paper's) under a tip wrench a
    million times the paper's: same shape as the paper robot under the paper's wrench, still converged (the
    absolute 1e-9 N m is below what float64 resolves in a balance of 1e5 N m)."""
    base = robot_for(model).with_gravity(None)
    paper = base.backbone
    k_e = 2e12 / paper.youngs_modulus
    radius = paper.outer_radius * (1e6 / k_e) ** 0.25
    stiff = scaled_robot(k_e, base, outer_radius=radius)
    assert stiff.backbone.bending_stiffness == pytest.approx(1e6 * paper.bending_stiffness, rel=1e-9)
    wrench = paper_loads()
    ref = solve(base, wrench, model=model)
    big = solve(stiff, Loads(np.zeros(8), wrench.tip_force * 1e6, wrench.tip_moment * 1e6), model=model)
    assert ref.converged and big.converged, (big.residual, big.atol)
    assert big.atol > 1e-9  # the floor: a part in 10^12 of the scale
    np.testing.assert_allclose(big.tip_position, ref.tip_position, atol=1e-7)


def test_a_soft_backbone_under_a_small_tension_bends() -> None:
    """The issue's example: E = 1 Pa (accepted) under a small tension is bent by about a radian, not "converged
    straight in 0 iterations"; the same shape as the paper's backbone under the tension scaled by the stiffness."""
    soft = scaled_robot(1.0 / 54e9).with_gravity(None)
    assert soft.backbone.youngs_modulus == pytest.approx(1.0)
    t = np.zeros(8)
    t[0] = 5.0 / 54e9  # [N]: bends the first segment by about a radian
    sol = solve(soft, Loads(t))
    stiff = solve(paper_robot().with_gravity(None), Loads(t * 54e9))
    assert sol.converged and sol.iterations > 0
    tip = sol.tip_position
    assert np.linalg.norm(tip[:2]) > 0.05  # far from the straight robot's tip (0, 0, 0.4)
    np.testing.assert_allclose(tip, stiff.tip_position, atol=1e-7)
    axis = sol.disk_rotations[-1][:, 2]
    assert np.degrees(np.arccos(axis[2])) > 40.0  # the tip's axis turned by most of a radian


@pytest.mark.parametrize("model", MODELS)
def test_the_straight_start_is_not_accepted_for_small_loads(model: str) -> None:
    """Tiny tensions on a soft robot: the solve iterates (the residual of the straight robot is the whole load),
    and the shape matches the linear response of a stiffer robot."""
    robot = scaled_robot(1e-9, robot_for(model)).with_gravity(None)
    t = TENSIONS * 1e-9
    sol = solve(robot, Loads(t), model=model)
    assert sol.converged and sol.iterations > 0
    assert sol.residual < 1e-6 * moment_scale(robot, Loads(t), t)[0]
    assert np.linalg.norm(sol.tip_position[:2]) > 1e-3


def test_the_tolerance_rule() -> None:
    """clip(atol, 1e-12 S, 1e-8 S), with S the moment scale; a robot with no load at all still has the elastic
    scale EI / L (its straight pose converges with residual 0, any warm start converges too)."""
    robot = paper_robot()
    loads = paper_loads(TENSIONS)
    s = moment_scale(robot, loads, TENSIONS)[0]
    wrench = 0.4 * np.linalg.norm(loads.tip_force) + np.linalg.norm(loads.tip_moment)
    weight = 9.81 * (0.0115 * 0.4 + 20 * 0.2e-3) * 0.4
    assert s == pytest.approx(7.0 * 0.01 + wrench + weight + robot.backbone.bending_stiffness / 0.4)
    for atol in (1e-14, 1e-9, 1e-4):
        tol, step = tolerances(robot, loads, TENSIONS[None], atol)
        assert tol[0] == pytest.approx(min(max(atol, FLOOR * s), RELATIVE * s))
        assert step[0] >= tol[0]
    free = robot.with_gravity(None)
    none = Loads(np.zeros(8))
    straight = solve(free, none)
    assert straight.converged and straight.residual == 0.0 and straight.atol > 0.0
    warm = solve(free, none, q0=np.full((20, 3), 0.3))
    assert warm.converged
    np.testing.assert_allclose(warm.tip_position, [0.0, 0.0, 0.4], atol=1e-9)


@pytest.mark.parametrize("model", ["pcc", "cosserat"])
def test_a_batch_reports_each_cases_tolerance(model: str) -> None:
    """Each row of a batch is judged by its own scale, and says so in ``atol``; a row is the same as its single
    solve."""
    robot = robot_for(model)
    T = np.array([TENSIONS, TENSIONS * 1e-3, np.zeros(8)])
    loads = Loads(np.zeros(8))
    batch = solve_batch(robot, T, loads, model=model)
    tol, _ = tolerances(robot, loads, T, 1e-9)
    np.testing.assert_array_equal(batch.atol, tol)
    assert batch.atol[1] < batch.atol[0]
    for b in range(3):
        one = solve(robot, loads.with_tensions(T[b]), model=model)
        assert one.atol == batch.atol[b]
        np.testing.assert_allclose(one.tip_position, batch.tip_position[b], atol=1e-12)
    assert batch.rows(np.array([2])).atol.tolist() == [tol[2]]

"""The PCC model against physics: closed forms, symmetries, limits and invariants."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ATOL, FD_AGREE, SAME_SHAPE, fd_jacobian, rod

from pytdcr import (
    ConstantFriction,
    ExponentialFriction,
    Loads,
    NoFriction,
    PCCEquations,
    PointLoad,
    Robot,
    Segment,
    SolverOptions,
    Tendon,
    solve,
    solve_batch,
)
from pytdcr.contact import bending_curvature
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT

PAPER_FORCE = np.array(PAPER_TIP_FORCE)
PAPER_MOMENT = np.array(PAPER_TIP_MOMENT)


def test_straight_robot_without_load(paper):
    for robot in (paper, paper.with_gravity(None)):
        sol = solve(robot, Loads(np.zeros(8)))
        assert sol.converged
        assert sol.iterations == 0  # the straight robot is already in equilibrium
        assert np.allclose(sol.q, 0.0)
        assert np.allclose(sol.tip_position, [0, 0, 0.4], atol=1e-15)


@pytest.mark.parametrize("axis", [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.6, -0.8, 0.0)])
def test_pure_tip_moment_gives_a_circular_arc(backbone, axis):
    """Constant moment about an in-plane axis: every subsegment bends with k = M / EI."""
    robot = rod(backbone, 20)
    M = 0.004
    axis = np.asarray(axis)
    sol = solve(robot, Loads(np.zeros(0), tip_moment=M * axis))
    assert sol.converged and sol.residual <= ATOL
    EI = backbone.bending_stiffness
    kappa = M / EI
    # curvature vector (-gamma, beta) is EI^-1 times the moment, in every frame
    assert np.allclose(-sol.q[:, 1], kappa * axis[0], atol=ATOL / EI * 10)
    assert np.allclose(sol.q[:, 0], kappa * axis[1], atol=ATOL / EI * 10)
    assert np.allclose(sol.q[:, 2], 0.0, atol=1e-9)
    L = robot.length
    bend_dir = np.array([axis[1], -axis[0], 0.0])  # z x axis
    tip = bend_dir * (1 - np.cos(kappa * L)) / kappa + np.array([0, 0, np.sin(kappa * L) / kappa])
    assert np.allclose(sol.tip_position, tip, atol=1e-10)
    # every disk on the circle of radius 1/kappa
    centre = bend_dir / kappa
    assert np.allclose(np.linalg.norm(sol.disk_positions - centre, axis=1), 1 / kappa, rtol=1e-9)
    # the curvature the disk frames give (the design studies' peak stress E kappa r) is M / EI everywhere
    assert np.allclose(bending_curvature(sol.disk_rotations, robot.subsegment_lengths), kappa, rtol=1e-7)


def test_pure_torsion_twists_uniformly(backbone):
    robot = rod(backbone, 10)
    Mz = 0.002
    sol = solve(robot, Loads(np.zeros(0), tip_moment=[0, 0, Mz]))
    assert sol.converged
    expect = Mz / backbone.torsional_stiffness * robot.subsegment_lengths
    assert np.allclose(sol.q[:, 2], expect, rtol=1e-9)
    assert np.allclose(sol.q[:, :2], 0.0, atol=1e-12)


# measured: (tip deflection - F L^3 / 3EI) / (F L^3 / 3EI) = 0.0368 at 20 disks, 0.0186 at 40,
# 0.0093 at 80: first order in the disk spacing (moments are lumped at each subsegment's base)
CANTILEVER_ERROR = {20: 0.0369, 40: 0.0186, 80: 0.0094}


def test_small_tip_force_gives_the_cantilever_deflection(backbone):
    L, F = 0.4, 1e-3
    ref = F * L**3 / (3 * backbone.bending_stiffness)
    errors = {}
    for n in CANTILEVER_ERROR:
        sol = solve(rod(backbone, n, L), Loads(np.zeros(0), tip_force=[F, 0, 0]))
        assert sol.converged
        assert abs(sol.tip_position[1]) < 1e-15
        errors[n] = (sol.tip_position[0] - ref) / ref
    for n, bound in CANTILEVER_ERROR.items():
        assert 0 < errors[n] <= bound
    # halves with each doubling of the disk count
    assert errors[40] / errors[20] == pytest.approx(0.5, abs=0.02)
    assert errors[80] / errors[40] == pytest.approx(0.5, abs=0.02)


def _rotated(tensions: np.ndarray, shift: int) -> np.ndarray:
    """Tension of the tendon at angle a goes to the tendon at a + shift * 90 deg."""
    t = np.asarray(tensions)
    return np.concatenate([np.roll(t[:4], shift), np.roll(t[4:], shift)])


@pytest.mark.parametrize("friction", [NoFriction(), ExponentialFriction(), ConstantFriction(mu=0.3)])
def test_turning_the_tendon_forces_turns_the_shape(paper, friction):
    robot = paper.with_friction(friction)
    t = np.array([6.0, 1.0, 0.0, 2.5, 0.0, 3.0, 1.0, 0.5])
    f = np.array([0.02, -0.01, -0.03])
    base = solve(robot, Loads(t, tip_force=f))
    assert base.converged
    for shift in (1, 2, 3):
        a = shift * np.pi / 2
        Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        turned = solve(robot, Loads(_rotated(t, shift), tip_force=Rz @ f))
        assert turned.converged
        assert np.allclose(turned.disk_positions, base.disk_positions @ Rz.T, atol=SAME_SHAPE)
        assert np.allclose(turned.tensions, np.vstack([np.roll(base.tensions[:4], shift, axis=0),
                                                       np.roll(base.tensions[4:], shift, axis=0)]), atol=1e-9)


def test_length_invariant_and_reach_bound(paper):
    rng = np.random.default_rng(7)
    T = rng.uniform(0.0, 20.0, (40, 8))
    batch = solve_batch(paper, T, Loads(np.zeros(8), tip_force=PAPER_FORCE, tip_moment=PAPER_MOMENT))
    assert batch.converged.mean() >= 0.95
    assert np.all(batch.reach[batch.converged] <= paper.length)
    lengths = paper.subsegment_lengths
    for b in np.flatnonzero(batch.converged)[:10]:
        sol = solve(paper, Loads(T[b], tip_force=PAPER_FORCE, tip_moment=PAPER_MOMENT))
        gaps = np.linalg.norm(np.diff(sol.disk_positions, axis=0), axis=1)
        assert np.all(gaps <= lengths * (1 + 1e-12))


def test_zero_friction_equals_frictionless(paper):
    t = np.array([5.0, 0.0, 1.0, 0.0, 0.0, 4.0, 0.0, 2.0])
    ref = solve(paper.with_friction(NoFriction()), Loads(t))
    for law in (ConstantFriction(mu=0.0), ExponentialFriction(mu0=0.0)):
        for release in (False, True):
            sol = solve(paper.with_friction(law), Loads(t, release=release))
            assert np.array_equal(sol.q, ref.q)
    # and the tension is the same along each frictionless tendon
    assert np.allclose(ref.tensions[:4, :10], t[:4, None])
    assert np.allclose(ref.tensions[4:], t[4:, None])


def test_friction_pull_and_release(paper):
    t = np.array([8.0, 0, 0, 0, 0, 0, 0, 0])
    frictionless = solve(paper.with_friction(NoFriction()), Loads(t))
    pull = solve(paper, Loads(t))
    release = solve(paper, Loads(t, release=True))
    piece = pull.tensions[0, :10]
    assert np.all(np.diff(piece) <= 0) and piece[-1] < t[0]
    assert np.all(np.diff(release.tensions[0, :10]) >= 0) and release.tensions[0, 9] > t[0]
    # less tension reaching the disks bends the robot less, and more bends it more
    # (segment 1's bend angle, sum of kappa * l; the tip's sideways reach is no measure once it curls past 90 deg)
    bend = [np.sum(np.hypot(s.q[:10, 0], s.q[:10, 1])) * 0.02 for s in (pull, frictionless, release)]
    assert bend[0] < bend[1] < bend[2]


@pytest.mark.parametrize("n", [10, 40, 160])
def test_capstan_limit(backbone, n):
    """Constant mu, more disks over the same bend: T_out / T_in -> exp(-mu * Theta)."""
    mu, kappa, L = 0.1, 5.0, 0.2
    robot = Robot(backbone=backbone, segments=(Segment(length=L, n_disks=n),),
                  tendons=(Tendon(segment=1, radius=0.01, angle_deg=0.0),), gravity=(0, 0, 0),
                  friction=ConstantFriction(mu=mu))
    model = PCCEquations.build(robot, Loads([1.0]))
    q = np.zeros((n, 3))
    q[:, 0] = kappa
    T = model.tensions(q)[0]
    ratio = T[-1] / T[0]
    capstan = np.exp(-mu * kappa * L)
    # measured: relative gap = 0.096 / n (the tendon turns at n - 1 holes)
    assert abs(ratio / capstan - 1) <= 0.1 / n


def test_gravity_lowers_a_sideways_bent_robot(paper):
    t = np.array([10.0, 0, 0, 0, 3.0, 0, 0, 3.0])
    without = solve(paper.with_gravity(None), Loads(t))
    with_g = solve(paper, Loads(t))
    assert without.converged and with_g.converged
    assert without.tip_position[0] > 0.15  # bent sideways towards +x
    assert with_g.tip_position[2] < without.tip_position[2] - 1e-3
    # gravity along the base x-axis pushes the tip along +x
    side = solve(paper.with_gravity((9.81, 0.0, 0.0)), Loads(np.zeros(8)))
    assert side.tip_position[0] > 1e-3


def test_point_load_at_the_tip_equals_tip_load(paper):
    t = np.array([3.0, 0, 1.0, 0, 0, 2.0, 0, 0])
    a = solve(paper, Loads(t, tip_force=PAPER_FORCE / 4, tip_moment=PAPER_MOMENT / 4))
    b = solve(paper, Loads(t, point_loads=(PointLoad(20, PAPER_FORCE / 4, PAPER_MOMENT / 4),)))
    assert np.allclose(a.q, b.q, atol=1e-12)
    free = solve(paper, Loads(t))
    pushed = solve(paper, Loads(t, point_loads=(PointLoad(10, [0, 0.05, 0]),)))
    assert pushed.converged and pushed.tip_position[1] > free.tip_position[1] + 1e-3


@pytest.mark.parametrize(
    ("friction", "release"),
    [(NoFriction(), False), (ExponentialFriction(), False), (ConstantFriction(mu=0.25), True)],
)
def test_jacobian_matches_finite_differences(paper, friction, release):
    rng = np.random.default_rng(11)
    robot = paper.with_friction(friction)
    loads = Loads(rng.uniform(0, 20, 8), tip_force=PAPER_FORCE, tip_moment=PAPER_MOMENT, release=release,
                  point_loads=(PointLoad(7, [0.03, -0.02, 0.01], [0.0, 0.01, -0.02]),))
    model = PCCEquations.build(robot, loads)
    for scale in (0.3, 3.0):
        q = rng.normal(0.0, scale, (20, 3))
        J = model.jacobian(q)
        assert np.abs(J - fd_jacobian(model, q)).max() <= FD_AGREE * max(1.0, np.abs(J).max())


def test_rao_2021_regression_values(rao):
    """Published PCC values of Rao et al. 2021 (their C++ code), to the 1e-6 m they print."""
    cases = {(4, 0, 0, 0, 2, 0): (0.127542, 0.143276, 0.336556), (2, 0, 0, 0, 2, 0): (0.130473, 0.036558, 0.367539)}
    for t, tip in cases.items():
        sol = solve(rao, Loads(np.array(t, dtype=float)))
        assert sol.converged
        assert np.allclose(sol.tip_position, tip, atol=1.5e-6)


def test_solutions_are_in_equilibrium(paper):
    loads = Loads(np.array([2.0, 9.0, 0, 1.0, 4.0, 0, 0, 7.0]), tip_force=PAPER_FORCE, tip_moment=PAPER_MOMENT)
    sol = solve(paper, loads)
    assert sol.converged
    r = PCCEquations.build(paper, loads).residual(sol.q)
    assert np.abs(r).max() == pytest.approx(sol.residual, abs=1e-15)
    assert np.abs(r).max() <= SolverOptions().atol


def test_loads_without_tensions_are_slack_tendons(paper):
    """``Loads(tip_force=...)``: no tensions given is every tendon at 0 N, for a solve and a continuation from it."""
    from pytdcr import Loads

    f = np.array([0.05, -0.02, -0.1])
    bare = solve(paper, Loads(tip_force=f))
    zero = solve(paper, Loads(np.zeros(8), tip_force=f))
    assert bare.converged and np.array_equal(bare.tip_position, zero.tip_position)
    assert Loads().tensions.shape == (0,) and np.array_equal(Loads().tensions_for(8), np.zeros(8))
    pulled = Loads(np.array([3.0, 0, 0, 0, 0, 0, 0, 0]), tip_force=f)
    assert np.allclose(solve(paper, pulled, start=bare).tip_position, solve(paper, pulled, start=zero).tip_position,
                       atol=1e-12)

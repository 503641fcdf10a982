"""pcc2 and sscr against physics and against each other: limits, orders, closed forms, the solver's honesty."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import FD_AGREE, fd_jacobian, rod

from pytdcr import (
    ConstantFriction,
    CosseratOptions,
    ExponentialFriction,
    Loads,
    NoFriction,
    PointLoad,
    Robot,
    Segment,
    Tendon,
    paper_loads,
    paper_robot,
    solve,
    solve_batch,
    tip_gradient,
)
from pytdcr.paper import PAPER_TIP_FORCE
from pytdcr.statics import PCCEquations, SSCREquations, SSCROptions
from pytdcr.statics.kernels.pcc import BALANCE_MIDPOINT


def robot_with(n_disks: int, friction=None, gravity: bool = True) -> Robot:
    """The paper robot with ``n_disks`` per segment (same lengths, routing and total disk mass)."""
    p = paper_robot(friction)
    seg = Segment(length=0.2, n_disks=n_disks, disk_mass=0.2e-3 * 10 / n_disks)
    r = p.model_copy(update={"segments": (seg, seg)})
    return r if gravity else r.with_gravity(None)


def fine(n_disks: int) -> SSCROptions:
    """The reference: 80 Runge-Kutta steps over each segment whatever the disk count."""
    return SSCROptions(steps_per_subsegment=max(2, 80 // n_disks))


def gap(a, b) -> float:
    assert a.converged and b.converged
    return float(np.linalg.norm(a.tip_position - b.tip_position))


def test_sscr_without_tendons_is_the_cosserat_rod():
    robot = paper_robot(NoFriction())
    for loads in (paper_loads(), Loads(np.zeros(8), tip_force=[0.05, -0.02, -0.1], tip_moment=[0, 0.01, 0.02])):
        a = solve(robot, loads, model="sscr")
        b = solve(robot, loads, model="cosserat")
        assert np.max(np.linalg.norm(a.disk_positions - b.disk_positions, axis=1)) < 1e-6


def test_sscr_approaches_the_smeared_cosserat_rod_as_disks_multiply():
    # tendons, gravity and a tip force: the chords between disks tend to the tendon's smooth path
    t = np.array([3.0, 0, 0, 0, 2.0, 0, 0, 0])
    loads = Loads(t, tip_force=PAPER_TIP_FORCE)
    gaps = []
    for n in (10, 20, 40):
        r = robot_with(n, NoFriction())
        rod_opts = CosseratOptions(steps_per_subsegment=max(2, 80 // n))
        gaps.append(gap(solve(r, loads, model="sscr", options=fine(n)), solve(r, loads, model="cosserat",
                                                                              options=rod_opts)))
    assert np.all(np.diff(gaps) < 0)
    assert gaps[0] / gaps[1] > 3.0 and gaps[1] / gaps[2] > 3.0  # second order


def test_twisted_tendons_part_the_in_plane_rule_from_the_smeared_tendon():
    """A known, documented difference, not a discretisation error (docs/models.md).

    At a disk a tendon only passes through, MODEL.md's disk takes only the in-plane part of the tendon's
    resultant. Twist tilts the tendons against the backbone, and the dropped axial part is then a systematic
    load that more disks do not remove: the smeared Cosserat rod, whose tendon presses on it along its whole
    length, stays about 25 mm away. (With the whole resultant taken, the two converge at second order.)
    """
    loads = Loads(np.array([3.0, 0, 0, 0, 2.0, 0, 0, 0]), tip_moment=[0.0, 0.0, 0.05])
    gaps = [gap(solve(r, loads, model="sscr", options=fine(n)), solve(r, loads, model="cosserat"))
            for n in (10, 40) for r in [robot_with(n, NoFriction(), gravity=False)]]
    assert gaps[1] > 0.02 and gaps[1] > 0.8 * gaps[0]


def test_pcc2_is_second_order_under_tip_loads_and_pcc_first():
    loads = paper_loads()  # gravity and the paper's tip force and moment, no tension
    errors = {"pcc": [], "pcc2": []}
    for n in (5, 10, 20, 40):
        r = robot_with(n, NoFriction())
        ref = solve(r, loads, model="sscr", options=fine(n))
        for m in errors:
            errors[m].append(gap(solve(r, loads, model=m), ref))
    e1, e2 = np.array(errors["pcc"]), np.array(errors["pcc2"])
    # measured: pcc 119, 65, 32, 16 mm; pcc2 7.2, 1.8, 0.44, 0.11 mm
    assert np.all(1.7 < e1[:-1] / e1[1:]) and np.all(e1[:-1] / e1[1:] < 2.3)
    assert np.all(3.5 < e2[:-1] / e2[1:]) and np.all(e2[:-1] / e2[1:] < 4.5)
    assert e2[1] < 2.5e-3  # 10 disks per segment: within 2.5 mm of the reference (pcc: 65 mm)


def test_under_tendon_loads_alone_both_are_second_order_and_pcc2_halves_the_error():
    """The tendon loads act at the disks, where both balances hold; what remains is the arc assumption.

    Between disks the rod carries the tendons' resultant, and its moment changes along the subsegment only by
    that force's lever: both models are second order, and the midpoint balance halves the constant.
    """
    loads = Loads(np.array([3.0, 0, 0, 0, 2.0, 0, 0, 0]))
    ratio = []
    errors = []
    for n in (10, 20, 40):
        r = robot_with(n, NoFriction(), gravity=False)
        ref = solve(r, loads, model="sscr", options=fine(n))
        e = [gap(solve(r, loads, model=m), ref) for m in ("pcc", "pcc2")]
        errors.append(e)
        ratio.append(e[1] / e[0])
    errors = np.array(errors)
    assert np.all(errors[:-1] / errors[1:] > 3.5)
    assert np.allclose(ratio, 0.5, atol=0.05)


def test_sscr_capstan_limit(backbone):
    """Constant mu, the rod bent on an exact arc by a pure moment: T_out / T_in -> exp(-mu Theta)."""
    mu, kappa, L = 0.1, 5.0, 0.2
    for n, bound in ((10, 0.1 / 10), (40, 0.1 / 40)):
        robot = Robot(backbone=backbone, segments=(Segment(length=L, n_disks=n),),
                      tendons=(Tendon(segment=1, radius=0.01, angle_deg=0.0),), gravity=(0, 0, 0),
                      friction=ConstantFriction(mu=mu))
        eq = SSCREquations.build(robot, Loads([1.0]))
        q = np.zeros((n, 6))
        q[:, 4] = kappa * backbone.bending_stiffness  # the same moment about y in every disk's frame: an arc
        T = eq.evaluate(q).tensions[0]
        assert abs(T[-1] / T[0] / np.exp(-mu * kappa * L) - 1) <= bound


@pytest.mark.parametrize("force", [0.1, 10.0])
def test_an_axial_tip_force_compresses_the_rod_only_with_extension(backbone, force):
    robot = rod(backbone, 10)
    loads = Loads(np.zeros(0), tip_force=[0.0, 0.0, -force])
    stiff = solve(robot, loads, model="sscr")
    soft = solve(robot, loads, model="sscr", options=SSCROptions(shear_extension=True))
    area = np.pi * backbone.outer_radius**2
    L = robot.length
    assert stiff.tip_position[2] == pytest.approx(L, abs=1e-15)
    assert soft.tip_position[2] == pytest.approx(L - force * L / (backbone.youngs_modulus * area), rel=1e-12)
    # past Euler's load (0.157 N) the loading path keeps the straight branch: nothing perturbs it
    assert np.all(soft.tip_position[:2] == 0.0)


def test_sscr_closed_forms(backbone):
    robot = rod(backbone, 10)
    m, ei, L = 0.02, backbone.bending_stiffness, robot.length
    arc = solve(robot, Loads(np.zeros(0), tip_moment=[0, m, 0]), model="sscr")
    k = m / ei
    assert np.allclose(arc.tip_position, [(1 - np.cos(k * L)) / k, 0.0, np.sin(k * L) / k], atol=1e-9)
    f = 1e-4
    can = solve(robot, Loads(np.zeros(0), tip_force=[f, 0, 0]), model="sscr")
    assert abs(can.tip_position[0] / (f * L**3 / (3 * ei)) - 1) < 1e-4


@pytest.mark.parametrize(
    ("model", "friction", "release"),
    [("sscr", NoFriction(), False), ("sscr", ExponentialFriction(), False), ("sscr", ConstantFriction(mu=0.25), True),
     ("pcc2", ExponentialFriction(), False)],
)
def test_jacobians_match_finite_differences(model, friction, release):
    rng = np.random.default_rng(11)
    robot = paper_robot(friction)
    loads = Loads(rng.uniform(0, 20, 8), tip_force=PAPER_TIP_FORCE, tip_moment=[-0.1, 0.1, 0.1], release=release,
                  point_loads=(PointLoad(7, [0.03, -0.02, 0.01], [0.0, 0.01, -0.02]),))
    if model == "sscr":
        eq = SSCREquations.build(robot, loads)
        qs = [rng.normal(0.0, s, (20, 6)) for s in (0.005, 0.05)]
        step = 1e-7
    else:
        eq = PCCEquations.build(robot, loads, BALANCE_MIDPOINT)
        qs = [rng.normal(0.0, s, (20, 3)) for s in (0.3, 3.0)]
        step = 1e-6
    for q in qs:
        J = eq.jacobian(q)
        assert np.abs(J - fd_jacobian(eq, q, step)).max() <= 10 * FD_AGREE * max(1.0, np.abs(J).max())


@pytest.mark.parametrize("model", ["sscr", "pcc2"])
def test_tip_gradient_matches_finite_differences_of_solves(model):
    robot = paper_robot()
    t = np.array([6.0, 1.0, 0.0, 2.0, 3.0, 0.0, 1.0, 0.0])
    loads = Loads(t, tip_force=[0.02, 0.0, -0.02])
    opts = SSCROptions(atol=1e-13) if model == "sscr" else None
    sol = solve(robot, loads, model=model, options=opts)
    tip, grad = tip_gradient(robot, loads, sol, model=model, options=opts)
    assert np.array_equal(tip, sol.tip_position)
    for c in (0, 4, 6):
        e = np.eye(8)[c] * 1e-4
        up = solve(robot, loads.with_tensions(t + e), model=model, options=opts, q0=sol.q).tip_position
        dn = solve(robot, loads.with_tensions(t - e), model=model, options=opts, q0=sol.q).tip_position
        assert np.allclose(grad[:, c], (up - dn) / 2e-4, atol=1e-7)


def test_turning_the_tensions_turns_the_sscr_shape():
    robot = paper_robot()
    t = np.array([6.0, 1.0, 0.0, 2.5, 0.0, 3.0, 1.0, 0.5])
    f = np.array([0.02, -0.01, -0.03])
    base = solve(robot, Loads(t, tip_force=f), model="sscr")
    rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    turned = np.concatenate([np.roll(t[:4], 1), np.roll(t[4:], 1)])
    b = solve(robot, Loads(turned, tip_force=rz @ f), model="sscr")
    assert np.allclose(b.disk_positions, base.disk_positions @ rz.T, atol=1e-9)


def test_sscr_converges_under_the_paper_load_and_batches_agree():
    # every one of these random tension vectors converges on the loading path (the full 200: bench/models.py)
    robot = paper_robot()
    T = np.random.default_rng(0).uniform(0, 20, (12, 8))
    batch = solve_batch(robot, T, paper_loads(), model="sscr")
    assert batch.converged.all()
    assert np.all(batch.reach <= robot.length)
    again = solve_batch(robot, T, paper_loads(), model="sscr", threads=1)
    assert np.array_equal(batch.q, again.q)
    one = solve(robot, paper_loads(T[3]), model="sscr")
    assert np.array_equal(one.q, batch.q[3])
    # the backbone between the disks keeps its length
    pts = one.backbone_points(robot)
    assert np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() == pytest.approx(robot.length, rel=1e-3)

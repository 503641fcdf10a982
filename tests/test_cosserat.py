"""The Cosserat-rod model: closed forms, the published regression, agreement with PCC, the solver's honesty."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import rod
from scipy.integrate import solve_ivp
from scipy.special import ellipeinc, ellipkinc

from pytdcr import (
    CosseratOptions,
    Loads,
    NoFriction,
    NotConvergedError,
    Segment,
    UnsupportedFeatureError,
    paper_loads,
    paper_robot,
    solve,
    solve_batch,
    tip_gradient,
)
from pytdcr.statics import CosseratShooting
from pytdcr.statics.kernels import cosserat as CK  # the right-hand side kernel, tested on purpose

#: Rao et al. 2021, tensions [4, 0, 0, 0, 2, 0] N: their Cosserat model's tip (6 digits published) [m]
RAO_COSSERAT_TIP = np.array([0.127608, 0.143467, 0.336407])
#: half a unit of the last published digit [m]
PUBLISHED = 1.5e-6
#: the RK4 discretisation (4 steps between disks) against SciPy's DOP853 [m]
RK4_AGREE = 2e-5


def paper_nf(n_disks: int = 10, gravity: bool = True):
    """The paper robot without friction, ``n_disks`` per segment (total disk mass kept)."""
    p = paper_robot(NoFriction())
    seg = Segment(length=0.2, n_disks=n_disks, disk_mass=0.2e-3 * 10 / n_disks)
    r = p.model_copy(update={"segments": (seg, seg)})
    return r if gravity else r.with_gravity(None)


def test_rao_regression_with_shear_and_extension(rao):
    # their model lets the rod shear and stretch (K_se = diag(GA, GA, EA))
    sol = solve(rao, Loads([4.0, 0, 0, 0, 2, 0]), model="cosserat", options=CosseratOptions(shear_extension=True))
    assert sol.converged and sol.model == "cosserat"
    assert np.max(np.abs(sol.tip_position - RAO_COSSERAT_TIP)) <= PUBLISHED


def test_inextensible_rod_is_close_to_the_extensible_one(rao):
    a = solve(rao, Loads([4.0, 0, 0, 0, 2, 0]), model="cosserat")
    # the 4-6 N tendon load shortens the rod by ~T L / EA = 6 * 0.4 / 83 kN = 29 um
    d = np.linalg.norm(a.tip_position - RAO_COSSERAT_TIP)
    assert 5e-6 < d < 5e-5


def test_pure_tip_moment_gives_a_circular_arc(backbone):
    robot = rod(backbone, 10)
    ei = backbone.bending_stiffness
    m = 0.02  # N m about base y: bends towards +x
    sol = solve(robot, Loads(np.zeros(0), tip_moment=[0, m, 0]), model="cosserat")
    k = m / ei
    L = robot.length
    expect = np.array([(1 - np.cos(k * L)) / k, 0.0, np.sin(k * L) / k])
    assert sol.converged
    assert np.max(np.abs(sol.tip_position - expect)) < 1e-9
    # every disk lies on the same circle of radius 1/k
    centre = np.array([1 / k, 0.0, 0.0])
    assert np.allclose(np.linalg.norm(sol.disk_positions - centre, axis=1), 1 / k, atol=1e-9)


def test_small_tip_force_gives_the_cantilever_deflection(backbone):
    robot = rod(backbone, 10)
    f = 1e-4
    sol = solve(robot, Loads(np.zeros(0), tip_force=[f, 0, 0]), model="cosserat")
    linear = f * robot.length**3 / (3 * backbone.bending_stiffness)
    # geometric non-linearity at this load: relative 1e-5
    assert abs(sol.tip_position[0] / linear - 1) < 1e-4


def elastica_tip(load: float, ei: float, length: float) -> tuple[float, float]:
    """Large-deflection cantilever with a transverse end load (Bisshopp & Drucker 1945).

    Returns (transverse deflection, axial projection) of the tip [m]. With
    1 + sin(theta) = 2 k^2 sin^2(phi): sqrt(P/EI) L = K(k) - F(phi0, k),
    sin(phi0) = 1/(k sqrt 2); deflection = L - 2 sqrt(EI/P) (E(k) - E(phi0, k)),
    axial projection = sqrt(EI/P) sqrt(2 (2k^2 - 1)).
    """
    from scipy.optimize import brentq

    a = np.sqrt(load / ei) * length

    def gap(m: float) -> float:
        phi0 = np.arcsin(1.0 / np.sqrt(2.0 * m))
        return ellipkinc(np.pi / 2, m) - ellipkinc(phi0, m) - a

    m = brentq(gap, 0.5 + 1e-12, 1.0 - 1e-15)
    phi0 = np.arcsin(1.0 / np.sqrt(2.0 * m))
    c = np.sqrt(ei / load)
    deflection = length - 2.0 * c * (ellipeinc(np.pi / 2, m) - ellipeinc(phi0, m))
    axial = c * np.sqrt(2.0 * (2.0 * m - 1.0))
    return deflection, axial


@pytest.mark.parametrize("alpha", [1.0, 3.0, 10.0])
def test_large_deflection_elastica_both_models(backbone, alpha):
    length = 0.4
    ei = backbone.bending_stiffness
    load = alpha * ei / length**2  # P L^2 / EI = alpha
    defl, axial = elastica_tip(load, ei, length)
    loads = Loads(np.zeros(0), tip_force=[load, 0, 0])
    cr = solve(rod(backbone, 10, length), loads, model="cosserat")
    assert cr.converged
    assert abs(cr.tip_position[0] - defl) < 1e-6 * length
    assert abs(cr.tip_position[2] - axial) < 1e-6 * length
    errors = []
    for n in (10, 20, 40, 80):
        pcc = solve(rod(backbone, n, length), loads)
        assert pcc.converged
        errors.append(np.hypot(pcc.tip_position[0] - defl, pcc.tip_position[2] - axial))
    # the PCC model's moment balance about each subsegment's base is first order in the disk spacing
    assert np.all(np.diff(errors) < 0)
    assert 1.6 < errors[-2] / errors[-1] < 2.4


def test_pcc_converges_to_cosserat_as_disks_multiply():
    tensions = np.array([2.0, 0, 0, 3.0, 1.0, 0, 0, 0])
    # tendon-only: second order in the disk spacing
    gaps = []
    for n in (10, 20, 40):
        r = paper_nf(n, gravity=False)
        a = solve(r, Loads(tensions))
        b = solve(r, Loads(tensions), model="cosserat")
        gaps.append(np.linalg.norm(a.tip_position - b.tip_position))
    assert gaps[0] < 1e-3
    assert gaps[1] / gaps[2] > 3.5 and gaps[0] / gaps[1] > 3.5
    # with the weights of the disks and backbone: first order
    gaps = []
    for n in (10, 20, 40, 80):
        r = paper_nf(n)
        a = solve(r, Loads(tensions))
        b = solve(r, Loads(tensions), model="cosserat")
        gaps.append(np.linalg.norm(a.tip_position - b.tip_position))
    assert np.all(np.diff(gaps) < 0)
    assert 1.7 < gaps[-2] / gaps[-1] < 2.3  # halves with the spacing: the two models share one limit


def test_models_agree_on_tendon_only_cases():
    # stated bound: 1.5 % of the length for tensions up to 5 N (paper robot, 10 disks per segment, no
    # gravity); measured: max 1.14 %, the PCC model's second-order discretisation of the tendon path
    robot = paper_nf(10, gravity=False)
    T = np.random.default_rng(3).uniform(0.0, 5.0, size=(30, 8))
    pcc = solve_batch(robot, T)
    cr = solve_batch(robot, T, model="cosserat")
    assert pcc.converged.all() and cr.converged.all()
    d = np.linalg.norm(pcc.tip_position - cr.tip_position, axis=1)
    assert d.max() < 0.015 * robot.length


def _dop853_tip(model: CosseratShooting, m0: np.ndarray) -> np.ndarray:
    """The same shooting integration with SciPy's DOP853 (adaptive, rtol 1e-11) instead of fixed-step RK4."""
    p = model.packed
    n = p.sub.shape[0]
    y = np.zeros(18)
    y[[3, 7, 11]] = 1.0
    y[12:15] = m0
    y[15:18] = p.pforce.sum(0) + p.sub[:, 3].sum() * p.grav + model.mpl * p.sub[:, 0].sum() * p.grav
    x = np.array([0, 0, 0, 0, 0, 1.0])
    A = np.empty((6, 6))
    F = np.empty(6)
    for i in range(n):
        active = p.anchor >= i + 1

        def f(_s, yy, active=active):
            dy = np.empty(18)
            fw = -model.mpl * p.grav
            assert CK.rhs(yy, model.holes, p.tension, active, model.stiff, model.shear_extension, fw, x, A, F, dy)
            return dy

        y = solve_ivp(f, (0.0, p.sub[i, 0]), y, method="DOP853", rtol=1e-11, atol=1e-13).y[:, -1].copy()
        y[15:18] -= p.pforce[i] + p.sub[i, 3] * p.grav
        y[12:15] -= p.pmoment[i]
    assert np.max(np.abs(y[12:15])) < 1e-6  # the same equilibrium
    return y[:3]


def test_fixed_step_integration_matches_scipy_dop853():
    robot = paper_nf(10)
    T = np.array([6.0, 0, 1.0, 0, 0, 3.0, 0, 2.0])
    loads = Loads(T, tip_force=[0.02, -0.01, -0.02], tip_moment=[0.0, 0.005, 0.0])
    for steps, agree in ((4, RK4_AGREE), (16, RK4_AGREE / 100)):
        opts = CosseratOptions(steps_per_subsegment=steps)
        sol = solve(robot, loads, model="cosserat", options=opts)
        ref = _dop853_tip(CosseratShooting.build(robot, loads, opts), sol.q)
        assert np.linalg.norm(sol.tip_position - ref) < agree


def test_inextensible_backbone_keeps_its_length_and_reach_bound():
    robot = paper_nf(10)
    T = np.random.default_rng(5).uniform(0.0, 20.0, size=(10, 8))
    for t in T:
        sol = solve(robot, Loads(t, tip_force=[0.05, 0.0, -0.05]), model="cosserat")
        assert sol.converged
        pts = sol.backbone_points(robot)
        chord = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
        assert chord <= robot.length + 1e-12
        assert chord > robot.length * (1 - 1e-3)  # chords of 80 points on a smooth curve
        assert sol.reach <= robot.length
        rot = sol.disk_rotations
        assert np.allclose(rot @ rot.transpose(0, 2, 1), np.eye(3), atol=1e-8)


def test_turning_the_tensions_by_the_routing_angle_turns_the_shape():
    robot = paper_nf(10, gravity=False)
    T = np.array([5.0, 1.0, 0.0, 0.5, 2.0, 0.0, 0.0, 1.0])
    a = solve(robot, Loads(T), model="cosserat")
    turned = np.roll(T.reshape(2, 4), 1, axis=1).ravel()  # each tendon's force moves to the next hole, +90 deg
    b = solve(robot, Loads(turned), model="cosserat")
    rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(b.disk_positions, a.disk_positions @ rz.T, atol=1e-10)


def test_friction_is_refused():
    with pytest.raises(UnsupportedFeatureError, match="model 'cosserat' does not support tendon friction") as err:
        solve(paper_robot(), Loads(np.zeros(8)), model="cosserat")
    assert err.value.model == "cosserat" and err.value.feature == "tendon friction"
    # a constant mu of 0 is no friction
    from pytdcr import ConstantFriction

    sol = solve(paper_robot(ConstantFriction(mu=0.0)), Loads(np.zeros(8)), model="cosserat")
    assert sol.converged


def test_wrong_options_type_is_refused(rao):
    from pytdcr import SolverOptions

    with pytest.raises(TypeError, match="CosseratOptions"):
        solve(rao, Loads(np.zeros(6)), model="cosserat", options=SolverOptions())
    with pytest.raises(ValueError, match="model must be one of"):
        solve(rao, Loads(np.zeros(6)), model="prbm")


def test_non_convergence_is_reported_with_its_residual():
    robot = paper_nf(10)
    opts = CosseratOptions(max_eval=4, load_stepping="never")
    sol = solve(robot, Loads(np.full(8, 0.0), tip_force=[0.3, 0.0, 0.0], tip_moment=[0, 0.05, 0]),
                model="cosserat", options=opts)
    assert not sol.converged
    assert sol.residual > opts.atol
    with pytest.raises(NotConvergedError):
        _ = sol.tip_position
    assert sol.to_dict()["tip_position"] is None


def test_loading_path_converges_where_the_cold_start_may_not():
    robot = paper_nf(10)
    loads = paper_loads(np.array([15.0, 2.0, 20.0, 16.0, 20.0, 20.0, 12.0, 12.0]))
    sol = solve(robot, loads, model="cosserat")
    assert sol.converged and sol.path in ("loading", "snap")
    assert sol.load_steps >= 2


def test_warm_start_and_batch_agree_with_single_solves(rao):
    T = np.array([[4.0, 0, 0, 0, 2, 0], [1.0, 2.0, 0, 0, 0, 3.0]])
    loads = Loads(np.zeros(6), tip_force=[0.01, 0.0, -0.01])
    batch = solve_batch(rao, T, loads, model="cosserat")
    for k in range(2):
        one = solve(rao, loads.with_tensions(T[k]), model="cosserat")
        assert np.allclose(batch.tip_position[k], one.tip_position, atol=1e-12)
        warm = solve(rao, loads.with_tensions(T[k]), model="cosserat", q0=one.q)
        assert warm.converged and warm.path == "direct"
        assert warm.iterations <= 2
        assert np.allclose(warm.tip_position, one.tip_position, atol=1e-12)


def test_tip_gradient_matches_finite_differences_of_solves():
    robot = paper_nf(10)
    T = np.array([6.0, 1.0, 0.0, 2.0, 3.0, 0.0, 1.0, 0.0])
    loads = Loads(T, tip_force=[0.02, 0.0, -0.02])
    opts = CosseratOptions(atol=1e-13)
    sol = solve(robot, loads, model="cosserat", options=opts)
    tip, grad = tip_gradient(robot, loads, sol, model="cosserat", options=opts)
    assert np.allclose(tip, sol.tip_position, atol=1e-14)
    h = 1e-4
    for c in (0, 3, 6):
        e = np.zeros(8)
        e[c] = h
        up = solve(robot, loads.with_tensions(T + e), model="cosserat", options=opts, q0=sol.q).tip_position
        dn = solve(robot, loads.with_tensions(T - e), model="cosserat", options=opts, q0=sol.q).tip_position
        assert np.allclose(grad[:, c], (up - dn) / (2 * h), atol=1e-7)


def test_point_wrench_at_a_disk(backbone):
    from pytdcr import PointLoad

    robot = rod(backbone, 20)
    L, ei, f = robot.length, backbone.bending_stiffness, 1e-4
    # at the last disk it is the tip load
    a = solve(robot, Loads(np.zeros(0), point_loads=(PointLoad(20, force=[f, 0, 0], moment=[0, 1e-4, 0]),)),
              model="cosserat")
    b = solve(robot, Loads(np.zeros(0), tip_force=[f, 0, 0], tip_moment=[0, 1e-4, 0]), model="cosserat")
    assert np.allclose(a.disk_positions, b.disk_positions, atol=1e-15)
    # at mid-length: beam theory f a^2 (3L - a) / 6EI at the tip, a = L/2 (small load: linear)
    mid = solve(robot, Loads(np.zeros(0), point_loads=(PointLoad(10, force=[f, 0, 0]),)), model="cosserat")
    expect = f * (L / 2) ** 2 * (3 * L - L / 2) / (6 * ei)
    assert abs(mid.tip_position[0] / expect - 1) < 1e-4


def test_loading_path_matches_a_fine_fixed_step_path():
    # the adaptive continuation takes a few large load steps; a 100-step path with warm starts (every load
    # scaled by lam, Newton alone at each step) must end on the same equilibrium (no branch skipped) under the
    # paper's heavy tip load
    robot = paper_robot(NoFriction())
    step = CosseratOptions(atol=1e-10, load_stepping="never")
    for t in np.random.default_rng(5).uniform(0.0, 20.0, size=(4, 8)):
        m0 = np.zeros(3)
        for lam in np.linspace(0.0, 1.0, 101)[1:]:
            part = robot.with_gravity(tuple(lam * np.array(robot.gravity)))
            sol = solve(part, paper_loads(t).scaled(lam), model="cosserat", q0=m0, options=step)
            assert sol.converged
            m0 = sol.q
        fine = sol.tip_position
        sol = solve(robot, paper_loads(t), model="cosserat")
        assert sol.converged and np.linalg.norm(sol.tip_position - fine) < 1e-8


def test_pcc_approaches_the_rod_under_a_bending_and_twisting_tip_moment(backbone):
    # the PCC moment balance about each subsegment's base is first order: the gap falls ~4x per 4x disks
    loads = Loads(np.zeros(0), tip_moment=[0.0, 0.02, 0.02])
    rod_tip = solve(rod(backbone, 10), loads, model="cosserat").tip_position
    gaps = [np.linalg.norm(solve(rod(backbone, n), loads).tip_position - rod_tip) for n in (20, 80, 320)]
    assert np.all(np.diff(gaps) < 0)
    assert 3.5 < gaps[0] / gaps[1] < 4.5 and 3.5 < gaps[1] / gaps[2] < 4.5

"""The static stability flag (MODEL.md, appendix B): buckling, the paper's cases, honest reporting."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import rod

from pytdcr import Loads, NoFriction, Robot, Segment, Tendon, TensionBounds, paper_loads, paper_robot, solve
from pytdcr.cli import main
from pytdcr.optimize import ReachProblem

EULER = np.pi**2 / 4  # the cantilever's buckling load is EULER * EI / L^2


def compression(robot, force: float, model: str = "pcc"):
    return solve(robot, Loads(np.zeros(robot.n_tendons), tip_force=[0.0, 0.0, -force]), model=model)


def test_the_straight_robot_buckles_near_eulers_load(backbone):
    robot = rod(backbone, 20)  # no gravity, no tendons
    euler = EULER * backbone.bending_stiffness / robot.length**2  # 0.157 N
    below, above = compression(robot, 0.1), compression(robot, 0.3)
    assert below.stable is True and above.stable is False
    # past the buckling load the loading path keeps the straight branch, flagged unstable, not perturbed
    assert np.array_equal(above.tip_position[:2], [0.0, 0.0])
    assert above.tip_position[2] == pytest.approx(robot.length, abs=1e-15)
    # buckling of a symmetric rod: a pair of real eigenvalues crosses zero
    assert above.stability.n_real_nonpositive == 2
    far = compression(robot, 50.0).stability
    assert far.min_real_eigenvalue == pytest.approx(-3.3, abs=0.05)  # MODEL.md's measurement
    assert 0.1 < euler < 0.3


def buckling_load(robot, model: str, lo: float = 0.05, hi: float = 0.5) -> float:
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if compression(robot, mid, model).stable else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize(("model", "order"), [("pcc", 1), ("pcc2", 2)])
def test_the_buckling_load_tends_to_eulers_as_disks_multiply(backbone, model, order):
    # measured: pcc -7.5, -4.3, -2.3, -1.2 %; pcc2 +0.41, +0.10, +0.026, +0.0064 % at 5, 10, 20, 40 disks
    euler = EULER * backbone.bending_stiffness / 0.4**2
    errors = np.array([abs(buckling_load(rod(backbone, n), model) / euler - 1) for n in (5, 10, 20, 40)])
    assert np.all(np.diff(errors) < 0) and errors[-1] < 0.015
    assert np.all(np.abs(errors[:-1] / errors[1:] - 2.0**order) < 0.4 * order)


def test_the_paper_cases():
    robot = paper_robot()
    assert solve(robot, paper_loads(np.array([3.0, 0, 0, 0, 2.0, 0, 0, 0]))).stable is True
    # the reach optimum: stable, with a complex pair of negative real part (MODEL.md: -0.0069 +/- 0.039i)
    opt = solve(robot, paper_loads(np.array([15.914, 5.379, 20.0, 20.0, 20.0, 20.0, 13.542, 11.781])))
    st = opt.stability
    assert st.stable and st.flutter_pairs >= 1
    assert st.least_damped.real == pytest.approx(-0.0069, abs=5e-4)
    assert abs(st.least_damped.imag) == pytest.approx(0.039, abs=2e-3)


def test_models_without_the_test_report_none_and_nonconverged_has_none():
    robot = paper_robot(NoFriction())
    assert solve(robot, paper_loads(), model="cosserat").stable is None
    assert solve(robot, paper_loads(), model="sscr").stable is True
    assert solve(robot, paper_loads(), model="pcc2").stable is True
    from pytdcr import SolverOptions

    bad = solve(paper_robot(), paper_loads(np.full(8, 10.0)), options=SolverOptions(max_iter=1, load_stepping="never"))
    assert not bad.converged and bad.stable is None and bad.to_dict()["stable"] is None


def test_json_and_text_carry_the_flag(capsys):
    assert main(["solve", "--tensions", "0,0,0,0,0,0,0,0", "--tip-force", "0,0,-1", "--no-gravity", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["stable"] is False and data["stability"]["n_real_nonpositive"] == 2
    assert main(["solve", "--tensions", "0,0,0,0,0,0,0,0", "--tip-force", "0,0,-1", "--no-gravity"]) == 0
    assert "UNSTABLE" in capsys.readouterr().out


def test_stable_only_makes_unstable_equilibria_infeasible(backbone):
    # one segment pushed down its axis past Euler's load: straight (unstable) unless the tendons bend it
    robot = Robot(backbone=backbone, segments=(Segment(length=0.2, n_disks=10),), gravity=(0, 0, 0),
                  tendons=tuple(Tendon(segment=1, radius=0.01, angle_deg=a) for a in (0, 180)))
    loads = Loads(np.zeros(2), tip_force=[0.0, 0.0, -1.0])
    bounds = TensionBounds.uniform(2, 0.0, 3.0)
    T = np.array([[0.0, 0.0], [1.0, 1.0], [3.0, 0.0]])
    free = ReachProblem.create(robot, loads, bounds).evaluate(T)
    strict = ReachProblem.create(robot, loads, bounds, stable_only=True).evaluate(T)
    st = free.batch.stable
    assert free.feasible.all() and st[0] == 0.0 and st[1] == 0.0  # straight: converged, unstable
    assert np.array_equal(strict.feasible, free.feasible & (st == 1.0))
    assert not strict.feasible[0] and strict.cost[0] > 100


@pytest.mark.parametrize("model", ["pcc", "pcc2", "sscr"])
def test_a_batchs_stability_is_each_solutions_own(model):
    """The batch's test (compiled stiffness, one stacked eigenvalue call) is the single solution's, bit for bit,
    whatever the threads; unstable equilibria are among them under the paper's load."""
    from pytdcr.statics import solve_batch
    from pytdcr.statics.registry import resolve

    robot, loads = paper_robot(), paper_loads()
    T = np.random.default_rng(1).uniform(0.0, 20.0, (300 if model != "sscr" else 120, robot.n_tendons))
    m, opts = resolve(model, robot, loads, None)
    eq = m.equations(robot, loads, opts)
    got = [solve_batch(robot, T, loads, model=model, threads=k) for k in (1, 2)]
    assert got[0].stability == got[1].stability
    ref = [m.stability_at(eq.with_tensions(t), q.reshape(-1)) if ok else None
           for t, q, ok in zip(T, got[0].q, got[0].converged, strict=True)]
    assert list(got[0].stability) == ref
    assert any(s is not None and not s.stable for s in ref) and any(s is not None and s.stable for s in ref)


# ---------------------------------------------------------------- sscr: the stiffness of the disks' poses


def test_sscr_buckles_at_eulers_load(backbone):
    """The rod between the disks is continuous: the cantilever's buckling load is Euler's whatever the disks
    (measured -2.4e-6, -3.0e-6, -3.0e-6 at 5, 10, 20 disks: the rod's axial compliance and Runge-Kutta), by a
    pair of real eigenvalues."""
    for n in (5, 20):
        robot = rod(backbone, n)
        euler = EULER * backbone.bending_stiffness / robot.length**2
        assert buckling_load(robot, "sscr") / euler - 1 == pytest.approx(0.0, abs=2e-5)
        assert compression(robot, 1.01 * euler, "sscr").stability.n_real_nonpositive == 2


def _sscr_stiffness(robot, loads, **options):
    from pytdcr.statics.options import SSCROptions
    from pytdcr.statics.registry import resolve

    opts = SSCROptions(**options)
    sol = solve(robot, loads, model="sscr", options=opts)
    assert sol.converged
    m, _ = resolve("sscr", robot, loads, opts)
    eq = m.equations(robot, loads, opts)
    return m, eq, sol.q.reshape(-1)


def test_sscr_stiffness_is_symmetric_under_conservative_loads():
    """Gravity and a dead tip force derive from a potential, so K (poses with their conjugate wrenches) is
    symmetric at an equilibrium, up to the discretisation: its antisymmetric part falls at fourth order in
    the Runge-Kutta step (measured 0.0344, 0.0022, 0.000136, 8.4e-6 N m at 2, 4, 8, 16 steps), and the sign
    and scaling of every block are checked by it."""
    robot = paper_robot(NoFriction())
    loads = Loads(np.zeros(robot.n_tendons), tip_force=[0.3, 0.1, -0.1])
    asym = []
    for steps in (2, 4, 8):
        m, eq, q = _sscr_stiffness(robot, loads, steps_per_subsegment=steps)
        K = m.tangent_stiffness(eq, q)
        asym.append(np.abs(K - K.T).max())
        assert asym[-1] < 1e-4 * np.abs(K).max()
    ratios = np.array(asym[:-1]) / np.array(asym[1:])
    assert np.all((ratios > 12.0) & (ratios < 20.0))


def test_sscr_tendons_derive_from_a_potential_only_without_pass_through_disks(backbone):
    """A tendon of constant tension between two holes derives from a potential (T times its length): anchored at
    the first disk, K's antisymmetric part falls at fourth order as above (measured 0.0333, 0.00189, 0.000111,
    6.7e-6 N m at 2, 4, 8, 16 steps). Passing through disks it does not (0.0554, 0.0064, 0.0033, 0.0031 N m):
    a pass-through disk takes only the in-plane part of the tendon's resultant (the model's rule), which no
    potential gives."""
    asym = {}
    for segment in (1, 2):
        robot = Robot(backbone=backbone, segments=(Segment(length=0.02, n_disks=1), Segment(length=0.38, n_disks=19)),
                      gravity=(0, 0, 0), friction=NoFriction(),
                      tendons=(Tendon(segment=segment, radius=0.01, angle_deg=30),))
        for steps in (4, 8, 16):
            m, eq, q = _sscr_stiffness(robot, Loads(np.array([3.0])), steps_per_subsegment=steps)
            K = m.tangent_stiffness(eq, q)
            asym[segment, steps] = np.abs(K - K.T).max() / np.abs(K).max()
    assert 12.0 < asym[1, 4] / asym[1, 8] < 20.0 and 12.0 < asym[1, 8] / asym[1, 16] < 20.0
    assert asym[2, 16] > 0.9 * asym[2, 8] > 100 * asym[1, 16]


def test_sscr_stiffness_tends_to_the_inextensible_rods():
    """The test reads K of the rod with its real axial and shear stiffness; the inextensible rod's own
    stiffness is the pencil (B, P) of its Kirchhoff derivatives, whose finite eigenvalues the penalised K's
    soft ones approach as EA and GA grow (measured 1.3e-3 relative at the real EA, GA; 1.3e-5 at 100 times)."""
    import scipy.linalg as sl

    robot = paper_robot(NoFriction())
    loads = paper_loads(np.array([12.0, 3.0, 0.0, 0.0, 6.0, 0.0, 0.0, 2.0]))
    m, eq, q = _sscr_stiffness(robot, loads)
    n = eq.n_disks
    J = eq.evaluate(q, jacobian=True).jacobian
    _, rot, _ = eq.shape(q)
    B = np.concatenate([rot[i + 1] @ J[3 * k:3 * k + 3] for i in range(n) for k in (2 * i, 2 * i + 1)])
    P = eq.pose_jacobians(q)[1:].copy()
    P[:, :3] /= eq.packed.sub[:, 0, None, None]
    w = sl.eigvals(B, P.reshape(6 * n, -1))
    pencil = np.sort(w[np.abs(w) < 1.0].real)[:6]
    for scale, tol in ((1.0, 5e-3), (100.0, 1e-4)):
        rod_ = eq.packed.rod.copy()
        rod_[:2] *= scale
        stiff = m.tangent_stiffness(replace(eq, packed=eq.packed._replace(rod=rod_)), q)
        soft = np.sort(np.linalg.eigvals(stiff).real)[:6]
        assert np.allclose(soft, pencil, rtol=tol, atol=0.0)


def test_sscr_and_pcc2_agree_where_their_shapes_do(backbone):
    """A segment pushed along its axis and bent by a tendon (20 disks), below and past Euler's load: wherever
    the two models' tips lie within 1 mm, their tests agree, count for count (the eigenvalues differ: relative
    angles for pcc2, the disks' poses here)."""
    robot = Robot(backbone=backbone, segments=(Segment(length=0.2, n_disks=20),), gravity=(0, 0, 0),
                  tendons=tuple(Tendon(segment=1, radius=0.01, angle_deg=a) for a in (0, 180)))
    compared = {True: 0, False: 0}
    for force in (0.3, 0.6, 0.9):
        for tension in (0.0, 0.05, 1.0):
            loads = Loads(np.array([tension, 0.0]), tip_force=[0.0, 0.0, -force])
            a, b = solve(robot, loads, model="pcc2"), solve(robot, loads, model="sscr")
            if np.linalg.norm(a.tip_position - b.tip_position) < 1e-3:
                assert a.stable is b.stable
                assert a.stability.n_real_nonpositive == b.stability.n_real_nonpositive
                compared[bool(a.stable)] += 1
    assert compared[True] >= 5 and compared[False] >= 2


def test_sscr_the_paper_reach_optimum():
    """Under sscr the pcc reach optimum's tensions give a stable pose with a complex pair of negative real part,
    as under pcc (measured -0.00048 +/- 0.00094i)."""
    sol = solve(paper_robot(), paper_loads(np.array([15.914, 5.379, 20.0, 20.0, 20.0, 20.0, 13.542, 11.781])),
                model="sscr")
    assert sol.stable is True and sol.stability.flutter_pairs >= 1

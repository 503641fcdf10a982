"""The static stability flag (MODEL.md, appendix B): buckling, the paper's cases, honest reporting."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import rod

from pytdcr import Loads, NoFriction, Segment, TensionBounds, paper_loads, paper_robot, solve
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
    assert solve(robot, paper_loads(), model="sscr").stable is None
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
    from pytdcr import Robot, Tendon

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


@pytest.mark.parametrize("model", ["pcc", "pcc2"])
def test_a_batchs_stability_is_each_solutions_own(model):
    """The batch's test (compiled stiffness, one stacked eigenvalue call) is the single solution's, bit for bit,
    whatever the threads; unstable equilibria are among them under the paper's load."""
    from pytdcr.statics import solve_batch
    from pytdcr.statics.registry import resolve

    robot, loads = paper_robot(), paper_loads()
    T = np.random.default_rng(1).uniform(0.0, 20.0, (300, robot.n_tendons))
    m, opts = resolve(model, robot, loads, None)
    eq = m.equations(robot, loads, opts)
    got = [solve_batch(robot, T, loads, model=model, threads=k) for k in (1, 2)]
    assert got[0].stability == got[1].stability
    ref = [m.stability_at(eq.with_tensions(t), q.reshape(-1)) if ok else None
           for t, q, ok in zip(T, got[0].q, got[0].converged, strict=True)]
    assert list(got[0].stability) == ref
    assert any(s is not None and not s.stable for s in ref) and any(s is not None and s.stable for s in ref)

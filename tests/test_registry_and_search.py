"""One registry of models, one shape for the reach search, exact gradients, thread-independent batches."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pytdcr import (
    MODELS,
    Loads,
    Model,
    PointLoad,
    SolverOptions,
    TensionBounds,
    UnsupportedFeatureError,
    get_model,
    paper_loads,
    solve,
    solve_batch,
    tip_gradient,
)
from pytdcr.compare import compare_models
from pytdcr.kinematics import forward_kinematics, tip_jacobian
from pytdcr.optimize import MemeticGA, ReachProblem, Termination, maximize_reach, polish_reach
from pytdcr.statics import configure, resolve
from pytdcr.statics.pcc import PCC, PCCModel


def test_registry_names_describe_and_resolve():
    assert {"pcc", "pcc2", "sscr", "cosserat"} <= set(MODELS)
    for name, m in MODELS.items():
        assert isinstance(m, Model) and m.name == name
        assert m.description and "\n" not in m.description
        assert isinstance(m.default_options(), m.options_type)
    assert get_model("pcc") is PCC
    with pytest.raises(ValueError, match=r"model must be one of \['pcc', .*'cosserat'\], got 'prbm'"):
        get_model("prbm")
    with pytest.raises(TypeError, match="registered name"):
        get_model(3.0)  # type: ignore[arg-type]


def test_refusals_come_from_one_place_naming_model_and_feature(paper):
    with pytest.raises(UnsupportedFeatureError) as err:
        configure("pcc", shear_extension=True)
    assert err.value.model == "pcc" and "shear_extension" in err.value.feature
    with pytest.raises(UnsupportedFeatureError, match="model 'cosserat' does not support tendon friction"):
        resolve("cosserat", paper, paper_loads())
    with pytest.raises(TypeError, match=r"robot must be a pytdcr\.Robot"):
        solve(None, paper_loads())  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"loads must be a pytdcr\.Loads"):
        solve(paper, np.zeros(8))  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class _TipOnlyPCC(PCCModel):
    """A model defined outside the registry: the PCC model that claims no point wrenches and no gradient."""

    name: str = "pcc-tip-only"
    capabilities = dataclasses.replace(PCC.capabilities, point_wrenches=False, gradient=None)


def test_a_model_object_outside_the_registry_is_accepted_and_checked(paper):
    m = _TipOnlyPCC()
    t = np.array([3.0, 0, 1.0, 0, 0, 2.0, 0, 0])
    a = solve(paper, Loads(t), model=m)
    b = solve(paper, Loads(t))
    assert a.model == "pcc-tip-only" and np.array_equal(a.q, b.q)
    with pytest.raises(UnsupportedFeatureError, match="wrenches at disks other than the tip"):
        solve(paper, Loads(t, point_loads=(PointLoad(5, [0.0, 0.01, 0.0]),)), model=m)
    with pytest.raises(UnsupportedFeatureError, match="tip gradient"):
        tip_gradient(paper, Loads(t), a, model=m)
    cmp = compare_models(paper, Loads(np.zeros(8)), t[None, :], models=("pcc", m))
    assert cmp.models == ("pcc", "pcc-tip-only") and cmp.difference("pcc-tip-only")[0] == 0.0


@pytest.mark.parametrize("scale", [0.0, 1.0, 15.0, 60.0])
def test_exact_tip_jacobian_matches_central_differences(scale):
    """The straight robot, gently and strongly bent ones (up to 1.2 rad per subsegment), twisted."""
    rng = np.random.default_rng(int(scale) + 1)
    n = 20
    lengths = np.full(n, 0.02)
    q = rng.normal(0.0, scale, (n, 3)) if scale else np.zeros((n, 3))
    q[:, 2] *= 0.02  # twists of a few hundredths of a radian per unit of scale
    sub = np.zeros((n, 5))
    sub[:, 0] = lengths
    J = tip_jacobian(q.ravel(), sub)
    h = 1e-6
    fd = np.empty_like(J)
    for j in range(3 * n):
        qp, qm = q.ravel().copy(), q.ravel().copy()
        qp[j] += h
        qm[j] -= h
        fd[:, j] = (forward_kinematics(qp, lengths)[0][-1] - forward_kinematics(qm, lengths)[0][-1]) / (2 * h)
    # central differences carry O(h^2) truncation and O(eps/h) rounding: about 1e-10 here
    assert np.abs(J - fd).max() < 1e-9 * max(1.0, np.abs(J).max())


def test_batch_results_do_not_depend_on_the_thread_count(paper):
    T = np.random.default_rng(2).uniform(0, 20, (40, 8))
    runs = [solve_batch(paper, T, paper_loads(), threads=k) for k in (1, 2, 3)]
    for r in runs[1:]:
        assert np.array_equal(r.q, runs[0].q) and np.array_equal(r.converged, runs[0].converged)
    one = solve(paper, paper_loads(T[7]))
    assert np.array_equal(one.q, runs[0].q[7])  # a single solve is the same compiled code


@pytest.fixture(scope="module")
def small_problem(backbone):
    from pytdcr import ConstantFriction, Robot, Segment, Tendon

    robot = Robot(name="small", backbone=backbone, segments=(Segment(length=0.12, n_disks=6, disk_mass=2e-4),),
                  tendons=tuple(Tendon(segment=1, radius=0.008, angle_deg=a) for a in (0, 90, 180, 270)),
                  friction=ConstantFriction(mu=0.1))
    loads = Loads(np.zeros(4), tip_force=[0.03, 0.0, -0.02], tip_moment=[0.0, 0.004, 0.0])
    return ReachProblem.create(robot, loads, TensionBounds.uniform(4, 0.0, 5.0))


def test_directional_objective_and_its_gradient(small_problem):
    d = np.array([1.0, 1.0, 0.0])
    p = small_problem.with_direction(d)
    assert np.allclose(p.direction, d / np.sqrt(2))
    t = np.array([3.0, 0.5, 1.0, 2.0])
    cost, grad, sol = p.cost_and_gradient(t)
    assert cost == pytest.approx(-(sol.tip_position @ p.direction))
    for c in range(4):
        e = np.eye(4)[c] * 1e-4
        up = p.cost_and_gradient(t + e)[0]
        dn = p.cost_and_gradient(t - e)[0]
        assert grad[c] == pytest.approx((up - dn) / 2e-4, rel=1e-5, abs=1e-10)
    with pytest.raises(ValueError, match="direction must be 3 finite numbers"):
        small_problem.with_direction([0.0, 0.0, 0.0])


def test_the_same_search_maximises_along_a_direction(small_problem):
    d = np.array([0.0, -1.0, 0.0])
    p = small_problem.with_direction(d)
    res = maximize_reach(p, MemeticGA(pop_size=10), Termination(1e-9, 3, 5), seed=3)
    assert res.value == pytest.approx(res.tip_position @ p.direction)
    assert res.cost == pytest.approx(-res.value)
    # no sampled tension vector goes farther along d than the optimum
    T = small_problem.bounds.sample(60, np.random.default_rng(0))
    ev = p.evaluate(T)
    ok = ev.batch.converged
    assert np.all(ev.batch.tip_position[ok] @ p.direction <= res.value + 1e-9)
    # and a polish from the optimum cannot improve it
    again = polish_reach(p, res.tensions)
    assert again.value <= res.value + 1e-9


def test_search_settings_are_validated(small_problem):
    with pytest.raises(ValueError, match="pop_size = 1: must be an integer >= 2"):
        MemeticGA(pop_size=1)
    with pytest.raises(ValueError, match="tol must be finite and > 0"):
        Termination(tol=0.0)
    with pytest.raises(ValueError, match="seed = -1: must be an integer >= 0"):
        maximize_reach(small_problem, seed=-1)
    with pytest.raises(ValueError, match="every tension is fixed"):
        ReachProblem.create(small_problem.robot, small_problem.loads, TensionBounds.uniform(4, 1.0, 1.0))
    with pytest.raises(TypeError, match=r"bounds must be a pytdcr\.TensionBounds"):
        ReachProblem.create(small_problem.robot, small_problem.loads, (0, 5))  # type: ignore[arg-type]


def test_solver_options_of_the_wrong_model_are_refused(rao):
    with pytest.raises(TypeError, match="takes CosseratOptions"):
        solve(rao, Loads(np.zeros(6)), model="cosserat", options=SolverOptions())

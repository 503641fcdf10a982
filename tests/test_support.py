"""The workspace's support function h(d) and the largest reach (issue 12): h is never below a sample, every
reported tip is the cold solve of its tensions, and the largest reach matches the reach search."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pytdcr import solve
from pytdcr.optimize import MemeticGA, ReachProblem, SearchFailed, Termination, maximize_reach
from pytdcr.paper import paper_bounds, paper_loads, paper_robot
from pytdcr.workspace import SupportFunction
from pytdcr.workspace import _support as support_module
from pytdcr.workspace._plan import plan_tensions
from pytdcr.workspace._solve import solve_plan
from pytdcr.workspace._support import (
    SampleStates,
    SupportSettings,
    fibonacci_directions,
    largest_reach,
    support_function,
)

#: h may fall short of a sample's d . tip by no more than this [m] (rounding)
SLACK = 1e-9
#: a re-solve of reported tensions reproduces the reported tip to this [m]
SAME_TIP = 1e-6


@pytest.fixture(scope="module")
def case():
    """The paper's robot and tip load, bounds [0, 20] N, and the feasible samples of a small plan."""
    robot, loads, bounds = paper_robot(), paper_loads(), paper_bounds()
    samples = solve_plan(robot, loads, plan_tensions(bounds, 256, seed=0))
    ok = samples.feasible
    return ReachProblem.create(robot, loads, bounds), samples.tensions[ok], samples.tip_position[ok]


@pytest.fixture(scope="module")
def states() -> SampleStates:
    """The states of the ``case`` fixture's feasible samples (the same plan, solved along the loading path)."""
    samples = solve_plan(paper_robot(), paper_loads(), plan_tensions(paper_bounds(), 256, seed=0))
    return SampleStates(samples.q[samples.feasible], continued=False)


@pytest.fixture(scope="module")
def support(case) -> SupportFunction:
    problem, T, P = case
    return support_function(problem, T, P, fibonacci_directions(12), threads=2)


@pytest.fixture(scope="module")
def warm(case, states) -> SupportFunction:
    """``support`` with the samples' states: every search warm from a sample's equilibrium."""
    problem, T, P = case
    return support_function(problem, T, P, fibonacci_directions(12), threads=2, states=states)


def test_fibonacci_directions_are_unit_and_well_spread():
    n = 200
    d = fibonacci_directions(n)
    assert d.shape == (n, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(d, fibonacci_directions(n))
    assert np.linalg.norm(d.mean(axis=0)) < 1.0 / n  # balanced over the sphere
    spacing = np.sqrt(4 * np.pi / n)  # the side of the equal-area patch of each direction [rad]
    angles = np.arccos(np.clip(d @ d.T, -1, 1)) + 4 * np.eye(n)
    nearest = angles.min(axis=1)
    assert nearest.min() > 0.6 * spacing and nearest.max() < 1.3 * spacing
    # every point of the sphere lies near a direction (the covering radius)
    probe = np.random.default_rng(0).normal(size=(20_000, 3))
    probe /= np.linalg.norm(probe, axis=1)[:, None]
    assert np.arccos(np.clip(probe @ d.T, -1, 1)).min(axis=1).max() < 0.9 * spacing
    # any count works, one included
    assert fibonacci_directions(1).shape == (1, 3)
    with pytest.raises(ValueError):
        fibonacci_directions(0)


def test_h_is_never_below_a_sample(case, support):
    _, _, P = case
    values = P @ support.directions.T  # (M, K): every feasible sample's d . tip
    assert np.all(support.h >= values.max(axis=0) - SLACK)
    np.testing.assert_allclose(support.sample_h, values.max(axis=0))
    assert np.all(support.gain >= -SLACK)
    # the search does better than the samples along most directions (a 256-point plan leaves room)
    assert np.sum(support.gain > 1e-4) >= support.h.size // 2


def test_reported_tensions_reproduce_the_reported_tips(case, support):
    problem, _, _ = case
    robot, loads = problem.robot, problem.loads
    assert np.all(support.tensions >= 0) and np.all(support.tensions <= 20)
    for k in range(support.h.size):
        sol = solve(robot, loads.with_tensions(support.tensions[k]))
        assert sol.converged
        assert np.linalg.norm(sol.tip_position - support.tip_position[k]) <= SAME_TIP
        assert support.h[k] == pytest.approx(support.tip_position[k] @ support.directions[k], abs=1e-15)


def test_h_is_the_support_function_of_the_reported_tips(support):
    values = support.tip_position @ support.directions.T  # values[j, k] = d_k . tip_j
    assert np.all(values.max(axis=0) <= support.h + 1e-12)
    assert np.all(support.evaluations > 0) and np.all(support.starts >= 1)
    out = json.loads(json.dumps(support.to_dict()))
    assert len(out["h"]) == support.h.size and out["summary"]["directions"] == support.h.size
    assert out["settings"]["objective"] == "support"
    rows = support.table()
    assert len(rows) == support.h.size and rows[0]["h_m"] == support.h[0]


def test_results_do_not_depend_on_the_threads(case):
    problem, T, P = case
    d = fibonacci_directions(12)[[2, 7, 9]]
    settings = SupportSettings(max_iter=4, restarts=0, exchange_rounds=1)
    one = support_function(problem, T, P, d, settings=settings, threads=1)
    two = support_function(problem, T, P, d, settings=settings, threads=2)
    for name in ("h", "tensions", "tip_position", "evaluations", "from_sample", "exchanged"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))


def test_warm_searches_do_about_as_well_as_the_cold_ones(warm, support):
    """Warm searches (from the samples' equilibria) reach, on average over the directions, within 1 mm of the
    cold searches' h."""
    assert np.mean(warm.h) >= np.mean(support.h) - 1e-3


def test_warm_searches_still_report_the_loading_paths_equilibria(case, states, warm):
    """With the samples' states the searches run warm from the samples' equilibria, and each end is solved by
    the samples' definition (here from rest): every reported tip is the cold solve of its tensions, h is never
    below a sample, and it does not depend on the threads."""
    problem, T, P = case
    d = fibonacci_directions(12)
    assert warm.parent is not None and warm.settings["equilibria"] == "loading path"
    assert np.all(warm.h >= (P @ d.T).max(axis=0) - SLACK)
    for k in range(warm.h.size):
        sol = solve(problem.robot, problem.loads.with_tensions(warm.tensions[k]))
        assert sol.converged and np.linalg.norm(sol.tip_position - warm.tip_position[k]) <= SAME_TIP
    np.testing.assert_array_equal(warm.tensions[warm.from_sample], T[warm.parent[warm.from_sample]])
    one = support_function(problem, T, P, d[[2, 7, 9]], threads=1, states=states,
                           settings=SupportSettings(max_iter=4, restarts=0, exchange_rounds=1))
    two = support_function(problem, T, P, d[[2, 7, 9]], threads=2, states=states,
                           settings=SupportSettings(max_iter=4, restarts=0, exchange_rounds=1))
    for name in ("h", "tensions", "tip_position", "evaluations", "parent"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    far = largest_reach(problem, T, P, warm, starts=2, states=states)
    assert far.reach >= np.linalg.norm(P, axis=1).max() - SLACK and far.parent >= 0
    sol = solve(problem.robot, problem.loads.with_tensions(far.tensions))
    assert np.linalg.norm(sol.tip_position - far.tip_position) <= SAME_TIP


def test_the_best_sample_is_kept_when_every_search_fails(case, monkeypatch):
    problem, T, P = case

    def fail(*args, **kwargs):
        raise SearchFailed("no")

    monkeypatch.setattr(support_module, "polish_reach", fail)
    seen: list[int] = []
    got = support_function(problem, T, P, fibonacci_directions(5), progress=seen.append)
    assert seen == [1] * 5
    assert np.all(got.from_sample) and not np.any(got.exchanged)
    np.testing.assert_array_equal(got.h, got.sample_h)
    best = np.argmax(P @ got.directions.T, axis=0)
    np.testing.assert_array_equal(got.tensions, T[best])
    far = largest_reach(problem, T, P, got, starts=2)
    assert far.from_sample and far.reach == far.sample_reach == np.linalg.norm(P, axis=1).max()


def test_bad_input_is_refused(case):
    problem, T, P = case
    with pytest.raises(ValueError, match="shape"):
        support_function(problem, T[:, :4], P)
    with pytest.raises(ValueError, match="feasible"):
        support_function(problem, T, np.where(np.arange(P.shape[0])[:, None] == 3, np.nan, P))
    with pytest.raises(ValueError, match="at least one"):
        support_function(problem, T[:0], P[:0])
    with pytest.raises(ValueError, match="nonzero"):
        support_function(problem, T, P, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="starts"):
        support_function(problem, T, P, settings=SupportSettings(starts=0))


@pytest.mark.slow
def test_largest_reach_beats_the_samples_and_reproduces(case, support):
    problem, T, P = case
    far = largest_reach(problem, T, P, support, starts=2)
    assert far.reach >= np.linalg.norm(P, axis=1).max() - SLACK
    assert far.reach >= np.linalg.norm(support.tip_position, axis=1).max() - SLACK
    assert far.reach <= problem.robot.length
    sol = solve(problem.robot, problem.loads.with_tensions(far.tensions))
    assert np.linalg.norm(sol.tip_position - far.tip_position) <= SAME_TIP
    assert json.loads(json.dumps(far.to_dict()))["reach"] == far.reach


@pytest.mark.slow
def test_largest_reach_matches_the_reach_search_over_seeds():
    """The support machinery's largest reach is within 0.1 mm of the memetic GA's best over seeds 0-7 (or
    beyond it) on the paper case."""
    robot, loads, bounds = paper_robot(), paper_loads(), paper_bounds()
    problem = ReachProblem.create(robot, loads, bounds)
    ga = max(maximize_reach(problem, MemeticGA(pop_size=50), Termination(1e-6, 5, 30), seed=s).reach
             for s in range(8))
    samples = solve_plan(robot, loads, plan_tensions(bounds, 1000, seed=0))
    ok = samples.feasible
    T, P = samples.tensions[ok], samples.tip_position[ok]
    support = support_function(problem, T, P, fibonacci_directions(12))
    far = largest_reach(problem, T, P, support)
    assert far.reach >= ga - 1e-4


def test_a_search_that_crossed_a_fold_keeps_the_best_equilibrium_the_definition_reaches():
    """Where a warm search ends on another branch than the continuation from its sample reaches, the support
    function keeps the best of the continuation's equilibria along the way and climbs from it: the tensions it
    returns reproduce its equilibrium when continued from the sample, stable, and it is at least as high as every
    equilibrium so reached at :data:`SEGMENT` of the way."""
    robot, loads, bounds = paper_robot(), paper_loads(), paper_bounds()
    problem = ReachProblem.create(robot, loads, bounds, stable_only=True).with_direction(np.array([1.0, 0.0, 0.0]))
    anchor = solve(robot, loads.with_tensions(np.full(8, 2.0)))
    assert anchor.converged and anchor.stable
    strict = problem.continued_from(anchor)
    start, far = anchor.loads.tensions.copy(), np.array([0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 20.0, 0.0])
    end = strict.solve(far, atol=1e-12)
    t, sol, n = support_module._across_a_fold(problem, strict, start, far, end)
    assert sol is not None and sol.converged and sol.stable and n >= len(support_module.SEGMENT) - 1
    again = strict.solve(t, atol=1e-12)
    assert np.linalg.norm(again.tip_position - sol.tip_position) <= SAME_TIP
    for frac in support_module.SEGMENT:
        other = strict.solve(start + frac * (far - start), atol=1e-12)
        if other.converged and other.stable:
            assert problem.value(sol.tip_position) >= problem.value(other.tip_position) - SLACK

"""The region of continued equilibria (issue 27, items 1-2): parents, replay, thread independence, what it holds
against the loading path's region, and multistability reported where the robot has two stable equilibria."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import solve
from pytdcr.cli.workspace import EQUILIBRIA_CHOICES
from pytdcr.paper import paper_bounds, paper_loads
from pytdcr.statics import get_model
from pytdcr.workspace import WorkspaceSettings
from pytdcr.workspace._grid import inside, region_from_points
from pytdcr.workspace._history import measure_multistability
from pytdcr.workspace._plan import TensionPlan, plan_tensions
from pytdcr.workspace._solve import FIRST_WAVE, ROOT, _Solver, continue_plan, solve_plan
from pytdcr.workspace.parts import RegionSamples

# one tension vector with two stable equilibria under the paper's load (tests/test_continuation.py)
BISTABLE = np.array([13.18, 14.16, 17.09, 16.97, 11.38, 19.27, 10.38, 18.73])


@pytest.fixture(scope="module")
def plan():
    return plan_tensions(paper_bounds(), 128, seed=3)


@pytest.fixture(scope="module")
def continued(paper, plan):
    return continue_plan(paper, paper_loads(), plan, threads=2)


def _replay(robot, samples: RegionSamples, k: int):
    """Sample ``k``'s equilibrium by the public calls: the root from rest, then each continuation of its path."""
    chain = []
    while k != ROOT:
        chain.append(k)
        k = int(samples.parent[k])
    sol = solve(robot, paper_loads())
    for j in reversed(chain):
        sol = solve(robot, paper_loads(samples.tensions[j]), start=sol)
    return sol, len(chain)


def test_every_sample_records_a_parent_solved_before_it(continued, plan):
    p = continued.parent
    assert p is not None and p.shape == (plan.tensions.shape[0],)
    rows = np.arange(p.size)
    assert np.all((p == ROOT) | ((p >= 0) & (p < rows)))
    # the first wave comes from the root; a parent outside it was solved in an earlier wave, stable
    assert np.all(p[:FIRST_WAVE] == ROOT)
    later = p[p >= 0]
    assert later.size > 0 and np.all(continued.feasible[later])


def test_a_replayed_path_gives_the_same_equilibrium(paper, continued):
    deep = [k for k in np.flatnonzero(continued.feasible) if continued.parent[k] >= 0]
    for k in deep[-3:]:
        sol, steps = _replay(paper, continued, int(k))
        assert steps >= 2
        assert sol.converged
        np.testing.assert_allclose(sol.tip_position, continued.tip_position[k], rtol=0, atol=1e-12)


def test_continued_samples_do_not_depend_on_the_threads(paper, plan, continued):
    one = continue_plan(paper, paper_loads(), plan, threads=1)
    np.testing.assert_array_equal(one.parent, continued.parent)
    np.testing.assert_array_equal(one.converged, continued.converged)
    np.testing.assert_array_equal(np.nan_to_num(one.tip_position), np.nan_to_num(continued.tip_position))


def test_the_continued_region_holds_the_loading_paths_reachable_samples(paper, plan, continued):
    """A loading-path sample whose equilibrium the continuation reaches too lies in the continued region; and
    most of the loading path's stable samples do (the rest: another equilibrium of a multistable vector)."""
    cold = solve_plan(paper, paper_loads(), plan, warm=False, threads=2)
    both = cold.feasible & continued.feasible
    gap = np.linalg.norm(cold.tip_position - continued.tip_position, axis=1)
    same = both & (gap <= 1e-6)
    assert same.sum() >= 0.85 * cold.feasible.sum()
    region = region_from_points(continued.tip_position[continued.feasible], 0.0125)
    assert np.all(inside(region, cold.tip_position[same]))


def test_a_bistable_tension_vector_is_reported_as_multistable(paper):
    """BISTABLE continued from the root (zero tension under the load: the tensions rise with the load on) keeps
    the far equilibrium; the loading path from rest (every load ramped together) reaches the other one. Beside
    it, rows near rest where the branch is unique: the check reports BISTABLE alone."""
    T = np.vstack([BISTABLE, 0.5 * np.eye(8)[:4] + 0.5])
    plan = TensionPlan(T, np.zeros(T.shape[0], dtype=np.int8), T.shape[0], 0, 0, paper_bounds())
    s = continue_plan(paper, paper_loads(), plan, threads=2)
    assert np.all(s.parent == ROOT) and np.all(s.feasible)
    m = get_model("pcc")
    solver = _Solver(paper, paper_loads(), m, m.default_options(), 2, None, True)
    ms = measure_multistability(solver, s, 1000, seed=0)
    assert ms.checked == T.shape[0]
    np.testing.assert_array_equal(ms.distinct, [True, False, False, False, False])
    assert np.linalg.norm(ms.other_tip[0] - s.tip_position[0]) > 0.05 and ms.other_stable[0]
    d = ms.to_dict()
    assert d["distinct"] == 1 and d["checked"] == 5 and d["fraction"] == pytest.approx(0.2)


def test_equilibria_are_named_and_checked(paper):
    assert EQUILIBRIA_CHOICES == WorkspaceSettings.EQUILIBRIA
    assert WorkspaceSettings().equilibria_of(get_model("pcc")) == "continuation"
    assert WorkspaceSettings().equilibria_of(get_model("cosserat")) == "loading-path"
    with pytest.raises(ValueError, match="cannot continue"):
        WorkspaceSettings(equilibria="continuation").equilibria_of(get_model("cosserat"))
    with pytest.raises(ValueError, match="equilibria"):
        WorkspaceSettings(equilibria="sideways")
    with pytest.raises(ValueError, match="multistability"):
        WorkspaceSettings(multistability=-1)


@pytest.mark.slow
def test_h_and_the_largest_reach_come_from_stable_equilibria(paper):
    """Under the paper's load the support function and the reach search refuse unstable equilibria (issue 27,
    item 3), and report the equilibria of the continued region: every row is marked stable, and each searched
    row's tip is what continuing its parent sample's equilibrium to its tensions reaches, a stable equilibrium."""
    from pytdcr.workspace import workspace_study

    ws = workspace_study(paper, paper_loads(), paper_bounds(),
                         WorkspaceSettings(n=48, seed=4, search=False, directions=6, multistability=0, threads=2))
    sf, samples = ws.support, ws.samples
    assert sf is not None and np.all(sf.stable == 1.0) and all(r["stable"] for r in sf.table())
    assert sf.parent is not None and ws.reach_search is not None
    assert sf.settings["equilibria"] == "continued"

    def replayed(t: np.ndarray, parent: int):
        assert samples.feasible[parent]
        start = solve(paper, paper_loads(samples.tensions[parent]), q0=samples.q[parent])
        np.testing.assert_allclose(start.tip_position, samples.tip_position[parent], atol=1e-6)
        return solve(paper, paper_loads(t), start=start)

    searched = [k for k in range(sf.h.size) if not sf.from_sample[k]]
    assert searched
    for k in searched:
        sol = replayed(sf.tensions[k], int(sf.parent[k]))
        assert sol.converged and sol.stable
        assert np.linalg.norm(sol.tip_position - sf.tip_position[k]) <= 1e-6
    for k in np.flatnonzero(sf.from_sample):
        np.testing.assert_array_equal(sf.tensions[k], samples.tensions[sf.parent[k]])
    rs = ws.reach_search
    best = replayed(rs.tensions, rs.parent)
    assert best.converged and best.stable
    assert np.linalg.norm(best.tip_position - rs.tip_position) <= 1e-6


def test_an_unstable_root_leaves_the_continued_region_empty_and_says_so(paper, tmp_path):
    """An axial tip force of twice Euler's load (clamped-free, pi^2 EI / (4 L^2)), no gravity: the straight
    robot at zero tension is an unstable equilibrium. The continued region holds no sample (none has a stable
    parent), has no largest reach, and the run says why."""
    from pytdcr import Loads
    from pytdcr.runs import run_workspace

    robot = paper.with_gravity(None)
    euler = np.pi**2 * robot.backbone.bending_stiffness / (4 * robot.length**2)
    loads = Loads(np.zeros(8), tip_force=(0.0, 0.0, -2.0 * euler))
    assert not solve(robot, loads).stable
    settings = WorkspaceSettings(n=32, seed=1, search=False, directions=0, multistability=0, reach="samples")
    run = run_workspace(robot, loads, paper_bounds(), settings, tmp_path / "ws")
    s = run.record
    assert s.summary.equilibria == "continuation" and s.summary.root == "unstable"
    assert s.summary.fsw.points == 0 and s.summary.fsw.largest_reach_m is None
    assert any(w.code == "root-missing" and "not stable at zero tension" in w.text for w in s.warnings)
    samples = run.cases[0].region.samples
    assert not samples.converged.any() and np.all(samples.parent == -2)

"""Sampling, the GA of Eq. 29, its polish, figures and the study report (small budgets)."""

from __future__ import annotations

import json

import matplotlib.pyplot as plt
import numpy as np
import pytest

from pytdcr import Loads, Robot, Segment, SolverOptions, Tendon, TensionBounds, solve, tip_gradient
from pytdcr.optimize import MemeticGA, ReachProblem, Termination, maximize_reach, polish_reach
from pytdcr.plotting import plot_convergence, plot_reach_samples
from pytdcr.runs import OptimizeSettings, ReproduceSettings, SampleSettings, run_optimize, run_reproduce, run_sample
from pytdcr.workspace.sampling import sample_workspace


@pytest.fixture(scope="module")
def small(backbone) -> Robot:
    """One segment of 6 disks, four tendons, gravity and friction: quick to solve."""
    from pytdcr import ConstantFriction

    return Robot(name="small", backbone=backbone, segments=(Segment(length=0.12, n_disks=6, disk_mass=2e-4),),
                 tendons=tuple(Tendon(segment=1, radius=0.008, angle_deg=a) for a in (0, 90, 180, 270)),
                 friction=ConstantFriction(mu=0.1))


LOAD = Loads(np.zeros(4), tip_force=[0.03, 0.0, -0.02], tip_moment=[0.0, 0.004, 0.0])


@pytest.mark.parametrize(
    ("lo", "hi", "match"),
    [([0, 0], [1, -1], r"upper\[1\] \(tendon 2\) must be finite and >= 0"), ([2.0], [1.0], "lower 2.0 > upper 1.0"),
     ([np.nan], [1.0], r"lower\[0\]"), ([0, 0], [1], "lower has 2 entries, upper 1")],
)
def test_bounds_validation(lo, hi, match):
    with pytest.raises(ValueError, match=match):
        TensionBounds(np.array(lo, dtype=float), np.array(hi, dtype=float))


def test_sampling_is_seeded_and_bounded(small):
    b = TensionBounds(np.array([0.0, 1.0, 0.0, 2.0]), np.array([5.0, 1.0, 3.0, 4.0]))
    a = sample_workspace(small, LOAD, b, 12, seed=4)
    again = sample_workspace(small, LOAD, b, 12, seed=4)
    other = sample_workspace(small, LOAD, b, 12, seed=5)
    assert np.array_equal(a.tensions, again.tensions) and np.array_equal(a.tip_position, again.tip_position)
    assert not np.array_equal(a.tensions, other.tensions)
    assert np.all(a.tensions >= b.lower) and np.all(a.tensions <= b.upper)
    assert np.all(a.tensions[:, 1] == 1.0)  # a fixed tension stays fixed
    assert a.converged.all()
    assert np.all(a.reach <= small.length)
    with pytest.raises(ValueError, match="has 4 tendons, got bounds for 2"):
        sample_workspace(small, LOAD, TensionBounds.uniform(2, 0, 1), 3)


def test_reach_gradient_is_exact(small):
    t = np.array([3.0, 0.5, 1.0, 2.0])
    loads = Loads(t, LOAD.tip_force, LOAD.tip_moment)
    opts = SolverOptions(atol=1e-13)
    sol = solve(small, loads, options=opts)
    tip, d = tip_gradient(small, loads, sol, options=opts)
    assert np.allclose(tip, sol.tip_position)
    for c in range(4):
        h = 1e-4
        tp, tm = t.copy(), t.copy()
        tp[c] += h
        tm[c] -= h
        fp = solve(small, Loads(tp, LOAD.tip_force, LOAD.tip_moment), options=opts).tip_position
        fm = solve(small, Loads(tm, LOAD.tip_force, LOAD.tip_moment), options=opts).tip_position
        assert np.allclose(d[:, c], (fp - fm) / (2 * h), rtol=1e-6, atol=1e-10)


def ga(small, bounds, seed, pop_size=12, max_gen=6, tol=1e-9, window=3, options=None, **algo):
    problem = ReachProblem.create(small, LOAD, bounds, options=options)
    return maximize_reach(problem, MemeticGA(pop_size=pop_size, **algo), Termination(tol, window, max_gen), seed=seed)


def test_ga_is_deterministic_bounded_and_polished(small):
    b = TensionBounds.uniform(4, 0.0, 5.0)
    r1 = ga(small, b, seed=1)
    r2 = ga(small, b, seed=1)
    r3 = ga(small, b, seed=2)
    assert np.array_equal(r1.tensions, r2.tensions) and r1.history == r2.history
    assert r1.history["best"] != r3.history["best"]
    for r in (r1, r3):
        assert r.reach <= small.length and r.ga.reach <= small.length
        # every model solve is counted: the GA's (one per individual, one per locally improved leader) and
        # its local searches'
        ls = r.history["local_search_evaluations"][-1]
        assert r.evaluations == r.history["evaluations"][-1]
        assert r.evaluations - ls <= 12 * r.generations + r.settings["local_search_runs"]
        # the memetic GA's best is a local optimum already: the final polish barely moves it
        assert r.polish_gain < 1e-6
        assert np.all(np.diff(r.history["best"]) <= 0)  # elitist: the best never worsens
        assert r.ga.cost == pytest.approx(1 / r.ga.reach) and r.cost == pytest.approx(1 / r.reach)
        assert r.polished and r.cost <= r.ga.cost + 1e-12
        assert np.all(r.tensions >= 0) and np.all(r.tensions <= 5.0)
        # converged: the optimum's solve converged and the stopping rule was met (not the cap)
        assert r.converged == (r.stop_reason == "tolerance")
    # the polished optimum is a stationary point of the bounded problem: a small move does not help
    for c in range(4):
        for step in (-0.05, 0.05):
            t = np.clip(r1.tensions + step * np.eye(4)[c], 0, 5)
            s = solve(small, Loads(t, LOAD.tip_force, LOAD.tip_moment))
            assert 1 / s.reach >= r1.cost - 1e-9


def test_plain_ga_without_local_search(small):
    b = TensionBounds.uniform(4, 0.0, 5.0)
    r = ga(small, b, seed=1, max_gen=4, local_search=False)
    assert r.history["local_search_evaluations"][-1] == 0 and r.settings["local_search_runs"] == 0
    assert r.evaluations == r.history["evaluations"][-1] <= 12 * r.generations
    assert r.stop_reason == "generation cap" and not r.converged


def test_nonconverged_individuals_are_infeasible_and_counted(small):
    starved = SolverOptions(max_iter=4, load_stepping="never")  # about 20 % of these solves fail
    b = TensionBounds.uniform(4, 0.0, 8.0)
    r = ga(small, b, seed=0, pop_size=10, max_gen=3, tol=1e-6, window=5, options=starved, polish=False)
    assert r.nonconverged > 0
    assert r.nonconverged == sum(r.history["nonconverged"])
    # the optimum is a converged solve (checked again with the same options)
    again = solve(small, Loads(r.tensions, LOAD.tip_force, LOAD.tip_moment), options=starved)
    assert again.converged and again.reach == pytest.approx(r.reach)


def test_polish_keeps_fixed_tensions(small):
    b = TensionBounds(np.array([0.0, 2.0, 0.0, 0.0]), np.array([4.0, 2.0, 4.0, 4.0]))
    p = polish_reach(ReachProblem.create(small, LOAD, b), np.array([1.0, 2.0, 1.0, 1.0]))
    assert p.tensions[1] == 2.0 and p.polish_gain >= -1e-12


def test_figures_have_the_data(tmp_path, small):
    reach = np.array([0.1, 0.12, np.nan, 0.11, 0.13, 0.09, 0.1])
    ok = ~np.isnan(reach)
    ax = plot_reach_samples(reach, ok)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    assert len(lines["converged samples"].get_xdata()) == 6
    assert "smoothing spline" in lines
    assert len(lines["not converged (1)"].get_xdata()) == 1
    assert "[m]" in ax.get_ylabel()
    plt.close(ax.figure)
    ax = plot_convergence([3.0, 2.5, 2.5], [4.0, 3.0, 2.7])
    best, mean = ax.get_lines()
    assert list(best.get_ydata()) == [3.0, 2.5, 2.5] and list(mean.get_ydata()) == [4.0, 3.0, 2.7]
    plt.close(ax.figure)


def test_sample_and_optimize_runs_write_their_inputs(tmp_path, small):
    b = TensionBounds.uniform(4, 0.0, 4.0)
    run = run_sample(SampleSettings(n=8, seed=3), tmp_path / "s", robot=small, loads=LOAD, bounds=b)
    rows = (tmp_path / "s" / "samples.csv").read_text().strip().splitlines()
    assert len(rows) == 9 and rows[0].startswith("sample,T1_N")
    rec = json.loads((tmp_path / "s" / "sample_run.json").read_text())
    assert rec["inputs"]["seed"] == 3 and rec["inputs"]["robot"]["name"] == "small"
    assert rec["inputs"]["loads"]["tip_force"] == [0.03, 0.0, -0.02]
    assert all((tmp_path / "s" / f).stat().st_size > 1000 for f in run.files if f.endswith(".png"))
    opt = run_optimize(OptimizeSettings(pop=8, tol=1e-6, window=2, max_gen=3, seed=0), tmp_path / "o", robot=small,
                       loads=LOAD, bounds=b)
    res, files = opt.result, opt.files
    assert {"fig5_convergence.png", "fig6_optimum.pdf", "history.csv"} <= set(files)
    data = json.loads((tmp_path / "o" / "optimize.json").read_text())
    assert data["result"]["reach"] == res.reach and data["inputs"]["pop"] == 8
    assert len((tmp_path / "o" / "history.csv").read_text().strip().splitlines()) == res.generations + 1


@pytest.mark.slow
def test_reproduce_writes_a_report(tmp_path, small):
    out = tmp_path / "r"
    run = run_reproduce(small, out, seed=0, settings=ReproduceSettings(pops=(8, 10), n_samples=10, max_gen=3,
                                                                       bound_uppers=(5.0,), side_max_gen=2))
    report = (out / "report.md").read_text()
    for text in ("## Fig. 5", "| population 8 |", "| population 10 |", "fourth generation", "## Fig. 6",
                 "| 5 |", "backbone length", "## The paper's optimum under better models", "| sscr |",
                 "## The feasible static workspace as a region", "| no load |", "| paper wrench |"):
        assert text in report
    assert {"workspace_slices.png", "workspace_fsw_no_load.ply", "workspace_fsw_paper_wrench.ply"} <= set(run.files)
    assert run.to_dict()["files"] == run.files and run.seconds > 0 and set(run.ga) == {8, 10}
    for f in run.files:
        assert (out / f).stat().st_size > 0
    data = json.loads((out / "reproduce.json").read_text())
    assert data["inputs"]["seed"] == 0 and set(data["ga"]) == {"8", "10"}
    assert [v["model"] for v in data["better_models"]] == ["pcc2", "sscr"]

"""Inverse statics (issue 28, item 1): tensions that put the tip at a target, checked against the forward model.

Every target below is made by the forward model (the tip of random tensions, solved from rest) or lies where no
tip can be (farther from the base than the robot is long), so the answers can be checked without trusting the
search: a reachable answer is replayed from rest (its ``path`` must tell the truth), its tensions lie in the
bounds, its objective is compared with the tensions that made the target.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from pytdcr import (
    InverseSearch,
    TensionBounds,
    TipTarget,
    inverse_path,
    inverse_statics,
    paper_loads,
    paper_robot,
    solve,
    tip_gradient,
)
from pytdcr.optimize import OBJECTIVES
from pytdcr.optimize._inverse import objective_value
from pytdcr.optimize._inverse_search import sample_pool

ROBOT = paper_robot()
LOADS = paper_loads()  # the paper's tip wrench
BOUNDS = TensionBounds.uniform(8, 0.0, 20.0)
TOL = 1e-6


def _made_targets(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` tension vectors uniform in the bounds and their tips from rest (converged ones), (n, 8) and (n, 3)."""
    rng = np.random.default_rng(seed)
    t, p = [], []
    while len(t) < n:
        tens = BOUNDS.sample(1, rng)[0]
        sol = solve(ROBOT, LOADS.with_tensions(tens))
        if sol.converged:
            t.append(tens)
            p.append(sol.tip_position)
    return np.array(t), np.array(p)


def _check_truthful(r, target) -> None:
    """The answer as it says: inside the bounds, its tip where it says, its path what a replay from rest gives."""
    assert np.all(r.tensions >= BOUNDS.lower) and np.all(r.tensions <= BOUNDS.upper)
    rest = solve(ROBOT, LOADS.with_tensions(r.tensions))
    assert rest.converged
    moved = float(np.linalg.norm(rest.tip_position - r.tip_position))
    if r.path == "loading path":
        assert moved <= 1e-8, f"'loading path' answer, but from rest the tip lands {moved:.2e} m away"
    else:
        assert r.path == "another branch" and moved > TOL
    assert abs(r.distance_m - float(np.linalg.norm(r.tip_position - target))) < 1e-12


@pytest.mark.slow
def test_fifty_made_targets_are_reached_and_the_answers_tell_the_truth():
    tensions, targets = _made_targets(50, seed=28)
    results = [inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS) for p in targets]
    for r, p in zip(results, targets, strict=True):
        assert r.reachable and r.converged and r.distance_m <= TOL
        _check_truthful(r, p)
    # the least sum of squares is a local optimum of a non-convex problem: it beats the tensions that made the
    # target (uniform random, co-contracted) on nearly every target, and where it reaches off the loading path
    # the objective it found is below theirs too (that branch is the better one)
    better = [r.objective_value <= objective_value(t, "least-squares") + 1e-9 for r, t in
              zip(results, tensions, strict=True)]
    assert sum(better) >= 45, f"only {sum(better)} of 50 answers beat the tensions that made the target"
    assert sum(r.path == "loading path" for r in results) >= 45
    assert sum(r.optimal for r in results) >= 40


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_round_trip_for_each_objective(objective):
    _, targets = _made_targets(4, seed=3)
    for p in targets:
        r = inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS, objective=objective)
        assert r.reachable and r.objective == objective
        _check_truthful(r, p)
        assert r.objective_value == pytest.approx(objective_value(r.tensions, objective))


def test_least_max_lowers_the_largest_tension_and_least_squares_the_sum_of_squares():
    _, targets = _made_targets(3, seed=7)
    for p in targets:
        sq = inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS, objective="least-squares")
        mx = inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS, objective="least-max")
        if sq.path == mx.path == "loading path":
            assert mx.tensions.max() <= sq.tensions.max() + 1e-6
            assert sq.objective_value <= float(mx.tensions @ mx.tensions) + 1e-6


def test_the_optimal_flag_is_first_order_optimality():
    """Where an answer says ``optimal``, the objective's gradient 2T on the free tensions lies in the span of the
    tip Jacobian's rows (no move that keeps the tip lowers it) and no tension at its lower bound would rather go
    lower; where it does not (the loading path's edge held it), that gradient has a part the target allows."""
    _, targets = _made_targets(6, seed=11)
    seen = set()
    for p in targets:
        r = inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS)
        _, g = tip_gradient(ROBOT, LOADS.with_tensions(r.tensions), r.solution)
        free = (r.tensions > 1e-6) & (r.tensions < 20 - 1e-6)
        grad = 2 * r.tensions[free]
        lam, *_ = np.linalg.lstsq(g[:, free].T, grad, rcond=None)
        resid = np.linalg.norm(grad - g[:, free].T @ lam) / np.linalg.norm(grad)
        seen.add(r.optimal)
        if r.optimal:
            assert resid <= 1e-3, f"'optimal' with a projected gradient {resid:.3g} of the gradient at {p}"
            at_lo = r.tensions <= 1e-6
            assert np.all(2 * r.tensions[at_lo] - g[:, at_lo].T @ lam >= -1e-3 * np.linalg.norm(grad))
        else:
            assert resid > 1e-3
    assert True in seen


def test_tip_axis_target():
    tensions, _ = _made_targets(3, seed=5)
    for t in tensions:
        ref = solve(ROBOT, LOADS.with_tensions(t))
        axis = ref.tip_rotation[:, 2]
        r = inverse_statics(ROBOT, LOADS, TipTarget(ref.tip_position, axis), bounds=BOUNDS)
        assert r.reachable
        assert np.linalg.norm(r.tip_axis - axis) * ROBOT.length <= TOL * 1.01
        angle = np.arctan2(np.linalg.norm(np.cross(r.tip_axis, axis)), r.tip_axis @ axis)
        assert r.axis_error_rad == pytest.approx(angle, rel=1e-6, abs=1e-12)
        assert r.axis_error_rad <= 1.01 * TOL / ROBOT.length
        _check_truthful(r, ref.tip_position)


@pytest.mark.parametrize("target", [[0.5, 0.0, 0.0], [0.0, 0.0, 0.45], [-0.3, 0.3, 0.1]])
def test_a_target_out_of_reach_is_reported_with_the_nearest_point_found(target):
    target = np.array(target)
    r = inverse_statics(ROBOT, LOADS, target, bounds=BOUNDS)
    assert not r.reachable and r.converged
    # physics: the tip never lies farther from the base than the robot's length
    assert r.distance_m >= np.linalg.norm(target) - ROBOT.length - 1e-9
    _check_truthful(r, target)
    # never farther than the nearest of the start pool's equilibria (all solved from rest)
    from pytdcr.optimize._inverse import _setup

    tg = _setup(ROBOT, LOADS, target, BOUNDS, "pcc", "least-squares", InverseSearch())
    pool = sample_pool(tg, BOUNDS, seed=0)
    assert r.distance_m <= np.min(np.linalg.norm(pool.tips - target, axis=1)) + 1e-12


def test_a_start_of_ones_own_and_the_budget():
    _, targets = _made_targets(1, seed=9)
    r = inverse_statics(ROBOT, LOADS, targets[0], bounds=BOUNDS, start=np.full(8, 2.0))
    assert r.reachable
    small = inverse_statics(ROBOT, LOADS, [0.5, 0.0, 0.0], bounds=BOUNDS, search=InverseSearch(max_solves=10))
    assert small.evaluations <= 10 + 2 and not small.reachable


def test_a_smooth_path_gives_smooth_tensions():
    s = np.linspace(0.0, 1.0, 40)
    tens = np.stack([6 * s, 3 * np.sin(np.pi * s), 0 * s, 2 * s**2, 1 + 0 * s, 4 * s, 0 * s, 3 * (1 - s)], axis=1)
    pts, last = [], None
    for t in tens:
        sol = solve(ROBOT, LOADS.with_tensions(t), start=last)
        pts.append(sol.tip_position)
        last = sol
    res = inverse_path(ROBOT, LOADS, np.array(pts), bounds=BOUNDS)
    assert len(res) == 40 and all(r.reachable for r in res)
    assert all(r.path == "continued" for r in res[1:])
    steps = np.abs(np.diff([r.tensions for r in res], axis=0)).max(axis=1)
    assert steps.max() < 0.5, f"a tension jumps {steps.max():.3g} N between neighbouring targets"
    # each continued answer is what moving the tensions straight from the last one gives
    for a, b in itertools.pairwise(res):
        moved = solve(ROBOT, LOADS.with_tensions(b.tensions), start=a.solution)
        assert np.linalg.norm(moved.tip_position - b.tip_position) <= 1e-8


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"target": [0.1, 0.1]}, "target: give 3 finite numbers"),
    ({"target": [0.1, np.nan, 0.1]}, "target: give 3 finite numbers"),
    ({"objective": "least-cubes"}, "objective: must be one of least-squares, least-max, least-total"),
    ({"bounds": TensionBounds.uniform(4, 0, 20)}, "has 8 tendons, got bounds for 4"),
    ({"start": [1.0, 2.0]}, "start: give 8 finite tensions"),
    ({"model": "cosserat"}, "cosserat"),
])
def test_bad_input_names_the_argument(kwargs, words):
    """Each bad argument is refused before any solve, in words that name it."""
    args = {"target": [0.1, 0.1, 0.2], "bounds": BOUNDS, **kwargs}
    target = args.pop("target")
    with pytest.raises(ValueError) as err:
        inverse_statics(ROBOT, LOADS, target, **args)
    assert words in str(err.value)


def test_a_zero_direction_is_refused():
    with pytest.raises(ValueError, match="direction: give 3 finite numbers, not all zero"):
        TipTarget([0.1, 0.1, 0.1], [0, 0, 0])


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"tol": 0.0}, "tol: must be in (0, 0.01] m"), ({"tol": 0.5}, "tol: must be in (0, 0.01] m"),
    ({"starts": 0}, "starts = 0: must be an integer in [1, 100]"),
    ({"max_solves": 5}, "max_solves = 5: must be an integer >= 10"),
    ({"pool": (np.zeros((3, 8)), np.zeros((2, 3)))}, "pool: give finite tensions"),
])
def test_bad_search_settings(kwargs, words):
    with pytest.raises(ValueError) as err:
        InverseSearch(**kwargs)
    assert words in str(err.value)


def test_the_command_line(tmp_path, capsys):
    from pytdcr.cli import main

    _, targets = _made_targets(3, seed=21)
    wrench = ["--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1"]
    x, y, z = targets[0]
    assert main(["inverse", "--target", f"{x},{y},{z}", *wrench, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reachable"] and out["distance_m"] <= TOL and out["path"] == "loading path"
    assert out["axis_error_rad"] is None  # no direction asked
    assert set(out) >= {"tensions", "tip_position", "tip_axis", "distance_m", "reachable", "stable", "converged",
                        "path"}
    rest = solve(ROBOT, LOADS.with_tensions(np.array(out["tensions"])))
    assert np.linalg.norm(rest.tip_position - targets[0]) <= TOL
    assert main(["inverse", "--target", "0.5,0,0", *wrench]) == 1  # out of reach: exit 1, the nearest point said
    assert "NOT reachable" in capsys.readouterr().out
    f = tmp_path / "path.csv"
    f.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.9f}" for v in p) for p in targets) + "\n")
    table = tmp_path / "out" / "answers.csv"
    assert main(["inverse", "--targets", str(f), *wrench, "--csv", str(table)]) == 0
    import csv

    rows = list(csv.DictReader(table.open()))
    assert len(rows) == 3 and all(r["reachable"] == "True" for r in rows)
    assert list(rows[0])[:11] == ["target_x_m", "target_y_m", "target_z_m", *[f"T{k}_N" for k in range(1, 9)]]


@pytest.mark.parametrize(("args", "words"), [
    (["--target", "0.1,0.1"], "--target"),
    (["--target", "0.1,0.1,0.1", "--tol", "0"], "tdcr: error: --tol: must be in (0, 0.01] m"),
    (["--target", "0.1,0.1,0.1", "--direction", "0,0,0"],
     "tdcr: error: --direction: give 3 finite numbers, not all zero, got [0, 0, 0]"),
    (["--targets", "@MISSING"], "--targets"),
    (["--target", "0.1,0.1,0.1", "--workspace", "@EMPTY"], "--workspace"),
])
def test_the_command_line_refuses_bad_input(args, words, tmp_path, capsys):
    from pytdcr.cli import main

    args = [a.replace("@MISSING", str(tmp_path / "no.csv")).replace("@EMPTY", str(tmp_path)) for a in args]
    assert main(["inverse", *args]) == 2
    assert words in capsys.readouterr().err


@pytest.mark.slow
def test_a_workspace_runs_samples_are_reached_from_its_folder(tmp_path, capsys):
    """The FSW's own points (a workspace run's converged, stable samples) are reachable, starting from that
    run's samples (``--workspace``); a target beyond the robot's length is not."""
    from pytdcr.cli import main

    ws = tmp_path / "ws"
    assert main(["workspace", "--n", "200", "--seed", "5", "--directions", "0", "--budget", "1500",
                 "--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1", "--out", str(ws)]) in (0, 1)
    capsys.readouterr()
    with np.load(ws / "samples.npz") as z:
        ok = z["converged"] & (z["stable"] == 1.0)
        tips = z["tip"][ok]
    picks = tips[np.random.default_rng(0).choice(len(tips), 6, replace=False)]
    for p in picks:
        assert main(["inverse", "--workspace", str(ws), "--target", ",".join(f"{v:.12f}" for v in p),
                     "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["reachable"] and out["distance_m"] <= TOL
    assert main(["inverse", "--workspace", str(ws), "--target", "0,0,-0.45", "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["distance_m"] >= 0.05
    assert main(["inverse", "--workspace", str(ws), "--target", "0.1,0,0.2", "--robot", "rao"]) == 2
    assert "--workspace takes the robot, loads, bounds and model of its run: drop --robot" in capsys.readouterr().err


def test_the_start_pool_is_kept_on_disk_whole_or_made_again(tmp_path, monkeypatch):
    from pytdcr.optimize import _inverse_search as search
    from pytdcr.optimize._inverse import _setup

    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(search, "_POOLS", {})
    tg = _setup(ROBOT, LOADS, [0.1, 0.1, 0.2], BOUNDS, "pcc", "least-squares", InverseSearch())
    made = search.sample_pool(tg, BOUNDS, seed=3)
    files = list(tmp_path.glob("inverse-pool-*.npz"))
    assert len(files) == 1
    monkeypatch.setattr(search, "_POOLS", {})
    read = search.sample_pool(tg, BOUNDS, seed=3)
    assert np.array_equal(read.tensions, made.tensions) and np.array_equal(read.jacobians, made.jacobians)
    files[0].write_bytes(files[0].read_bytes()[:100])  # cut short: not whole
    monkeypatch.setattr(search, "_POOLS", {})
    again = search.sample_pool(tg, BOUNDS, seed=3)
    assert np.array_equal(again.tips, made.tips)
    assert search._read_pool(files[0], 8) is not None  # written whole again
    monkeypatch.setenv("PYTDCR_CACHE_DIR", "")
    assert search.cache_dir() is None


@pytest.mark.slow
def test_a_grid_deep_inside_the_fsw_is_reached():
    """Grid points deep inside the feasible static workspace (inside the region, and so are their six neighbours
    a voxel away) are all reached: the inverse and the region agree where the region is sure."""
    from pytdcr.workspace import WorkspaceSettings
    from pytdcr.workspace._compute import workspace_region
    from pytdcr.workspace._grid import inside

    voxel = 0.025
    wr = workspace_region(ROBOT, LOADS, BOUNDS, WorkspaceSettings(n=200, seed=1, voxel=voxel, budget=1500))
    tips = wr.samples.tip_position[wr.samples.feasible]
    lo, hi = tips.min(axis=0), tips.max(axis=0)
    grid = np.stack(np.meshgrid(*[np.linspace(lo[i], hi[i], 8) for i in range(3)], indexing="ij"), -1)
    grid = grid.reshape(-1, 3)
    deep = inside(wr.fsw_region, grid)
    for d in np.vstack([np.eye(3), -np.eye(3)]):
        deep &= inside(wr.fsw_region, grid + voxel * d)
    assert deep.sum() >= 5
    for p in grid[deep]:
        r = inverse_statics(ROBOT, LOADS, p, bounds=BOUNDS)
        assert r.reachable, f"{p} lies deep inside the FSW, but the nearest point found is {r.distance_m:.3g} m away"
        _check_truthful(r, p)

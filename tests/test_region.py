"""The workspace as a region: the tension plan, checked warm starts, realisability, and the volume estimator on
known shapes."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from pytdcr import Loads, NoFriction, TensionBounds, solve
from pytdcr.contact import disks_below_base, disks_touch
from pytdcr.paper import paper_bounds, paper_loads, paper_robot
from pytdcr.workspace import WorkspaceSettings
from pytdcr.workspace._compute import workspace_region
from pytdcr.workspace._frontier import tension_step
from pytdcr.workspace._grid import inside, region_from_points
from pytdcr.workspace._plan import SOURCES, plan_tensions
from pytdcr.workspace._solve import WarmStarts, solve_plan
from pytdcr.workspace._volume import estimate_volume, nested_stages


def test_plan_holds_sobol_then_corners_then_edges():
    b = TensionBounds(np.zeros(4), np.array([1.0, 2.0, 3.0, 0.0]))  # the last tendon fixed at 0
    plan = plan_tensions(b, 64, seed=3, edge_points=2)
    assert plan.count("sobol") == 64 and plan.count("corner") == 8 and plan.count("edge") == 3 * 4 * 2
    corners = plan.tensions[plan.source == SOURCES.index("corner")]
    assert {tuple(c) for c in corners} == {(x, y, z, 0.0) for x in (0, 1) for y in (0, 2) for z in (0, 3)}
    edges = plan.tensions[plan.source == SOURCES.index("edge")]
    at_bound = np.isclose(edges[:, :3], 0) | np.isclose(edges[:, :3], b.upper[:3])
    assert np.all(at_bound.sum(axis=1) == 2)  # one tendon inside its range, the others at a bound
    assert np.all(plan.tensions >= b.lower) and np.all(plan.tensions <= b.upper)
    half = plan_tensions(b, 32, seed=3)
    np.testing.assert_array_equal(half.tensions[:32], plan.tensions[:32])  # a prefix is a smaller plan


def test_plan_caps_corners_and_edges_at_n():
    plan = plan_tensions(TensionBounds.uniform(8, 0, 20), 100, seed=0)
    assert plan.count("corner") == 0 and plan.count("edge") == 100 and plan.edges_total == 8 * 128 * 2


def ball(n: int, radius: float, rng: np.random.Generator) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return radius * d / np.linalg.norm(d, axis=1)[:, None] * rng.random(n)[:, None] ** (1 / 3)


@pytest.mark.parametrize("shape", ["ball", "box"])
def test_volume_of_known_shapes_lies_within_its_error(shape):
    rng = np.random.default_rng(0)
    n = 40_000
    if shape == "ball":
        pts, exact = ball(n, 0.1, rng), 4 / 3 * np.pi * 0.1**3
    else:
        pts, exact = rng.random((n, 3)) * [0.2, 0.1, 0.05] + [0.0037, -0.0061, 0.0023], 0.2 * 0.1 * 0.05
    est, region = estimate_volume(pts, nested_stages(np.arange(n), n), n, voxel=0.01)
    assert abs(est.volume_m3 - exact) <= est.error_m3
    assert est.error_m3 < 0.25 * exact
    mesh = region.mesh()
    assert mesh.is_watertight and mesh.volume > 0


def test_the_error_band_at_n_holds_the_estimate_at_4n():
    rng = np.random.default_rng(1)
    pts = ball(16_000, 0.1, rng)
    small, _ = estimate_volume(pts[:4000], nested_stages(np.arange(4000), 4000), 4000, voxel=0.01)
    large, _ = estimate_volume(pts, nested_stages(np.arange(16_000), 16_000), 16_000, voxel=0.01)
    assert abs(large.volume_m3 - small.volume_m3) <= small.error_m3


def test_inside_a_region_with_a_hole():
    rng = np.random.default_rng(2)
    shell = ball(60_000, 0.1, rng)
    shell = shell[np.linalg.norm(shell, axis=1) > 0.06]  # a hollow ball: the hole must stay
    region = region_from_points(shell, 0.01)
    assert inside(region, np.array([[0.08, 0, 0], [0, -0.08, 0.0]])).all()
    assert not inside(region, np.array([[0.0, 0, 0], [0.3, 0, 0], [np.nan, 0, 0]])).any()
    assert region.mesh().body_count == 2  # the outer surface and the hole's


def test_the_boundary_of_a_ragged_region_is_watertight():
    """Voxels touching only along edges and at corners (a sparse random grid has thousands) still give a
    closed, manifold surface."""
    rng = np.random.default_rng(4)
    pts = rng.random((3000, 3)) * 0.3
    region = region_from_points(pts, 0.01, closing=0)
    mesh = region.mesh()
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert 0 < mesh.volume <= region.voxel_volume  # the surface runs inside the voxels' outer faces


def test_disk_realisability_on_built_shapes():
    straight = solve(paper_robot(), Loads(np.zeros(8)))
    pos, rot = straight.disk_positions[None], straight.disk_rotations[None]
    assert not disks_below_base(pos, rot, 0.012)[0] and not disks_touch(pos, rot, 0.012)[0]
    # disk 3 stands upright through disk 1 (two apart in the stack); then it lies flat 1 mm above it
    pos = np.array([[[0, 0, 0], [0, 0, 0.02], [0, 0, 0.04], [0, 0.001, 0.021]]], dtype=float)
    upright = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)  # the disk's normal along -y
    rot = np.repeat(np.eye(3)[None, None], 4, axis=1)
    rot[0, 3] = upright
    assert disks_touch(pos, rot, 0.01)[0]
    rot[0, 3] = np.eye(3)
    assert not disks_touch(pos, rot, 0.01)[0]  # parallel, 1 mm apart: no thickness, no contact
    flat = np.repeat(np.eye(3)[None, None], 4, axis=1)
    low = pos.copy()
    low[0, 3, 2] = 0.005
    assert not disks_below_base(low, flat, 0.01)[0]
    flat[0, 3] = upright  # upright, radius 10 mm, centre 5 mm up: it reaches below the base
    assert disks_below_base(low, flat, 0.01)[0]


def test_solved_plan_is_independent_of_threads_and_checks_its_warm_starts():
    robot = paper_robot().with_disks(3).with_friction(NoFriction()).with_gravity(None)
    b = TensionBounds.uniform(8, 0, 4)
    plan = plan_tensions(b, 512, seed=1, corners=False)
    one = solve_plan(robot, Loads(np.zeros(8)), plan, threads=1, warm=WarmStarts(check=200, seed=1))
    two = solve_plan(robot, Loads(np.zeros(8)), plan, threads=2, warm=WarmStarts(check=200, seed=1))
    np.testing.assert_array_equal(one.tip_position, two.tip_position)
    w = one.warm
    assert w.checked == 200 and w.anchors == 64 and w.to_dict()["required"] == 0.999
    assert w.mode == ("warm" if w.agreed >= 0.999 * w.checked else "loading path")
    cold = solve_plan(robot, Loads(np.zeros(8)), plan, warm=False)
    agree = np.linalg.norm(one.tip_position - cold.tip_position, axis=1) <= 1e-6
    assert agree.mean() >= 0.99  # the check's promise, seen on every sample
    assert one.converged.all() and np.linalg.norm(one.tip_position, axis=1).max() <= robot.length


def test_tdcr_workspace_writes_the_named_files(capsys, tmp_path):
    import json

    import trimesh

    from pytdcr.cli import main

    out = tmp_path / "ws"
    code = main(["workspace", "--bounds", "0,3", "--n", "64", "--seed", "2", "--no-gravity", "--budget", "300",
                 "--directions", "8", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    summary = json.loads((out / "workspace.json").read_text())
    assert summary["mesh"] == "fsw.ply" and summary["realisable"]["mesh"] == "fsw_realisable.ply"
    assert summary["volume_m3"] > 0 and summary["volume_err_m3"] > 0
    assert 0 < summary["largest_reach_m"] <= paper_robot().length * (1 + 1e-12)  # rounding of a straight robot
    search = summary["boundary_search"]
    assert 0 < search["solves"] <= 300 and summary["counts"]["by_source"]["search"] == search["solves"]
    assert search["stop"] == "budget"  # 300 solves cannot finish the search: the user is told, not left to guess
    assert any("stopped at its budget" in w for w in summary["warnings"]) and "raise --budget" in err
    support = summary["support"]
    assert len(support["h"]) == 8 and summary["inputs"]["directions"] == 8
    html = (out / "workspace.html").read_text()
    assert "plotly" in html and '<script src="http' not in html  # opens with no network
    assert summary["inputs"]["seed"] == 2 and summary["counts"]["by_source"]["sobol"] == 64
    # by default each sample is continued from a parent (samples.npz keeps them) and 200 are checked from rest
    assert summary["equilibria"] == "continuation" and summary["warm_start"]["mode"] == "continuation"
    ms = summary["multistability"]
    assert ms["checked"] == 200 and 0 <= ms["distinct"] <= ms["checked"] and ms["other"] == "loading path from rest"
    assert "multistability" in text and (out / "multistability.png").is_file()
    with np.load(out / "samples.npz") as npz:
        parent = npz["parent"]
        assert parent.shape == npz["converged"].shape and np.all(parent < np.arange(parent.size))
    mesh = trimesh.load(out / "fsw.ply")
    assert mesh.is_watertight and abs(mesh.volume) > 0
    for name in ("fsw_realisable.ply", "samples.npz", "slices.png", "slices.pdf", "report.md", "support.csv",
                 "support_map.png", "boundary_3d.pdf"):
        assert (out / name).is_file(), name
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    assert "FSW: volume" in text and "cm³" in text
    code = main(["workspace", "--voxel", "5", "--out", str(tmp_path / "bad")])
    assert code == 2 and "--voxel = 5: must be in" in capsys.readouterr().err


@pytest.mark.slow
def test_tdcr_workspace_equilibria_both_compares_the_two_regions(capsys, tmp_path):
    import json

    from pytdcr.cli import main

    out = tmp_path / "both"
    code = main(["workspace", "--bounds", "0,3", "--n", "64", "--seed", "2", "--no-gravity", "--budget", "100",
                 "--directions", "0", "--equilibria", "both", "--out", str(out)])
    text, err = capsys.readouterr()
    assert "  continuation:" in text and "  loading-path:" in text and "multistability" in text
    assert code == 0, err
    for kind, other, mode in (("continuation", "loading path from rest", ("continuation",)),
                              ("loading-path", "continuation from the root", ("warm", "loading path"))):
        summary = json.loads((out / kind.replace("-", "_") / "workspace.json").read_text())
        assert summary["equilibria"] == kind and summary["warm_start"]["mode"] in mode
        assert summary["multistability"]["other"] == other
    rows = json.loads((out / "comparison.json").read_text())["cases"]
    assert [r["case"] for r in rows] == ["continuation", "loading-path"] and all(r["volume_m3"] > 0 for r in rows)
    code = main(["workspace", "--equilibria", "both", "--compare-loads", "--out", str(tmp_path / "no")])
    assert code == 2 and "choose one comparison" in capsys.readouterr().err
    code = main(["workspace", "--model", "cosserat", "--friction", "none", "--equilibria", "continuation", "--out",
                 str(tmp_path / "no")])
    assert code == 2 and "cannot continue" in capsys.readouterr().err


def test_tension_step_stays_in_the_box_and_moves_the_tip_as_asked():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(3, 8)) * 0.01
    lo, hi = np.zeros(8), np.full(8, 20.0)
    t = np.full(8, 10.0)
    dp = np.array([0.002, -0.001, 0.0005])
    dt = tension_step(J, t, lo, hi, dp)
    np.testing.assert_allclose(J @ dt, dp, atol=1e-9)  # inside the box: met exactly, smallest step
    np.testing.assert_allclose(dt, np.linalg.pinv(J) @ dp, rtol=1e-6, atol=1e-9)
    t = np.array([0, 20, 0, 20, 0, 20, 0, 20], dtype=float)  # every tendon at a bound
    for _ in range(20):
        dp = rng.normal(size=3) * 0.05
        dt = tension_step(J, t, lo, hi, dp)
        assert np.all(t + dt >= lo - 1e-12) and np.all(t + dt <= hi + 1e-12)
        assert np.linalg.norm(J @ dt - dp) <= np.linalg.norm(dp) + 1e-12  # never worse than no step


def test_boundary_search_grows_the_region_with_loading_path_equilibria():
    robot, loads, b = paper_robot(), paper_loads(), paper_bounds()
    voxel = robot.length / 10
    plain = workspace_region(robot, loads, b, WorkspaceSettings(n=64, seed=3, voxel=voxel, search=False))
    found = workspace_region(robot, loads, b, WorkspaceSettings(n=64, seed=3, voxel=voxel, budget=600))
    s = found.samples
    extra = s.source == SOURCES.index("search")
    assert found.search is not None and found.search.solves == extra.sum() <= 600
    assert found.search.rounds and found.search.rounds[0].steps > 0
    assert found.fsw_region.occupied.sum() > plain.fsw_region.occupied.sum()
    assert found.fsw.volume_m3 > plain.fsw.volume_m3
    assert np.all(s.tensions[extra] >= b.lower) and np.all(s.tensions[extra] <= b.upper)
    # the search's points are the loading path's equilibria of their tensions, as every sample is
    rows = np.flatnonzero(extra & s.converged)[:: max(1, int((extra & s.converged).sum()) // 8)][:8]
    for r in rows:
        tip = solve(robot, loads.with_tensions(s.tensions[r])).tip_position
        np.testing.assert_allclose(tip, s.tip_position[r], atol=1e-6)
    assert found.fsw.to_dict()["scales"][0]["n_base"] == 16


def test_without_loads_the_region_has_the_robots_fourfold_symmetry():
    """Tendons at 0/90/180/270 and 45/135/225/315 deg: with no gravity and no tip load, the four quadrants
    about the base axis hold the same volume, within the estimate's error."""
    robot = paper_robot().with_gravity(None)
    found = workspace_region(robot, Loads(np.zeros(8)), paper_bounds(),
                             WorkspaceSettings(n=256, seed=1, voxel=robot.length / 12, budget=4000))
    reg = found.fsw_region
    centres = reg.origin + (np.argwhere(reg.occupied) + 0.5) * reg.voxel
    quadrant = (centres[:, 0] > 0).astype(int) * 2 + (centres[:, 1] > 0).astype(int)
    volumes = np.bincount(quadrant, minlength=4) * reg.voxel**3
    assert np.ptp(volumes) <= found.fsw.error_m3 / 4, (volumes, found.fsw.error_m3)


def test_a_search_cut_short_by_its_budget_widens_the_error_by_its_whole_last_round():
    from pytdcr.workspace._compute import _tail
    from pytdcr.workspace.parts import SearchRound

    def rounds(steps: int) -> list[SearchRound]:
        return [SearchRound(0, k, 1000, s, 1000, v, v, 1.0) for k, (s, v) in
                enumerate([(1000, 1000), (1000, 2000), (1000, 2500), (steps, 2500 + 250 * steps // 1000)])]

    whole = _tail(rounds(1000), "voxels", 1.0)  # growth 500 then 250: 250 more to come
    assert whole == pytest.approx(250.0)
    cut = _tail(rounds(100), "voxels", 1.0)  # a tenth of the last round ran: it stands for the whole
    assert cut == pytest.approx(whole)


def test_a_region_with_too_few_converged_samples_is_reported_and_not_meshed(tmp_path):
    import json

    from pytdcr.runs import run_workspace
    from pytdcr.statics import SolverOptions

    # one Newton iteration from the straight robot at full load, no load steps: no solve converges, so neither
    # region has a point (with load steps, one exact Newton iteration per small step does converge)
    run = run_workspace(paper_robot(), paper_loads(), paper_bounds(),
                        WorkspaceSettings(n=32, seed=1, budget=50, directions=4, equilibria="loading-path"),
                        tmp_path / "ws",
                        options=SolverOptions(max_iter=1, load_stepping="never"))
    summary = json.loads((tmp_path / "ws" / "workspace.json").read_text())
    assert summary["counts"]["converged"] == 0 and summary["mesh"] is None
    assert summary["realisable"]["mesh"] is None and summary["volume_m3"] == 0.0
    assert len(summary["warnings"]) == 2 and "fsw.ply is not written" in summary["warnings"][0]
    assert not (tmp_path / "ws" / "fsw.ply").exists() and not (tmp_path / "ws" / "fsw_realisable.ply").exists()
    for name in ("samples.npz", "report.md", "slices.png", "workspace.html"):
        assert (tmp_path / "ws" / name).is_file(), name
    assert "**Warning:**" in (tmp_path / "ws" / "report.md").read_text()
    assert "fsw.ply" not in run.files
    assert json.loads((tmp_path / "ws" / "manifest.json").read_text())["status"] == "complete"


def test_workspace_settings_hold_every_default_and_range():
    s = WorkspaceSettings()
    assert (s.n, s.seed, s.voxel, s.warm, s.search, s.budget, s.tol, s.directions, s.reach, s.threads) == (
        4000, 0, None, True, True, None, 0.002, 200, "search", None)
    robot = paper_robot()
    assert s.search_budget == 25 * 4000 and WorkspaceSettings(n=10, budget=0).search_budget == 0
    assert s.voxel_for(robot) == robot.length / 32 and s.with_voxel_for(robot).voxel == robot.length / 32
    assert WorkspaceSettings(voxel=0.02).voxel_for(robot) == 0.02
    with pytest.raises(ValueError, match=r"^voxel = 5: must be in \[0.0001, 0.4\] m \(the robot's length\)$"):
        WorkspaceSettings(voxel=5).check(robot)
    with pytest.raises(ValueError, match=r"^voxel = 5e-05: must be in \[0.0001, 0.4\] m"):
        WorkspaceSettings(voxel=5e-5).check(robot)
    with pytest.raises(ValueError, match=r"^directions = 100001: must be an integer in \[0, 100,000\]$"):
        WorkspaceSettings(directions=100_001)
    for bad, says in (({"n": 0}, "n = 0"), ({"budget": -1}, "budget = -1"), ({"seed": -1}, "seed = -1"),
                      ({"tol": 2.0}, "tol = 2"), ({"reach": "far"}, "reach = 'far'"), ({"threads": 0}, "threads"),
                      ({"directions": [[0.0, 0.0, 0.0]]}, "nonzero"), ({"directions": [[1.0, 0.0]]}, "shape")):
        with pytest.raises(ValueError, match=says):
            WorkspaceSettings(**bad)
    with pytest.raises(TypeError, match="warm"):
        WorkspaceSettings(warm=1)
    given = WorkspaceSettings(directions=[[0.0, 0.0, 2.0], [1.0, 1.0, 0.0]])
    assert given.direction_count == 2
    np.testing.assert_allclose(given.direction_vectors(), [[0, 0, 1], [2**-0.5, 2**-0.5, 0]])
    assert WorkspaceSettings(directions=0).direction_vectors() is None


def test_the_largest_reach_follows_its_rule():
    """"farthest" keeps the farthest of the reach search, the support function's tips and the samples;
    "samples" runs no search and keeps the farthest feasible sample."""
    from pytdcr.workspace import workspace_study

    robot, loads, b = paper_robot().with_gravity(None), Loads(np.zeros(8)), TensionBounds.uniform(8, 0, 4)
    base = {"n": 32, "seed": 2, "voxel": robot.length / 8, "search": False}
    far = workspace_study(robot, loads, b, WorkspaceSettings(**base, directions=3, reach="farthest"))
    s = far.samples
    sample_reach = np.linalg.norm(s.tip_position[s.feasible], axis=1).max()
    support_reach = np.linalg.norm(far.support.tip_position, axis=1).max()
    assert far.reach_search is not None and far.support.h.size == 3
    assert far.largest_reach.reach == max(sample_reach, support_reach, far.reach_search.reach)
    assert far.largest_reach.source in ("search", "support", "samples")
    numbers = far.to_dict()
    assert numbers["largest_reach_m"] == far.largest_reach.reach
    assert numbers["largest_reach"] == far.reach_search.to_dict() and numbers["voxel_m"] == robot.length / 8
    assert numbers["dimension"] == 3 and numbers["measure"] == "volume"
    assert set(numbers) == {"schema_version", "volume_m3", "volume_err_m3", "dimension", "measure",
                            "largest_reach_m", "reach_rule", "points", "volume", "realisable",
                            "voxel_m", "counts", "warm_start", "boundary_sources", "boundary_search", "support",
                            "largest_reach", "seconds_sampling", "equilibria", "multistability", "root",
                            "stability_test"}
    # each largest reach says what it is: searched only where the search gave it
    searched = {"search": "the reach search's optimum",
                "support": "the farthest tip attaining h(d), farther than the reach search's optimum",
                "samples": "the farthest feasible sample, farther than the reach search's optimum"}
    assert numbers["reach_rule"] == searched[far.largest_reach.source]
    plain = workspace_study(robot, loads, b, WorkspaceSettings(**base, directions=0, reach="samples"))
    assert plain.support is None and plain.reach_search is None and plain.largest_reach.source == "samples"
    assert plain.largest_reach.reach == sample_reach  # the same samples: the same seed and plan
    k = int(np.argmax(np.where(s.feasible, np.linalg.norm(s.tip_position, axis=1), -1.0)))
    np.testing.assert_array_equal(plain.largest_reach.tensions, s.tensions[k])
    assert plain.to_dict()["reach_rule"] == "the farthest feasible sample (not searched)"


def test_the_realisable_reach_is_labelled_the_farthest_realisable_sample():
    """``realisable.largest_reach_m`` is the farthest realisable sample, never searched, and says so; it can be
    below the FSW's searched optimum even when that optimum is itself realisable (checked here)."""
    from pytdcr.runs._workspace_report import _reach_note
    from pytdcr.workspace import workspace_study

    robot, loads, b = paper_robot().with_gravity(None), Loads(np.zeros(8)), TensionBounds.uniform(8, 0, 4)
    ws = workspace_study(robot, loads, b, WorkspaceSettings(n=32, seed=2, voxel=robot.length / 8, search=False,
                                                            directions=3, reach="search"))
    fsw, real, s = ws.summary.fsw, ws.summary.realisable, ws.samples
    assert real.reach_rule == "the farthest realisable sample (not searched)"
    assert real.largest_reach_m == np.linalg.norm(s.tip_position[s.realisable], axis=1).max()
    assert fsw.reach_rule == "the reach search's optimum" and ws.largest_reach.source == "search"
    assert real.largest_reach_m < fsw.largest_reach_m
    optimum = solve(robot, loads.with_tensions(ws.largest_reach.tensions))
    pos, rot, r = optimum.disk_positions[None], optimum.disk_rotations[None], robot.disk_radius
    assert not disks_below_base(pos, rot, r)[0] and not disks_touch(pos, rot, r)[0]  # realisable, yet unsearched
    note = _reach_note(fsw, real)
    assert "the realisable region's is the farthest realisable sample (not searched)" in note
    assert "may be below the FSW's" in note
    # both from the samples: the realisable one is below only where the farthest feasible sample is not realisable
    plain = workspace_study(robot, loads, b, WorkspaceSettings(n=32, seed=2, voxel=robot.length / 8, search=False,
                                                               directions=0, reach="samples")).summary
    assert "may be below" not in _reach_note(plain.fsw, plain.realisable)


def test_the_dimension_of_point_sets_of_known_shape():
    """A cloud filling a cube is 3-D, a square of points in a tilted plane 2-D with its area, points on a line 1-D
    with its length, one point 0-D; a slab thinner than a voxel counts as flat."""
    from pytdcr.workspace._volume import region_dimension

    rng = np.random.default_rng(0)
    voxel = 0.01
    cube = rng.uniform(0.0, 0.1, (4000, 3))
    assert region_dimension(cube, voxel).dimension == 3
    u, v = np.array([1.0, 1.0, 0.0]) / 2**0.5, np.array([0.0, 0.6, 0.8])
    v = v - u * (u @ v)
    v /= np.linalg.norm(v)
    ab = rng.uniform(0.0, 0.2, (20000, 2))
    square = ab[:, :1] * u + ab[:, 1:] * v + 0.05
    d = region_dimension(square, voxel)
    assert d.dimension == 2 and d.measure == "area" and d.extents_m[2] < 1e-12
    assert abs(d.area_m2 - 0.04) <= d.area_err_m2 and d.area_err_m2 < 0.1 * 0.04
    assert region_dimension(np.array([[0.0, 0.0, 0.0], [0.0, 0.1, 0.0]]), voxel).dimension == 1
    assert abs(abs(np.dot(np.cross(d.axes[0], d.axes[1]), np.cross(u, v))) - 1.0) < 1e-9
    slab = np.column_stack([rng.uniform(0, 0.2, 5000), rng.uniform(0, 0.2, 5000), rng.uniform(0, 0.5 * voxel, 5000)])
    assert region_dimension(slab, voxel).dimension == 2
    line = np.outer(rng.uniform(0.0, 0.3, 50), [0.0, 0.6, 0.8])
    d = region_dimension(np.vstack([line, [np.nan] * 3]), voxel)
    assert d.dimension == 1 and d.measure == "length" and d.length_m == pytest.approx(np.ptp(line @ [0, 0.6, 0.8]))
    assert region_dimension(np.zeros((5, 3)), voxel).dimension == 0
    assert region_dimension(np.empty((0, 3)), voxel).measure == "none"


def test_a_planar_robot_has_a_planar_workspace_with_no_volume(tmp_path):
    """Tendons at 0 and 180 deg in both segments, gravity along the axis: every tip lies in the x-z plane. The
    workspace is 2-D (volume 0, its area measured, no mesh written), whatever the budget; the paper robot's is
    3-D."""
    import json

    from pytdcr.cli import main
    from pytdcr.io import write_robot
    from pytdcr.robot import Tendon
    from pytdcr.workspace import workspace_study

    paper = paper_robot()
    tendons = tuple(Tendon(segment=s, radius=0.01, angle_deg=a) for s in (1, 2) for a in (0.0, 180.0))
    planar = paper.model_copy(update={"tendons": tendons, "name": "planar"})
    b = TensionBounds.uniform(4, 0.0, 10.0)
    loads = Loads(np.zeros(4))
    for budget in (0, 200):
        ws = workspace_study(planar, loads, b, WorkspaceSettings(n=64, seed=0, budget=budget, directions=0,
                                                                   reach="samples"))
        numbers = ws.to_dict()
        assert numbers["dimension"] == 2 and numbers["measure"] == "area"
        assert numbers["volume_m3"] == 0.0 and numbers["volume_err_m3"] == 0.0
        assert numbers["area_m2"] > 0.003 and numbers["realisable"]["dimension"] == 2  # tens of cm², not a line
        tips = ws.samples.tip_position[ws.samples.feasible]
        assert np.max(np.abs(tips[:, 1])) < 1e-9  # the tips do lie in the x-z plane
    path = tmp_path / "planar.toml"
    write_robot(planar, path)
    out = tmp_path / "ws"
    code = main(["workspace", "--robot", str(path), "--n", "64", "--no-search", "--directions", "0",
                 "--bounds", "0,10", "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "workspace.json").read_text())
    assert summary["dimension"] == 2 and summary["volume_m3"] == 0.0 and summary["mesh"] is None
    assert not (out / "fsw.ply").exists() and "fsw.ply" not in summary["files"]
    assert any("span 2 dimensions" in w and "area" in w for w in summary["warnings"])
    assert summary["volume"]["dimension"]["extents_m"][2] < 1e-9


def test_one_free_tendon_traces_a_curve_not_an_area():
    """One tendon free (the others held at a fixed tension by their bounds): the tips lie on a curve, bent in
    its plane and, under the paper's wrench, out of it; the region is 1-D (volume 0, no area), whatever its
    affine extents, and its length is measured along the curve."""
    from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT
    from pytdcr.workspace import workspace_study

    robot = paper_robot()
    lower = np.zeros(8)
    upper = np.zeros(8)
    upper[0] = 10.0
    b = TensionBounds(lower, upper)
    for loads in (Loads(np.zeros(8)), Loads(np.zeros(8), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)):
        ws = workspace_study(robot, loads, b, WorkspaceSettings(n=64, seed=0, search=False, directions=0,
                                                                 reach="samples"))
        numbers = ws.to_dict()
        assert numbers["dimension"] == 1 and numbers["measure"] == "length" and numbers["volume_m3"] == 0.0
        ext = numbers["volume"]["dimension"]["extents_m"]
        assert ext[1] >= ws.region.voxel  # the arc spans a plane: by its extents alone it would be 2-D
        assert numbers["length_m"] >= ext[0] and "area_m2" not in numbers


def _tiny_robot():
    """A 2 mm robot (two 1 mm segments, a 10 um backbone, tendons at 50 um), no friction or gravity."""
    from pytdcr import Robot
    from pytdcr.io import robot_to_dict

    d = robot_to_dict(paper_robot().with_disks(3).with_friction(NoFriction()).with_gravity(None))
    d.pop("schema_version")
    d["name"] = "tiny"
    d["backbone"].update(outer_radius=1e-5, mass_per_length=1e-6)
    for seg in d["segments"]:
        seg.update(length=1e-3, disk_mass=1e-10)
    for t in d["tendons"]:
        t["radius"] = 5e-5
    return Robot.model_validate(d)


def test_warm_starts_agree_to_a_share_of_the_robots_length():
    """The same equilibrium means the same tip to 1e-6 m per 0.4 m of the robot: exactly 1e-6 m on the paper's
    robot (its results unchanged), 5 nm on a 2 mm robot, where 1e-6 m would be half a thousandth of its length."""
    from pytdcr.workspace._solve import SAME_TIP, _agree, same_tip

    paper, tiny = paper_robot(), _tiny_robot()
    assert same_tip(paper) == SAME_TIP == 1e-6 and same_tip(tiny) == pytest.approx(5e-9, rel=1e-12)
    tips = np.array([[0.0, 0.0, 2e-3], [1e-3, 0.0, 1.5e-3]])
    warm = SimpleNamespace(converged=np.array([True, True]), tip_position=tips)
    off = SimpleNamespace(converged=np.array([True, True]), tip_position=tips + np.array([1e-7, 0.0, 0.0]))  # 0.1 um
    assert _agree(warm, off, same_tip(paper)).all() and not _agree(warm, off, same_tip(tiny)).any()
    # on the tiny robot warm starts still pass the check: its equilibria agree far within the scaled tolerance
    plan = plan_tensions(TensionBounds.uniform(8, 0, 0.01), 256, seed=1, corners=False)
    got = solve_plan(tiny, Loads(np.zeros(8)), plan, warm=WarmStarts(check=100, seed=1))
    cold = solve_plan(tiny, Loads(np.zeros(8)), plan, warm=False)
    assert got.warm.mode == "warm" and got.warm.agreed == got.warm.checked == 100
    assert got.converged.all() and np.linalg.norm(cold.tip_position, axis=1).min() < 0.999 * tiny.length  # bent
    assert np.linalg.norm(got.tip_position - cold.tip_position, axis=1).max() <= same_tip(tiny)

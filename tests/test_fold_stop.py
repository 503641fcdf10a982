"""Stopping at a fold (issue 27, item 4): ``fold="stop"`` ends a path where it meets a fold instead of snapping
through, and the boundary search can take its steps that way (``folds="stop"``), keeping only what it reached
without a snap."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pytdcr.cli.workspace import FOLD_CHOICES
from pytdcr.paper import paper_bounds, paper_loads
from pytdcr.statics import SolverOptions, solve_batch
from pytdcr.workspace import WorkspaceSettings
from pytdcr.workspace._compute import workspace_region
from pytdcr.workspace._frontier import GrowthSettings
from pytdcr.workspace._plan import plan_tensions


@pytest.fixture(scope="module")
def both_ways(paper):
    """64 tension vectors under the paper's load, each along the loading path from rest, snapping and stopping."""
    T = plan_tensions(paper_bounds(), 64, seed=11).tensions
    loads = paper_loads()
    return {fold: solve_batch(paper, T, loads, options=SolverOptions(fold=fold), threads=1)
            for fold in ("relax", "stop")}


def test_a_path_stops_where_it_would_snap(both_ways):
    snap, stop = both_ways["relax"], both_ways["stop"]
    snapped = snap.path == "snap"
    assert snapped.sum() >= 2, "the case must snap somewhere to test anything"
    # where the relaxed path snapped, the stopped one ends at the fold: not converged, its residual reported
    assert np.all(stop.path[snapped] == "fold") and not np.any(stop.converged[snapped])
    assert np.all(np.isfinite(stop.residual[snapped])) and np.all(stop.residual[snapped] > stop.atol[snapped])
    # elsewhere the two are the same computation: the same equilibria, bit for bit
    same = ~snapped & (stop.path != "fold")
    assert same.sum() >= 40
    assert np.array_equal(stop.tip_position[same], snap.tip_position[same])
    assert np.array_equal(stop.converged[same], snap.converged[same])


def test_the_fold_rule_is_checked_and_named_alike_everywhere():
    assert FOLD_CHOICES == WorkspaceSettings.FOLD_RULES
    with pytest.raises(ValueError, match="folds = 'bounce'"):
        WorkspaceSettings(folds="bounce")
    with pytest.raises(ValueError, match="folds = 'bounce'"):
        GrowthSettings(folds="bounce")
    with pytest.raises(ValueError, match="fold must be one of"):
        SolverOptions(fold="bounce")


@pytest.fixture(scope="module")
def stopped(paper):
    return workspace_region(paper, paper_loads(), paper_bounds(),
                            WorkspaceSettings(n=128, seed=4, budget=1500, multistability=0, folds="stop"))


def test_a_search_that_stops_at_folds_keeps_only_what_it_reached(paper, stopped):
    search = stopped.search
    assert search is not None and search.to_dict()["at_fold"] == sum(r.at_fold for r in search.rounds) > 0
    s = stopped.samples
    rows = np.flatnonzero(s.source == 3)
    assert rows.size == search.solves - search.to_dict()["at_fold"]
    # replaying a kept step from its parent, stopping at folds, reaches its equilibrium: it met no fold
    pick = rows[s.converged[rows]][:: max(1, rows.size // 40)]
    loads = paper_loads().with_tensions(np.zeros(8))
    again = solve_batch(paper, s.tensions[pick], loads, start=s.start_batch(s.parent[pick], loads, "pcc"),
                        options=SolverOptions(fold="stop"), threads=1)
    assert np.all(again.converged) and not np.any(again.path == "fold")
    assert np.max(np.abs(again.tip_position - s.tip_position[pick])) < 1e-9


def test_the_command_records_the_rule_and_the_steps_stopped(tmp_path, capsys):
    from pytdcr.cli import main

    out = tmp_path / "ws"
    code = main(["workspace", "--n", "64", "--seed", "4", "--budget", "400", "--directions", "0",
                 "--search-folds", "stop", "--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1", "-q",
                 "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    summary = json.loads((out / "workspace.json").read_text())
    assert summary["inputs"]["search_folds"] == "stop"
    assert summary["boundary_search"]["at_fold"] == sum(r["at_fold"] for r in summary["boundary_search"]["rounds"])
    code = main(["workspace", "--search-folds", "bounce", "--out", str(tmp_path / "no")])
    assert code == 2 and "--search-folds" in capsys.readouterr().err


def test_a_design_study_searches_by_its_fold_rule(paper):
    """``[budget] folds`` reaches each design's workspace study: a design evaluated with ``"stop"`` has the volume
    of the same workspace study run directly with that rule, and not the snapping one's."""
    from pytdcr.designs import apply_parameters, design_seed, evaluate_design, study_from_dict
    from pytdcr.workspace import workspace_study

    data = {"name": "f", "robot": "paper", "seed": 3, "bounds": [0.0, 20.0],
            "parameters": {"routing_radius_2": {"values": [0.01]}}, "loads": {"cases": ["paper wrench"]},
            "budget": {"samples": 32, "search": 400, "voxel": 0.025}}
    volume = {}
    for rule in WorkspaceSettings.FOLD_RULES:
        study, robot = study_from_dict({**data, "budget": {**data["budget"], "folds": rule}})
        rec = evaluate_design(study.model_dump(), robot.model_dump(), 0, {"routing_radius_2": 0.01})
        assert rec.status == "ok", rec.reason
        volume[rule] = rec.rows[0].volume_m3
    settings = WorkspaceSettings(n=32, seed=design_seed(3, 0), voxel=0.025, budget=400, directions=0,
                                 reach="support", threads=1, multistability=0, folds="stop")
    case_robot, loads = study.load_cases(apply_parameters(robot, {"routing_radius_2": 0.01}))["paper wrench"]
    direct = workspace_study(case_robot, loads, paper_bounds(), settings)
    assert direct.region.search is not None and direct.region.search.to_dict()["at_fold"] > 0
    assert volume["stop"] == direct.region.fsw.volume_m3 != volume["snap"]

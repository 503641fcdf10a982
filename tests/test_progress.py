"""The work a run plans and the time it says before it starts."""

from __future__ import annotations

import pytest

from pytdcr import Loads
from pytdcr.paper import paper_bounds, paper_robot
from pytdcr.workspace import WorkspaceSettings, workspace_estimate, workspace_study
from pytdcr.workspace._compute import planned_work
from pytdcr.workspace._estimate import STEP_SOLVES, solve_seconds


def test_planned_work_is_what_the_study_spends():
    robot, bounds = paper_robot(), paper_bounds()
    s = WorkspaceSettings(n=64, seed=3, budget=400, directions=6, multistability=20, reach="search")
    work = planned_work(robot, Loads(), bounds, s)
    study = workspace_study(robot, Loads(), bounds, s)
    region = study.region
    assert work["sampling"] + region.search.solves == region.samples.tensions.shape[0]
    assert region.search.solves <= work["boundary search"] == 400
    assert work["multistability"] == region.multistability.checked == 20
    assert work["support function h(d)"] == study.support.h.shape[0] == 6
    assert work["largest reach search"] == 1
    off = planned_work(robot, Loads(), bounds, WorkspaceSettings(n=64, search=False, directions=0, reach="samples"))
    assert off["boundary search"] == off["support function h(d)"] == off["largest reach search"] == 0


def test_the_estimate_grows_with_the_work_and_says_its_terms():
    robot, bounds = paper_robot(), paper_bounds()
    one = solve_seconds(robot, Loads(), bounds)
    assert 1e-5 < one < 1.0
    small = workspace_estimate([(robot, Loads(), WorkspaceSettings(n=64, budget=1000, directions=0), "pcc", None)],
                               bounds)
    big = workspace_estimate([(robot, Loads(), WorkspaceSettings(n=64, budget=100_000, directions=0), "pcc", None)],
                             bounds)
    assert big.solves - small.solves == pytest.approx(99_000 * STEP_SOLVES[False], abs=2)
    assert big.seconds > 10 * (small.seconds - 8.0)
    text = big.text()
    assert text.startswith("estimated time: about ") and f"{big.solves:,} solves" in text and "threads" in text


def test_a_long_workspace_run_says_its_estimate_first(capsys):
    from pytdcr.cli import _progress
    from pytdcr.cli.workspace import _say_estimate

    robot, bounds = paper_robot(), paper_bounds()
    long = WorkspaceSettings(n=4000, budget=1_000_000).check(robot)
    short = WorkspaceSettings(n=64, budget=100, directions=0).check(robot)
    _say_estimate(None, robot, Loads(), bounds, long, ("pcc", None))
    assert "estimated time: about" in capsys.readouterr().err
    _say_estimate(None, robot, Loads(), bounds, short, ("pcc", None))
    assert capsys.readouterr().err == ""  # under a minute: nothing said
    _progress.set_quiet(True)
    try:
        _say_estimate(None, robot, Loads(), bounds, long, ("pcc", None))
    finally:
        _progress.set_quiet(False)
    assert capsys.readouterr().err == ""

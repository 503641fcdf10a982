"""Answers that claim no more than was computed (issue 25, second class): loads act where physics puts them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pytdcr.paper import PAYLOAD_MASS, STANDARD_GRAVITY, payload_loads, workspace_load_cases


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (-9.81, 0.0, 0.0), (0.0, 3.0, 0.0), (1.0, -2.0, 2.0)])
def test_payloads_hang_along_the_robots_gravity(paper, gravity):
    robot = paper.with_gravity(gravity)
    g = np.asarray(gravity)
    assert np.allclose(payload_loads(robot).tip_force, PAYLOAD_MASS * g, rtol=0, atol=1e-15)
    cases = workspace_load_cases(robot)
    for mass in (0.005, 0.010, 0.020):
        case_robot, loads = cases[f"payload {mass * 1e3:g} g"]
        assert np.allclose(loads.tip_force, mass * np.asarray(case_robot.gravity), rtol=0, atol=1e-15)
        assert np.dot(loads.tip_force, g) > 0  # along gravity, never along the robot's own axis by default


def test_a_robot_without_gravity_gets_the_standard_gravity_for_its_payloads(rao):
    assert np.allclose(payload_loads(rao, 0.01).tip_force, 0.01 * np.asarray(STANDARD_GRAVITY))
    robot, loads = workspace_load_cases(rao)["payload 20 g"]
    assert robot.gravity == STANDARD_GRAVITY and np.allclose(loads.tip_force, 0.02 * np.asarray(STANDARD_GRAVITY))


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (-9.81, 0.0, 0.0), (1.0, -2.0, 2.0), None])
def test_the_accuracy_studys_payload_hangs_along_the_robots_gravity(paper, gravity):
    """``tdcr accuracy``'s payload group (:func:`pytdcr.accuracy.default_groups`) weighs along the robot's gravity
    (the standard one for a robot without), as the workspace's payloads do; the other groups carry none."""
    from pytdcr.accuracy import default_groups

    robot = paper.with_gravity(gravity)
    groups = default_groups(0.02)
    payload = groups[-1]
    applied = payload.apply(robot)
    g = np.asarray(STANDARD_GRAVITY if gravity is None else gravity)
    assert np.allclose(applied.gravity, g)
    assert np.allclose(payload.loads(np.zeros(8), applied).tip_force, 0.02 * g, rtol=0, atol=1e-15)
    assert np.all(groups[1].loads(np.zeros(8), groups[1].apply(robot)).tip_force == 0.0)


# ---------------------------------------------------------------- tdcr reproduce's report says what was computed
#: a GA's settings as a result records them (:class:`pytdcr.optimize.GASettings`), population 8
GA_SETTINGS = {"pop_size": 8, "tol": 1e-6, "window": 5, "max_gen": 30, "polish": True, "local_search": True,
               "local_search_runs": 0}


def _reach_result(reach: float, stable: bool | None = True, n_tendons: int = 8, upper: float = 20.0):
    """A final optimum of ``reach`` [m] (no GA stage, as a polish alone reports it), with its stability."""
    from pytdcr.optimize import ReachResult

    return ReachResult(tensions=np.full(n_tendons, upper / 2), tip_position=np.array([0.0, 0.0, reach]), reach=reach,
                       cost=1.0 / reach, value=reach, stable=stable, converged=True, stop_reason="tolerance",
                       generations=3, evaluations=40, nonconverged=0, seconds=1.0, seed=0,
                       history={"best": [1.0 / reach] * 3, "local_search_evaluations": [0, 0, 0]}, ga=None,
                       polish_evaluations=5, settings=dict(GA_SETTINGS))


def _numbers(text: str) -> list[float]:
    return [float(x) for x in text.split(",")]


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (-9.81, 0.0, 0.0), (0.0, 3.0, 4.0), None])
def test_the_reports_payload_force_is_the_one_the_payload_study_used(paper, gravity):
    """The payload study hangs its mass along the robot's gravity (:func:`payload_loads`, the standard one for a
    robot without): the report prints that force, not (0, 0, -m 9.81) whatever the robot."""
    import re

    from pytdcr.runs._reproduce_report import _payload_text

    robot = paper.with_gravity(gravity)
    text = _payload_text(robot, _reach_result(0.39))
    force = _numbers(re.search(r"force \(([^)]*)\) N", text).group(1))
    assert np.allclose(force, payload_loads(robot).tip_force, rtol=0, atol=5e-5)
    assert ("standard gravity (the robot has none)" in text) == (gravity is None)


@pytest.mark.parametrize(("reaches", "says", "never"), [
    ((0.30, 0.31, 0.315), "The reach grows with the upper bound, from 0.300000 m at 10 N to 0.315000 m at 40 N, "
                          "with diminishing returns (1, then 0.25 mm per N)", "stays"),
    ((0.30, 0.31, 0.33), "The reach grows with the upper bound", "diminishing"),  # 1, then 1 mm per N
    ((0.30, 0.30, 0.30), "The reach stays the same at every upper bound (0.300000 m", "grows"),
    ((0.30, 0.30 + 4e-7, 0.30), "The reach stays the same", "grows"),  # closer than the table shows
    ((0.30, 0.30, 0.31), "does not decrease with the upper bound, from 0.300000 m at 10 N to 0.310000 m at 40 N, "
                         "but stays the same (within 1e-06 m) between 10 and 20 N", "grows with"),
    ((0.30, 0.31, 0.305), "does not grow monotonically", "grows with"),
    ((0.30,), "One upper bound only: nothing to compare", "grows"),
])
def test_the_bounds_study_says_grows_only_when_the_reach_grows(reaches, says, never):
    from pytdcr.runs._reproduce_report import _bounds_comment

    text = _bounds_comment([(hi, _reach_result(r)) for hi, r in zip((10.0, 20.0, 40.0), reaches, strict=False)])
    assert says in text and never not in text


def _heavy_payload_optimum(paper):
    """A robot whose backbone buckles under the 5 g payload (E = 2 GPa: Euler's load 0.0058 N < 0.049 N), and its
    reach optimum under the payload: the straight robot, returned by the loading path flagged unstable."""
    from pytdcr.optimize import ReachProblem, polish_reach
    from pytdcr.paper import paper_bounds

    heavy = paper.model_copy(update={"name": "heavy",
                                     "backbone": paper.backbone.model_copy(update={"youngs_modulus": 2e9})})
    problem = ReachProblem.create(heavy, payload_loads(heavy), paper_bounds(8))
    found = polish_reach(problem, np.zeros(8), max_iter=3, restarts=0)
    return heavy, dataclasses.replace(found, settings={**found.settings, **GA_SETTINGS})  # as the GA would say


def test_the_report_says_whether_each_optimum_is_stable(paper):
    """Every optimum's stability test is reported: the payload sentence, the GA and bounds tables, and a warning
    naming each optimum flagged unstable (the heavy robot's payload optimum, computed here)."""
    from pytdcr.paper import paper_bounds
    from pytdcr.runs import PassiveSolveRecord, ReproduceRun, ReproduceSettings, SamplingRecord, WorkspaceSection
    from pytdcr.runs._reproduce_report import _payload_text, reproduce_report

    heavy, pay = _heavy_payload_optimum(paper)
    assert pay.stable is False and pay.reach == pytest.approx(heavy.length)
    text = _payload_text(heavy, pay)
    assert "the optimum is **flagged unstable**" in text and "statically stable" not in text
    assert "0.0491 N, is not below the straight robot's buckling load" in text
    assert "the optimum is statically stable" in _payload_text(paper, _reach_result(0.4, True))
    assert "untested (the model has no such test)" in _payload_text(paper, _reach_result(0.4, None))
    run = ReproduceRun(seed=0, files=[], sampling=SamplingRecord(n=4, converged=4, seconds=0.5, reach_max=0.39,
                                                                 reach_min=0.3),
                       passive=PassiveSolveRecord(converged=False), workspace=WorkspaceSection(16, 0.04, 0, ()),
                       seconds=1.0,
                       ga={8: _reach_result(0.39, True), 10: _reach_result(0.38, False)}, payload=pay,
                       bounds_study=[(10.0, _reach_result(0.37, True)), (20.0, _reach_result(0.39, None))],
                       verdicts=[])
    report = reproduce_report(heavy, run, paper_bounds(8), ReproduceSettings())
    assert "**Warning:** optimum flagged unstable: GA population 10, payload." in report
    assert "bounds [0, 10] N" not in report.split("**Warning:**")[1].split("\n")[0]  # a stable one is not named
    rows = [line for line in report.splitlines() if line.startswith("| population")]
    assert [row.split(" | ")[5] for row in rows] == ["yes", "**no**"]
    bounds = [line for line in report.splitlines() if line.startswith(("| 10 |", "| 20 |"))]
    assert [row.rstrip(" |").rsplit(" | ", 1)[1] for row in bounds] == ["yes", "untested"]
    assert "does not check the stability" not in report
    # the head reads the typed parts: the samples' counts and reach range, the passive solve's outcome
    assert "4 tension vectors uniform in the bounds" in report
    assert "4 converged; reach from 0.3000 to 0.3900 m" in report
    assert "The passive solve did not converge (no figure)." in report and "fig3b_loaded.png" not in report
    calm = dataclasses.replace(run, ga={8: _reach_result(0.39, True)}, payload=_reach_result(0.4, True),
                               bounds_study=[(20.0, _reach_result(0.39, True))],
                               passive=PassiveSolveRecord(True, (0.1, -0.2, 0.3), 0.37417))
    calm_report = reproduce_report(paper, calm, paper_bounds(8), ReproduceSettings())
    assert "**Warning:**" not in calm_report
    assert ("the load alone puts the tip at [0.1, -0.2, 0.3] m (reach 0.3742 m): `fig3b_loaded.png`."
            in calm_report) and "did not converge" not in calm_report


def test_the_axial_payload_sentence_is_said_only_where_it_holds(paper, rao):
    """The antagonistic-pair sentence needs a pair of opposite tendons (same segment and radius, angles pi apart)
    and a robot pointing up against its payload; the axial part needs the latter alone."""
    from pytdcr.robot import Tendon
    from pytdcr.runs._reproduce_report import _antagonistic_pairs, _payload_text

    r = _reach_result(0.4)
    assert _antagonistic_pairs(paper) == [(1, 3), (2, 4), (5, 7), (6, 8)]
    text = _payload_text(paper, r)
    assert "equal tensions in a pair of opposite tendons (1 and 3, 2 and 4, 5 and 7, 6 and 8)" in text
    assert "carries axially" in text and "buckling load" in text
    # no opposite pair (tendons at 90, -30, 210 deg): the straight robot still reaches farthest, no pair named
    assert _antagonistic_pairs(rao) == []
    text = _payload_text(rao, _reach_result(0.4, n_tendons=6))
    assert "carries axially" in text and "pair" not in text
    # mounted horizontally: the payload bends the robot, nothing about the straight robot or pairs is said
    text = _payload_text(paper.with_gravity((-9.81, 0.0, 0.0)), r)
    assert "axial" not in text and "pair" not in text and "straight" not in text and "buckling" not in text
    # opposite angles but different radii, or in different segments: no pair
    odd = paper.model_copy(update={"tendons": (Tendon(segment=1, radius=0.01, angle_deg=0.0),
                                               Tendon(segment=1, radius=0.008, angle_deg=180.0),
                                               Tendon(segment=1, radius=0.01, angle_deg=90.0),
                                               Tendon(segment=2, radius=0.01, angle_deg=270.0))})
    assert _antagonistic_pairs(odd) == []
    assert "pair" not in _payload_text(odd, _reach_result(0.4, n_tendons=4))


# ---------------------------------------------------------------- tdcr accuracy with nothing to compare
def _study_of(results, robot, n: int = 3, reference_steps: int = 160):
    from pytdcr.accuracy import AccuracyStudy, default_groups

    groups = default_groups()
    return AccuracyStudy(robot=robot, tensions=np.zeros((n, robot.n_tendons)), groups=groups,
                         models=tuple(dict.fromkeys(r.model for r in results)), results=tuple(results),
                         reference_steps=reference_steps, seconds=0.0)


def test_an_accuracy_study_says_when_nothing_could_be_compared(paper):
    from pytdcr.accuracy import ModelAccuracy, default_groups
    from pytdcr.runs._accuracy import accuracy_markdown

    names = [g.name for g in default_groups()]
    empty = np.zeros(0)
    dead = [ModelAccuracy(m, g, 3, 0, 0, empty, 1.0) for g in names for m in ("pcc", "pcc2")]
    study = _study_of(dead, paper)
    assert study.compared == 0
    assert study.nothing_compared() == ("the reference sscr converged on none of the 3 tension vectors under any "
                                        "load group")
    assert accuracy_markdown(study, [], "x").splitlines()[2].startswith("**Nothing could be compared:** the reference")
    unsupported = [ModelAccuracy("cosserat", g, 3, 3, 0, empty, float("nan"), unsupported="friction") for g in names]
    assert _study_of(unsupported, paper).nothing_compared() == "every model is unsupported under every load group"
    mixed = [ModelAccuracy("pcc", names[0], 3, 0, 0, empty, 1.0),
             *[ModelAccuracy("pcc", g, 3, 2, 0, empty, 1.0) for g in names[1:]]]
    assert _study_of(mixed, paper).nothing_compared() == (
        "the reference sscr converged on none of the 3 tension vectors under tendons; no model converged where the "
        "reference did under the other groups")
    some = [*dead[:-1], ModelAccuracy("pcc2", names[-1], 3, 2, 1, np.array([0.5]), 1.0)]
    study = _study_of(some, paper)
    assert study.compared == 1 and study.nothing_compared() == ""
    assert "Nothing could be compared" not in accuracy_markdown(study, [], "x")


@pytest.mark.parametrize(("disks", "per_sub", "per_segment"), [(10, 16, 160), (3, 54, 162), (80, 4, 320)])
def test_accuracy_md_states_the_reference_steps_it_used(paper, disks, per_sub, per_segment):
    """160 steps asked for per segment: ceil(160 / disks) per subsegment, at least 4 (80 disks: 320 per segment,
    not the 160 asked for)."""
    from pytdcr.runs._accuracy import accuracy_markdown

    study = _study_of([], paper.with_disks(disks))
    assert study.reference_steps_per_subsegment == per_sub
    md = accuracy_markdown(study, [], "x")
    assert f"with {per_sub} Runge-Kutta steps per subsegment between its disks ({per_segment} per segment" in md


def test_tdcr_accuracy_exits_1_when_nothing_could_be_compared(capsys, tmp_path):
    """Every model unsupported (the smeared rod and the paper robot's friction): one line says so, exit 1, and no
    table of NaN is printed."""
    import json

    from pytdcr.cli import main

    out = tmp_path / "acc"
    code = main(["accuracy", "--models", "cosserat", "--n", "1", "--order-cases", "0", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 1
    lines = [line for line in err.splitlines() if line.startswith("tdcr:")]
    assert lines == ["tdcr: accuracy: nothing could be compared: every model is unsupported under every load group"]
    assert "nan" not in text.lower() and "unsupported" not in text
    assert "**Nothing could be compared:**" in (out / "accuracy.md").read_text()
    assert json.loads((out / "accuracy.json").read_text())["summary"]["compared"] == 0

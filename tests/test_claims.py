"""Answers that claim no more than was computed (issue 25, second class): loads act where physics puts them."""

from __future__ import annotations

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

"""The backbone never passes through itself unnoticed: the contact test on known curves, and the rod models
refusing a pure-moment circle of more than one turn."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import Loads, NoFriction, solve, solve_batch
from pytdcr.contact import backbone_contact, turning_angle
from pytdcr.paper import paper_robot
from pytdcr.results import NotConvergedError


def helix(turns: float, radius: float, pitch: float, n: int = 400) -> np.ndarray:
    """Points of a helix about z (pitch: rise per turn) [m]."""
    t = np.linspace(0.0, 2 * np.pi * turns, n)
    return np.column_stack([radius * np.cos(t), radius * np.sin(t), pitch * t / (2 * np.pi)])


def test_turning_angle_of_known_curves():
    assert turning_angle(np.array([[0, 0, 0], [0, 0, 1], [0, 0, 2.0]])) == 0.0
    assert turning_angle(helix(0.5, 0.1, 0.0, 2001)) == pytest.approx(np.pi, rel=1e-3)


@pytest.mark.parametrize("pitch, touches", [(0.5e-3, True), (1.3e-3, True), (1.5e-3, False), (5e-3, False)])
def test_a_helix_touches_itself_when_its_pitch_is_less_than_the_diameter(pitch, touches):
    r = 0.7e-3  # diameter 1.4 mm; the test resolves contact to r/4
    found = backbone_contact(helix(1.5, 0.05, pitch), r)
    assert (found is not None) == touches
    if found is not None:
        assert found.distance == pytest.approx(pitch, abs=r / 4)
        assert found.arc_gap == pytest.approx(2 * np.pi * np.hypot(0.05, pitch / (2 * np.pi)), rel=0.02)


def test_tight_bends_are_not_contact():
    # a half circle of radius 2 r: points close along the curve are close in space, and that is not contact
    r = 0.7e-3
    assert backbone_contact(helix(0.5, 2 * r, 0.0), r) is None
    assert backbone_contact(np.array([[0, 0, 0], [0, 0, 0.1], [0, 0, 0.2]]), r) is None


def circle_load(turns: float) -> tuple:
    """The paper robot without gravity and friction under a tip moment that bends it into ``turns`` circles."""
    robot = paper_robot().with_gravity(None).with_friction(NoFriction())
    ei = robot.backbone.bending_stiffness
    return robot, Loads(np.zeros(8), tip_moment=[ei * 2 * np.pi * turns / robot.length, 0, 0])


@pytest.mark.parametrize("model", ["cosserat", "sscr"])
def test_rod_models_refuse_a_backbone_through_itself(model):
    robot, under = circle_load(0.9)
    ok = solve(robot, under, model=model)
    assert ok.converged and ok.path == "loading" and ok.failure == ""
    robot, over = circle_load(1.2)
    bad = solve(robot, over, model=model)
    assert bad.residual <= bad.atol  # the equations are satisfied ...
    assert not bad.converged and bad.path == "self-contact"  # ... but the pose is refused
    assert "passes through itself" in bad.failure and bad.to_dict()["failure"] == bad.failure
    with pytest.raises(NotConvergedError, match="passes through itself"):
        _ = bad.tip_position
    batch = solve_batch(robot, np.zeros((2, 8)), over, model=model)
    assert not batch.converged.any() and list(batch.path) == ["self-contact"] * 2
    assert np.isnan(batch.tip_position).all()

"""Robot description: validation, TOML round trip, clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from pytdcr import Backbone, ConstantFriction, ExponentialFriction, Loads, PointLoad, Robot, Segment, Tendon
from pytdcr.io import RobotFileError, load_robot, read_robot, robot_from_dict, robot_to_dict, write_robot


def test_paper_robot_matches_the_paper(paper):
    assert paper.n_disks == 20
    assert paper.n_tendons == 8
    assert paper.length == pytest.approx(0.4)
    assert list(paper.anchor_disks) == [10] * 4 + [20] * 4
    angles = [t.angle_deg for t in paper.tendons]
    assert angles == [0, 90, 180, 270, 45, 135, 225, 315]
    assert np.allclose(np.linalg.norm(paper.tendon_holes, axis=1), 0.01)
    assert isinstance(paper.friction, ExponentialFriction)
    assert paper.gravity == (0.0, 0.0, -9.81)
    bb = paper.backbone
    assert bb.shear == pytest.approx(54e9 / 2.6)
    assert bb.second_moment == pytest.approx(np.pi * 0.7e-3**4 / 4)
    assert bb.torsional_stiffness == pytest.approx(2 * bb.shear * bb.second_moment)


def test_toml_round_trip(tmp_path, paper, rao):
    for robot in (paper, rao, paper.with_friction(ConstantFriction(mu=0.2))):
        path = tmp_path / f"{robot.name}.toml"
        write_robot(robot, path)
        assert read_robot(path) == robot
    custom = Robot(
        name="three",
        backbone=Backbone(youngs_modulus=1e9, shear_modulus=4e8, outer_radius=1e-3, inner_radius=5e-4),
        segments=(Segment(length=0.1, n_disks=3, subsegment_lengths=(0.02, 0.03, 0.05)),
                  Segment(length=0.2, n_disks=2), Segment(length=0.05, n_disks=5, disk_mass=1e-3)),
        tendons=(Tendon(segment=3, radius=0.004, angle_deg=10.0), Tendon(segment=1, radius=0.006, angle_deg=-45)),
    )
    write_robot(custom, tmp_path / "c.toml")
    again = read_robot(tmp_path / "c.toml")
    assert again == custom
    assert np.allclose(again.subsegment_lengths[:3], [0.02, 0.03, 0.05])
    assert list(again.anchor_disks) == [10, 3]


def test_disk_radius_is_the_radius_in_use(tmp_path, paper):
    # Derived: 1.2 times the largest routing radius, and it follows the tendons when they move.
    assert paper.disk_radius_given is None
    assert paper.disk_radius == pytest.approx(1.2 * 0.01)
    wider = paper.model_copy(update={"tendons": [t.model_dump() | {"radius": 0.02} for t in paper.tendons]})
    assert wider.disk_radius == pytest.approx(1.2 * 0.02)
    assert robot_to_dict(wider).get("disk_radius") is None  # the derived value is never written down
    # Given: kept as given, written and read back under the same name.
    given = paper.model_copy(update={"disk_radius": 0.015})
    assert given.disk_radius == pytest.approx(0.015) and given.disk_radius_given == pytest.approx(0.015)
    write_robot(given, tmp_path / "g.toml")
    assert read_robot(tmp_path / "g.toml").disk_radius == pytest.approx(0.015)
    assert Robot(**{**paper.model_dump(), "disk_radius": 0.02}).disk_radius == pytest.approx(0.02)
    with pytest.raises(ValidationError, match="disk_radius_given"):  # one name for the input, not two
        Robot(**{**paper.model_dump(), "disk_radius_given": 0.02})


@pytest.mark.parametrize(
    ("patch", "words"),
    [
        ({"backbone": {"youngs_modulus": -1.0}}, ["backbone.youngs_modulus", "-1.0", "[0.001, 2e+12] Pa", "diamond"]),
        ({"backbone": {"poissons_ratio": 0.7}}, ["backbone.poissons_ratio", "0.7", "(-1, 0.5)"]),
        ({"backbone": {"inner_radius": 0.001}}, ["inner_radius", "smaller than outer_radius"]),
        ({"segments": [{"length": 0.2, "n_disks": 0}]}, ["segments.0.n_disks", "0", "greater than or equal to 1"]),
        ({"tendons": [{"segment": 3, "radius": 0.01, "angle_deg": 0.0}]}, ["tendons.0.segment", "between 1 and 2"]),
        ({"tendons": [{"segment": 1, "radius": 0.0005, "angle_deg": 0.0}]}, ["tendons.0.radius", "outer_radius"]),
        ({"colour": "red"}, ["colour", "unknown key"]),
        ({"backbone": {"stiffness": 3}}, ["backbone.stiffness", "unknown key"]),
        ({"friction": {"law": "coulomb"}}, ["friction"]),
        ({"gravity": [0, 0, float("nan")]}, ["gravity"]),
        ({"schema_version": 7}, ["schema_version", "7"]),
    ],
)
def test_bad_robot_files_name_the_field(paper, patch, words):
    data = robot_to_dict(paper)
    for key, value in patch.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    with pytest.raises(RobotFileError) as err:
        robot_from_dict(data, "robot.toml")
    msg = str(err.value)
    assert msg.startswith("robot.toml:")
    for w in words:
        assert w in msg, msg


def test_unparsable_and_missing_files(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[backbone\nyoungs_modulus = 1\n")
    with pytest.raises(RobotFileError, match="not valid TOML"):
        read_robot(bad)
    with pytest.raises(RobotFileError, match="cannot read"):
        read_robot(tmp_path / "missing.toml")
    with pytest.raises(RobotFileError, match="not a built-in robot"):
        load_robot("nonsense")


def test_python_api_validates_too():
    with pytest.raises(ValidationError, match="n_disks"):
        Segment(length=0.2, n_disks=-3)
    with pytest.raises(ValidationError, match="exactly one"):
        Backbone(youngs_modulus=1e9, outer_radius=1e-3)
    with pytest.raises(ValidationError, match="sum to length"):
        Segment(length=0.2, n_disks=2, subsegment_lengths=(0.1, 0.2))
    with pytest.raises(ValidationError):
        Tendon(segment=1, radius=float("inf"), angle_deg=0)


@pytest.mark.parametrize(
    ("tensions", "match"),
    [([1.0, -0.5], r"tensions\[1\] \(tendon 2\) must be finite and >= 0"), ([np.nan, 1.0], r"tensions\[0\]"),
     ([np.inf], r"tensions\[0\]"), ([[1.0]], "1-D")],
)
def test_bad_tensions(tensions, match):
    with pytest.raises(ValueError, match=match):
        Loads(tensions)


def test_bad_wrenches():
    with pytest.raises(ValueError, match=r"tip_force must have shape \(3,\)"):
        Loads([1.0], tip_force=[1.0, 2.0])
    with pytest.raises(ValueError, match="tip_moment must be finite"):
        Loads([1.0], tip_moment=[0, np.inf, 0])
    with pytest.raises(ValueError, match="disk must be an integer >= 1"):
        PointLoad(0, [1, 0, 0])

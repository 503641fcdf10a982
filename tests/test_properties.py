"""Property-based tests (hypothesis): what no one thought of.

- the robot-file parser: any valid robot survives the round trip through TOML; any document, however broken,
  gives a robot or one line naming the file, never a traceback;
- command-line numbers: any text gives finite numbers or one clean line; numbers survive their own printing;
- the solver: converged equilibria under random tensions and loads inside the validated ranges satisfy their
  equations and respect the backbone's length.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tomli_w
import tomllib
from conftest import ATOL
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pytdcr import Backbone, ConstantFriction, ExponentialFriction, Loads, NoFriction, Robot, Segment, Tendon, solve
from pytdcr.io import RobotFileError, robot_from_dict, robot_to_dict
from pytdcr.robot import MIN_GRAVITY
from pytdcr.statics import get_model
from pytdcr.validate import parse_numbers

# ------------------------------------------------------------------------------------------------ strategies
finite = st.floats(allow_nan=False, allow_infinity=False)


@st.composite
def robots(draw: st.DrawFn) -> Robot:
    """Valid robots: one to three segments, one to four tendons each, any friction law."""
    ro = draw(st.floats(3e-4, 2e-3))
    backbone = Backbone(youngs_modulus=draw(st.floats(1e9, 3e11)), poissons_ratio=draw(st.floats(0.0, 0.49)),
                        outer_radius=ro, inner_radius=draw(st.sampled_from([0.0, 0.5 * ro])),
                        mass_per_length=draw(st.floats(0.0, 0.05)))
    n_seg = draw(st.integers(1, 3))
    segments = tuple(Segment(length=draw(st.floats(0.02, 0.4)), n_disks=draw(st.integers(1, 25)),
                             disk_mass=draw(st.floats(0.0, 0.01))) for _ in range(n_seg))
    tendons = []
    for s in range(1, n_seg + 1):
        angles = draw(st.lists(st.integers(0, 71), min_size=1, max_size=4, unique=True))
        r = draw(st.floats(1.5 * ro, 0.02))
        tendons += [Tendon(segment=s, radius=r, angle_deg=5.0 * a - 180.0) for a in angles]
    friction = draw(st.sampled_from([NoFriction(), ConstantFriction(mu=0.1), ExponentialFriction()]))
    g = draw(st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-9.81, 0)))
    if math.hypot(*g) < MIN_GRAVITY:  # a gravity is none (0) or at least MIN_GRAVITY: a weaker one has no direction
        g = (0.0, 0.0, 0.0)
    name = draw(st.text(st.characters(blacklist_categories=("Cc", "Cs")), min_size=1, max_size=12))
    return Robot(name=name, backbone=backbone, segments=segments, tendons=tuple(tendons), gravity=g, friction=friction)


toml_scalars = st.one_of(st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(), st.text(max_size=20))
toml_values = st.recursive(toml_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)), max_leaves=12)


def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, (*prefix, i))


def _set(obj, path, value):
    if not path:
        return value
    obj[path[0]] = _set(obj[path[0]], path[1:], value)
    return obj


# ------------------------------------------------------------------------------------------------ robot files
@settings(max_examples=60, deadline=None)
@given(robots())
def test_robot_round_trips_through_toml(robot):
    text = tomli_w.dumps(robot_to_dict(robot))
    again = robot_from_dict(tomllib.loads(text), "r.toml")
    assert again == robot
    assert tomli_w.dumps(robot_to_dict(again)) == text


def _one_line_about(err: RobotFileError, source: str) -> None:
    msg = str(err)
    assert msg.startswith(f"{source}:")
    assert "\n" not in msg and "\r" not in msg
    assert not any(ord(c) < 32 for c in msg), msg
    assert len(msg) < 1000


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(robots(), st.data())
def test_any_corrupted_robot_document_gives_a_robot_or_one_line(robot, data):
    """Replace one value anywhere in a valid document by anything TOML can hold."""
    doc = robot_to_dict(robot)
    doc = tomllib.loads(tomli_w.dumps(doc))  # plain TOML types
    path = data.draw(st.sampled_from(list(_paths(doc))[1:]))
    doc = _set(doc, list(path), data.draw(toml_values))
    try:
        got = robot_from_dict(doc, "bad.toml")
    except RobotFileError as err:
        _one_line_about(err, "bad.toml")
    else:
        assert isinstance(got, Robot)


@settings(max_examples=200, deadline=None)
@given(st.dictionaries(st.text(max_size=12), toml_values, max_size=6))
def test_any_document_gives_a_robot_or_one_line(doc):
    try:
        robot_from_dict(doc, "any.toml")
    except RobotFileError as err:
        _one_line_about(err, "any.toml")


# ------------------------------------------------------------------------------------------------ numbers
@settings(max_examples=300, deadline=None)
@given(st.text(max_size=60))
def test_any_text_gives_finite_numbers_or_one_clean_line(text):
    try:
        vals = parse_numbers(text, "--x")
    except ValueError as err:
        msg = str(err)
        assert msg.startswith("--x") and "\n" not in msg
        assert not any(ord(c) < 32 or 127 <= ord(c) < 160 for c in msg), msg
        assert len(msg) < 300
    else:
        assert vals.dtype == float and vals.size >= 1 and np.all(np.isfinite(vals))


@settings(max_examples=200, deadline=None)
@given(st.lists(finite, min_size=1, max_size=10))
def test_numbers_survive_their_own_printing(xs):
    assert parse_numbers(",".join(repr(x) for x in xs), "--x").tolist() == xs
    assert parse_numbers(" , ".join(f"{x:.17g}" for x in xs), "--x").tolist() == xs


@pytest.mark.parametrize("text", ["1_0", "0x10", "1e", "--1", "1,,2", "", " ", "inf", "nan", "True", "1;2",
                                  "\u0661", "\uff11"])
def test_numbers_python_would_accept_are_refused(text):
    with pytest.raises(ValueError):
        parse_numbers(text, "--x")


# ------------------------------------------------------------------------------------------------ the solver
@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tensions=st.lists(st.floats(0.0, 20.0), min_size=8, max_size=8),
       force=st.tuples(*[st.floats(-0.2, 0.2)] * 3), moment=st.tuples(*[st.floats(-0.1, 0.1)] * 3),
       model=st.sampled_from(["pcc", "pcc2"]))
def test_converged_equilibria_satisfy_their_equations(paper, tensions, force, moment, model):
    loads = Loads(np.array(tensions), tip_force=force, tip_moment=moment)
    sol = solve(paper, loads, model=model)
    assume(sol.converged)  # not converging is allowed (and reported); what converges must be right
    eq = get_model(model).equations(paper, loads)
    assert np.max(np.abs(eq.evaluate(sol.q.ravel()).residual)) <= ATOL
    assert sol.residual <= ATOL
    # the backbone never stretches: each chord at most its arc, the tip at most the length from the base
    pts = sol.disk_positions
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert np.all(chords <= paper.subsegment_lengths * (1 + 1e-12))
    assert sol.reach <= paper.length * (1 + 1e-12)
    R = sol.tip_rotation
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12) and math.isclose(np.linalg.det(R), 1.0, abs_tol=1e-12)

"""Numbers at the edge of the floats (issue 44, class 7): every vector and scalar input is range-checked or scaled
safely before use, no NumPy RuntimeWarning reaches the user, and no error or distance is shown as 0 when it is not.

The example: ``tdcr inverse --direction 1e200,1e200,0`` overflowed its normalisation (the norm is inf, the
direction became zeros) and reported an axis error of 0 for an axis far off. A direction's scale is free, so that
one is (1, 1, 0) / sqrt(2), and the axis error reported must be the true angle.
"""

from __future__ import annotations

import json
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from pytdcr import (
    InverseSearch,
    Loads,
    TensionBounds,
    TipTarget,
    inverse_path,
    inverse_statics,
    paper_loads,
    paper_robot,
    solve,
    tip_compliance,
)
from pytdcr.design import Backbone
from pytdcr.io import RobotFileError, read_robot, robot_to_dict
from pytdcr.loads import PointLoad
from pytdcr.optimize import ReachProblem
from pytdcr.statics import CosseratOptions, SolverOptions, SSCROptions
from pytdcr.validate import SettingsError, check_real, unit_vector, unit_vectors

#: a RuntimeWarning (overflow, invalid value, divide by zero) anywhere in these tests is an error
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

ROBOT = paper_robot()
LOADS = paper_loads()
BOUNDS = TensionBounds.uniform(8, 0.0, 20.0)
#: a target the tip reaches (the tip of these tensions, from rest), and a quick search
TENSIONS = np.array([6.0, 2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 1.0])
QUICK = InverseSearch(starts=1, max_solves=20)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two vectors [rad] (independent of the code under test): ``2 atan2(|u - v|, |u + v|)``
    of their unit vectors u, v, accurate for small angles too."""
    u = np.asarray(a, dtype=float) / math.sqrt(float(np.dot(a, a)))
    v = np.asarray(b, dtype=float) / math.sqrt(float(np.dot(b, b)))
    return 2.0 * math.atan2(float(np.linalg.norm(u - v)), float(np.linalg.norm(u + v)))


@pytest.fixture(scope="module")
def target() -> np.ndarray:
    sol = solve(ROBOT, LOADS.with_tensions(TENSIONS))
    assert sol.converged
    return sol.tip_position


# ---------------------------------------------------------------- the example: a huge direction is a direction
@pytest.mark.parametrize("scale", [1e200, 1e308, 1e-200, 3e-308])
def test_a_direction_of_any_scale_is_its_unit_vector(scale):
    """Scaled by its largest component first, (s, s, 0) is (1, 1, 0) / sqrt(2) for every s the floats hold:
    the old normalisation gave zeros for 1e200 (its norm overflows) and refused 1e-200 (its norm underflows)."""
    want = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    np.testing.assert_allclose(TipTarget([0.1, 0.0, 0.3], [scale, scale, 0.0]).direction, want, rtol=1e-15)
    p = ReachProblem.create(ROBOT, LOADS, BOUNDS, direction=[scale, scale, 0.0])
    np.testing.assert_allclose(p.direction, want, rtol=1e-15)
    np.testing.assert_allclose(unit_vectors([[scale, 0.0, -scale], [0.0, scale, 0.0]], "directions"),
                               [[2**-0.5, 0.0, -(2**-0.5)], [0.0, 1.0, 0.0]], rtol=1e-15)


@pytest.mark.parametrize(("value", "words"), [
    ([0.0, 0.0, 0.0], "not all zero"), ([-0.0, 0.0, -0.0], "not all zero"), ([np.nan, 1.0, 0.0], "finite"),
    ([5e-324, 0.0, 0.0], "below 2.23e-308"), ([1e-310, -1e-310, 0.0], "below 2.23e-308"),
])
def test_a_direction_that_is_not_one_is_refused_naming_the_field(value, words):
    """Zero (also -0.0), not finite, or subnormal (too few bits left for the direction written): one line
    naming the field."""
    with pytest.raises(SettingsError, match="direction") as err:
        unit_vector(value, "direction")
    assert words in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ValueError, match=r"^direction: give 3 finite numbers"):
        TipTarget([0.1, 0.0, 0.3], value)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_answer_s_axis_error_is_the_true_angle(target, sign):
    """The example, in Python: the direction (1e200, 1e200, 0) is the direction (1, 1, 0), and the axis error
    reported is the angle between the tip's axis and it (the old code reported 0 for any axis, and searched
    with a zero direction). Along (1, 1, 0) this target's axis is reached to a micro-radian; along (-1, -1, 0)
    it stays far off."""
    d = sign * np.array([1.0, 1.0, 0.0])
    huge = inverse_statics(ROBOT, LOADS, TipTarget(target, 1e200 * d), bounds=BOUNDS, search=QUICK)
    plain = inverse_statics(ROBOT, LOADS, TipTarget(target, d), bounds=BOUNDS, search=QUICK)
    truth = _angle(huge.tip_axis, d)
    assert huge.axis_error_rad == pytest.approx(truth, rel=1e-6, abs=1e-12)
    assert truth > (0.5 if sign < 0 else 0.0)
    np.testing.assert_array_equal(huge.tensions, plain.tensions)
    assert huge.axis_error_rad == pytest.approx(plain.axis_error_rad, rel=1e-12)


def test_the_command_line_reports_the_true_axis_error(target, capsys):
    """The example, on the command line: ``--direction -1e200,-1e200,0`` is accepted as -(1, 1, 0) / sqrt(2) and
    the JSON answer's axis error is the angle between its tip axis and that direction (not 0)."""
    from pytdcr.cli import main

    code = main(["inverse", "--target", ",".join(repr(float(x)) for x in target), "--direction", "-1e200,-1e200,0",
                 "--starts", "1", "--max-solves", "20", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1  # that axis is out of reach there
    truth = _angle(out["tip_axis"], [-1.0, -1.0, 0.0])
    assert truth > 0.01
    assert out["axis_error_rad"] == pytest.approx(truth, rel=1e-6)


def test_an_unreachable_answer_never_shows_its_distance_as_zero(capsys):
    """A miss of 0.4 micrometres (beyond a tolerance of 0.1) is printed as such, not as ``0.000000 m``."""
    from pytdcr.cli.inverse import _print_one

    r = SimpleNamespace(axis_error_rad=None, reachable=False, distance_m=4e-7, path="loading path",
                        objective="least-squares", target=np.zeros(3), tensions=np.zeros(8), objective_value=0.0,
                        stable=True, tip_position=np.zeros(3), tip_axis=np.array([0.0, 0.0, 1.0]), evaluations=1,
                        seconds=0.0)
    _print_one(ROBOT, "pcc", r)
    line = capsys.readouterr().out.splitlines()[0]
    assert "4e-07 m away" in line, line


# ---------------------------------------------------------------- positions: within what any robot reaches
@pytest.mark.parametrize("value", [[1e200, 0.0, 0.3], [0.0, -1e308, 0.0], [1001.0, 0.0, 0.0], [10**400, 0, 0]])
def test_a_target_beyond_any_robot_is_refused(value):
    """Every coordinate within +/-1000 m (100 segments of 10 m at most): 1e200 once overflowed the search's
    distances; now one line naming the target and the range."""
    with pytest.raises(SettingsError, match=r"^target: .*(1000 m|finite)"):
        TipTarget(value)
    with pytest.raises(SettingsError, match=r"^targets.*1000 m"):
        inverse_path(ROBOT, LOADS, [[0.1, 0.0, 0.3], [1e200, 0.0, 0.0]], bounds=BOUNDS, search=QUICK)


def test_an_inverse_search_s_own_inputs_are_range_checked():
    """The seed within --seed's range, the pool's tensions and tips checked as tensions and positions (an int
    too large for a float is a ValueError naming the pool, not an OverflowError)."""
    with pytest.raises(SettingsError, match=r"^seed = 1099511627776: must be an integer in \[0, 4,294,967,295\]"):
        InverseSearch(seed=2**40)
    with pytest.raises(ValueError, match=r"^pool"):
        InverseSearch(pool=([[10**400] * 8], [[0.0, 0.0, 0.3]]))
    with pytest.raises(ValueError, match=r"^pool: tips.*1000 m"):
        InverseSearch(pool=([[1.0] * 8], [[0.0, 0.0, 1e9]]))
    with pytest.raises(ValueError, match=r"^pool: tensions.*at most 10000 N"):
        InverseSearch(pool=([[1e300] * 8], [[0.0, 0.0, 0.3]]))


# ---------------------------------------------------------------- loads, bounds, options
def test_negative_zero_is_stored_as_zero():
    """-0.0 is a valid tension or load; it is kept as +0.0, so no answer shows "-0"."""
    loads = Loads([-0.0] * 8, tip_force=[-0.0, 0.0, 0.0], tip_moment=[0.0, -0.0, 0.0])
    for arr in (loads.tensions, loads.tip_force, loads.tip_moment):
        assert not np.any(np.signbit(arr))


def test_scaling_loads_past_the_full_load_is_refused_without_overflow():
    """``Loads.scaled`` walks the loading path, factor in [0, 1]: 1e300 once overflowed the multiply first."""
    with pytest.raises(SettingsError, match=r"^factor = 1e\+300: must be in \[0, 1\]"):
        paper_loads(np.full(8, 1.0)).scaled(1e300)
    np.testing.assert_array_equal(paper_loads(np.full(8, 1.0)).scaled(0.5).tensions, np.full(8, 0.5))


def test_huge_counts_are_refused_before_anything_is_allocated():
    """A tendon count beyond any robot's (1000) is refused, not allocated (the old code asked for 8 TB); a point
    load's disk beyond any robot's (1,000,000) likewise."""
    with pytest.raises(ValueError, match=r"^n_tendons = 1000000000000: must be an integer in \[1, 1,000\]"):
        TensionBounds.uniform(10**12, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"point load disk must be an integer >= 1 and <= 1,000,000"):
        PointLoad(10**400, np.array([0.0, 0.0, 1.0]))


@pytest.mark.parametrize(("make", "words"), [
    (lambda: SolverOptions(max_iter=10**20), r"max_iter = 100000000000000000000: must be an integer in \[1, "),
    (lambda: SolverOptions(step_iter=2**64), "step_iter"),
    (lambda: SolverOptions(max_dtheta=5e-324), r"max_dtheta = 4.94066e-324: must be in \[0.0001, 3.14159\] rad"),
    (lambda: SolverOptions(max_dtheta=1e300), "max_dtheta"),
    (lambda: CosseratOptions(max_eval=10**20), r"max_eval = 100000000000000000000: must be an integer in \[4, "),
    (lambda: SSCROptions(steps_per_subsegment=10**30),
     r"steps_per_subsegment = .*: must be an integer in \[1, 1,000\]"),
])
def test_solver_options_are_range_checked(make, words):
    """Iteration counts beyond 64 bits once reached the compiled solver (a typing error there); a step of 5e-324
    rad a loading path of endless steps."""
    with pytest.raises(ValueError, match=words):
        make()


def test_solver_option_counts_must_be_integers():
    with pytest.raises(TypeError, match="max_eval must be an integer"):
        CosseratOptions(max_eval=4.5)
    with pytest.raises(TypeError, match="steps_per_subsegment must be an integer"):
        CosseratOptions(steps_per_subsegment=2.5)


def test_check_real_names_the_field_and_range():
    with pytest.raises(SettingsError, match=r"^x = 1e\+200: must be in \[0, 10\] m \(why\)$"):
        check_real(1e200, "x", 0.0, 10.0, "m", "why")
    with pytest.raises(SettingsError, match=r"^x = 1000000.*: must be finite"):
        check_real(10**400, "x", 0.0, 10.0, "m")
    with pytest.raises(TypeError):
        check_real(True, "x", 0.0, 10.0, "m")
    assert not math.copysign(1.0, check_real(-0.0, "x", 0.0, 10.0, "m")) < 0


# ---------------------------------------------------------------- robot files and backbones
@pytest.mark.parametrize(("kw", "words"), [
    ({"youngs_modulus": 5e-324}, "youngs_modulus"),
    ({"youngs_modulus": 1e-300}, "youngs_modulus"),
    ({"poissons_ratio": -1.0 + 1e-16}, "shear modulus"),
    ({"inner_radius": 0.0007 * (1 - 1e-15)}, "wall of at least"),
])
def test_a_backbone_whose_stiffness_is_lost_to_rounding_is_refused(kw, words):
    """E of 5e-324 Pa (EI underflows to 0, and the solver divides by it), nu a hair above -1 (G = E / (2 (1 +
    nu)) near 1e26 Pa), a wall thinner than rounding: refused with the field and its range."""
    args = {"youngs_modulus": 54e9, "poissons_ratio": 0.3, "outer_radius": 0.0007, **kw}
    with pytest.raises(ValueError, match=words):
        Backbone(**args)


def _robot_file(tmp_path, old: str, new: str):
    import tomli_w

    text = tomli_w.dumps(robot_to_dict(ROBOT))
    assert old in text
    path = tmp_path / "robot.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(("old", "new", "words"), [
    ("segment = 1,", f"segment = {'9' * 400},", ["tendons[0].segment", "64 bits"]),
    ("youngs_modulus = 54000000000.0", f"youngs_modulus = {'1' * 5000}", ["robot.toml", "64 bits"]),
    ("youngs_modulus = 54000000000.0", "youngs_modulus = 1e400", ["backbone.youngs_modulus = inf", "finite"]),
    ("outer_radius = 0.0007", "outer_radius = nan", ["backbone.outer_radius = nan", "finite"]),
])
def test_a_robot_file_number_no_field_takes_is_refused_naming_its_key(tmp_path, old, new, words):
    """An integer beyond 64 bits (Python's TOML reader takes any; beyond 4300 digits it fails without naming
    the file), or a float that is not finite: one short line naming the file and the key."""
    with pytest.raises(RobotFileError) as err:
        read_robot(_robot_file(tmp_path, old, new))
    text = str(err.value)
    assert all(w in text for w in words), text
    assert len(text) < 300 and "\n" not in text


# ---------------------------------------------------------------- results at the edge
def test_the_compliance_of_a_straight_robot_is_reported(tmp_path):
    """The straight inextensible robot cannot move its tip along its axis: its translational stiffness is
    infinite there, written as null, not a LinAlgError (once reported as bad input, exit 2)."""
    sol = solve(ROBOT, Loads(np.zeros(8)))
    c = tip_compliance(ROBOT, Loads(np.zeros(8)), sol)
    d = c.to_dict()
    assert d["translational_stiffness_N_per_m"] is None
    soft, stiff = d["translational_stiffness_range_N_per_m"]
    assert 0.0 < soft < math.inf and stiff == math.inf


def test_a_self_contact_message_never_shows_zero_for_a_small_distance():
    from pytdcr.contact import Contact

    text = Contact(distance=3e-6, arc_gap=4e-5).describe(2e-5)
    assert "0.003 mm apart, less" in text and "0.04 mm apart along" in text, text
    assert " 0.00 mm" not in text and " 0.0 mm" not in text


def test_a_memory_budget_beyond_a_petabyte_is_refused(monkeypatch):
    from pytdcr.limits import MEMORY_ENV, memory_budget

    monkeypatch.setenv(MEMORY_ENV, "1e300")
    with pytest.raises(ValueError, match="PYTDCR_MEMORY_GB='1e300': must be a positive number of gigabytes up to"):
        memory_budget()


@pytest.mark.parametrize(("args", "words"), [
    (["--disk-force", "\u00b2:0,0,1"], "--disk-force"),
    (["--disk-force", f"{'9' * 5000}:0,0,1"], "--disk-force"),
])
def test_the_command_line_refuses_odd_disk_numbers_naming_the_option(args, words, capsys):
    """A superscript digit (str.isdigit takes it, int() does not) or a 5000-digit disk number: one line naming
    the option, exit 2."""
    from pytdcr.cli import main

    assert main(["solve", "--tensions", "0,0,0,0,0,0,0,0", *args]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1


def test_no_runtime_warning_in_an_inverse_answer_at_the_edges(target):
    """The example and a tiny direction, with every RuntimeWarning an error: none is raised."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = inverse_statics(ROBOT, LOADS, TipTarget(target, [1e-300, 1e-300, 0.0]), bounds=BOUNDS, search=QUICK)
    assert r.axis_error_rad == pytest.approx(_angle(r.tip_axis, [1.0, 1.0, 0.0]), rel=1e-6, abs=1e-12)

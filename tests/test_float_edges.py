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
from pytdcr.io import RobotFileError, read_robot, robot_to_dict
from pytdcr.loads import PointLoad
from pytdcr.optimize import ReachProblem
from pytdcr.results import NotConvergedError
from pytdcr.robot import Backbone
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
                        seconds=0.0, pulled_in=np.zeros(8))
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


# ---------------------------------------------------------------- members: load arrows, directions, messages
def test_a_load_arrow_is_its_unit_vector_at_any_scale_and_none_below_it():
    """The figures' load arrows use the one direction rule: a tip force of 5e-324 N (all components subnormal)
    has no arrow (the old code divided by its norm, 0: a RuntimeWarning and a NaN arrow), a tip moment of 1e-200
    N m an arrow along its axis labelled with its magnitude (the old norm underflowed to 0)."""
    from pytdcr.runs._output import load_arrows

    loads = Loads(np.zeros(8), tip_force=[5e-324, 5e-324, 0.0], tip_moment=[1e-200, 0.0, -1e-200])
    sol = SimpleNamespace(tip_position=np.array([0.0, 0.0, 0.4]))
    arrows = load_arrows(sol, loads, ROBOT)
    assert [a[3].split(",")[0] for a in arrows] == ["tip moment axis"]
    origin, vector, _, label = arrows[0]
    np.testing.assert_array_equal(origin, sol.tip_position)
    want = np.array([1.0, 0.0, -1.0]) / math.sqrt(2.0) * (0.25 * ROBOT.length * 0.6)
    np.testing.assert_allclose(vector, want, rtol=1e-15)
    assert label == f"tip moment axis, {math.sqrt(2.0) * 1e-200:.3g} N m"


def test_solve_plots_a_subnormal_tip_force_without_a_warning(tmp_path):
    """The member's command: ``tdcr solve --tip-force 5e-324,5e-324,0 --plot x.png`` (exit 70 under
    ``-W error::RuntimeWarning`` before) draws its figure and exits 0."""
    from pytdcr.cli import main

    png = tmp_path / "x.png"
    code = main(["solve", "--tensions", "3,0,0,0,2,0,0,0", "--tip-force", "5e-324,5e-324,0", "--plot", str(png)])
    assert code == 0 and png.stat().st_size > 0


@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_workspace_directions_of_any_scale_are_directions(scale):
    """``WorkspaceSettings(directions=...)`` and ``support_function``'s directions: (s, s, 0) is (1, 1, 0) /
    sqrt(2) at every scale (the old code made 1e200 a zero direction, h = 0, and refused 1e-200 as zero)."""
    from pytdcr.workspace import WorkspaceSettings
    from pytdcr.workspace._support import _check_directions

    rows = [[scale, scale, 0.0], [0.0, -scale, 0.0], [0.0, 0.0, 2.0]]
    want = [[2**-0.5, 2**-0.5, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    np.testing.assert_allclose(WorkspaceSettings(directions=rows).direction_vectors(), want, rtol=1e-15)
    np.testing.assert_allclose(_check_directions(np.array(rows)), want, rtol=1e-15)


def test_workspace_directions_all_subnormal_are_refused_naming_directions():
    """A row whose components are all below MIN_DIRECTION has no direction: one line naming ``directions``
    (the old code accepted 5e-324 and divided by a norm of 0)."""
    from pytdcr.workspace import WorkspaceSettings
    from pytdcr.workspace._support import _check_directions

    rows = [[0.0, 0.0, 1.0], [5e-324, 0.0, -5e-324]]
    for make in (lambda: WorkspaceSettings(directions=rows), lambda: _check_directions(np.array(rows))):
        with pytest.raises(ValueError, match=r"^directions \(row 2\): .*below 2.23e-308") as err:
            make()
        assert "\n" not in str(err.value)


def test_ordinary_directions_keep_every_bit():
    """Directions whose lengths are in range are divided by ``np.linalg.norm`` as before (the scaled rule could
    move a last bit, and the workspace baselines pin h(d)): the Fibonacci sphere's and arbitrary ones."""
    from pytdcr.workspace import WorkspaceSettings
    from pytdcr.workspace._support import _check_directions, fibonacci_directions

    rng = np.random.default_rng(4)
    for d in (fibonacci_directions(200), rng.normal(size=(50, 3)) * 10.0 ** rng.uniform(-100, 100, (50, 1))):
        plain = d / np.linalg.norm(d, axis=1)[:, None]
        np.testing.assert_array_equal(_check_directions(d), plain)
        np.testing.assert_array_equal(WorkspaceSettings(directions=d.tolist()).direction_vectors(), plain)


def _design_study(direction: list[float]) -> dict:
    return {"name": "t", "robot": "paper", "bounds": [0.0, 10.0],
            "parameters": {"backbone_radius": {"values": [0.0007]}}, "budget": {"samples": 24},
            "loads": {"cases": ["no load"]}, "measures": {"directions": {"up": direction}}}


def test_a_design_study_s_direction_of_any_scale_is_its_direction():
    """A study's measured direction (1e-200, 0, 1e-200) is accepted (the old check, ``norm == 0``, called it
    zero) and becomes (1, 0, 1) / sqrt(2) where h(d) is computed (the settings the designs are evaluated with)."""
    from pytdcr.designs import study_from_dict
    from pytdcr.workspace import WorkspaceSettings

    for scale in (1e-200, 1e300):
        study, _ = study_from_dict(_design_study([scale, 0.0, scale]), "s.toml")
        given = tuple(tuple(v) for v in study.measures.directions.values())
        np.testing.assert_allclose(WorkspaceSettings(directions=given).direction_vectors(),
                                   [[2**-0.5, 0.0, 2**-0.5]], rtol=1e-15)


def test_a_design_study_s_subnormal_direction_is_refused_naming_it():
    """All components subnormal: refused, one line naming the file, the key and the direction (the old check
    accepted it, and h(d) divided by a norm of 0)."""
    from pytdcr.designs import StudyError, study_from_dict

    with pytest.raises(StudyError) as err:
        study_from_dict(_design_study([5e-324, 0.0, 0.0]), "s.toml")
    text = str(err.value)
    assert text.startswith("s.toml: measures.directions") and "direction 'up'" in text, text
    assert "below 2.23e-308" in text and "\n" not in text


def test_optimize_never_prints_negative_zero(capsys):
    """A rounded coordinate or tension of zero is printed 0.0, not -0.0 (``np.round(-1e-9, 6)`` is -0.0)."""
    from pytdcr.cli.optimize import print_reach

    ga = SimpleNamespace(tensions=np.array([-1e-7, 2.0]), reach=0.4, cost=2.5)
    res = SimpleNamespace(ga=ga, generations=3, stop_reason="tolerance", evaluations=10, nonconverged=0, seconds=1.0,
                          polished=True, reach=0.4, cost=2.5, polish_gain=0.0, tensions=np.array([-0.0, 2.0]),
                          tip_position=np.array([-1e-9, -0.0, 0.4]), stable=True, rejected_unstable=0)
    print_reach(res, SimpleNamespace(pop=4, seed=0))
    out = capsys.readouterr().out
    assert "optimum tip [0.0, 0.0, 0.4]" in out and "tensions [0.0, 2.0]" in out, out
    assert "-0.0" not in out


class _FakeComparison:
    """What ``tdcr compare`` prints from: two models, the other's tip 0.3 micrometres off at most."""

    reference, others, n_all_converged = "pcc", ("pcc2",), 2

    def __len__(self) -> int:
        return 2

    def summaries(self) -> dict:
        one = {"difference_median_mm": None, "difference_max_mm": None, "ms_median": 1.0, "not_converged": 0}
        return {"pcc": SimpleNamespace(**one),
                "pcc2": SimpleNamespace(**{**one, "difference_median_mm": 0.0, "difference_max_mm": 3e-4})}


def test_compare_never_prints_a_small_tip_difference_as_zero(monkeypatch, tmp_path, capsys):
    """A tip difference of 0.3 micrometres is printed 0.0003 mm, not 0.000 mm; a true zero stays 0.000."""
    import pytdcr.runs
    from pytdcr.cli import main

    fake = SimpleNamespace(comparison=_FakeComparison(), robot=ROBOT, friction_off=(), files=["compare.csv"])
    monkeypatch.setattr(pytdcr.runs, "run_compare", lambda *a, **k: fake)
    assert main(["compare", "--models", "pcc,pcc2", "--n", "2", "--out", str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out
    assert "median 0.000 mm, max 0.0003 mm" in out, out


def test_accuracy_never_prints_a_small_error_as_zero_and_keeps_its_columns(monkeypatch, tmp_path, capsys):
    """Errors under half a micrometre once printed 0.000 mm; now 3 significant digits, in the same 9 columns (the
    'mm' after each error at the same place on every line)."""
    import pytdcr.runs
    from pytdcr.accuracy import AccuracyRow
    from pytdcr.cli import main

    def row(median: float, p95: float) -> AccuracyRow:
        return AccuracyRow("pcc", "tendons only", 3, 3, 3, 1.0, median, p95, p95, 1.0)

    rows = [row(1.25, 12.5), row(3e-4, 2e-7), row(0.0, 4.9e-4)]
    study = SimpleNamespace(nothing_compared=lambda: None, robot=ROBOT, groups=[1], models=["pcc"], seconds=0.0,
                            rows=lambda: rows)
    fake = SimpleNamespace(study=study, orders=[], files=["accuracy.csv"])
    monkeypatch.setattr(pytdcr.runs, "run_accuracy", lambda *a, **k: fake)
    assert main(["accuracy", "--n", "2", "--order-cases", "0", "--out", str(tmp_path / "a")]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if "median" in ln]
    assert len(lines) == 3
    assert "median     1.250 mm, 95th pct    12.500 mm" in lines[0], lines[0]
    assert "median    0.0003 mm, 95th pct     2e-07 mm" in lines[1], lines[1]
    assert "median     0.000 mm, 95th pct   0.00049 mm" in lines[2], lines[2]
    assert len({ln.index(" mm, 95th") for ln in lines}) == 1 and len({ln.index(" mm, converged") for ln in lines}) == 1


@pytest.mark.parametrize("model", ["pcc", "pcc2"])
@pytest.mark.parametrize("load", [{"tip_moment": [1000.0, 0.0, 0.0]}, {"tip_moment": [0.0, 300.0, 0.0]},
                                  {"tip_force": [1e6, 0.0, 0.0]}, {"tip_moment": [1e6, 1e6, 0.0]}])
def test_an_extreme_tip_load_gives_an_answer_never_an_arithmetic_error(model, load):
    """Loads inside what :class:`Loads` accepts but far past what the robot bears: the compiled solver raised
    ZeroDivisionError (a load step below the load factor's resolution after a huge secant rate; a tendon turned
    back on itself, whose normal direction is undefined). Now the solve ends: converged, or not converged with its
    residual at full load, never an exception (a bug to the user: exit 70)."""
    robot = paper_robot()
    sol = solve(robot, Loads(np.zeros(robot.n_tendons), **{k: np.array(v) for k, v in load.items()}), model=model)
    assert np.isfinite(sol.residual)
    if sol.converged:
        assert sol.residual <= sol.atol and np.all(np.isfinite(sol.tip_position))
    else:
        assert sol.residual > sol.atol
        with pytest.raises(NotConvergedError, match="did not converge"):  # no shape is given for it
            _ = sol.tip_position


# ---------------------------------------------------------------- the review: one rule, the old bits kept
def _ordinary(seed: int) -> np.ndarray:
    """Ordinary directions: the Fibonacci sphere's, random normals at scales from 1e-100 to 1e100, (0.3, 0.2,
    0.9), and rows with a zero (also -0.0) component."""
    from pytdcr.workspace._support import fibonacci_directions

    rng = np.random.default_rng(seed)
    return np.vstack([fibonacci_directions(200), rng.normal(size=(300, 3)),
                      rng.normal(size=(100, 3)) * 10.0 ** rng.uniform(-100, 100, (100, 1)),
                      [[0.3, 0.2, 0.9], [0.0, -0.0, 1.0], [-2.0, 0.0, 0.0]]])


def test_an_ordinary_direction_is_v_over_its_norm_bit_for_bit():
    """``unit_vector`` (the target's axis, the reach problem's direction) is ``v / np.linalg.norm(v)`` and
    ``unit_vectors`` (the workspace's given directions) ``d / np.linalg.norm(d, axis=1)``, each bit for bit as
    computed before the one rule (the scaled rule moved 123 of the 200 default directions; NumPy's length of one
    vector and of a stack's rows may differ in the last bit, so each keeps its own)."""
    D = _ordinary(11)
    np.testing.assert_array_equal(unit_vectors(D, "directions"), D / np.linalg.norm(D, axis=1)[:, None])
    problem = ReachProblem.create(ROBOT, LOADS, BOUNDS, direction=[0.3, 0.2, 0.9])
    for v in D:
        want = v / np.linalg.norm(v)
        np.testing.assert_array_equal(unit_vector(v, "direction"), want)
        np.testing.assert_array_equal(TipTarget([0.1, 0.0, 0.3], v).direction, want)
        np.testing.assert_array_equal(problem.with_direction(v).direction, want)
    v = np.array([0.3, 0.2, 0.9])
    np.testing.assert_array_equal(ReachProblem.create(ROBOT, LOADS, BOUNDS, direction=v).direction,
                                  v / np.linalg.norm(v))


@pytest.mark.parametrize("scale", [1e150, 1e-150, 1e300, 1e-300, 2.5e-308])
def test_a_direction_at_the_edges_of_the_plain_rule_is_its_unit_vector(scale):
    """At and beyond the plain rule's interval (1e-150, 1e150) the scaled rule takes over: no overflow, no
    underflow, the same direction to rounding, in a row of a stack or alone."""
    row = np.array([scale, -2.0 * scale, 0.5 * scale])
    want = np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)
    np.testing.assert_allclose(unit_vector(row, "direction"), want, rtol=1e-15)
    got = unit_vectors([row, [0.3, 0.2, 0.9]], "directions")
    np.testing.assert_allclose(got[0], want, rtol=1e-15)
    np.testing.assert_array_equal(got[1], np.array([0.3, 0.2, 0.9]) / np.linalg.norm([[0.3, 0.2, 0.9]], axis=1))
    np.testing.assert_allclose(ReachProblem.create(ROBOT, LOADS, BOUNDS, direction=row).direction, want, rtol=1e-15)


def test_region_directions_go_through_the_one_rule():
    """The workspace's directions are :func:`pytdcr.validate.unit_vectors`' (no second rule in the region)."""
    import pytdcr.workspace._support as support
    from pytdcr.workspace import WorkspaceSettings
    from pytdcr.workspace._support import _check_directions

    assert not hasattr(support, "unit_directions") and not hasattr(support, "PLAIN_SCALE")
    rows = [[1e200, 1e200, 0.0], [0.3, 0.2, 0.9]]
    np.testing.assert_array_equal(_check_directions(np.array(rows)), unit_vectors(rows, "directions"))
    np.testing.assert_array_equal(WorkspaceSettings(directions=rows).direction_vectors(),
                                  unit_vectors(rows, "directions"))
    with pytest.raises(ValueError, match="nonzero"):
        _check_directions(np.zeros((2, 3)))


@pytest.mark.parametrize(("value", "want"), [
    ([0.0, 0.0, 0.0], None), ([-0.0, 0.0, 0.0], None), ([5e-324, 0.0, -5e-324], None), ([np.nan, 1.0, 0.0], None),
    ([np.inf, 0.0, 0.0], None), ([0.0, -np.inf, 1.0], None),
    ([1e-300, 0.0, -1e-300], [2**-0.5, 0.0, -(2**-0.5)]), ([0.0, 0.0, -9.81], [0.0, 0.0, -1.0]),
    ([1e300, 1e300, 0.0], [2**-0.5, 2**-0.5, 0.0]),
])
def test_direction_or_none_is_the_unit_vector_or_none(value, want):
    """A vector that may be too small to have a direction (a load's arrow, a gravity): its unit vector, or None
    when every component is below MIN_DIRECTION or one is not finite; never a warning or an exception."""
    from pytdcr.validate import direction_or_none

    got = direction_or_none(value, "arrow")
    if want is None:
        assert got is None
    else:
        np.testing.assert_allclose(got, want, rtol=1e-15)
        v = np.array(value)
        if 1e-150 < np.max(np.abs(v)) < 1e150:
            np.testing.assert_array_equal(got, v / np.linalg.norm(v))


def test_direction_or_none_refuses_what_is_no_vector_naming_it():
    from pytdcr.validate import direction_or_none

    with pytest.raises(SettingsError, match=r"^arrow: give 3 finite numbers"):
        direction_or_none([1.0, 0.0], "arrow")
    with pytest.raises(TypeError, match="arrow"):
        direction_or_none([True, 0.0, 0.0], "arrow")


def test_an_explorer_arrow_of_a_load_without_a_direction_is_not_drawn():
    """The explorer's arrows follow the same rule: nothing for a zero, subnormal or non-finite vector (an
    infinite one was refused with an exception before), an arrow of the length asked for otherwise."""
    from pytdcr.explore._figure import _arrow

    origin = np.array([0.0, 0.0, 0.4])
    for v in ([0.0, 0.0, 0.0], [5e-324, 0.0, 0.0], [np.inf, 0.0, 0.0], [np.nan, 0.0, 1.0]):
        assert _arrow(origin, np.array(v), 0.1).shape == (0, 3)
    pts = _arrow(origin, np.array([1e-200, 0.0, 0.0]), 0.1)
    np.testing.assert_allclose(pts[1], origin + np.array([0.1, 0.0, 0.0]), rtol=1e-15)


def test_the_optimiser_s_dicts_follow_the_json_rule():
    """``Optimum.to_dict`` and ``ReachResult.to_dict`` are :func:`pytdcr.runtime.to_jsonable`'s (the rule of
    every JSON file): no -0.0, and a non-finite number None (strict JSON), not NaN."""
    from pytdcr.optimize import Optimum, ReachResult

    opt = Optimum(np.array([-0.0, 1.5]), np.array([0.2, -0.0, 0.3]), math.nan, -0.0, None)
    res = ReachResult(tensions=opt.tensions, tip_position=opt.tip_position, reach=0.36, cost=-0.0, value=-0.0,
                      stable=None, converged=False, stop_reason="generation cap", generations=2, evaluations=24,
                      nonconverged=24, seconds=1.0, seed=1,
                      history={"best": [math.inf, -0.0], "mean": [math.nan, 1.0], "evaluations": [12, 24]},
                      ga=opt, settings={"direction": np.array([-0.0, 0.0, 1.0])})
    d = opt.to_dict()
    assert d == {"tensions": [0.0, 1.5], "tip_position": [0.2, 0.0, 0.3], "reach": None, "cost": 0.0, "stable": None}
    text = json.dumps(res.to_dict(), allow_nan=False)
    assert "-0.0" not in text
    back = json.loads(text)
    assert back["history"]["best"] == [None, 0.0] and back["ga"]["reach"] is None
    assert back["settings"]["direction"] == [0.0, 0.0, 1.0]


def test_finite_real_is_check_real_s_rule_for_answers_without_an_exception():
    """One finite-number check (:func:`pytdcr.validate.finite_real`, by :func:`check_real`): the explorer's
    boxes and a design record's numbers use it."""
    from pytdcr.designs._records import is_number
    from pytdcr.validate import finite_real

    for bad in (True, False, np.True_, "1", None, [1.0], math.nan, math.inf, -math.inf, 10**400, -(10**400), 1j):
        assert finite_real(bad) is None, bad
        assert is_number(bad) is False, bad
    for good, want in ((0, 0.0), (-0.0, 0.0), (3, 3.0), (2.5, 2.5), (10**300, 1e300), (np.float32(0.5), 0.5)):
        got = finite_real(good)
        assert got == want and type(got) is float and not math.copysign(1.0, got) < 0
        assert is_number(good) is True


def test_the_explorer_s_boxes_keep_their_messages_and_ranges():
    """The explorer's load boxes take what :class:`pytdcr.Loads` takes (``MAX_FORCE_N``, ``MAX_MOMENT_NM``), and
    a value that is no finite number (an integer beyond the floats, true, NaN) gets the box's own message."""
    import importlib

    import pytdcr.explore._app as app
    import pytdcr.validate as validate

    ex = SimpleNamespace(bounds=SimpleNamespace(lower=np.zeros(8), upper=np.full(8, 20.0)),
                         robot=SimpleNamespace(n_tendons=8))
    options = {"gravity": ["on"], "friction": "own", "model": "pcc"}
    wrench = [0.0] * 7
    assert app._controls(ex, [1.0] * 8, [10**400, *wrench[1:]], options) == \
        "force x: give a number in [-1e+06, 1e+06] N"
    assert app._controls(ex, [1.0] * 8, [*wrench[:4], True, 0.0, 0.0], options) == \
        "moment y: give a number in [-1e+06, 1e+06] N m"
    assert app._controls(ex, [True, *[1.0] * 7], wrench, options) == "T1: give a tension in [0, 20] N"
    assert app._controls(ex, [1.0] * 8, [*wrench[:6], math.nan], options) == "payload: give a number in [0, 10000] kg"
    assert not isinstance(app._controls(ex, [1.0] * 8, wrench, options), str)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(validate, "MAX_FORCE_N", 7.0)
        m.setattr(validate, "MAX_MOMENT_NM", 3.0)
        ranges = dict(importlib.reload(app)._WRENCH_RANGE)
    importlib.reload(app)
    assert ranges["force-z"] == (-7.0, 7.0, "N") and ranges["moment-x"] == (-3.0, 3.0, "N m")
    assert app._WRENCH_RANGE["force-x"] == (-validate.MAX_FORCE_N, validate.MAX_FORCE_N, "N")


def test_number_text_is_the_validation_layer_s_rule():
    """``number_text`` lives next to ``show_number`` (the one rule of the command line too) and stays
    importable from :mod:`pytdcr.runs` and its report."""
    import pytdcr.runs
    import pytdcr.runs._reproduce_report
    from pytdcr.validate import number_text

    assert pytdcr.runs.number_text is number_text and pytdcr.runs._reproduce_report.number_text is number_text
    assert number_text(2e-4) == "0.0002" and number_text(-0.0) == "0.000" and number_text(1.25, 3, 9) == "    1.250"

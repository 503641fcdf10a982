"""Numbers at the edge of the floats (issue 44, class 7), the last members: a gravity too weak to have a
direction, a non-zero error shown as 0, the reach cost at a tip on the base, -0.0 in the optimiser's JSON.

Every test runs with NumPy's RuntimeWarning as an error: no warning may reach the user.
"""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import tomli_w
from pydantic import BaseModel

from pytdcr import Loads
from pytdcr.compare import ModelComparison
from pytdcr.io import robot_to_dict
from pytdcr.optimize import Optimum, ReachProblem, ReachResult
from pytdcr.optimize._problem import MIN_COST_REACH
from pytdcr.paper import paper_bounds, paper_robot
from pytdcr.robot import MIN_GRAVITY, Robot
from pytdcr.runs._accuracy import _fmt
from pytdcr.runs._compare import _compare_markdown
from pytdcr.runs._reproduce_report import _axial_text, _bounds_trend, _payload_is_axial, number_text

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

#: gravities with no direction a float can hold: every component subnormal, or its squares underflow
TOO_WEAK = [(0.0, 0.0, -5e-324), (1e-200, 0.0, -1e-200), (5e-324, 5e-324, 5e-324)]


def _unchecked(robot: Robot, gravity: tuple[float, float, float]) -> Robot:
    """``robot`` with ``gravity`` set past the robot's validation (as a model built without it would be)."""
    return BaseModel.model_copy(robot, update={"gravity": gravity})


# ---------------------------------------------------------------- gravity
@pytest.mark.parametrize("gravity", TOO_WEAK)
def test_a_gravity_without_a_direction_is_not_axial_and_warns_nothing(gravity):
    """The report's axial-payload test normalises gravity by the one rule (:func:`pytdcr.validate.unit_vector`):
    the old ``g / ||g||`` divided by zero for these (||g|| underflows)."""
    assert _payload_is_axial(_unchecked(paper_robot(), gravity)) is False


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (0.0, 0.0, -100.0), (5e-324, 0.0, -MIN_GRAVITY)])
def test_gravity_along_minus_z_is_axial_at_any_accepted_scale(gravity):
    assert _payload_is_axial(paper_robot().with_gravity(gravity)) is True
    assert _payload_is_axial(paper_robot().with_gravity((1.0, 0.0, -9.81))) is False


@pytest.mark.parametrize("gravity", [*TOO_WEAK, (0.0, 0.0, -0.5 * MIN_GRAVITY)])
def test_a_robot_refuses_a_gravity_too_weak_to_have_a_direction(gravity):
    """Old: accepted, so the payload hung along a direction rounding had made up."""
    with pytest.raises(ValueError, match=r"gravity: \|g\| = .* must be in \[0, 100\] m/s\^2.*either 0 .*at least "
                                         r"1e-06 m/s\^2") as err:
        paper_robot().with_gravity(gravity)
    assert "\n" not in str(err.value).split("Value error, ", 1)[1].split(" [type=")[0]


@pytest.mark.parametrize("gravity", [(0.0, 0.0, 0.0), (0.0, -0.0, 0.0), (0.0, 0.0, -MIN_GRAVITY),
                                     (5e-324, 0.0, -9.81), (0.0, 60.0, -80.0)])
def test_no_gravity_and_every_real_gravity_stay_accepted(gravity):
    assert paper_robot().with_gravity(gravity).gravity == gravity


def test_the_cli_refuses_a_robot_file_with_a_subnormal_gravity(tmp_path):
    """One line naming the field and the allowed range, exit status 2."""
    path = tmp_path / "weak.toml"
    path.write_text(tomli_w.dumps({**robot_to_dict(paper_robot()), "gravity": [1e-200, 0.0, -1e-200]}))
    out = subprocess.run([sys.executable, "-m", "pytdcr.cli", "solve", "--robot", str(path), "--tensions",
                          "1,0,0,0,0,0,0,0"], capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 2, out.stderr
    assert out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "gravity" in out.stderr and "1e-06 m/s^2" in out.stderr and "[0, 100] m/s^2" in out.stderr


# ---------------------------------------------------------------- no non-zero number shown as 0
@pytest.mark.parametrize("value", [2e-4, -2e-4, 4.9e-4, 1e-9, 5e-324])
def test_number_text_never_shows_a_non_zero_value_as_zero(value):
    text = number_text(value)
    assert float(text) != 0.0 and np.sign(float(text)) == np.sign(value)
    assert float(text) == pytest.approx(value, rel=5e-3)


def test_number_text_is_three_decimals_for_ordinary_values_and_agrees_with_the_cli():
    """Ordinary values print as before (the golden texts stay); ``error_mm`` follows the same rule."""
    from pytdcr.cli.compare import error_mm

    rng = np.random.default_rng(3)
    values = [0.0, 5e-4, 0.0123, 1.0, 12.3456, 999.9995, *rng.uniform(-50.0, 50.0, 50),
              *10.0 ** rng.uniform(-12, -3, 50)]
    for v in values:
        assert number_text(v, 3, 9) == error_mm(v, 9)
        if abs(v) >= 5e-4:
            assert number_text(v) == f"{v:.3f}"
    assert number_text(-0.0) == "0.000"
    assert number_text(float("nan")) == "nan"


def test_the_accuracy_tables_never_show_a_non_zero_error_as_zero():
    """Old ``_fmt``: ``format(x, '.3f')``, so a median error of 2e-4 mm read 0.000."""
    assert float(_fmt(2e-4)) == pytest.approx(2e-4)
    assert float(_fmt(3e-5, 4)) == pytest.approx(3e-5)
    assert _fmt(1.23456) == "1.235" and _fmt(1.23456, 4) == "1.2346" and _fmt(0.0) == "0.000"
    assert _fmt(float("nan")) == "-"


def _solution(tip: tuple[float, float, float] | None) -> SimpleNamespace:
    """What a comparison reads of a solve: converged at ``tip`` [m], or not converged (None)."""
    return SimpleNamespace(converged=tip is not None, tip_position=np.asarray(tip or (0.0, 0.0, 0.0), dtype=float),
                           seconds=1e-3, residual=1e-12, path="loading")


def test_the_comparison_report_never_shows_a_non_zero_difference_as_zero():
    """Old ``_compare_markdown``: ``.3f``, so a difference of 2e-4 mm (5e-5 % of L) read 0.000 in the table and
    the summary; a case that did not converge still reads n/c, and ordinary differences keep three decimals."""
    robot = paper_robot()
    tips = [(0.1, 0.0, 0.3), (0.1, 0.0, 0.3), (0.2, 0.1, 0.3)]
    cmp = ModelComparison(
        tensions=np.zeros((3, robot.n_tendons)), models=("pcc", "pcc2"), length=robot.length,
        solutions={"pcc": [_solution(t) for t in tips],
                   "pcc2": [_solution((0.1, 0.0, 0.3 + 2e-7)), _solution(None), _solution((0.2, 0.1, 0.3 + 1.5e-3))]})
    text = _compare_markdown(cmp, robot, Loads(np.zeros(robot.n_tendons)), {})
    table = [line for line in text.splitlines() if line.startswith("| ")]
    head = [c.strip() for c in table[0].strip("|").split("|")]
    cells = [[c.strip() for c in row.strip("|").split("|")] for row in table[1:]]
    mm, pct = head.index("pcc2 diff [mm]"), head.index("pcc2 diff [% L]")
    assert float(cells[0][mm]) == pytest.approx(2e-4, rel=5e-3)
    assert float(cells[0][pct]) == pytest.approx(2e-7 / robot.length * 100, rel=5e-3)
    assert cells[1][mm] == "n/c" and cells[1][pct] == "n/c"
    assert cells[2][mm] == f"{1.5:.3f}" and cells[2][pct] == f"{1.5e-3 / robot.length * 100:.3f}"
    summary = next(line for line in text.splitlines() if line.startswith("- `pcc2` from `pcc`"))
    assert "median 0.000 " not in summary and "(0.000 %" not in summary


def test_the_report_never_shows_a_non_zero_buckling_load_as_zero():
    """A soft robot (E at its floor, 1e-3 Pa) buckles under micronewtons: old ``.3f`` wrote 0.000 N."""
    paper = paper_robot()
    soft = paper.model_copy(update={"backbone": paper.backbone.model_copy(update={"youngs_modulus": 1e-3})})
    text = _axial_text(soft)
    assert "= 0.000 N" not in text
    load = float(text.rsplit("= ", 1)[1].split(" N")[0])
    want = np.pi**2 * soft.backbone.bending_stiffness / (4 * soft.length**2)
    assert load == pytest.approx(want, rel=5e-3)
    assert _axial_text(paper).endswith(f"= {np.pi**2 * paper.backbone.bending_stiffness / (4 * 0.4**2):.3f} N).")


def test_the_bounds_trend_of_an_upper_bound_given_twice_divides_by_no_zero():
    """``ReproduceSettings(bound_uppers=(20, 20, 40))``: the old rate per newton divided by 20 - 20."""
    text = _bounds_trend([0.30, 0.31, 0.32], [20.0, 20.0, 40.0])
    assert text.startswith("The reach grows with the upper bound") and "per N" not in text
    assert "mm per N" in _bounds_trend([0.30, 0.32, 0.33], [10.0, 20.0, 40.0])


# ---------------------------------------------------------------- the reach cost at the base
def _problem() -> ReachProblem:
    robot = paper_robot()
    return ReachProblem.create(robot, Loads(np.zeros(robot.n_tendons)), paper_bounds(robot.n_tendons))


def test_the_reach_cost_is_finite_and_ordered_down_to_a_tip_on_the_base():
    """Old: ``1 / ||tip||`` divided by zero at the origin (and where ||tip|| underflows)."""
    p = _problem()
    reaches = [0.0, 1e-200, 1e-12, MIN_COST_REACH, 1e-6, 1e-3, 0.3]
    tips = np.array([[r, 0.0, 0.0] for r in reaches])
    cost = p.cost(tips)
    assert np.all(np.isfinite(cost))
    assert np.all(np.diff(cost) <= 0.0) and np.all(np.diff(cost[3:]) < 0.0)
    assert cost[0] == cost[3] == pytest.approx(1.0 / MIN_COST_REACH)
    assert cost[-1] == pytest.approx(1.0 / 0.3, rel=1e-15)
    assert float(p.cost(np.zeros(3))) == cost[0]


def test_the_reach_cost_gradient_is_finite_at_a_tip_on_the_base():
    """The cost is constant below MIN_COST_REACH: its gradient there is 0 (old: 0/0)."""
    p = _problem()
    dtip = np.ones((3, p.robot.n_tendons))
    for tip in (np.zeros(3), np.array([1e-200, 0.0, 0.0])):
        g = p.cost_gradient(tip, dtip)
        assert g.shape == (p.robot.n_tendons,) and np.all(g == 0.0)
    tip = np.array([0.3, 0.0, 0.0])
    np.testing.assert_allclose(p.cost_gradient(tip, dtip), -0.3 / 0.3**3, rtol=1e-14)


# ---------------------------------------------------------------- -0.0 in JSON
def test_the_optimiser_writes_no_negative_zero():
    """Old ``to_dict``: a tip at y = -0.0 or a cost of -0.0 (-d . tip) went into the JSON as -0.0."""
    opt = Optimum(np.array([0.0, -0.0, 1.5]), np.array([0.2, -0.0, 0.3]), 0.36, -0.0, None)
    res = ReachResult(tensions=opt.tensions, tip_position=opt.tip_position, reach=0.36, cost=-0.0, value=-0.0,
                      stable=None, converged=True, stop_reason="tolerance", generations=2, evaluations=24,
                      nonconverged=0, seconds=1.0, seed=1,
                      history={"best": [-0.0, -0.0], "mean": [1.0, -0.0], "evaluations": [12, 24]},
                      ga=opt, polish_gain=-0.0, settings={"direction": [-0.0, 0.0, 1.0], "pop_size": 12})
    text = json.dumps(res.to_dict())
    assert "-0.0" not in text
    assert "-0.0" not in json.dumps(opt.to_dict())
    back = json.loads(text)
    assert back["history"]["evaluations"] == [12, 24] and isinstance(back["generations"], int)
    assert back["tip_position"] == [0.2, 0.0, 0.3] and back["tensions"] == [0.0, 0.0, 1.5]
    assert back["stable"] is None and back["seed"] == 1


def _ordinary_directions() -> np.ndarray:
    from pytdcr.workspace._support import fibonacci_directions

    rng = np.random.default_rng(7)
    return np.vstack([fibonacci_directions(200), rng.normal(size=(500, 3)), [[0.3, 0.2, 0.9], [0.0, -0.0, 1.0]],
                      rng.normal(size=(50, 3)) * 1e-120, rng.normal(size=(50, 3)) * 1e120])


def test_an_ordinary_direction_keeps_every_bit():
    """The one direction rule scales by the largest component only where a length would over- or underflow:
    every ordinary direction is ``v / norm(v)`` bit for bit, as the target's axis, the reach problem's
    direction and the figures computed it before the rule (h(d), polishes and inverse answers read them; the
    scaled rule moved 123 of the 200 default directions' last bits)."""
    from pytdcr import TipTarget
    from pytdcr.validate import unit_vector

    robot = paper_robot()
    loads = Loads(np.zeros(robot.n_tendons))
    for v in _ordinary_directions():
        want = v / float(np.linalg.norm(v))
        np.testing.assert_array_equal(unit_vector(v, "d"), want)
        np.testing.assert_array_equal(TipTarget([0.0, 0.0, 0.2], v).direction, want)
    for v in _ordinary_directions()[:20]:
        p = ReachProblem.create(robot, loads, paper_bounds(), direction=v)
        np.testing.assert_array_equal(p.direction, v / float(np.linalg.norm(v)))

"""Typed settings: Python and the command line accept the same inputs and refuse the rest with the same words
(the command line calls each field by its option); the results' typed summaries."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import Loads
from pytdcr.accuracy import check_accuracy_plan
from pytdcr.cli import main
from pytdcr.cli._args import FLAGS
from pytdcr.compare import ModelSummary, check_models, compare_models
from pytdcr.runs import (
    AccuracySettings,
    BoundsSpec,
    CompareSettings,
    LoadSpec,
    ModelSpec,
    OptimizeSettings,
    RobotSpec,
    SampleSettings,
    SolveSettings,
    run_accuracy,
)
from pytdcr.validate import SettingsError, field_ref


def cli_error(capsys, *args: str) -> str:
    code = main(list(args))
    _, err = capsys.readouterr()
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.startswith("tdcr:")]
    assert len(lines) == 1, err
    return lines[0].removeprefix("tdcr: error: ")


Z8 = "0,0,0,0,0,0,0,0"
SAME = [
    (lambda: RobotSpec(friction=11.0), ["solve", "--tensions", Z8, "--friction", "11"], "friction"),
    (lambda: RobotSpec(friction=-1), ["solve", "--tensions", Z8, "--friction", "-1"], "friction"),
    (lambda: ModelSpec("pcc", shear_extension=True), ["solve", "--tensions", Z8, "--shear-extension"],
     "shear_extension"),
    (lambda: SolveSettings(tensions=(1, 2, 3, 4, 5, 6, 7, -8)), ["solve", "--tensions", "1,2,3,4,5,6,7,-8"],
     "tensions"),
    (lambda: BoundsSpec(5.0, 1.0), ["sample", "--bounds", "5,1"], "bounds"),
    (lambda: BoundsSpec(-1.0, 3.0), ["sample", "--bounds", "-1,3"], "bounds"),
    (lambda: OptimizeSettings(pop=1), ["optimize", "--pop", "1"], "pop"),
    (lambda: OptimizeSettings(tol=0.0), ["optimize", "--tol", "0"], "tol"),
    (lambda: CompareSettings(models=("pcc", "prbm")), ["compare", "--models", "pcc,prbm"], "models"),
    (lambda: CompareSettings(models=("pcc", "pcc")), ["compare", "--models", "pcc,pcc"], "models"),
    (lambda: CompareSettings(cases="c.csv", bounds=BoundsSpec(0.0, 1.0)),
     ["compare", "--cases", "c.csv", "--bounds", "0,1"], "cases"),
    (lambda: AccuracySettings(reference_steps=3), ["accuracy", "--reference-steps", "3"], "reference_steps"),
    (lambda: AccuracySettings(payload_g=2000.0), ["accuracy", "--payload-g", "2000"], "payload_g"),
    (lambda: AccuracySettings(models=("pcc", "prbm")), ["accuracy", "--models", "pcc,prbm"], "models"),
    (lambda: LoadSpec(tip_force=(0.0, 0.0, 1e7)), ["solve", "--tensions", Z8, "--tip-force", "0,0,1e7"], "tip_force"),
    (lambda: LoadSpec(tip_moment=(0.0, 2e6, 0.0)), ["sample", "--tip-moment", "0,2e6,0"], "tip_moment"),
    (lambda: ModelSpec(atol=1.0), ["solve", "--tensions", Z8, "--atol", "1"], "atol"),
    (lambda: ModelSpec("sscr", atol=1e-300), ["solve", "--tensions", Z8, "--model", "sscr", "--atol", "1e-300"],
     "atol"),
    (lambda: OptimizeSettings(model=ModelSpec("cosserat"), stable_only=True),
     ["optimize", "--model", "cosserat", "--stable-only"], "stable_only"),
    (lambda: OptimizeSettings(bounds=BoundsSpec(3.0, 3.0)).build(), ["optimize", "--bounds", "3,3"], "bounds"),
    (lambda: OptimizeSettings(pop=0), ["optimize", "--pop", "0"], "pop"),
    (lambda: SampleSettings(n=-2), ["sample", "--n", "-2"], "n"),
    (lambda: AccuracySettings(order_cases=-1), ["accuracy", "--order-cases", "-1"], "order_cases"),
]


@pytest.mark.parametrize(("make", "args", "field"), SAME, ids=[" ".join(a[:1] + a[-2:]) for _, a, _ in SAME])
def test_python_and_the_command_line_refuse_alike(capsys, tmp_path, make, args, field):
    with pytest.raises(SettingsError) as err:
        make()
    assert err.value.field == field and str(err.value).startswith(field)
    out = [] if args[0] == "solve" else ["--out", str(tmp_path / "out")]
    assert cli_error(capsys, *args, *out) == err.value.worded(FLAGS)
    assert not (tmp_path / "out").exists()


def test_a_settings_error_names_other_fields_by_the_callers_names():
    err = SettingsError("cases", f": give either {field_ref('cases')} or {field_ref('n')}")
    assert str(err) == "cases: give either cases or n"
    assert err.worded({"cases": "--cases", "n": "--n"}) == "--cases: give either --cases or --n"


def test_settings_hold_their_defaults_and_refuse_wrong_types():
    s = SampleSettings()
    assert (s.n, s.seed, s.n_shapes, s.model.name, s.robot.robot) == (100, 0, 10, "pcc", "paper")
    b = s.bounds.build(s.robot.build())
    assert b.lower.tolist() == [0.0] * 8 and b.upper.tolist() == [20.0] * 8
    with pytest.raises(TypeError, match=r"robot must be a pytdcr\.runs\.RobotSpec"):
        SampleSettings(robot="paper")
    with pytest.raises(SettingsError, match=r"seed = 4294967296: must be an integer in \[0, 4,294,967,295\]"):
        SampleSettings(seed=2**32)
    with pytest.raises(TypeError, match="release must be True or False"):
        LoadSpec(release=1)
    with pytest.raises(ValueError, match="tip_force must be within"):
        LoadSpec(tip_force=(0, 0, 1e7))
    with pytest.raises(SettingsError, match="model: 'prbm' is not a model"):
        ModelSpec("prbm")


def test_the_specs_build_what_the_command_line_builds(paper):
    robot = RobotSpec(gravity=False, friction="none").build()
    assert not np.any(robot.gravity) and robot.friction.is_frictionless
    assert RobotSpec(robot=paper, friction=0.1).build().friction.law == "constant"
    loads = LoadSpec(tip_force=(0.1, 0.1, -0.1), release=True).build(robot)
    assert loads.tip_force.tolist() == [0.1, 0.1, -0.1] and loads.release and loads.tensions.tolist() == [0.0] * 8
    b = BoundsSpec(lower=0.0, upper=tuple(range(1, 9))).build(robot)
    assert b.upper.tolist() == list(map(float, range(1, 9)))
    with pytest.raises(SettingsError, match="bounds: robot 'paper' has 8 tendons, got bounds for 3"):
        BoundsSpec(upper=(1.0, 2.0, 3.0)).build(robot)
    model, options = ModelSpec("cosserat", atol=1e-9).resolve(robot, loads)
    assert model.name == "cosserat" and options.atol == 1e-9


def test_the_comparisons_models_are_checked_once(paper):
    with pytest.raises(SettingsError) as by_settings:
        CompareSettings(models=("pcc",))
    with pytest.raises(SettingsError) as by_function:
        compare_models(paper, Loads(np.zeros(8)), np.zeros((1, 8)), models=("pcc",))
    assert str(by_settings.value) == str(by_function.value) == "models: give two or more distinct models, got ['pcc']"
    assert [m.name for m in check_models(["pcc", "pcc2"])] == ["pcc", "pcc2"]


def test_the_accuracy_plan_is_checked_before_any_work(paper, tmp_path):
    with pytest.raises(SettingsError, match="disks: the order study needs two or more different disk counts"):
        check_accuracy_plan(paper, disks=(5, 5), order=True)
    check_accuracy_plan(paper, disks=(5,), order=False)
    with pytest.raises(SettingsError, match="reference_steps 99999999999: with 10 disks per segment"):
        run_accuracy(AccuracySettings(reference_steps=99_999_999_999, order_cases=0), tmp_path / "a")
    assert not (tmp_path / "a").exists()


def test_the_comparisons_typed_summary_is_its_json_summary(rao):
    cmp = compare_models(rao, Loads(np.zeros(6)), np.array([[2.0, 0, 0, 0, 1, 0], [0, 1, 0, 0, 0, 1.0]]),
                         models=("pcc", "pcc2"))
    per = cmp.summaries()
    assert list(per) == ["pcc", "pcc2"] and all(isinstance(s, ModelSummary) for s in per.values())
    assert per["pcc"].difference_median_mm is None and per["pcc2"].difference_max_mm > 0
    summ = cmp.summary()
    assert summ.all_converged == cmp.n_all_converged == 2 and summ.per_model == tuple(per.values())
    d = summ.to_json()
    assert d["pcc2_difference_median_mm"] == per["pcc2"].difference_median_mm
    assert d["pcc_ms_median"] == per["pcc"].ms_median and "pcc_difference_median_mm" not in d


def test_plot_robot_takes_the_robot_first(rao):
    from pytdcr import solve
    from pytdcr.plotting import RobotStyle, plot_robot, pyplot

    sol = solve(rao, Loads(np.array([2.0, 0, 0, 0, 1, 0])))
    ax = plot_robot(rao, sol, style=RobotStyle(disks=False, tendons=False, frames=False), color="tab:blue",
                    label="backbone")
    assert len(ax.get_lines()) == 1 and ax.get_lines()[0].get_label() == "backbone"
    assert ax.get_lines()[0].get_color() == "tab:blue"
    pyplot().close(ax.figure)

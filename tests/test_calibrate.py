"""Calibration (:mod:`pytdcr.calibrate`): exact derivatives through the equilibrium, recovery of known parameters
from synthetic data (exactly without noise, within their standard errors with noise), the identifiability
warnings, and the refusals of bad data and settings."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pytdcr import Loads, paper_robot, solve
from pytdcr.calibrate import CalibrationOptions, Measurements, calibrate, parameters, read_measurements
from pytdcr.calibrate._problem import Problem
from pytdcr.robot import NoFriction
from pytdcr.statics.registry import resolve
from pytdcr.validate import SettingsError

ROBOT = paper_robot()


def _tensions(seed: int, b: int, top: float = 6.0) -> np.ndarray:
    """``b`` tension vectors: each tendon uniform in [0, top] N with probability 0.4, else slack."""
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, top, (b, ROBOT.n_tendons)) * (rng.random((b, ROBOT.n_tendons)) < 0.4)


def _tips(robot, tensions: np.ndarray, model: str = "pcc", force=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The loading-path tips (B, 3) [m] of ``robot`` at each row of ``tensions``."""
    out = []
    for t in tensions:
        sol = solve(robot, Loads(t, tip_force=force), model=model)
        assert sol.converged
        out.append(sol.tip_position)
    return np.array(out)


def _with(robot, *, modulus=None, mu0=None, radius=None):
    """``robot`` with the given modulus [Pa], friction mu0 and every tendon's radius [m], set by hand (not through
    the package's parameter map, so that a slip there shows as a failed recovery)."""
    update = {}
    if modulus is not None:
        update["backbone"] = robot.backbone.model_copy(update={"youngs_modulus": modulus})
    if mu0 is not None:
        update["friction"] = robot.friction.model_copy(update={"mu0": mu0})
    if radius is not None:
        update["tendons"] = tuple(t.model_copy(update={"radius": radius}) for t in robot.tendons)
    return robot.model_copy(update=update)


@pytest.mark.parametrize("model", ["pcc", pytest.param("sscr", marks=pytest.mark.slow)])
def test_jacobian_matches_finite_differences_through_the_solver(model):
    """The implicit-function Jacobian of the residuals equals central differences of re-solved equilibria."""
    t = _tensions(3, 3)
    data = Measurements.from_arrays(ROBOT, t, _tips(ROBOT, t) + 1e-3, sigma=1e-3)
    names = ["youngs_modulus", "friction.mu0", "friction.decay_per_deg", "tendon_radius", "pretension", "payload",
             "base_z", "base_rx"]
    m, opts = resolve(model, ROBOT, None, None, gradient=True)
    # a tolerance 1000 times the default's keeps the solver's own error (~1e-9 m at the tip) out of the differences
    problem = Problem(ROBOT, data, parameters(ROBOT, names), m, dataclasses.replace(opts, atol=1e-12))
    v = problem.initial + np.array([0, 0, 0, 0, 0.2, 0.01, 0, 0])  # off the pretension's and payload's bound 0
    exact = problem.jacobian(v, problem.solutions(v))

    def at(i: int, h: float) -> np.ndarray:
        e = np.zeros_like(v)
        e[i] = h
        return problem.residuals(v + e, problem.solutions(v + e))

    def central(i: int, h: float) -> np.ndarray:
        # five points, truncation O(h^4): a step large enough that the solver's own error (its tolerance floor,
        # ~4e-12 m at the tip) divided by h stays below 1e-6; the three-point difference at h = 1e-3 scales moved
        # by 2e-5 between steps of 3e-4 and 3e-3 scales (that noise, not the Jacobian)
        return (-at(i, 2 * h) + 8 * at(i, h) - 8 * at(i, -h) + at(i, -2 * h)) / (12 * h)

    fd = np.column_stack([central(i, h) for i, h in enumerate(1e-2 * problem.scales)])
    scale = np.abs(fd).max(axis=0)
    assert np.all(scale > 0)
    np.testing.assert_allclose(exact / scale, fd / scale, atol=1e-5)


def test_noise_free_data_give_back_the_parameters_exactly():
    """Data made by pcc from known E, mu0, tendon radius and frame offset: the fit from the paper robot's values
    returns them (the model is exact for its own data)."""
    truth = _with(ROBOT, modulus=60e9, mu0=0.5, radius=0.0105)
    t = _tensions(1, 16)
    tips = _tips(truth, t) + np.array([0.0, 0.0, 1.5e-3])
    data = Measurements.from_arrays(ROBOT, t, tips, sigma=0.5e-3)
    result = calibrate(ROBOT, data, ["youngs_modulus", "friction.mu0", "tendon_radius", "base_z"],
                       options=CalibrationOptions(loss="linear", folds=0, tolerance=1e-10))
    assert result.converged, result.message
    assert result.rms_before_m > 3e-3
    assert result.rms_after_m < 1e-7
    np.testing.assert_allclose([result.value("youngs_modulus"), result.value("friction.mu0"),
                                result.value("tendon_radius"), result.value("base_z")],
                               [60e9, 0.5, 0.0105, 1.5e-3], rtol=1e-5, atol=1e-8)
    assert result.robot.backbone.youngs_modulus == pytest.approx(60e9, rel=1e-5)


def test_a_turned_and_shifted_measurement_frame_is_recovered():
    """Tips measured in a frame turned 0.05 rad about z and shifted (2, -1, 0.5) mm: the frame's pose comes back."""
    t = _tensions(2, 10)
    rot = Rotation.from_rotvec([0.0, 0.0, 0.05])
    shift = np.array([2e-3, -1e-3, 0.5e-3])
    data = Measurements.from_arrays(ROBOT, t, rot.apply(_tips(ROBOT, t)) + shift)
    result = calibrate(ROBOT, data, ["base_x", "base_y", "base_z", "base_rz"],
                       options=CalibrationOptions(loss="linear", folds=0, tolerance=1e-10))
    assert result.converged
    np.testing.assert_allclose([result.value(n) for n in ("base_x", "base_y", "base_z", "base_rz")],
                               [*shift, 0.05], atol=1e-8)


def test_noisy_data_give_the_truth_within_its_standard_errors():
    """0.5 mm noise per axis: each parameter within 3 standard errors of the truth (the errors are honest, not
    tiny), the residual scatter at the noise's level and the held-out error close to the fitted one."""
    truth = _with(ROBOT, modulus=48e9, mu0=0.6)
    t = _tensions(4, 30)
    noise = np.random.default_rng(5).normal(0.0, 0.5e-3, (30, 3))
    data = Measurements.from_arrays(ROBOT, t, _tips(truth, t) + noise, sigma=0.5e-3)
    result = calibrate(ROBOT, data, ["youngs_modulus", "friction.mu0"], options=CalibrationOptions(folds=3))
    assert result.converged and not result.warnings
    for p, true in zip(result.parameters, (48e9, 0.6), strict=True):
        assert abs(p.value - true) < 3 * p.standard_error, (p.name, p.value, p.standard_error)
        assert p.standard_error < 0.05 * true
    assert 0.5 < result.chi2 / result.dof < 1.6
    assert result.rms_after_m < 1.2e-3
    cv = result.cross_validation
    assert cv is not None and cv.failed_folds == 0 and np.all(np.isfinite(cv.errors_m))
    assert result.rms_after_m < cv.rms_m < 1.5 * result.rms_after_m
    doc = json.loads(json.dumps(result.to_json()))
    assert doc["schema_version"] == 1 and len(doc["rows"]) == 30 and doc["data"]["source"] == "arrays"


def test_a_modulus_and_a_routing_radius_that_only_act_together_are_named():
    """Without gravity and friction the PCC model's curvature under tensions alone is nearly T r / (E I): mostly
    E / r matters, and the fit warns that the data do not tell E and the tendon radius apart."""
    robot = ROBOT.model_copy(update={"gravity": (0.0, 0.0, 0.0), "friction": NoFriction()})
    t = _tensions(6, 12)
    data = Measurements.from_arrays(robot, t, _tips(robot, t))
    result = calibrate(robot, data, ["youngs_modulus", "tendon_radius"],
                       options=CalibrationOptions(folds=0, max_evaluations=5))
    joint = [w for w in result.warnings if "do not determine" in w]
    assert len(joint) == 1 and "youngs_modulus" in joint[0] and "tendon_radius" in joint[0], result.warnings
    assert result.singular_values[-1] < 1e-2
    assert abs(result.correlation[0, 1]) > 0.99


def test_a_parameter_the_data_never_move_is_named():
    """Tendon 8 is slack in every row: its routing radius acts on nothing."""
    t = _tensions(7, 6)
    t[:, 7] = 0.0
    data = Measurements.from_arrays(ROBOT, t, _tips(ROBOT, t))
    result = calibrate(ROBOT, data, ["youngs_modulus", "tendon_radius_8"], options=CalibrationOptions(folds=0))
    assert any(w.startswith("tendon_radius_8: the data do not depend on it") for w in result.warnings)
    assert result.parameters[1].standard_error == np.inf


def test_a_fit_stopped_by_its_budget_says_it_did_not_converge():
    truth = _with(ROBOT, modulus=70e9)
    t = _tensions(8, 6)
    data = Measurements.from_arrays(ROBOT, t, _tips(truth, t))
    result = calibrate(ROBOT, data, ["youngs_modulus", "friction.mu0"],
                       options=CalibrationOptions(folds=0, max_evaluations=1))
    assert not result.converged
    assert result.warnings[0].startswith("the fit did not converge")


def test_parameter_bounds_keep_the_robot_valid():
    (r,) = parameters(ROBOT, ["tendon_radius"])
    assert r.lower > ROBOT.backbone.outer_radius and r.upper > r.initial
    (e,) = parameters(ROBOT, ["youngs_modulus"])
    assert 0 < e.lower < e.initial < e.upper


@pytest.mark.parametrize(("names", "words"), [
    (["friction.mu"], "friction law to be constant"),
    (["stiffness"], "unknown parameter 'stiffness'"),
    (["base_z", "base_z"], "base_z is named twice"),
    (["tendon_radius", "tendon_radius_3"], "overlap"),
    (["tendon_radius_9"], "the robot has tendons 1 to 8"),
    ([], "name at least one parameter"),
])
def test_parameters_the_robot_cannot_take_are_refused(names, words):
    with pytest.raises(SettingsError, match=words):
        parameters(ROBOT, names)


def _csv(tmp_path, header: str, *rows: str):
    path = tmp_path / "data.csv"
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


HEADER = ",".join([f"T{k}_N" for k in range(1, 9)] + ["tip_x_m", "tip_y_m", "tip_z_m"])
GOOD = "1,0,0,0,0,0,0,0,0.01,0.0,0.2"


def test_a_good_file_reads_with_its_hash(tmp_path):
    data = read_measurements(_csv(tmp_path, HEADER + ",sigma_m", GOOD + ",0.0005", GOOD + ",0.002"), ROBOT)
    assert data.n_rows == 2 and data.sigma.tolist() == [0.0005, 0.002] and len(data.sha256) == 64
    assert data.tensions[0, 0] == 1.0 and data.tip_position[1].tolist() == [0.01, 0.0, 0.2]


@pytest.mark.parametrize(("header", "row", "words"), [
    (HEADER, "1,0,0,0,0,0,0,0,0.01,nan,0.2", "row 2, column tip_y_m: nan is not a finite number"),
    (HEADER, "1,0,0,0,0,0,0,0,0.01,abc,0.2", "row 2, column tip_y_m: 'abc' is not a number"),
    (HEADER, "1,0,0,0,0,0,0,0,10,0,200", "row 2, column tip_x_m: .*millimetres"),
    (HEADER, "-1,0,0,0,0,0,0,0,0.01,0,0.2", "row 2, column T1_N: -1 must be in"),
    (HEADER + ",weight", GOOD + ",1", "column weight: unknown"),
    (HEADER + ",pulled_in_1_m", GOOD + ",0.001", "give a pull-in as DK_m"),
    (HEADER.replace(",tip_z_m", ""), GOOD.rsplit(",", 1)[0], "column tip_z_m: missing"),
    (HEADER + ",sigma_m", GOOD + ",0", "column sigma_m: 0 must be in"),
])
def test_a_bad_file_is_refused_naming_row_and_column(tmp_path, header, row, words):
    path = _csv(tmp_path, header, GOOD if header.count(",") == HEADER.count(",") else row, row)
    with pytest.raises(SettingsError, match=words):
        read_measurements(path, ROBOT)


@pytest.mark.parametrize(("options", "words"), [
    ({"loss": "l2"}, "loss = 'l2'"),
    ({"folds": 1}, "folds = 1"),
    ({"max_evaluations": 0}, "max_evaluations = 0"),
    ({"identifiability": 0.9}, "identifiability = 0.9"),
])
def test_bad_options_are_refused(options, words):
    with pytest.raises(SettingsError, match=words):
        CalibrationOptions(**options)


def test_more_folds_than_rows_and_a_model_without_derivatives_are_refused():
    t = _tensions(9, 3)
    data = Measurements.from_arrays(ROBOT, t, _tips(ROBOT, t))
    with pytest.raises(SettingsError, match="folds = 5: must be at most the number of rows"):
        calibrate(ROBOT, data, ["youngs_modulus"])


def test_tdcr_calibrate_writes_a_run_whose_fitted_robot_reads_back(tmp_path, capsys):
    from pytdcr.cli import main
    from pytdcr.io import read_robot

    truth = _with(ROBOT, modulus=60e9)
    t = _tensions(10, 8)
    tips = _tips(truth, t)
    lines = [HEADER + ",sigma_m"]
    lines += [",".join(f"{x:.17g}" for x in (*a, *b, 1e-3)) for a, b in zip(t, tips, strict=True)]
    (tmp_path / "m.csv").write_text("\n".join(lines) + "\n")
    out = tmp_path / "run"
    code = main(["calibrate", str(tmp_path / "m.csv"), "--fit", "youngs_modulus", "--folds", "0", "--loss", "linear",
                 "--out", str(out), "-q"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "converged" in text and "youngs_modulus" in text
    fitted = read_robot(out / "robot_fitted.toml")
    assert fitted.backbone.youngs_modulus == pytest.approx(60e9, rel=1e-4)
    doc = json.loads((out / "calibration.json").read_text())
    assert doc["schema_version"] == 1 and doc["inputs"]["robot"]["backbone"]["youngs_modulus"] == 54e9
    assert (out / "rows.csv").read_text().count("\n") == 9 and (out / "fig_calibration.png").stat().st_size > 0
    # the folder holds this calibration: other parameters need --restart (a stopped run would be resumed)
    other = ["calibrate", str(tmp_path / "m.csv"), "--fit", "base_z", "--folds", "0", "--out", str(out), "-q"]
    assert main(other) == 2 and "--restart" in capsys.readouterr().err
    assert main([*other, "--restart"]) == 0 and "base_z" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "words"), [
    (["--fit", "stiffness"], "--fit: unknown parameter 'stiffness'"),
    (["--fit", "base_z", "--folds", "9"], "--folds = 9: must be at most the number of rows (2)"),
    (["--fit", "friction.mu"], "--fit: friction.mu needs the robot's friction law to be constant"),
])
def test_tdcr_calibrate_refuses_bad_input_in_one_line_and_writes_nothing(tmp_path, capsys, argv, words):
    from pytdcr.cli import main

    data = _csv(tmp_path, HEADER, GOOD, GOOD)
    out = tmp_path / "run"
    assert main(["calibrate", str(data), *argv, "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert not out.exists()


def test_a_row_without_an_equilibrium_is_named(monkeypatch):
    """The model's solver fails on the second row (a stand-in for a row beyond the model's reach): the fit refuses
    to start, naming the row and the solver's residual."""
    import pytdcr.calibrate._problem as problem_module

    t = _tensions(11, 3)
    data = Measurements.from_arrays(ROBOT, t, _tips(ROBOT, t))
    real = problem_module.solve

    def failing(robot, loads, **kwargs):
        sol = real(robot, loads, **kwargs)
        hit = np.allclose(loads.tensions, t[1])
        return dataclasses.replace(sol, converged=False, residual=0.25, failure="stand-in") if hit else sol

    monkeypatch.setattr(problem_module, "solve", failing)
    with pytest.raises(SettingsError, match=r"data \(arrays\): row 2: the 'pcc' model finds no equilibrium .*"
                                            r"residual 0\.25 N m"):
        calibrate(ROBOT, data, ["youngs_modulus"], options=CalibrationOptions(folds=0))


def _driven_rows(robot, tensions: np.ndarray, stiffness: float, offset: float = 0.0):
    """Rows whose segment-1 tendons (1 to 4) are driven by displacement: each row's pull-ins are those of the
    tension solve of ``robot`` at ``tensions`` (tendons of ``stiffness`` [N/m]), less a motor zero ``offset`` [m];
    (displacements (B, 8) with NaN for tendons 5 to 8, tips (B, 3))."""
    from pytdcr import pulled_in

    pulls, tips = [], []
    for t in tensions:
        sol = solve(robot, Loads(t))
        assert sol.converged
        pulls.append(np.where(np.arange(8) < 4, pulled_in(robot, sol, stiffness) - offset, np.nan))
        tips.append(sol.tip_position)
    return np.array(pulls), np.array(tips)


def test_displacement_rows_have_exact_derivatives_too(monkeypatch):
    """Rows driving tendons 1 to 4 by their pull-ins: the Jacobian (through the equilibrium and the pull-in
    conditions, with the driven tensions as unknowns) equals central differences of re-solved rows."""
    import functools

    import pytdcr.calibrate._problem as problem_module
    from pytdcr import DisplacementOptions, solve_displacements

    tight = functools.partial(solve_displacements, drive=DisplacementOptions(tol=1e-11))
    monkeypatch.setattr(problem_module, "solve_displacements", tight)  # the solver's error out of the differences
    t = _tensions(3, 3)
    t[:, 0], t[:, 2] = [2.0, 4.0, 0.0], [0.0, 0.0, 3.0]
    k = np.full(8, 3.5e4)
    pulls, tips = _driven_rows(ROBOT, t, 3.5e4)
    data = Measurements.from_arrays(ROBOT, t, tips + 1e-3, displacements=pulls, sigma=1e-3)
    names = ["youngs_modulus", "friction.mu0", "tendon_stiffness", "displacement_offset", "pretension_5", "base_z"]
    m, opts = resolve("pcc", ROBOT, None, None, gradient=True)
    problem = Problem(ROBOT, data, parameters(ROBOT, names, k), m, dataclasses.replace(opts, atol=1e-12), k)
    v = problem.initial + np.array([0, 0, 0, 0, 0.1, 0])
    exact = problem.jacobian(v, problem.solutions(v))

    def central(i: int, h: float) -> np.ndarray:
        e = np.zeros_like(v)
        e[i] = h
        rise = problem.residuals(v + e, problem.solutions(v + e)) - problem.residuals(v - e, problem.solutions(v - e))
        return rise / (2 * h)

    fd = np.column_stack([central(i, h) for i, h in enumerate(1e-3 * problem.scales)])
    scale = np.abs(fd).max(axis=0)
    np.testing.assert_allclose(exact / scale, fd / scale, atol=2e-5)


def test_displacement_data_give_back_the_tendon_stiffness_and_a_motor_offset():
    """Noise-free rows with tendons 1 to 4 driven by displacement, made from tendons of 2e4 N/m and motors whose
    zero is 0.3 mm off: the fit from 3.5e4 N/m and no offset returns both (and E)."""
    truth = _with(ROBOT, modulus=60e9)
    t = _tensions(12, 14)
    t[:, :4] = np.random.default_rng(13).uniform(0.0, 8.0, (14, 4)) * (np.arange(4) % 2 == np.arange(14)[:, None] % 2)
    pulls, tips = _driven_rows(truth, t, 2e4, offset=0.3e-3)
    data = Measurements.from_arrays(ROBOT, t, tips, displacements=pulls, sigma=0.5e-3)
    result = calibrate(ROBOT, data, ["youngs_modulus", "tendon_stiffness", "displacement_offset"], stiffness=3.5e4,
                       options=CalibrationOptions(loss="linear", folds=0, tolerance=1e-10))
    assert result.converged, result.message
    assert result.rms_before_m > 3e-3 and result.rms_after_m < 1e-5
    np.testing.assert_allclose([result.value("youngs_modulus"), result.value("tendon_stiffness"),
                                result.value("displacement_offset")], [60e9, 2e4, 0.3e-3], rtol=2e-3)


def test_a_file_driving_tendons_by_displacement_reads(tmp_path):
    header = ",".join([f"D{k}_m" for k in range(1, 5)] + [f"T{k}_N" for k in range(5, 9)]
                      + ["tip_x_m", "tip_y_m", "tip_z_m"])
    data = read_measurements(_csv(tmp_path, header, "0.001,0,-0.001,0,0,1,0,0,0.01,0,0.2"), ROBOT)
    assert data.displacements is not None and np.isnan(data.displacements[0, 4:]).all()
    assert data.displacements[0, :4].tolist() == [0.001, 0.0, -0.001, 0.0] and data.tensions[0].tolist()[5] == 1.0
    with pytest.raises(SettingsError, match="column D1_m: tendon 1 has both a tension"):
        read_measurements(_csv(tmp_path, HEADER + ",D1_m", GOOD + ",0.001"), ROBOT)
    with pytest.raises(SettingsError, match=r"tendon_stiffness fits one stiffness .* from a finite"):
        parameters(ROBOT, ["tendon_stiffness"])


def test_an_unmoved_parameter_leaves_the_others_errors_alone():
    """With tendon 8 slack in every row, its routing radius gets no error (inf) and one warning; E keeps the
    error it has when fitted alone."""
    t = _tensions(7, 6)
    t[:, 7] = 0.0
    truth = _with(ROBOT, modulus=60e9)
    noise = np.random.default_rng(3).normal(0.0, 0.5e-3, (6, 3))
    data = Measurements.from_arrays(ROBOT, t, _tips(truth, t) + noise, sigma=0.5e-3)
    options = CalibrationOptions(folds=0, loss="linear")
    alone = calibrate(ROBOT, data, ["youngs_modulus"], options=options)
    both = calibrate(ROBOT, data, ["youngs_modulus", "tendon_radius_8"], options=options)
    assert both.parameters[1].standard_error == np.inf and np.isfinite(both.parameters[0].standard_error)
    assert both.parameters[0].standard_error == pytest.approx(alone.parameters[0].standard_error, rel=0.2)
    assert [w for w in both.warnings if "tendon_radius_8" in w] == [
        "tendon_radius_8: the data do not depend on it at all; fix it or add data that move it"]
    assert both.correlation[0, 0] == pytest.approx(1.0)


def test_a_fit_at_an_upper_bound_and_parameters_that_act_on_nothing(tmp_path):
    """A routing radius just under the given disks' radius differences inward (no invalid robot); a start
    outside the fit's range, a pretension of a displacement-driven tendon and a motor offset of tension-driven
    data are refused naming the parameter; NaN in arrays is refused naming the row."""
    robot = ROBOT.model_validate({**ROBOT.model_dump(), "disk_radius": 0.01 * (1 + 5e-6)})
    t = _tensions(14, 4)
    data = Measurements.from_arrays(robot, t, _tips(robot, t))
    result = calibrate(robot, data, ["tendon_radius"], options=CalibrationOptions(folds=0, max_evaluations=3))
    assert np.isfinite(result.parameters[0].standard_error)
    with pytest.raises(SettingsError, match="displacement_offset acts on tendons driven by displacement"):
        calibrate(ROBOT, data, ["displacement_offset"], options=CalibrationOptions(folds=0))
    pulls, tips = _driven_rows(ROBOT, t, 3.5e4)
    driven = Measurements.from_arrays(ROBOT, t, tips, displacements=pulls)
    with pytest.raises(SettingsError, match="pretension_2 offsets a tension, but the data drive tendon 2"):
        calibrate(ROBOT, driven, ["pretension_2"], stiffness=3.5e4, options=CalibrationOptions(folds=0))
    slippery = ROBOT.model_copy(update={"friction": ROBOT.friction.model_copy(update={"mu0": 2.5})})
    assert calibrate(slippery, Measurements.from_arrays(slippery, t, _tips(slippery, t)), ["friction.mu0"],
                     options=CalibrationOptions(folds=0, max_evaluations=2)).parameters[0].initial == 2.5
    pulls[1, 0] = np.nan
    with pytest.raises(SettingsError, match=r"row 2, column D1_m: nan is not a finite number"):
        Measurements.from_arrays(ROBOT, t, tips, displacements=pulls)
    with pytest.raises(SettingsError, match=r"row 1, column tip_x_m: nan"):
        Measurements.from_arrays(ROBOT, t, np.where(np.arange(3) == 0, np.nan, tips))


def test_a_stopped_calibration_run_resumes_with_its_finished_stages(tmp_path):
    """Ctrl-C after the second of three folds: the folder keeps the fit and two folds; the same call resumes,
    computes only the third fold, and gives exactly the result of a run that was never stopped."""
    from pytdcr.runs import CalibrationSettings, run_calibration

    def read_manifest(folder):
        return json.loads((folder / "manifest.json").read_text())

    truth = _with(ROBOT, modulus=60e9)
    t = _tensions(15, 9)
    data = Measurements.from_arrays(ROBOT, t, _tips(truth, t) + np.random.default_rng(2).normal(0, 5e-4, (9, 3)))
    options = CalibrationOptions(folds=3)

    def stop(line: str) -> None:
        if line.startswith("held-out fold 2"):
            raise KeyboardInterrupt

    out = tmp_path / "run"
    with pytest.raises(BaseException) as err:
        run_calibration(ROBOT, data, CalibrationSettings(("youngs_modulus",), options=options), out, progress=stop)
    assert isinstance(err.value, KeyboardInterrupt) or "interrupt" in type(err.value).__name__.lower()
    assert read_manifest(out)["status"] == "interrupted"
    assert sorted(p.name for p in out.glob("stage_*")) == ["stage_fit.json", "stage_fold_1.json", "stage_fold_2.json"]
    lines: list[str] = []
    settings = CalibrationSettings(("youngs_modulus",), options=options)
    resumed = run_calibration(ROBOT, data, settings, out, progress=lines.append).result
    assert lines == ["held-out fold 1 of 3 (kept)", "held-out fold 2 of 3 (kept)", "held-out fold 3 of 3"]
    fresh = calibrate(ROBOT, data, ["youngs_modulus"], options=options)
    assert resumed.value("youngs_modulus") == fresh.value("youngs_modulus")
    np.testing.assert_array_equal(resumed.cross_validation.errors_m, fresh.cross_validation.errors_m)
    assert read_manifest(out)["status"] == "complete" and (out / "calibration.json").exists()

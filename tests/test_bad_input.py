"""Hostile and careless input: every answer is one line naming the field, the value and what is allowed.

The cases are the ones found by trying the project as a new user would (issue 14), each with what it now answers.
"""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pytdcr import ConstantFriction, Loads, TensionBounds, solve, solve_batch
from pytdcr.cli import main
from pytdcr.io import robot_to_dict
from pytdcr.limits import MEMORY_ENV, ResourceLimitError, memory_budget
from pytdcr.optimize import MemeticGA, ReachProblem, SearchFailed, Termination, maximize_reach
from pytdcr.paper import paper_robot
from pytdcr.workspace.sampling import SamplingConfig, sample_workspace

ZERO8 = "0,0,0,0,0,0,0,0"


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.startswith("tdcr:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def robot_file(tmp_path, name: str, patch) -> str:
    data = copy.deepcopy(robot_to_dict(paper_robot()))
    patch(data)
    path = tmp_path / name
    path.write_text(tomli_w.dumps(data))
    return str(path)


ROBOT_PATCHES = {
    "tiny_segment": (lambda d: d["segments"][0].update(length=1e-300),
                     ["segments.0.length", "1e-300", "[0.001, 10] m"]),
    "bool_modulus": (lambda d: d["backbone"].update(youngs_modulus=True),
                     ["backbone.youngs_modulus", "True", "real number, not bool"]),
    "string_modulus": (lambda d: d["backbone"].update(youngs_modulus="54e9"),
                       ["backbone.youngs_modulus", "'54e9'", "not str"]),
    "string_disks": (lambda d: d["segments"][0].update(n_disks="10"),
                     ["segments.0.n_disks", "'10'", "integer, not str"]),
    "nested_gravity": (lambda d: d.update(gravity=[[0, 0], -9.81]), ["gravity.0", "not list"]),
    "huge_gravity": (lambda d: d.update(gravity=[0, 0, -1e300]), ["gravity", "1e+300", "[0, 100] m/s^2"]),
    "huge_angle": (lambda d: d["tendons"][0].update(angle_deg=1e300),
                   ["tendons.0.angle_deg", "1e+300", "[-360, 360] deg"]),
    "tendon_outside_disk": (lambda d: d.update(disk_radius=0.005),
                            ["tendons.0.radius", "smaller than the disk radius 0.005 m"]),
}


@pytest.mark.parametrize("case", sorted(ROBOT_PATCHES))
def test_bad_robot_files_one_line(capsys, tmp_path, case):
    patch, words = ROBOT_PATCHES[case]
    path = robot_file(tmp_path, f"{case}.toml", patch)
    code, out, err = run(capsys, "solve", "--robot", path, "--tensions", ZERO8)
    line = one_error_line(err)
    assert code == 2 and out == ""
    assert f"{case}.toml" in line
    for w in words:
        assert w in line, line


def test_unreadable_robot_files(capsys, tmp_path):
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"name = \x00\xff\xfe")
    code, _, err = run(capsys, "solve", "--robot", str(binary), "--tensions", "1")
    assert code == 2 and "binary.toml" in one_error_line(err) and "binary" in err
    code, _, err = run(capsys, "solve", "--robot", "/dev/zero", "--tensions", "1")
    assert code == 2 and "/dev/zero" in one_error_line(err) and "not a regular file" in err
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)  # reading it would block for ever
    code, _, err = run(capsys, "solve", "--robot", str(fifo), "--tensions", "1")
    assert code == 2 and "fifo.toml" in one_error_line(err) and "not a regular file" in err
    huge = tmp_path / "huge.toml"
    huge.write_text("# " + "x" * 1_100_000)
    code, _, err = run(capsys, "solve", "--robot", str(huge), "--tensions", "1")
    assert code == 2 and "larger than 1,000,000 bytes" in one_error_line(err)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["solve", "--tensions", "1,,2,0,0,0,0,0,0"], ["--tensions", "value 2 of 9 is empty"]),
        (["solve", "--tensions", "1_0,0,0,0,0,0,0,0"], ["--tensions", "not a number", "'1_0'"]),
        (["solve", "--tensions", "-inf,0,0,0,0,0,0,0"], ["--tensions", "'-inf'", "finite"]),
        (["solve", "--tensions", "True,0,0,0,0,0,0,0"], ["--tensions", "not a number"]),
        (["solve", "--tensions", "1,0,0,0,0,0,0,0", "--atol", "1e300"], ["--atol", "[1e-14, 0.0001] N m"]),
        (["solve", "--tensions", "1,0,0,0,0,0,0,0", "--atol", "1e-300"], ["--atol", "[1e-14, 0.0001] N m"]),
        (["accuracy", "--disks", "5,10,20000"], ["--disks", "per_segment", "[1, 10,000]", "20000"]),
        (["accuracy", "--disks", "5,5"], ["--disks", "two or more different"]),
        (["accuracy", "--reference-steps", "99999999999"], ["--reference-steps", "more than 1000"]),
        (["solve", "--tensions", "1,0,0,0,0,0,0,0", "--friction", "1e400"], ["--friction", "finite"]),
        (["solve", "--tensions", "1,0,0,0,0,0,0,0", "--tip-force", "0,0,1e7"], ["--tip-force", "1e+06"]),
        (["solve", "--tensions", "2e4,0,0,0,0,0,0,0"], ["tendon 1", "10000"]),
        (["solve", "--tensions", "1,0,0,\x1b[31m,0"], ["\\x1b[31m"]),
        (["sample", "--seed", "-1"], ["--seed", "[0, 4294967295]", "'-1'"]),
        (["sample", "--n", "0"], ["--n = 0: must be an integer >= 1"]),
        (["sample", "--n", "1e3"], ["--n", "integer"]),
        (["optimize", "--pop", "1"], ["--pop = 1: must be an integer >= 2"]),
    ],
)
def test_bad_arguments_one_line(capsys, args, words):
    code, out, err = run(capsys, *args)
    line = one_error_line(err)
    assert code == 2 and out == ""
    assert "\x1b" not in err  # control characters are escaped, never echoed
    for w in words:
        assert w in line, line


def test_long_arguments_are_shortened(capsys):
    code, _, err = run(capsys, "solve", "--tensions", "x" * 100_000)
    line = one_error_line(err)
    assert code == 2 and len(line) < 700


def test_bad_case_files(capsys, tmp_path):
    typo = tmp_path / "typo.csv"
    typo.write_text("1,0,0,0,0,0,0,O\n1,0,0,0,0,0,0,0\n")  # a letter O for a zero: not a header
    code, _, err = run(capsys, "compare", "--cases", str(typo), "--out", str(tmp_path / "a"))
    assert code == 2 and "line 1: value 8 is not a number: 'O'" in one_error_line(err)
    semi = tmp_path / "semi.csv"
    semi.write_text("1;0;0;0;0;0;0;0\n")
    code, _, err = run(capsys, "compare", "--cases", str(semi), "--out", str(tmp_path / "b"))
    assert code == 2 and "separated by commas, found ';'" in one_error_line(err)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_output_paths_refused_before_any_work(capsys, tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    for cmd in ("sample", "optimize", "reproduce", "compare", "accuracy"):
        code, out, err = run(capsys, cmd, "--out", str(afile))
        assert code == 2 and out == "" and "is a file, not a folder" in one_error_line(err)
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "thesis.tex").write_text("precious")
    code, _, err = run(capsys, "sample", "--n", "2", "--out", str(tmp_path / "notes"))
    assert code == 2 and "not part of a tdcr run ('thesis.tex')" in one_error_line(err)
    assert (tmp_path / "notes" / "thesis.tex").read_text() == "precious"
    code, _, err = run(capsys, "solve", "--tensions", ZERO8, "--plot", str(tmp_path))
    assert code == 2 and "is a folder" in one_error_line(err)
    code, _, err = run(capsys, "robot", "--out", str(tmp_path))
    assert code == 2 and "is a folder" in one_error_line(err)
    code, _, err = run(capsys, "robot", "--out", str(tmp_path / "missing" / "r.toml"))
    assert code == 2 and "does not exist" in one_error_line(err)
    assert not (tmp_path / "missing").exists()


def test_memory_budget_refuses_with_the_estimate(capsys, tmp_path, monkeypatch):
    big = paper_robot().with_disks(5000)  # 10,000 disks: a dense 30,000^2 Jacobian
    with pytest.raises(ResourceLimitError, match=r"10000 disks.*needs about 36\.\d GB.*30,000 unknowns"):
        solve(big, Loads(np.zeros(8)))
    path = tmp_path / "big.toml"
    path.write_text(tomli_w.dumps(robot_to_dict(big)))
    code, _, err = run(capsys, "solve", "--robot", str(path), "--tensions", ZERO8)
    assert code == 2 and "memory budget" in one_error_line(err) and MEMORY_ENV in err
    code, _, err = run(capsys, "sample", "--n", "999999999999", "--out", str(tmp_path / "s"))
    assert code == 2 and "999,999,999,999 tension vectors" in one_error_line(err)
    code, _, err = run(capsys, "optimize", "--pop", "999999999999")
    assert code == 2 and "population of 999,999,999,999" in one_error_line(err)
    # the budget is a setting
    monkeypatch.setenv(MEMORY_ENV, "0.001")
    assert memory_budget() == pytest.approx(1e6)
    with pytest.raises(ResourceLimitError, match="1 MB"):
        solve(paper_robot().with_disks(200), Loads(np.zeros(8)))
    monkeypatch.setenv(MEMORY_ENV, "lots")
    with pytest.raises(ValueError, match=f"{MEMORY_ENV}='lots': must be a positive number"):
        memory_budget()


def test_api_misuse_says_what_was_expected(paper):
    with pytest.raises(TypeError, match=r"loads must be a pytdcr\.Loads"):
        solve(paper, None)
    with pytest.raises(TypeError, match=r"loads must be a pytdcr\.Loads"):
        solve(paper, np.zeros(8))
    with pytest.raises(TypeError, match=r"robot must be a pytdcr\.Robot"):
        solve(None, Loads(np.zeros(8)))
    with pytest.raises(TypeError, match=r"bounds must be a pytdcr\.TensionBounds"):
        sample_workspace(paper, Loads(np.zeros(8)), (0, 20), 5)
    bounds = TensionBounds.uniform(8, 0, 20)
    with pytest.raises(ValueError, match=r"block = 0: must be an integer >= 1"):
        sample_workspace(paper, Loads(np.zeros(8)), bounds, 5, config=SamplingConfig(block=0))
    with pytest.raises(TypeError, match=r"n must be an integer, got 5\.0"):
        sample_workspace(paper, Loads(np.zeros(8)), bounds, 5.0)
    with pytest.raises(ValueError, match=r"tensions must have shape \(B, 8\)"):
        solve_batch(paper, np.zeros(8))
    with pytest.raises(ValueError, match=r"q0 must have shape \(20, 3\)"):
        solve(paper, Loads(np.zeros(8)), q0=np.zeros(7))
    no_friction = paper.with_friction(ConstantFriction(mu=0.0))
    with pytest.raises(ValueError, match="q0 must be 3 finite numbers"):
        solve(no_friction, Loads(np.zeros(8)), model="cosserat", q0=np.zeros(5))
    with pytest.raises(TypeError, match=r"tensions must be real numbers, got \[True"):
        Loads([True, 0, 0, 0, 0, 0, 0, 0])
    with pytest.raises(TypeError, match="tensions must be real numbers"):
        Loads(np.array([1 + 1j, 0, 0, 0, 0, 0, 0, 0]))


def test_constant_friction_of_zero_is_no_friction(paper):
    """mu = 0 is no friction: the friction-free models take it and it equals the 'none' law."""
    mu0 = paper.with_friction(ConstantFriction(mu=0.0))
    loads = Loads(np.array([3.0, 0, 0, 0, 2, 0, 0, 0]))
    sol = solve(mu0, loads, model="cosserat")
    assert sol.converged
    from pytdcr import NoFriction

    ref = solve(paper.with_friction(NoFriction()), loads, model="cosserat")
    assert np.array_equal(sol.tip_position, ref.tip_position)


def test_nothing_converged_is_exit_1_with_the_count(capsys, tmp_path):
    crush = ["--tip-force", "1000,0,-1000", "--tip-moment", "50,0,0"]
    code, out, err = run(capsys, "sample", "--n", "3", *crush, "--out", str(tmp_path / "s"))
    assert code == 1 and "0 converged, 3 not" in out and "none of the 3 samples converged" in err
    rows = (tmp_path / "s" / "samples.csv").read_text().splitlines()
    head = rows[0].split(",")
    for row in rows[1:]:  # no tip, reach or stability where none was computed; the tensions and residual stay
        cells = dict(zip(head, row.split(","), strict=True))
        assert [cells[k] for k in ("tip_x_m", "tip_y_m", "tip_z_m", "reach_m", "stable")] == [""] * 5
        assert cells["converged"] == "0" and float(cells["residual_Nm"]) > 0 and cells["T1_N"]
    code, out, err = run(capsys, "compare", "--n", "2", "--models", "pcc,pcc2", *crush, "--out", str(tmp_path / "c"))
    assert code == 1 and "no case converged for every model" in err and "median n/a" in out
    code, out, err = run(capsys, "optimize", "--pop", "4", "--max-gen", "2", *crush)
    assert code == 1 and out == "" and "no tension vector within the bounds gave a converged" in one_error_line(err)
    assert "8 tried" in err and "Warning" not in err


def test_search_failure_is_its_own_error(paper):
    problem = ReachProblem.create(paper, Loads(np.zeros(8), tip_force=[1000, 0, -1000], tip_moment=[50, 0, 0]),
                                  TensionBounds.uniform(8, 0.0, 20.0))
    with pytest.raises(SearchFailed, match="no tension vector"):
        maximize_reach(problem, MemeticGA(pop_size=4), Termination(max_gen=2))


@pytest.mark.parametrize("model", ["cosserat", "sscr"])
def test_rod_crushed_beyond_its_axial_stiffness_does_not_converge(paper, model):
    """With extension the rod law allows an axial strain down to -1; past it the rod would pass through itself.

    The tip is pushed along the backbone with twice EA: no equilibrium, reported as such (before: "converged"
    with the tip below the base).
    """
    from pytdcr import NoFriction
    from pytdcr.statics import get_model

    robot = paper.with_friction(NoFriction()).with_gravity(None)
    bb = robot.backbone
    ea = bb.youngs_modulus * np.pi * (bb.outer_radius**2 - bb.inner_radius**2)
    opts = get_model(model).options_type(shear_extension=True)
    ok = solve(robot, Loads(np.zeros(8), tip_force=[0, 0, -0.5 * ea]), model=model, options=opts)
    if ok.converged:  # half of EA: a legal (if absurd) strain of -1/2, the rod at half its length
        assert ok.tip_position[2] == pytest.approx(0.5 * robot.length, rel=1e-3)
    crushed = solve(robot, Loads(np.zeros(8), tip_force=[0, 0, -2.0 * ea]), model=model, options=opts)
    assert not crushed.converged
    data = json.loads(json.dumps(crushed.to_dict()))
    assert data["tip_position"] is None and data["q"] is None and data["tensions"] is None


def test_a_batch_row_not_converged_carries_no_unknowns(paper):
    """solve_batch: a row that did not converge has NaN unknowns, tip and disks (no last iterate read as an
    equilibrium); the converged rows are untouched and warm-start a new batch."""
    loads = Loads(np.zeros(8), tip_force=[1000, 0, -1000], tip_moment=[50, 0, 0])
    T = np.array([[0.0] * 8, [19.2, 14.5, 10.8, 5.5, 3.2, 19.4, 10.3, 2.3]])
    free = solve_batch(paper, T, Loads(np.zeros(8)))
    crushed = solve_batch(paper, T, loads)
    assert free.converged.all() and not crushed.converged.any()
    assert np.all(np.isfinite(free.q))
    for field in ("q", "tip_position", "disk_positions", "disk_rotations"):
        assert np.isnan(getattr(crushed, field)).all(), field
    assert np.all(crushed.residual > 0) and np.all(crushed.iterations > 0)
    assert np.isnan(crushed.rows(np.array([1])).q).all()
    again = solve_batch(paper, T, Loads(np.zeros(8)), q0=free.q)
    assert np.allclose(again.tip_position, free.tip_position, atol=1e-9)


#: a design study to name with --workers
STUDY = Path(__file__).resolve().parents[1] / "examples" / "design_study_small.toml"

# every count option states its range as one fact, whichever bad value is given (the settings check it, the
# command line only reads the integer)
COUNT_RANGES = [
    (["optimize"], "--pop", ["1", "0", "-1"], "must be an integer >= 2"),
    (["optimize"], "--window", ["0", "-2"], "must be an integer >= 1"),
    (["optimize"], "--max-gen", ["0", "-2"], "must be an integer >= 1"),
    (["sample"], "--n", ["0", "-3"], "must be an integer >= 1"),
    (["compare"], "--n", ["0", "-3"], "must be an integer >= 1"),
    (["accuracy"], "--n", ["0", "-3"], "must be an integer >= 1"),
    (["accuracy"], "--order-cases", ["-1", "-7"], "must be an integer >= 0"),
    (["accuracy"], "--reference-steps", ["15", "0"], "must be an integer >= 16"),
    (["workspace"], "--n", ["0", "-1"], "must be an integer >= 1"),
    (["workspace"], "--budget", ["-1", "-9"], "must be an integer >= 0"),
    (["workspace"], "--directions", ["-1", "100001"], "must be an integer in [0, 100,000]"),
    (["designs", str(STUDY)], "--workers", ["0", "100000"], "must be an integer in [1, 4,096]"),
]


@pytest.mark.parametrize(("command", "option", "values", "words"), COUNT_RANGES,
                         ids=[f"{c[0]} {o}" for c, o, _, _ in COUNT_RANGES])
def test_a_count_states_its_range_alike_for_every_bad_value(capsys, tmp_path, command, option, values, words):
    for value in values:
        code, out, err = run(capsys, *command, option, value, "--out", str(tmp_path / "out"))
        assert code == 2 and out == ""
        assert one_error_line(err) == f"tdcr: error: {option} = {value}: {words}"
    code, _, err = run(capsys, *command, option, "2.5", "--out", str(tmp_path / "out"))
    assert code == 2 and f"argument {option}: must be an integer, got '2.5'" in one_error_line(err)
    code, _, err = run(capsys, *command, option, "9" * 19, "--out", str(tmp_path / "out"))
    assert code == 2 and "must be an integer of at most 18 digits" in one_error_line(err)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", [["sample", "--n", "3"], ["optimize"], ["workspace", "--n", "10"],
                                     ["compare", "--n", "2"], ["accuracy", "--n", "2"],
                                     ["sample", "--bounds", "0,1"], ["optimize", "--bounds", "2,3"]])
def test_a_robot_without_tendons_is_refused_by_its_option(capsys, tmp_path, command):
    """The robot is what is wrong, whatever other option is given (before: '--bounds: n_tendons = 0' for a run
    without --bounds)."""
    path = robot_file(tmp_path, "bare.toml", lambda d: d.update(name="bare", tendons=[]))
    code, out, err = run(capsys, *command, "--robot", path, "--out", str(tmp_path / "out"))
    line = one_error_line(err)
    assert code == 2 and out == "" and not (tmp_path / "out").exists()
    assert line == "tdcr: error: --robot: robot 'bare' has no tendons; a run over tension bounds needs at least one"
    code, _, err = run(capsys, "solve", "--robot", path, "--tensions", "0")
    assert code == 2 and one_error_line(err) == ("tdcr: error: --robot: robot 'bare' has no tendons, so it takes no "
                                                 "tensions (got 1)")


#: bad input whose message came (or could come) from a layer below the settings, named by a field
NAMED_BY_OPTION = [
    (["optimize", "--bounds", "3,3"], "--bounds: every tension is fixed (lower == upper); nothing to optimise"),
    (["workspace", "--bounds", "2,2"], "--bounds: every tension is fixed (lower == upper); there is no workspace"),
    (["optimize", "--bounds-file", "@FIXED"], "--bounds-file '"),
    (["workspace", "--bounds-file", "@FIXED"], "--bounds-file '"),
    (["sample", "--bounds", "5,1"], "--bounds: tendon 1 has lower 5.0 > upper 1.0 N"),
    (["solve", "--tensions", ZERO8, "--tip-force", "0,0,1e7"], "--tip-force must be within +/-1e+06"),
    (["sample", "--tip-moment", "0,1e7,0"], "--tip-moment must be within +/-1e+06"),
    (["solve", "--tensions", ZERO8, "--atol", "1"], "--atol must be in [1e-14, 0.0001] N m"),
    (["optimize", "--stable-only", "--model", "cosserat", "--friction", "none"],
     "--stable-only: model 'cosserat' has no static stability test"),
    (["robot", "--out", "@TMP"], "--out '"),
]


@pytest.mark.parametrize(("args", "start"), NAMED_BY_OPTION, ids=[" ".join(a[:3]) for a, _ in NAMED_BY_OPTION])
def test_every_message_names_its_option_as_typed(capsys, tmp_path, args, start):
    from pytdcr.cli._args import FLAGS

    fixed = tmp_path / "fixed.toml"
    fixed.write_text("lower = [3, 3, 3, 3, 3, 3, 3, 3]\nupper = [3, 3, 3, 3, 3, 3, 3, 3]\n")
    args = [str(fixed) if a == "@FIXED" else str(tmp_path) if a == "@TMP" else a for a in args]
    out = [] if args[0] in ("solve", "robot") else ["--out", str(tmp_path / "out")]
    code, _, err = run(capsys, *args, *out)
    line = one_error_line(err).removeprefix("tdcr: error: ")
    assert code == 2 and line.startswith(start), line
    for name in FLAGS:  # no setting by its Python name where an option was typed
        assert not line.startswith((f"{name}:", f"{name} ", f"{name}=")), line
    assert not (tmp_path / "out").exists()

"""Bad input of the kinds a hostile user tries (issue 25): each refused with one line and exit 2, never an internal
error, and tried on several members of its class."""

from __future__ import annotations

import pytest

from pytdcr.cli import main
from pytdcr.io import MAX_NESTING


def _deep_array(depth: int) -> str:
    return "[" * depth + "1" + "]" * depth


def _deep_table(depth: int) -> str:
    return "{a = " * depth + "1" + "}" * depth


@pytest.mark.parametrize("depth", [MAX_NESTING + 1, 500, 5000])
@pytest.mark.parametrize("shape", [_deep_array, _deep_table])
def test_deeply_nested_files_are_bad_input(tmp_path, capsys, depth, shape):
    robot = tmp_path / "robot.toml"
    robot.write_text(f'name = "x"\ndeep = {shape(depth)}\n')
    bounds = tmp_path / "bounds.toml"
    bounds.write_text(f"lower = {shape(depth)}\nupper = [1]\n")
    study = tmp_path / "study.toml"
    study.write_text(f'[base]\nrobot = "paper"\nseed = {shape(depth)}\n')
    for args in (["robot", "--robot", str(robot)], ["sample", "--n", "2", "--bounds-file", str(bounds), "--out",
                                                    str(tmp_path / "o")], ["designs", str(study), "--out",
                                                                           str(tmp_path / "d")]):
        capsys.readouterr()
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"deeper than {MAX_NESTING} levels" in err, (args, err)


def test_nesting_within_the_limit_reaches_the_usual_checks(tmp_path, capsys):
    bounds = tmp_path / "bounds.toml"
    bounds.write_text(f"lower = {_deep_array(MAX_NESTING - 1)}\nupper = [1]\n")
    assert main(["sample", "--n", "2", "--bounds-file", str(bounds), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "deeper than" not in err and "--bounds-file" in err


@pytest.mark.parametrize(("value", "shown"), [(10000.000001, "10000.000001"), (10000.0000000001, "10000.0000000001"),
                                              (10000.5, "10000.5"), (-1e-300, "-1e-300")])
def test_a_value_just_past_a_limit_is_never_shown_as_the_limit(value, shown, capsys):
    import numpy as np

    from pytdcr.loads import check_tensions

    with pytest.raises(ValueError, match=rf"got {shown}$"):
        check_tensions(np.array([value, 0, 0, 0, 0, 0, 0, 0]), 8)
    assert main(["solve", "--tensions", f"{value!r},0,0,0,0,0,0,0"]) == 2
    assert capsys.readouterr().err.rstrip().endswith(f"got {shown}")


@pytest.mark.parametrize("atol", [1.00000001e-4, 9.9999999e-15])
def test_a_tolerance_just_past_its_range_is_shown_with_its_digits(atol):
    from pytdcr import SolverOptions

    with pytest.raises(ValueError, match=rf"got {atol!r}$"):
        SolverOptions(atol=atol)

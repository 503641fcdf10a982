"""Issue 44, class 4: every case's requirements are checked against its model's capabilities before the first
solve (exit 2, one line naming the flag, the case and the capability), and a case that fails while running
leaves the finished cases' files and comparison in place (exit 1)."""

from __future__ import annotations

import json
import traceback

import numpy as np
import pytest

import pytdcr.runs._workspace as workspace_module
import pytdcr.workspace._estimate as estimate_module
import pytdcr.workspace._solve as solve_module
from pytdcr import Loads, NoFriction, NotConvergedError, paper_robot
from pytdcr.cli import main
from pytdcr.runs import ReproduceSettings, check_reproduce
from pytdcr.validate import SettingsError
from pytdcr.workspace import WorkspaceSettings

#: the smallest workspace run: a handful of samples, no search, no h(d), big voxels
TINY = ["--n", "4", "--no-search", "--directions", "0", "--voxel", "0.1"]


@pytest.fixture
def no_solve(monkeypatch):
    """Any solve of a workspace study (or of its time estimate) fails the test."""
    def refuse(*_a, **_k):
        raise AssertionError("a solve ran before the capability check")

    monkeypatch.setattr(solve_module, "solve_batch", refuse)
    monkeypatch.setattr(estimate_module, "solve", refuse)


def _error(capsys) -> list[str]:
    return [line for line in capsys.readouterr().err.splitlines() if line.startswith("tdcr: error")]


def test_compare_models_refused_before_any_solve(tmp_path, capsys, no_solve):
    """The issue's example: cosserat cannot continue a solved state, which the multistability check of its
    loading-path region needs; today pcc's case was solved first and everything lost."""
    out = tmp_path / "w"
    code = main(["workspace", "--compare-models", "pcc,cosserat", "--friction", "none", *TINY, "--out", str(out)])
    lines = _error(capsys)
    assert code == 2
    assert len(lines) == 1
    assert "--compare-models" in lines[0] and "case 'cosserat'" in lines[0]
    assert "continuation from a solved state" in lines[0] and "--multistability 0" in lines[0]
    assert not out.exists()


def test_compare_models_friction_refused_naming_the_case(tmp_path, capsys, no_solve):
    """The robot's friction law, which cosserat does not model, is named with the flag and the case."""
    out = tmp_path / "w"
    code = main(["workspace", "--compare-models", "pcc,cosserat", *TINY, "--out", str(out)])
    lines = _error(capsys)
    assert code == 2 and len(lines) == 1
    assert "--compare-models" in lines[0] and "case 'cosserat'" in lines[0] and "tendon friction" in lines[0]
    assert not out.exists()


def test_single_workspace_refused_before_any_solve(tmp_path, capsys, no_solve):
    """One case too: the multistability check a model cannot run is refused before the sampling."""
    out = tmp_path / "w"
    code = main(["workspace", "--model", "cosserat", "--friction", "none", *TINY, "--out", str(out)])
    lines = _error(capsys)
    assert code == 2 and len(lines) == 1 and "cosserat" in lines[0] and "--multistability 0" in lines[0]
    assert not out.exists()


def test_single_workspace_names_the_setting_at_fault(tmp_path, capsys, no_solve):
    """The refusal names the flag of the setting at fault, found by the check itself, not by the message's
    words: cosserat's loading-path region is fine, its multistability check is not (it was labelled --model)."""
    out = tmp_path / "w"
    code = main(["workspace", "--model", "cosserat", "--friction", "none", "--n", "8", "--no-search",
                 "--directions", "0", "--voxel", "0.1", "--out", str(out)])
    lines = _error(capsys)
    assert code == 2 and len(lines) == 1
    assert lines[0].startswith("tdcr: error: --multistability: model 'cosserat' does not support continuation")
    assert not out.exists()


def test_the_check_s_errors_name_the_setting_at_fault():
    """model: the model cannot take the robot (friction) whatever the settings; equilibria: continuation asked
    of a model that cannot continue; multistability: the loading-path region's check. Each error carries the
    setting it is about (``SettingsError.field``, ``UnsupportedFeatureError.setting``), never read from its words."""
    from pytdcr.workspace import check_workspace

    robot = paper_robot()  # exponential friction
    free = robot.with_friction(NoFriction())
    loads = Loads(np.zeros(robot.n_tendons))
    s = WorkspaceSettings(n=8, search=False, directions=0, voxel=0.1)
    cont = WorkspaceSettings(n=8, search=False, directions=0, voxel=0.1, equilibria="continuation")
    for rob, settings, want in ((robot, s, "model"), (free, cont, "equilibria"), (free, s, "multistability")):
        with pytest.raises(ValueError) as info:
            check_workspace(rob, loads, settings, model="cosserat")
        assert (getattr(info.value, "field", None) or getattr(info.value, "setting", None)) == want


def test_design_study_refused_before_any_design(tmp_path, capsys, monkeypatch):
    """A design study whose model cannot solve its base robot's load cases is refused when it is read, naming
    the model and the load case; no design is evaluated and no folder made."""
    import pytdcr.designs._evaluate as evaluate_module

    def refuse(*_a, **_k):
        raise AssertionError("a design was evaluated")

    monkeypatch.setattr(evaluate_module, "workspace_study", refuse)
    monkeypatch.setattr(evaluate_module, "workspace_estimate", refuse)
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "examples" / "design_study_small.toml").read_text()
    study = tmp_path / "study.toml"
    study.write_text(text.replace('model = "pcc"', 'model = "cosserat"'))
    out = tmp_path / "d"
    code = main(["designs", str(study), "--workers", "1", "--out", str(out)])
    lines = _error(capsys)
    assert code == 2 and len(lines) == 1
    assert "model = 'cosserat'" in lines[0] and "load case 'paper wrench'" in lines[0] and "friction" in lines[0]
    assert not out.exists()


def test_reproduce_checks_its_models_first():
    """tdcr reproduce's better models and workspace models are checked before its output folder is made."""
    robot = paper_robot()  # exponential friction
    with pytest.raises(SettingsError, match=r"verdict_models.*cosserat.*friction"):
        check_reproduce(robot, ReproduceSettings(verdict_models=("cosserat",)))
    with pytest.raises(SettingsError, match=r"workspace_models.*case 'cosserat'.*friction"):
        check_reproduce(robot, ReproduceSettings(workspace_models=("pcc", "cosserat")))
    check_reproduce(robot, ReproduceSettings())  # the defaults pass


def test_a_case_failing_while_running_keeps_the_others(tmp_path, capsys, monkeypatch):
    """A case that fails while running (a solver's error) is reported and exits 1; the finished case's files
    and the comparison of what finished are kept, and the manifest is complete."""
    real = workspace_module._case

    def flaky(name, *args, **kw):
        if name == "pcc2":
            raise NotConvergedError("the solver gave up")
        return real(name, *args, **kw)

    monkeypatch.setattr(workspace_module, "_case", flaky)
    out = tmp_path / "w"
    code = main(["workspace", "--compare-models", "pcc,pcc2", *TINY, "--multistability", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    assert "pcc2: failed while running" in err and "the solver gave up" in err
    assert (out / "pcc" / "workspace.json").is_file() and (out / "pcc" / "report.md").is_file()
    comparison = json.loads((out / "comparison.json").read_text())
    assert [c["case"] for c in comparison["cases"]] == ["pcc"]
    assert [f["case"] for f in comparison["failed"]] == ["pcc2"]
    assert "the solver gave up" in (out / "comparison.md").read_text()
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    assert not (out / "pcc2").exists()  # nothing of it was saved: no half-written folder


def _bug_in(monkeypatch, bad_case: str, err: Exception) -> None:
    """``_case`` raises ``err`` (a bug's exception, not a failure found while running) for ``bad_case``."""
    real = workspace_module._case

    def buggy(name, *args, **kw):
        if name == bad_case:
            raise err
        return real(name, *args, **kw)

    monkeypatch.setattr(workspace_module, "_case", buggy)


COMPARE_LOADS = ["workspace", "--compare-loads", *TINY, "--multistability", "0"]


def _kept(out) -> dict:
    """The finished first case kept whole, the bug's case and those after it listed as failed."""
    assert (out / "no_load" / "workspace.json").is_file() and (out / "no_load" / "report.md").is_file()
    comparison = json.loads((out / "comparison.json").read_text())
    assert [c["case"] for c in comparison["cases"]] == ["no load"]
    failed = {f["case"]: f["error"] for f in comparison["failed"]}
    assert "internal error" in failed["gravity only"] and "paper wrench" in failed
    assert all(v.startswith("not run") for k, v in failed.items() if k not in ("no load", "gravity only"))
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    return failed


def test_a_bug_in_a_case_is_an_internal_error_and_keeps_what_finished(tmp_path, capsys, monkeypatch):
    """A bug (here an AttributeError) is not 'failed while running' (exit 1): the cases finished before it are
    saved with their comparison, the rest are not run, and the command line says internal error (exit 70)."""
    monkeypatch.delenv("PYTDCR_DEBUG", raising=False)
    _bug_in(monkeypatch, "gravity only", AttributeError("'NoneType' object has no attribute 'q'"))
    out = tmp_path / "w"
    code = main([*COMPARE_LOADS, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 70
    assert "tdcr: internal error: AttributeError: 'NoneType' object has no attribute 'q'" in err
    assert "failed while running" not in err
    assert "AttributeError" in _kept(out)["gravity only"]


def test_a_type_error_in_a_case_propagates_with_its_traceback(tmp_path, capsys, monkeypatch):
    """A TypeError from a bug propagates too (it was caught as a failed case, exit 1, no traceback): with
    PYTDCR_DEBUG=1 its traceback reaches the user, from the frame that raised it, and what finished is kept.
    (Without PYTDCR_DEBUG the command line words a TypeError as bad input, exit 2: cli/_runtime.py's rule.)"""
    _bug_in(monkeypatch, "gravity only", TypeError("unsupported operand type(s) for +: 'int' and 'str'"))
    monkeypatch.setenv("PYTDCR_DEBUG", "1")
    out = tmp_path / "w"
    with pytest.raises(TypeError, match="unsupported operand") as info:
        main([*COMPARE_LOADS, "--out", str(out)])
    assert "in buggy" in "".join(traceback.format_exception(info.value))
    assert "TypeError" in _kept(out)["gravity only"]
    monkeypatch.delenv("PYTDCR_DEBUG")
    again = tmp_path / "w2"
    code = main([*COMPARE_LOADS, "--out", str(again)])
    assert code in (2, 70) and "failed while running" not in capsys.readouterr().err
    _kept(again)


@pytest.mark.parametrize("err", [MemoryError(), FloatingPointError("overflow in exp"),
                                 OSError(28, "No space left on device")])
def test_failures_a_user_can_act_on_keep_the_others(tmp_path, capsys, monkeypatch, err):
    """Memory, a numerical failure and a file not written are failures found while running: reported, exit 1,
    the other cases run and are compared."""
    _bug_in(monkeypatch, "pcc", err)
    out = tmp_path / "w"
    code = main(["workspace", "--compare-models", "pcc,pcc2", *TINY, "--multistability", "0", "--out", str(out)])
    assert code == 1
    assert "pcc: failed while running" in capsys.readouterr().err
    comparison = json.loads((out / "comparison.json").read_text())
    assert [c["case"] for c in comparison["cases"]] == ["pcc2"]
    assert [f["case"] for f in comparison["failed"]] == ["pcc"]
    assert (out / "pcc2" / "workspace.json").is_file() and not (out / "pcc").exists()

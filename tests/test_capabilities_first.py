"""Issue 44, class 4: every case's requirements are checked against its model's capabilities before the first
solve (exit 2, one line naming the flag, the case and the capability), and a case that fails while running
leaves the finished cases' files and comparison in place (exit 1)."""

from __future__ import annotations

import json

import pytest

import pytdcr.region._estimate as estimate_module
import pytdcr.region._solve as solve_module
import pytdcr.study._workspace as workspace_module
from pytdcr import paper_robot
from pytdcr.cli import main
from pytdcr.study import ReproduceSettings, check_reproduce
from pytdcr.validate import SettingsError

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
            raise RuntimeError("the solver gave up")
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

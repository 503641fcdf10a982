"""Issue 44, class 5: a sample's stability is stable, unstable or untested, and nothing claims a test that was not
run: for a model without the static stability test every count, table, text and file says "untested", never
"stable" or "0 unstable"; a model with the test still says stable, with the same counts as before."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pytdcr.cli import main
from pytdcr.designs import MEASURES, measures_for
from pytdcr.statics import feasible_words, stability_counts, stability_test, stability_words
from pytdcr.workspace import Multistability

TINY = ["--n", "4", "--no-search", "--directions", "0", "--voxel", "0.1", "--multistability", "0"]


def test_the_words_and_counts_come_from_the_model():
    assert stability_test("pcc") == "run" and stability_test("cosserat") == "untested"
    assert stability_test("sscr") == "run"
    ok = np.array([True, True, True, False])
    st = np.array([1.0, 0.0, np.nan, np.nan])
    assert stability_counts(ok, st) == {"stable": 1, "unstable": 1, "untested": 1}
    assert stability_counts(ok, np.full(4, np.nan), "untested") == {"stable": None, "unstable": None, "untested": 3}
    assert feasible_words("run") == "converged, stable"
    assert "untested" in feasible_words("untested") and "stable," not in feasible_words("untested")
    assert stability_words({"unstable": 0, "stability_untested": 0}, "run") == "0 unstable"
    words = stability_words({"unstable": None, "stability_untested": 5}, "untested")
    assert "untested" in words and "unstable" not in words
    with pytest.raises(ValueError, match="stability_test"):
        feasible_words("maybe")


def test_multistability_claims_no_unstable_count_untested():
    no = np.zeros(2, dtype=bool)
    ms = Multistability("continuation", "loading path from rest", np.arange(2), np.zeros((2, 3)), ~no, ~no, no,
                        0.0, tested=False)
    assert ms.to_dict()["distinct_unstable"] is None
    assert Multistability("continuation", "x", np.arange(2), np.zeros((2, 3)), ~no, ~no, no, 0.0
                          ).to_dict()["distinct_unstable"] == 0


def test_design_measures_say_untested():
    assert measures_for("pcc") == MEASURES
    assert "untested" in measures_for("cosserat")["volume_m3"]
    assert "stable equilibria" not in measures_for("cosserat")["volume_m3"]


def _run(tmp_path, capsys, *args):
    out = tmp_path / "w"
    code = main(["workspace", *args, *TINY, "--out", str(out)])
    text = capsys.readouterr()
    return code, out, text.out, text.err


def test_untested_workspace_says_untested(tmp_path, capsys):
    """cosserat has no stability test: the JSON records it and its counts, the report and the printout say
    untested, and nothing says stable or 0 unstable."""
    code, out, stdout, stderr = _run(tmp_path, capsys, "--model", "cosserat", "--friction", "none")
    assert code in (0, 1), stderr
    ws = json.loads((out / "workspace.json").read_text())
    c = ws["counts"]
    assert ws["stability_test"] == "untested"
    assert c["stable"] is None and c["unstable"] is None and c["stability_untested"] == c["converged"] > 0
    assert ws["root"] != "stable"
    report = (out / "report.md").read_text()
    assert "converged, stable" not in report and "0 unstable" not in report
    assert "FSW (converged, stability untested)" in report and "Stability untested" in report
    assert "0 unstable" not in stdout and "stability untested" in stdout
    assert "stable sample" not in stderr
    z = np.load(out / "samples.npz")
    assert np.all(np.isnan(z["stable"]))


def test_tested_workspace_still_says_stable(tmp_path, capsys):
    """pcc tests stability: the same words and counts as before, and the new keys agree with them."""
    code, out, stdout, _ = _run(tmp_path, capsys)
    assert code in (0, 1)
    ws = json.loads((out / "workspace.json").read_text())
    c = ws["counts"]
    z = np.load(out / "samples.npz")
    assert ws["stability_test"] == "run" and ws["root"] == "stable"
    assert c["unstable"] == int(np.sum(z["stable"] == 0.0))
    assert c["stable"] == int(np.sum(z["converged"] & (z["stable"] == 1.0)))
    assert c["stable"] + c["unstable"] + c["stability_untested"] == c["converged"]
    assert "FSW (converged, stable)" in (out / "report.md").read_text()
    assert f"{c['unstable']} unstable" in stdout


def test_sample_run_records_untested(tmp_path):
    """tdcr sample under a model without the test: sample_run.json says untested, not 0 unstable."""
    out = tmp_path / "s"
    assert main(["sample", "--n", "3", "--seed", "1", "--model", "cosserat", "--friction", "none", "--out",
                 str(out)]) == 0
    rec = json.loads((out / "sample_run.json").read_text())
    assert rec["stability_test"] == "untested" and rec["unstable"] is None
    assert rec["stability_untested"] == rec["converged"]
    out = tmp_path / "p"
    assert main(["sample", "--n", "3", "--seed", "1", "--out", str(out)]) == 0
    rec = json.loads((out / "sample_run.json").read_text())
    assert rec["stability_test"] == "run" and isinstance(rec["unstable"], int)


@pytest.mark.slow
def test_continued_root_of_an_untested_model_is_not_called_stable(tmp_path, capsys, monkeypatch):
    """A model that continues its samples from the root but cannot test it (sscr with its test taken away: no
    registered model is so today): the root is "stability untested"."""
    from dataclasses import replace

    from pytdcr.statics.sscr import SSCR

    monkeypatch.setattr(SSCR, "capabilities", replace(SSCR.capabilities, stability=False))
    code, out, _, _ = _run(tmp_path, capsys, "--model", "sscr")
    assert code in (0, 1)
    ws = json.loads((out / "workspace.json").read_text())
    assert ws["equilibria"] == "continuation" and ws["root"] == "stability untested"
    assert ws["stability_test"] == "untested" and ws["counts"]["unstable"] is None
    assert not any("root" in w for w in ws["warnings"])


def test_unstable_counts_only_the_converged_samples():
    """The unstable count is stability_counts' (of the converged samples), in a region's counts and a sample
    run's: a row that did not converge is never unstable, even if its stability array held 0 there (every
    solver leaves NaN there, so the numbers of real runs, and the golden baselines, do not move)."""
    from types import SimpleNamespace

    from pytdcr.runs import SampleRunCounts
    from pytdcr.workspace.parts import SampleCounts

    ok = np.array([True, True, False, False])
    st = np.array([0.0, 1.0, 0.0, np.nan])  # row 2 did not converge: its 0 is not a tested state
    no = np.zeros(4, dtype=bool)
    region = SimpleNamespace(converged=ok, stable=st, below_base=no, disks_touch=no, realisable=ok,
                             source=np.zeros(4, dtype=np.int8))
    c = SampleCounts.of(region, "run")
    assert c.unstable == 1 and c.stable == 1 and c.stable + c.unstable + c.stability_untested == 2
    assert SampleCounts.of(region, "untested").unstable is None
    tips = np.array([[0.1, 0.0, 0.2]] * 2 + [[np.nan] * 3] * 2)
    sample = SimpleNamespace(converged=ok, stable=st, reach=np.linalg.norm(tips, axis=1))
    assert SampleRunCounts.of(sample, "pcc").unstable == 1
    assert SampleRunCounts.of(sample, "cosserat").unstable is None

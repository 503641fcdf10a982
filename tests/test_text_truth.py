"""Every text true (issue 29, item 6): the report's and the warnings' sentences, on constructed cases, agree with
the numbers they carry."""

from __future__ import annotations

import re

import pytest

from pytdcr.runs._reproduce_report import _stability, _stable_cell
from pytdcr.runs._workspace_report import _error_words, _warnings, search_stop_words
from pytdcr.workspace import WorkspaceSummary
from pytdcr.workspace._solve import WarmStartCheck
from pytdcr.workspace.parts import BoundarySearch, RegionNumbers, SampleCounts, VolumeEstimate


def _summary(stop: str, volume_cm3: float, error_cm3: float, growth_cm3: float) -> WorkspaceSummary:
    """A workspace summary with a boundary search stopped by ``stop`` and a 3D region of these numbers."""
    vol = VolumeEstimate(volume_cm3 * 1e-6, error_cm3 * 1e-6, error_cm3 * 1e-6, 0.0, 1.0, (), growth_cm3 * 1e-6)
    region = RegionNumbers.of(vol, 500, 0.2, "the farthest feasible sample (not searched)")
    counts = SampleCounts(500, 500, 0, 0, 0, 500, 0, 0, 0.0, 0.0, 1.0, {})
    return WorkspaceSummary(region, region, 0.01, counts, WarmStartCheck("warm", 0, 0, 0), {},
                            BoundarySearch((), 1500, stop, 0.002, 1500), None, None, 0.0, "continued", "stable",
                            "run", None).with_meshes("fsw.ply", "fsw_realisable.ply")


@pytest.mark.parametrize(("error", "growth"), [(533, 0), (533, 100), (533, 300), (98990, 96730), (10, 10)])
def test_the_budget_warning_says_what_its_error_holds(error, growth):
    (warning,) = _warnings(_summary("budget", 1816, error, growth))
    text = warning.text
    assert warning.code == "search-budget"
    assert "stopped at its budget (1500 solves)" in text
    said = re.search(r"its error \(± (\d+) cm³\) (.*?); raise --budget", text)
    assert said and int(said.group(1)) == error
    words = said.group(2)
    if growth == 0:
        assert "mostly" not in words and "no further growth" in words
    elif growth >= 0.5 * error:
        assert f"is mostly the growth the last rounds point to ({growth} cm³)" == words
    else:
        assert words.startswith(f"holds {growth} cm³ of growth") and "mostly" not in words
    assert _error_words(growth * 1e-6, error * 1e-6) == words


def test_a_converged_search_gets_no_budget_warning():
    assert not any("budget" in w.text for w in _warnings(_summary("converged", 1816, 533, 0)))


@pytest.mark.parametrize("stop", ["converged", "budget", "no boundary left", "rounds"])
def test_the_reason_a_search_stopped_is_the_one_it_records(stop):
    words = search_stop_words(BoundarySearch((), 1500, stop, 0.002, 1500))
    if stop == "converged":
        assert words.startswith("converged") and "budget" not in words and "added less than 0.2%" in words
    else:
        assert not words.startswith("converged")
        assert ("1500 solves" in words) == (stop == "budget")
        assert ("would have meant converged" in words) == (stop == "budget")


@pytest.mark.parametrize(("stable", "cell", "words"), [(True, "yes", "is statically stable"),
                                                        (False, "**no**", "flagged unstable"),
                                                        (None, "untested", "untested")])
def test_an_optimums_stability_is_worded_as_flagged(stable, cell, words):
    assert _stable_cell(stable) == cell and words in _stability(stable)
    if stable:
        assert "unstable" not in _stability(stable) and "untested" not in _stability(stable)


def test_every_warning_has_a_code_its_text_gives_back():
    """A warning is written as its text alone; read back, the text gives its code again (what a script tests)."""
    from dataclasses import replace

    from pytdcr.records import RunWarning
    from pytdcr.runs._workspace_records import WARNING_KINDS
    from pytdcr.workspace._volume import RegionDimension

    s = _summary("budget", 1816, 533, 100)
    flat = RegionDimension(2, (0.3, 0.2, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), None, None,
                           0.05, 0.004)
    planar = RegionNumbers.of(VolumeEstimate(0.0, 0.0, 0.0, 0.0, 1.0, (), 0.0, flat), 500, 0.2, "a rule")
    few = replace(s.realisable, points=3, mesh=None)
    cases = {"search-budget": s, "root-missing": replace(s, root="unstable"),
             "low-dimension": replace(s, realisable=planar), "too-few-points": replace(s, realisable=few)}
    for code, summary in cases.items():
        said = {w.code: w for w in _warnings(summary)}
        assert code in said, code
        assert RunWarning.from_text(said[code].text, WARNING_KINDS).code == code
        assert str(said[code]) == said[code].text
    assert set(cases) == set(WARNING_KINDS)
    assert RunWarning.from_text("a warning of another version", WARNING_KINDS).code == "other"

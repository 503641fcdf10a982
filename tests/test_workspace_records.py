"""The files of a workspace run as typed records (issue 45): every ``workspace.json`` the golden baselines hold
reads into :class:`WorkspaceRecord` and writes back its keys; ``comparison.json`` round-trips, an old one
without a schema version loads, a missing key is named by its path."""

from __future__ import annotations

import copy
import json

import pytest
from test_workspace_summary import GOLDEN_FILES, _without_times

from pytdcr.records import RecordKeyError
from pytdcr.runs._workspace_records import (
    WARNING_KINDS,
    CaseComparison,
    FailedCase,
    PairComparison,
    WorkspaceComparison,
    WorkspaceRecord,
)
from pytdcr.workspace.parts import RegionOverlap


@pytest.mark.parametrize(("name", "data"), GOLDEN_FILES, ids=[n for n, _ in GOLDEN_FILES])
def test_every_golden_workspace_json_is_a_record(name, data):
    record = WorkspaceRecord.from_json(data)
    written = _without_times(record.to_json())
    assert written.pop("schema_version") == 1
    assert written == data, name
    assert [w.text for w in record.warnings] == data["warnings"]
    assert all(w.code in WARNING_KINDS for w in record.warnings)
    assert record.inputs == data["inputs"] and list(record.files) == data["files"]


def _comparison() -> WorkspaceComparison:
    row = CaseComparison("no load", "pcc", "continued", "run", 0.05, 0.004, 0.03, 0.003, 0.31,
                         "the reach search's optimum", 1.0, (0.0, 0.01, 0.2), (0.0, 0.0, 0.0), "no_load")
    other = CaseComparison("payload", "pcc", "continued", "run", 0.04, 0.004, 0.02, 0.003, None,
                           "none: no feasible sample", 0.8, (float("nan"),) * 3, (float("nan"),) * 3, "payload")
    pair = PairComparison("no load", "payload", RegionOverlap(0.02, 0.02, 0.01, 0.7, 0.95, 1000, 800))
    return WorkspaceComparison((row, other), (pair,), (FailedCase("wrench", "NotConvergedError: ..."),),
                               ("comparison.md", "comparison.json"))


def test_a_comparison_round_trips_through_its_json_text():
    c = _comparison()
    text = json.dumps(c.to_json(), allow_nan=True)
    back = WorkspaceComparison.from_json(json.loads(text))
    assert json.dumps(back.to_json(), allow_nan=True) == text
    assert back.pairs[0].overlap.a_in_b == 0.7 and back.failed[0].case == "wrench"


def test_a_comparison_written_before_schema_versions_loads_and_another_version_is_refused():
    old = _comparison().to_json()
    del old["schema_version"]
    assert WorkspaceComparison.from_json(old).to_json()["cases"] == old["cases"]
    newer = {**old, "schema_version": 2}
    with pytest.raises(ValueError, match=r"comparison\.json: schema_version 2"):
        WorkspaceComparison.from_json(newer)


@pytest.mark.parametrize(("edit", "named"), [
    (lambda d: d["cases"][1].pop("volume_m3"), "cases[1].volume_m3"),
    (lambda d: d["pairs"][0].pop("hausdorff_m"), "pairs[0].hausdorff_m"),
    (lambda d: d.pop("failed"), "failed"),
])
def test_a_missing_key_of_a_comparison_is_named_by_its_path(edit, named):
    data = copy.deepcopy(_comparison().to_json())
    edit(data)
    with pytest.raises(RecordKeyError) as info:
        WorkspaceComparison.from_json(data)
    assert info.value.key == named and info.value.file == "comparison.json"


def test_a_workspace_json_that_is_not_an_object_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"workspace\.json: the file must be a JSON object, got list"):
        WorkspaceRecord.from_json([1, 2])


@pytest.mark.parametrize("name", ["reproduce", "reproduce_demo"])
def test_the_golden_reproduce_workspace_sections_read_and_write_back(name):
    from pathlib import Path

    from pytdcr.runs._workspace_records import WorkspaceSection

    golden = Path(__file__).resolve().parent / "golden" / f"{name}.json"
    section = json.loads(golden.read_text())["data"]["files"]["reproduce.json"]["summary"]["workspace"]
    typed = WorkspaceSection.from_json(section)
    assert typed.to_json() == section
    assert [c.case for c in typed.cases] == ["no load", "paper wrench"]
    assert typed.cases[0].volume_m3 == section["cases"][0]["volume_m3"] and typed.budget == section["budget"]


def test_a_workspace_section_with_models_round_trips():
    from pytdcr.runs._workspace_records import ModelsSection, WorkspaceSection

    c = _comparison()
    section = WorkspaceSection(32, 0.04, 200, c.cases, ModelsSection(16, 0.05, c.cases, c.pairs))
    text = json.dumps(section.to_json(), allow_nan=True)
    back = WorkspaceSection.from_json(json.loads(text))
    assert json.dumps(back.to_json(), allow_nan=True) == text and back.models is not None
    broken = json.loads(text)
    del broken["models"]["pairs"][0]["a_in_b"]
    with pytest.raises(RecordKeyError) as info:
        WorkspaceSection.from_json(broken)
    assert info.value.key == "models.pairs[0].a_in_b" and info.value.file == "reproduce.json"

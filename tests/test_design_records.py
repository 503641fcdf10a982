"""A design's evaluation as a typed record (issue 45): :class:`DesignRecord` (a :class:`CaseRow` per load case)
writes a design's file key for key, reads back every design file the golden baseline holds, builds the golden
table from them, and a file whose keys were renamed is refused naming the key, so that a resumed study computes
that design again instead of failing."""

from __future__ import annotations

import copy
import csv
import json
import math
import pickle
from concurrent.futures import Future
from pathlib import Path
from typing import Any, ClassVar

import pytest

from pytdcr.designs import (
    DesignsRunOptions,
    _run,
    choose_designs,
    evaluate_design,
    load_study,
    run_designs,
    study_from_dict,
)
from pytdcr.designs._records import CaseRow, DesignRecord, DesignsSummary, RecordShape, Timing
from pytdcr.designs._report import build_table
from pytdcr.records import RecordKeyError
from pytdcr.runtime import dump_json

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = json.loads((ROOT / "tests" / "golden" / "designs.json").read_text())["data"]["files"]
#: the golden run's design files (their times scrubbed: ``timing`` is ``{}``)
DESIGN_FILES = {name: rec for name, rec in GOLDEN.items() if name.startswith("designs/")}
#: what the golden baseline dropped of each record's timing, put back to read it
TIMING = {"seconds": 12.5, "host": "a-host", "pid": 4242}


def _golden_record(name: str) -> dict[str, Any]:
    """A golden design file's record with a timing again (the baseline scrubs its keys)."""
    return {**copy.deepcopy(DESIGN_FILES[name]), "timing": dict(TIMING)}


def _golden_study() -> tuple[Any, Any, list[dict[str, float]]]:
    """The study the golden run ran (``examples/design_study_small.toml``), its base robot and its designs."""
    study, robot, _ = load_study(str(ROOT / "examples" / "design_study_small.toml"))
    return study, robot, choose_designs(study.parameters, study.designs.method, study.designs.count, seed=study.seed)


def _index(name: str) -> int:
    stem = Path(name).stem
    return -1 if stem == "reference" else int(stem)


def test_the_golden_baseline_holds_design_files():
    assert sorted(DESIGN_FILES) == [f"designs/{k:06d}.json" for k in range(4)] + ["designs/reference.json"]


@pytest.mark.parametrize("name", sorted(DESIGN_FILES))
def test_every_golden_design_file_reads_and_writes_back_key_for_key(name):
    with pytest.raises(RecordKeyError) as info:  # as the baseline keeps it: no time, so not a record to trust
        DesignRecord.from_json(DESIGN_FILES[name])
    assert info.value.key == "timing.seconds"
    data = _golden_record(name)
    rec = DesignRecord.from_json(data)
    out = rec.to_json()
    assert out.pop("schema_version") == 1
    assert out == data and list(out) == list(data)  # today's keys, in today's order
    for row, raw in zip(out["rows"], data["rows"], strict=True):
        assert list(row) == list(raw)
    # read by attribute: the same numbers
    assert rec.design == _index(name) and rec.status == "ok" and rec.ok and rec.generation == data["generation"]
    assert rec.params == data["params"] and rec.timing == Timing(**TIMING)
    [row] = rec.rows
    raw = data["rows"][0]
    assert row.load_case == raw["load_case"] == "paper wrench" and rec.row("paper wrench") is row
    assert row.volume_m3 == raw["volume_m3"] and row.largest_reach_m == raw["largest_reach_m"]
    assert row.fsw_dimension == raw["fsw_dimension"] and type(row.fsw_dimension) is int  # an integer stays one
    assert row.h_m == {"up": raw["h_up_m"], "side": raw["h_side_m"]}
    assert row.measure("h_side_m") == raw["h_side_m"] and math.isnan(row.measure("h_down_m"))
    assert row.reach_tensions_n == tuple(raw["reach_tensions_n"])
    # the record is this study's, for this design
    study, robot, designs = _golden_study()
    planned = {} if rec.design < 0 else designs[rec.design]
    assert RecordShape.of(study, robot).mismatch(rec, rec.design, planned) is None


def test_the_golden_table_is_built_from_the_typed_records():
    """The table of the golden run, built again from its design files read as records, is its ``designs.csv``,
    digit for digit."""
    study, robot, designs = _golden_study()
    records = {_index(n): DesignRecord.from_json(_golden_record(n)) for n in DESIGN_FILES}
    table = build_table(study, robot, records, dict.fromkeys(range(len(designs)), 0))
    rows = list(csv.reader(table.to_csv(index=False).splitlines()))
    assert {"columns": rows[0], "rows": rows[1:]} == GOLDEN["designs.csv"]


def test_the_golden_summary_reads_and_writes_back():
    data = GOLDEN["summary.json"]
    s = DesignsSummary.from_json(data)
    out = s.to_json()
    dropped = {"schema_version", "executor", "seconds", "versions"}  # the baseline scrubs them
    assert {k: v for k, v in out.items() if k not in dropped} == data
    assert list(k for k in out if k not in dropped) == list(data)
    [best] = s.best
    assert (best.load_case, best.design, best.robot_file) == ("paper wrench", 3, "best/design_000003.toml")
    assert best.value == data["best"][0]["value"] and best.error == data["best"][0]["error"]
    assert s.designs == 4 and s.load_cases == ("paper wrench",) and s.unranked == () and len(s.warnings) == 1
    assert s.designs_computed == 4
    with pytest.raises(TypeError):  # read by attribute: no dict-style access
        s["designs_computed"]


def test_a_record_round_trips_through_its_file_and_a_pickle():
    """A record with what only some records hold (a NaN measure, no tensions, a traceback, a failed status)
    is written as strict JSON and read back the same; a worker's pickle is the same record."""
    row = CaseRow("no load", 0.02, 0.001, 0.01, 0.0005, 3, 1.0, 0.5, math.nan, 0.4, {"up": 0.3}, 0.35, None)
    ok = DesignRecord(7, {"disks": 10, "routing_radius_2": 0.006}, "ok", "", (row,), Timing(1.5, "h", 12), 2)
    failed = DesignRecord(8, {"disks": 4, "routing_radius_2": 0.006}, "failed", "ValueError: no", (),
                          Timing(math.nan, "", -1), 0, "Traceback ...")
    for rec in (ok, failed):
        text = dump_json(rec.to_json())
        assert "NaN" not in text
        back = DesignRecord.from_json(json.loads(text))
        assert dump_json(back.to_json()) == text
        assert dump_json(pickle.loads(pickle.dumps(rec)).to_json()) == text
    back = DesignRecord.from_json(json.loads(dump_json(ok.to_json())))
    assert math.isnan(back.rows[0].peak_stress_pa) and back.rows[0].reach_tensions_n is None
    assert back.params == ok.params and type(back.params["disks"]) is int
    assert "traceback" not in ok.to_json() and failed.to_json()["traceback"] == "Traceback ..."
    assert ok.rows[0].volume_m3 == 0.02 and ok.ok and not failed.ok
    with pytest.raises(TypeError):  # read by attribute: no dict-style access
        ok["status"]


@pytest.mark.parametrize(("path", "named"), [
    (("design",), "design"),
    (("params",), "params"),
    (("status",), "status"),
    (("rows",), "rows"),
    (("timing",), "timing"),
    (("rows", 0, "volume_m3"), "rows[0].volume_m3"),
    (("rows", 0, "load_case"), "rows[0].load_case"),
    (("rows", 0, "reach_tensions_n"), "rows[0].reach_tensions_n"),
    (("timing", "pid"), "timing.pid"),
])
def test_a_renamed_key_is_refused_naming_it_and_the_design_is_computed_again(path, named, tmp_path):
    study, robot, designs = _golden_study()
    data = _golden_record("designs/000001.json")
    part: Any = data
    for key in path[:-1]:
        part = part[key]
    part[path[-1] + "_renamed"] = part.pop(path[-1])
    with pytest.raises(RecordKeyError) as info:
        DesignRecord.from_json(data)
    assert info.value.key == named and repr(named) in str(info.value)
    # a resume reads the file: not this study's record, so the design is computed again (no error)
    (tmp_path / "designs").mkdir()
    shape = RecordShape.of(study, robot)
    (tmp_path / "designs" / "000001.json").write_text(dump_json(_golden_record("designs/000001.json")))
    kept = _run._reuse(tmp_path, 1, designs[1], shape)
    assert isinstance(kept, DesignRecord) and kept.design == 1 and kept.rows[0].volume_m3 > 0
    (tmp_path / "designs" / "000001.json").write_text(dump_json(data))
    assert _run._reuse(tmp_path, 1, designs[1], shape) is None


@pytest.mark.parametrize(("change", "says"), [
    (lambda d: d.update(design=2), "another design"),
    (lambda d: d["params"].update(segment_length_1=0.2), "other values"),
    (lambda d: d["rows"].append(copy.deepcopy(d["rows"][0])), "2 rows"),
    (lambda d: d["rows"][0].update(load_case="no load"), "load case 'no load'"),
    (lambda d: d["rows"][0].pop("h_up_m"), "h along ['side'], not along the study's directions ['side', 'up']"),
    (lambda d: d["rows"][0].update(h_down_m=0.1), "h along ['down', 'side', 'up']"),
    (lambda d: d["rows"][0].update(reach_tensions_n=[1.0] * 3), "3 tensions"),
])
def test_a_well_formed_record_of_another_design_or_study_is_not_this_one(change, says):
    """A record that reads (:meth:`DesignRecord.from_json`) is still checked against the study and the design
    planned (:meth:`RecordShape.mismatch`), with the reason."""
    study, robot, designs = _golden_study()
    data = _golden_record("designs/000001.json")
    change(data)
    rec = DesignRecord.from_json(data)
    why = RecordShape.of(study, robot).mismatch(rec, 1, designs[1])
    assert why is not None and says in why


@pytest.mark.parametrize(("change", "says"), [
    (lambda d: d.update(status="great"), "status"),
    (lambda d: d.update(design=True), "design must be an integer"),
    (lambda d: d["rows"][0].update(volume_m3="big"), "volume_m3 must be a finite number"),
    (lambda d: d["rows"][0].update(colour="red"), "'colour'"),
    (lambda d: d["timing"].update(injected="x"), "'injected'"),
    (lambda d: d.update(schema_version=2), "schema_version 2"),
    (lambda d: d.update(rows={}), "rows must be a list"),
])
def test_a_malformed_record_is_refused_saying_what(change, says):
    data = _golden_record("designs/000001.json")
    change(data)
    with pytest.raises(ValueError, match="design record") as info:
        DesignRecord.from_json(data)
    assert says in str(info.value)


# ---------------------------------------------------------------- a run: the records it makes and resumes
class _InProcess:
    """An executor that evaluates each design in this process as it is submitted, noting what it returned."""

    results: ClassVar[list[Any]] = []

    def __init__(self, workers: int) -> None:
        self.name = "this process"

    def submit(self, *args: Any) -> Future:
        fut: Future = Future()
        rec = evaluate_design(*args)
        _InProcess.results.append(rec)
        fut.set_result(pickle.loads(pickle.dumps(rec)))  # as a worker hands it back
        return fut

    def close(self, cancel: bool) -> None:
        pass


def _small_study():
    """Two designs and the base robot, one load case, a small budget."""
    return study_from_dict({
        "name": "r", "robot": "paper", "seed": 5, "bounds": [0.0, 10.0],
        "parameters": {"routing_radius_2": {"values": [0.006, 0.01]}},
        "budget": {"samples": 16, "search": 0}, "loads": {"cases": ["no load"]},
        "measures": {"directions": {"up": [0.0, 0.0, 1.0]}}})


def test_a_run_writes_typed_records_and_recomputes_a_file_whose_key_was_renamed(tmp_path, monkeypatch):
    monkeypatch.setattr(_run, "_Local", _InProcess)
    study, robot = _small_study()
    _InProcess.results = []
    first = run_designs(study, robot, tmp_path, options=DesignsRunOptions(workers=1, figures=False))
    assert all(isinstance(r, DesignRecord) for r in _InProcess.results) and len(_InProcess.results) == 3
    assert sorted(r.design for r in _InProcess.results) == [-1, 0, 1]
    assert isinstance(first.summary, DesignsSummary) and first.summary.designs_computed == 2
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert DesignsSummary.from_json(saved) == first.summary and saved == json.loads(dump_json(first.summary.to_json()))
    path = tmp_path / "designs" / "000001.json"
    written = json.loads(path.read_text())
    assert written["schema_version"] == 1 and written["generation"] == 0
    assert DesignRecord.from_json(written).rows[0].volume_m3 == first.table.loc[2, "volume_m3"]
    # a key renamed in design 1's file: that design alone is computed again, the same
    written["rows"][0]["volume_renamed_m3"] = written["rows"][0].pop("volume_m3")
    path.write_text(json.dumps(written))
    _InProcess.results = []
    again = run_designs(study, robot, tmp_path, options=DesignsRunOptions(workers=1, figures=False))
    assert [r.design for r in _InProcess.results] == [1]
    assert (again.summary.designs_reused, again.summary.designs_computed) == (1, 1)
    assert again.table.equals(first.table)
    assert "volume_m3" in json.loads(path.read_text())["rows"][0]


def test_the_figures_draw_the_best_designs_from_the_typed_records(tmp_path):
    """The best designs' figure reads each record's farthest tensions and reach by attribute: its panels are the
    base robot and the Pareto front's best, titled with their records' numbers."""
    from pytdcr.designs._figures import _best_figure, _picked, write_design_figures

    study, robot, designs = _golden_study()
    records = {_index(n): DesignRecord.from_json(_golden_record(n)) for n in DESIGN_FILES}
    table = build_table(study, robot, records, dict.fromkeys(range(len(designs)), 0))
    picked = _picked(study, table)
    assert picked[0] == -1 and set(picked[1:]) <= set(table.loc[table["pareto"], "design"]) and len(picked) > 1
    fig = _best_figure(study, robot, table, records)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert len(titles) == len(picked)
    for k, title in zip(picked, titles, strict=True):
        row = records[k].rows[0]
        assert f"reach {row.largest_reach_m * 1e3:.0f} mm, FSW {row.volume_m3 * 1e6:.0f} cm³" in title, title
    names = write_design_figures(tmp_path, study, robot, table, records)
    assert sorted(names) == sorted(f"{n}.{e}" for n in ("pareto", "measures", "best_designs") for e in ("png", "pdf"))
    assert all((tmp_path / n).stat().st_size > 0 for n in names)

"""The compare and accuracy runs' results as typed records (issue 45): ``compare.json`` and ``accuracy.json`` read
into :class:`CompareResult` and :class:`AccuracyResult` (the golden baseline's file and a fresh run's), write back
key for key, are read by attribute, and a file whose keys were renamed, or of another schema, is refused naming
the key."""

from __future__ import annotations

import copy
import csv
import json
import math
import re
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from pytdcr.accuracy import AccuracyRow, AccuracySummary, OrderFit, OrderRecord
from pytdcr.compare import ComparisonSummary, ModelSummary, compare_models
from pytdcr.loads import Loads
from pytdcr.records import RecordKeyError
from pytdcr.runs import CompareSettings, RobotSpec
from pytdcr.runs._accuracy import SCHEMA_VERSION as ACCURACY_SCHEMA
from pytdcr.runs._accuracy import AccuracyResult
from pytdcr.runs._compare import SCHEMA_VERSION as COMPARE_SCHEMA
from pytdcr.runs._compare import CaseSource, CompareResult
from pytdcr.runtime import to_jsonable

GOLDEN = Path(__file__).resolve().parent / "golden"
#: the golden baselines drop these keys (tests/test_golden.py's VOLATILE): times, versions
VOLATILE = re.compile(r"(second|^ms_|_ms(_|$)|time|version|^python$|^pytdcr$)")


def _scrub(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _scrub(v) for k, v in data.items() if not VOLATILE.search(k)}
    if isinstance(data, list):
        return [_scrub(v) for v in data]
    return data


def _golden_files() -> dict[str, Any]:
    return json.loads((GOLDEN / "compare.json").read_text())["data"]["files"]


def _same_number(a: float | None, b: float | None) -> bool:
    """Equal, NaN and None (a non-finite number written strict) being the same."""
    nan_a = a is None or math.isnan(a)
    nan_b = b is None or math.isnan(b)
    return nan_a == nan_b and (nan_a or a == b)


# ---------------------------------------------------------------- compare.json: the golden baseline
def test_the_golden_compare_json_reads_and_writes_back():
    files = _golden_files()
    data = files["compare.json"]
    r = CompareResult.from_json(data)
    out = r.to_json()
    assert out["schema_version"] == COMPARE_SCHEMA
    assert _scrub(out) == data  # every key and value of the file
    assert list(_scrub(out)["inputs"]) == list(data["inputs"]) and list(_scrub(out)["summary"]) == list(data["summary"])
    # read by attribute: the same numbers
    s = r.summary
    assert s.models == tuple(data["summary"]["models"]) and s.reference == data["summary"]["reference"]
    assert s.cases == data["summary"]["cases"] and s.all_converged == data["summary"]["all_converged"]
    for m in s.per_model:
        assert m.not_converged == data["summary"][f"{m.model}_not_converged"]
        assert math.isnan(m.ms_median)  # the baseline dropped the times: not recorded
    for m in s.others:
        assert m.difference_max_mm == data["summary"][f"{m.model}_difference_max_mm"]
        assert m.difference_median_pct_length == data["summary"][f"{m.model}_difference_median_pct_length"]
    assert s.of("pcc").difference_median_mm is None
    with pytest.raises(KeyError, match="sscr"):
        s.of("sscr")
    assert r.files == tuple(data["files"])
    # the cases' source, in the file and in the manifest
    src = r.source
    assert src.kind == "random" and src.seed == data["inputs"]["seed"] and src.cases == data["inputs"]["cases"]
    assert src.bounds is not None and src.bounds.upper.tolist() == data["inputs"]["bounds"]["upper"]
    manifest = CaseSource.from_json(files["manifest.json"]["inputs"])
    assert manifest.to_json() == src.to_json()


def test_the_golden_summary_agrees_with_its_table():
    """The typed summary's numbers are the golden table's (compare.csv), recomputed from its rows."""
    files = _golden_files()
    s = CompareResult.from_json(files["compare.json"]).summary
    table = files["compare.csv"]
    cols = {name: [row[k] for row in table["rows"]] for k, name in enumerate(table["columns"])}
    assert s.cases == len(table["rows"])
    for m in s.per_model:
        assert m.not_converged == cols[f"{m.model}_converged"].count("False")
    for m in s.others:
        d = np.array([float(x) for x in cols[f"{m.model}_difference_mm"]])
        assert m.difference_max_mm == pytest.approx(np.nanmax(d), rel=1e-11)  # the CSV keeps 12 digits
        assert m.difference_median_mm == pytest.approx(np.nanmedian(d), rel=1e-11)


# ---------------------------------------------------------------- a fresh tdcr compare
@pytest.fixture(scope="module")
def compare_run(tmp_path_factory):
    from pytdcr.cli import main

    out = tmp_path_factory.mktemp("compare") / "c"
    code = main(["compare", "--robot", "rao", "--n", "3", "--seed", "4", "--bounds", "0,3", "--models", "pcc,pcc2",
                 "--out", str(out)])
    return code, out


def test_a_fresh_compare_json_reads_and_writes_back_exactly(compare_run):
    code, out = compare_run
    assert code == 0
    text = (out / "compare.json").read_text()
    data = json.loads(text)
    assert data["schema_version"] == COMPARE_SCHEMA and next(iter(data)) == "schema_version"
    r = CompareResult.from_json(data)
    assert to_jsonable(r.to_json()) == data  # times and versions included
    assert json.dumps(to_jsonable(r.to_json()), indent=2) == text.strip()  # key order included
    # the numbers are the table's
    rows = list(csv.DictReader((out / "compare.csv").open()))
    assert r.summary.cases == len(rows) == 3 and r.summary.models == ("pcc", "pcc2")
    d = np.array([float(x["pcc2_difference_mm"]) for x in rows])
    assert r.summary.of("pcc2").difference_max_mm == pytest.approx(np.nanmax(d), rel=1e-11)
    assert r.summary.of("pcc").ms_median == pytest.approx(float(np.median([float(x["pcc_ms"]) for x in rows])),
                                                          rel=1e-11)
    assert r.source.kind == "random" and r.source.seed == 4 and r.source.bounds is not None
    assert r.source.bounds.upper.tolist() == [3.0] * len(r.source.bounds.upper)
    manifest = json.loads((out / "manifest.json").read_text())
    assert CaseSource.from_json(manifest["inputs"]).to_json() == r.source.to_json()
    assert manifest["inputs"]["models"] == ["pcc", "pcc2"]


def test_a_comparisons_summary_is_typed_and_round_trips(rao):
    cmp = compare_models(rao, Loads(np.zeros(6)), np.array([[2.0, 0, 0, 0, 1, 0], [0, 1, 0, 0, 0, 1.0]]),
                         models=("pcc", "pcc2"))
    s = cmp.summary()
    assert isinstance(s, ComparisonSummary) and s.per_model == tuple(cmp.summaries().values())
    assert s.all_converged == cmp.n_all_converged == 2 and s.cases == 2
    d = s.to_json()
    assert list(d) == ["cases", "reference", "models", "all_converged", "pcc_not_converged", "pcc_ms_median",
                       "pcc2_not_converged", "pcc2_ms_median", "pcc2_difference_median_mm", "pcc2_difference_max_mm",
                       "pcc2_difference_median_pct_length"]
    assert d["pcc2_difference_median_mm"] == s.of("pcc2").difference_median_mm > 0
    assert ComparisonSummary.from_json(json.loads(json.dumps(d))) == s


def test_a_comparisons_cases_are_typed_rows_with_the_tables_columns(paper):
    """Each case is a typed row (its solves and differences by attribute) whose CSV row has the golden table's
    columns, in order."""
    from pytdcr.robot import NoFriction

    paper = paper.with_friction(NoFriction())  # as tdcr compare makes it for the smeared rod
    T = np.array([[1.0, 0, 0, 0, 0.5, 0, 0, 0], [0, 2.0, 0, 0, 0, 0, 1.0, 0]])
    cmp = compare_models(paper, Loads(np.zeros(8)), T, models=("pcc", "pcc2", "cosserat"))
    c = cmp.cases()[1]
    assert c.case == 2 and c.tensions_N == tuple(T[1].tolist())
    assert [s.model for s in c.solves] == ["pcc", "pcc2", "cosserat"]
    assert [d.model for d in c.differences] == ["pcc2", "cosserat"]
    for s in c.solves:
        sol = cmp.solutions[s.model][1]
        assert s.converged and s.tip_m == tuple(sol.tip_position.tolist()) and s.ms == sol.seconds * 1e3
    for d in c.differences:
        assert d.mm == cmp.difference(d.model)[1] * 1e3 > 0
        assert d.pct_length == pytest.approx(d.mm * 1e-3 / paper.length * 100, rel=1e-12)
    row = c.to_row()
    assert [k for k in row if not VOLATILE.search(k)] == _golden_files()["compare.csv"]["columns"]
    assert row["cosserat_difference_mm"] == c.differences[1].mm and row["pcc2_y_m"] == c.solves[1].tip_m[1]
    assert cmp.rows() == [x.to_row() for x in cmp.cases()]


def test_a_comparison_where_nothing_converged_for_both_writes_null_differences():
    s = ComparisonSummary(4, 0, (ModelSummary("pcc", 4, 1.5), ModelSummary("cosserat", 0, 3.0)))
    d = json.loads(json.dumps(to_jsonable(s.to_json())))
    assert d["cosserat_difference_median_mm"] is None and d["cosserat_difference_max_mm"] is None
    assert ComparisonSummary.from_json(d) == s
    d["reference"] = "cosserat"
    with pytest.raises(ValueError, match="must be the first of the models"):
        ComparisonSummary.from_json(d)


def test_each_kind_of_case_source_is_recorded_and_reads_back(rao, tmp_path):
    spec = RobotSpec(robot="rao")
    path = tmp_path / "cases.csv"
    path.write_text("1,0,0,0,0,0\n0,2,0,0,0,0\n")
    kinds = {"file": CompareSettings(robot=spec, models=("pcc", "pcc2"), cases=str(path)),
             "given": CompareSettings(robot=spec, models=("pcc", "pcc2"), cases=np.zeros((2, 6))),
             "random": CompareSettings(robot=spec, models=("pcc", "pcc2"), n=3, seed=9)}
    for kind, settings in kinds.items():
        T, record = settings.tensions(rao)
        src = CaseSource.from_json(record)
        assert src.kind == kind, record
        assert src.to_json() == to_jsonable(record)
        assert CaseSource.from_json(json.loads(json.dumps(src.to_json()))).to_json() == src.to_json()
    assert src.bounds is not None and src.seed == 9 and T.shape == (3, 6)
    with pytest.raises(KeyError, match="bounds"):
        CaseSource.from_json({"cases": "3 random within bounds, seed 9", "seed": 9})


# ---------------------------------------------------------------- refusals
def _renamed(data: dict[str, Any], path: tuple[Any, ...]) -> dict[str, Any]:
    data = copy.deepcopy(data)
    part = data
    for key in path[:-1]:
        part = part[key]
    part[path[-1] + "_renamed"] = part.pop(path[-1])
    return data


@pytest.mark.parametrize(("path", "named"), [
    (("summary", "cosserat_difference_max_mm"), "summary.cosserat_difference_max_mm"),
    (("summary", "pcc2_not_converged"), "summary.pcc2_not_converged"),
    (("summary", "all_converged"), "summary.all_converged"),
    (("inputs", "cases"), "inputs.cases"),
    (("inputs", "bounds"), "inputs.bounds"),
    (("inputs", "bounds", "upper"), "inputs.bounds.upper"),
    (("files",), "files"),
])
def test_a_renamed_compare_key_is_refused_naming_it(path, named):
    data = _renamed(_golden_files()["compare.json"], path)
    with pytest.raises(RecordKeyError) as info:
        CompareResult.from_json(data)
    assert info.value.key == named and repr(named) in str(info.value) and "compare.json" in str(info.value)


def test_a_compare_json_of_another_schema_or_shape_is_refused():
    data = copy.deepcopy(_golden_files()["compare.json"])
    assert CompareResult.from_json({**data, "schema_version": COMPARE_SCHEMA}).summary.cases == 6
    with pytest.raises(ValueError, match=f"compare.json: schema_version {COMPARE_SCHEMA + 1}"):
        CompareResult.from_json({**data, "schema_version": COMPARE_SCHEMA + 1})
    with pytest.raises(ValueError, match="summary must be a JSON object"):
        CompareResult.from_json({**data, "summary": [1, 2]})
    with pytest.raises(ValueError, match="the file must be a JSON object"):
        CompareResult.from_json([data])


# ---------------------------------------------------------------- a fresh tdcr accuracy
@pytest.fixture(scope="module")
def accuracy_run(tmp_path_factory):
    from pytdcr.cli import main

    out = tmp_path_factory.mktemp("accuracy") / "a"
    code = main(["accuracy", "--robot", "rao", "--n", "2", "--bounds", "0,3", "--models", "pcc,pcc2", "--order-cases",
                 "1", "--disks", "5,10", "--out", str(out)])
    return code, out


def test_a_fresh_accuracy_json_reads_and_writes_back_exactly(accuracy_run):
    code, out = accuracy_run
    assert code == 0
    text = (out / "accuracy.json").read_text()
    data = json.loads(text)
    assert data["schema_version"] == ACCURACY_SCHEMA and next(iter(data)) == "schema_version"
    r = AccuracyResult.from_json(data)
    assert to_jsonable(r.to_json()) == data
    assert json.dumps(to_jsonable(r.to_json()), indent=2) == text.strip()
    s = r.summary
    assert len(s.rows) == 2 * 4 and {x.model for x in s.rows} == {"pcc", "pcc2"}
    assert s.compared == sum(x.converged for x in s.rows) > 0 and s.seconds > 0
    assert r.inputs["models"] == ["pcc", "pcc2"] and r.inputs["disks"] == [5, 10]
    # the rows are the table's, cell for cell
    table = list(csv.DictReader((out / "accuracy.csv").open()))
    assert [t["model"] for t in table] == [x.model for x in s.rows]
    for t, x in zip(table, s.rows, strict=True):
        assert t["group"] == x.group and int(t["converged"]) == x.converged and t["unsupported"] == x.unsupported
        assert _same_number(float(t["median_error_mm"]), x.median_error_mm)
        assert _same_number(float(t["max_error_mm"]), x.max_error_mm)
    # the order studies are order.csv's
    assert [o.group for o in s.orders] == [g["name"] for g in r.inputs["groups"]]
    order = list(csv.DictReader((out / "order.csv").open()))
    flat = [(o.group, f.model, d, f"{x:.6g}", f"{f.order:.4f}") for o in s.orders for f in o.fits
            for d, x in zip(o.disks, f.errors_mm, strict=True)]
    assert flat == [(t["group"], t["model"], int(t["disks_per_segment"]), t["median_error_mm"], t["order"])
                    for t in order]
    assert all(o.disks == (5, 10) and len(o.spacing_m) == 2 and o.spacing_m[0] > o.spacing_m[1] for o in s.orders)


def test_an_accuracy_json_without_its_times_reads(accuracy_run):
    _, out = accuracy_run
    data = _scrub(json.loads((out / "accuracy.json").read_text()))
    assert "seconds" not in data["summary"] and "median_ms" not in data["summary"]["rows"][0]
    r = AccuracyResult.from_json(data)
    assert r.summary.seconds == 0.0 and all(o.seconds == 0.0 for o in r.summary.orders)
    assert all(math.isnan(x.median_ms) for x in r.summary.rows)
    assert _scrub(r.to_json()) == data


@pytest.mark.parametrize(("path", "named"), [
    (("summary", "rows", 1, "median_error_mm"), "summary.rows[1].median_error_mm"),
    (("summary", "rows", 0, "unsupported"), "summary.rows[0].unsupported"),
    (("summary", "orders", 0, "order"), "summary.orders[0].order"),
    (("summary", "orders", 1, "spacing_m"), "summary.orders[1].spacing_m"),
    (("summary", "orders", 0, "order", "pcc2"), "summary.orders[0].order.pcc2"),
    (("summary", "compared"), "summary.compared"),
    (("summary", "reference_steps_per_subsegment"), "summary.reference_steps_per_subsegment"),
    (("inputs",), "inputs"),
])
def test_a_renamed_accuracy_key_is_refused_naming_it(accuracy_run, path, named):
    _, out = accuracy_run
    data = _renamed(json.loads((out / "accuracy.json").read_text()), path)
    with pytest.raises(RecordKeyError) as info:
        AccuracyResult.from_json(data)
    assert info.value.key == named and repr(named) in str(info.value) and "accuracy.json" in str(info.value)


def test_an_accuracy_json_of_another_schema_or_shape_is_refused(accuracy_run):
    _, out = accuracy_run
    data = json.loads((out / "accuracy.json").read_text())
    with pytest.raises(ValueError, match=f"accuracy.json: schema_version {ACCURACY_SCHEMA + 1}"):
        AccuracyResult.from_json({**data, "schema_version": ACCURACY_SCHEMA + 1})
    with pytest.raises(ValueError, match="rows must be a JSON list"):
        AccuracyResult.from_json({**data, "summary": {**data["summary"], "rows": {}}})
    bad = copy.deepcopy(data)
    bad["summary"]["orders"][0]["errors_mm"]["pcc"].append(1.0)
    with pytest.raises(ValueError, match=r"errors_mm\.pcc holds 3 errors for 2 disk counts"):
        AccuracyResult.from_json(bad)
    old = {k: v for k, v in data.items() if k != "schema_version"}  # written before the key existed: version 1
    assert AccuracyResult.from_json(old).summary == AccuracyResult.from_json(data).summary


# ---------------------------------------------------------------- the records one by one
def test_an_accuracy_row_with_non_finite_numbers_round_trips_through_strict_json():
    row = AccuracyRow("cosserat", "+tip wrench", 3, 3, 0, 0.0, float("nan"), float("nan"), float("nan"), float("nan"),
                      "friction")
    d = json.loads(json.dumps(to_jsonable(row.to_json()), allow_nan=False))
    assert d["median_error_mm"] is None and d["median_ms"] is None
    back = AccuracyRow.from_json(d)
    assert back.to_json().keys() == row.to_json().keys()
    assert all(_same_number(a, b) if isinstance(a, float) else a == b
               for a, b in zip(back.to_json().values(), row.to_json().values(), strict=True))
    ok = AccuracyRow("pcc", "tendons", 3, 2, 2, 1.0, 0.5, 0.9, 1.0, 2.5)
    assert AccuracyRow.from_json(json.loads(json.dumps(ok.to_json()))) == ok


def test_an_order_record_round_trips_and_keeps_the_study(rao):
    from pytdcr.accuracy import default_groups, order_study

    st = order_study(rao, np.array([1.0, 0, 0, 0, 0.5, 0]), default_groups()[0], disks=(5, 10), models=("pcc",))
    rec = OrderRecord.of(st)
    assert rec.group == st.group and rec.disks == st.disks and rec.spacing_m == tuple(st.spacing.tolist())
    assert rec.fits == (OrderFit("pcc", tuple(st.errors_mm["pcc"].tolist()), st.order["pcc"]),)
    back = OrderRecord.from_json(json.loads(json.dumps(to_jsonable(rec.to_json()))))
    assert back == rec
    summary = AccuracySummary((), 0, 16, 1.5, (rec,))
    assert AccuracySummary.from_json(json.loads(json.dumps(summary.to_json()))) == summary


# ---------------------------------------------------------------- the command line reads the typed rows
def test_tdcr_accuracy_prints_the_typed_rows_never_a_small_error_as_zero(monkeypatch, tmp_path, capsys):
    """The command line reads each :class:`AccuracyRow` by attribute: errors under half a micrometre in three
    significant digits, in the same columns."""
    import pytdcr.runs
    from pytdcr import rao_robot
    from pytdcr.cli import main

    def row(model: str, median: float, p95: float, converged: int = 3, unsupported: str = "") -> AccuracyRow:
        return AccuracyRow(model, "tendons", 3, 3, converged, converged / 3, median, p95, p95, 1.0, unsupported)

    rows = [row("pcc", 1.25, 12.5), row("pcc2", 3e-4, 2e-7), row("sscr", 0.0, 4.9e-4), row("prbm", 0.0, 0.0, 0),
            row("cosserat", 0.0, 0.0, 0, "friction")]
    study = SimpleNamespace(nothing_compared=lambda: "", robot=rao_robot(), groups=[1], models=["pcc"], seconds=0.0,
                            rows=lambda: rows)
    fake = SimpleNamespace(study=study, orders=[], files=["accuracy.csv"])
    monkeypatch.setattr(pytdcr.runs, "run_accuracy", lambda *a, **k: fake)
    assert main(["accuracy", "--n", "2", "--order-cases", "0", "--out", str(tmp_path / "a")]) == 0
    lines = capsys.readouterr().out.splitlines()
    medians = [ln for ln in lines if " median " in ln]
    assert len(medians) == 3
    assert "median     1.250 mm, 95th pct    12.500 mm, converged 3/3, 1.00 ms" in medians[0], medians[0]
    assert "median    0.0003 mm, 95th pct     2e-07 mm" in medians[1], medians[1]
    assert len({ln.index(" mm, 95th") for ln in medians}) == 1
    assert any(ln.endswith("prbm      nothing compared: converged 0/3") for ln in lines), lines
    assert any(ln.endswith("cosserat  unsupported") for ln in lines), lines

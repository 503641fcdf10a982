"""Inverse statics' results as typed records (issue 45, item 2): :class:`pytdcr.optimize.InverseResult` and the
object ``tdcr inverse --json`` prints (:class:`pytdcr.runs.InverseRun`) write themselves with ``to_json`` (today's
keys plus ``schema_version``) and read back with ``from_json``: every field of a real answer survives the round
trip, a file without ``schema_version`` (written before it existed) reads as version 1, another version is
refused, a missing key is named by its path, and the CSV table keeps its columns.
"""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pytdcr import InverseSearch, TensionBounds, inverse_statics, paper_loads, paper_robot, solve
from pytdcr.cli import main
from pytdcr.optimize import InversePath, InverseResult
from pytdcr.records import RecordKeyError
from pytdcr.runs import InverseRun, WorkspaceRecord, inverse_columns, read_workspace_inputs
from pytdcr.runtime import dump_json

ROBOT = paper_robot()
LOADS = paper_loads()
BOUNDS = TensionBounds.uniform(8, 0.0, 20.0)
#: the keys ``InverseResult.to_dict`` writes (``tdcr inverse --json`` of one target): those it wrote before typed
#: records, then the pull-ins (absent from older files, which read with ``pulled_in`` None)
RESULT_KEYS = ["target", "tensions", "tip_position", "tip_axis", "distance_m", "axis_error_rad", "reachable",
               "stable", "converged", "path", "objective", "objective_value", "optimal", "evaluations", "seconds",
               "pulled_in_m"]


def _as_written(d: dict) -> dict:
    """``d`` as a file holds it: strict JSON text read back."""
    return json.loads(dump_json(d))


def _same(a: InverseResult, b: InverseResult) -> None:
    """Every field of two answers equal (arrays exactly), ``b`` read back without an equilibrium."""
    for name in ("target", "tensions", "tip_position", "tip_axis"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name in ("distance_m", "axis_error_rad", "reachable", "stable", "converged", "path", "objective",
                 "objective_value", "optimal", "evaluations", "seconds"):
        assert getattr(a, name) == getattr(b, name), name
    assert type(b.path) is InversePath and b.solution is None
    assert (a.pulled_in is None) == (b.pulled_in is None)
    assert a.pulled_in is None or np.array_equal(a.pulled_in, b.pulled_in)


@pytest.fixture(scope="module")
def answer() -> InverseResult:
    """A real answer on the paper robot under its wrench, at a small budget: a target made by the forward model."""
    t = np.array([6.0, 0.0, 3.0, 0.0, 0.0, 2.0, 0.0, 0.0])
    made = solve(ROBOT, LOADS.with_tensions(t))
    assert made.converged
    r = inverse_statics(ROBOT, LOADS, made.tip_position, bounds=BOUNDS, search=InverseSearch(starts=1, max_solves=40))
    assert r.reachable and r.solution is not None
    return r


def test_an_answer_round_trips(answer):
    d = answer.to_json()
    assert d["schema_version"] == 1 and list(d)[1:] == RESULT_KEYS  # today's keys, in order, and the version
    assert d["path"] == answer.path.value and isinstance(d["path"], str) and type(d["path"]) is str
    back = InverseResult.from_json(_as_written(d))
    _same(answer, back)
    assert _as_written(back.to_json()) == _as_written(d)
    assert answer.to_dict() == {k: v for k, v in d.items() if k != "schema_version"}
    # the optional parts set the other way: an axis error [rad], stability untested, another path
    other = replace(answer, axis_error_rad=0.25, stable=None, path=InversePath.ANOTHER_BRANCH, reachable=False)
    _same(other, InverseResult.from_json(_as_written(other.to_json())))


def test_an_answer_gives_its_pull_ins_and_an_older_file_reads_without_them(answer):
    from pytdcr import pulled_in

    np.testing.assert_array_equal(answer.pulled_in, pulled_in(ROBOT, answer.solution))
    old = {k: v for k, v in _as_written(answer.to_json()).items() if k != "pulled_in_m"}
    assert InverseResult.from_json(old).pulled_in is None


def test_an_answer_without_schema_version_reads_as_version_1_and_another_is_refused(answer):
    old = _as_written(answer.to_dict())  # a file written before the key existed
    assert "schema_version" not in old
    _same(answer, InverseResult.from_json(old))
    with pytest.raises(ValueError, match="schema_version 2: this version of pytdcr reads 1"):
        InverseResult.from_json({**old, "schema_version": 2})
    del old["seconds"]  # the golden baselines drop times: read as 0
    assert InverseResult.from_json(old).seconds == 0.0


@pytest.mark.parametrize("key", ["tensions", "path", "reachable", "axis_error_rad", "evaluations"])
def test_a_missing_key_of_an_answer_is_named(answer, key):
    d = _as_written(answer.to_json())
    del d[key]
    with pytest.raises(RecordKeyError) as err:
        InverseResult.from_json(d)
    assert err.value.key == key and f"'{key}' is missing" in str(err.value)


def test_a_path_that_is_no_inverse_path_is_refused(answer):
    d = _as_written(answer.to_json())
    with pytest.raises(ValueError, match="path 'sideways': not one of 'loading path', 'continued'"):
        InverseResult.from_json({**d, "path": "sideways"})
    with pytest.raises(ValueError, match="must be a JSON object"):
        InverseResult.from_json([1, 2])  # type: ignore[arg-type]


# the object `tdcr inverse --json` prints, from a tiny workspace run's samples as the existing CLI tests do

@pytest.fixture(scope="module")
def workspace_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run") / "ws"
    assert main(["workspace", "--n", "64", "--budget", "60", "--directions", "0", "--out", str(out), "-q"]) in (0, 1)
    return out


def _targets(ws: Path, k: int) -> np.ndarray:
    """``k`` tips of the run's converged, stable samples (reachable from its pool)."""
    with np.load(ws / "samples.npz") as z:
        ok = z["converged"] & (z["stable"] == 1.0)
        return z["tip"][ok][:k]


def _printed(capsys, args: list[str]) -> dict:
    assert main(["inverse", *args, "--max-solves", "40", "--json"]) in (0, 1)
    return json.loads(capsys.readouterr().out)


def test_one_targets_file_round_trips(workspace_run, capsys):
    p = _targets(workspace_run, 1)[0]
    printed = _printed(capsys, ["--workspace", str(workspace_run), "--target", ",".join(f"{v:.12f}" for v in p)])
    assert list(printed)[:4] == ["schema_version", "robot", "model", "objective"]
    # the answer's keys after the head's (its objective the head's, as before)
    assert list(printed)[4:] == [k for k in RESULT_KEYS if k != "objective"] and printed["schema_version"] == 1
    run = InverseRun.from_json(printed)
    assert (run.robot, run.model, run.objective, run.along_path) == ("paper", "pcc", "least-squares", False)
    (r,) = run.results
    assert r.reachable and r.distance_m <= 1e-6 and type(r.path) is InversePath
    assert np.array_equal(r.target, np.array(printed["target"])) and r.solution is None
    assert _as_written(run.to_json()) == printed
    old = {k: v for k, v in printed.items() if k != "schema_version"}  # as `tdcr inverse --json` printed it before
    assert _as_written(InverseRun.from_json(old).to_json()) == printed
    del old["objective_value"]
    with pytest.raises(RecordKeyError) as err:
        InverseRun.from_json(old)
    assert err.value.key == "objective_value" and err.value.file == "inverse answers"


def test_a_paths_file_and_its_table_round_trip(workspace_run, tmp_path, capsys):
    targets = tmp_path / "path.csv"
    targets.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.12f}" for v in p) for p in _targets(workspace_run, 3)))
    table = tmp_path / "out" / "answers.csv"
    printed = _printed(capsys, ["--workspace", str(workspace_run), "--targets", str(targets), "--csv", str(table)])
    assert list(printed) == ["schema_version", "robot", "model", "objective", "points"]
    assert all(list(p) == RESULT_KEYS for p in printed["points"])  # no version repeated in each point
    run = InverseRun.from_json(printed)
    assert run.along_path and len(run.results) == 3
    assert _as_written(run.to_json()) == printed
    rows = list(csv.reader(table.open()))
    assert rows[0] == inverse_columns(8)
    for row, r in zip(rows[1:], run.results, strict=True):  # the table holds what the JSON holds
        assert [float(v) for v in row[:22]] == [*r.target, *r.tensions, *r.pulled_in, *r.tip_position]
        assert row[23] == str(r.reachable) and row[25] == r.path.value
    broken = _as_written(printed)
    del broken["points"][1]["path"]
    with pytest.raises(RecordKeyError) as err:
        InverseRun.from_json(broken)
    assert err.value.key == "points[1].path" and "'points[1].path' is missing" in str(err.value)
    old = {k: v for k, v in printed.items() if k != "schema_version"}
    assert _as_written(InverseRun.from_json(old).to_json()) == printed
    with pytest.raises(ValueError, match="schema_version 7"):
        InverseRun.from_json({**printed, "schema_version": 7})


def test_one_target_has_one_answer(answer):
    with pytest.raises(ValueError, match="one target has one answer, got 2"):
        InverseRun("paper", "pcc", "least-squares", (answer, answer))


def test_the_workspace_inputs_read_their_file_as_a_typed_record(workspace_run):
    inputs = read_workspace_inputs(workspace_run)
    record = inputs.record
    assert isinstance(record, WorkspaceRecord)
    assert record.inputs == inputs.summary["inputs"]
    assert record.summary.fsw.volume_m3 == inputs.summary["volume_m3"]

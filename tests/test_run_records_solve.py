"""The solve, sample and optimize runs' typed records (issue 45): each reads what the golden baselines hold of
``tdcr solve --json``, ``sample_run.json``, ``tdcr optimize --json`` and ``optimize*.json``, writes it back key for
key, reads a fresh run's output, is read by attribute, and refuses a renamed key naming it, a part that is not an
object and another schema version."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pytdcr.optimize._result import SCHEMA_VERSION, GASettings, Optimum, ReachResult
from pytdcr.records import RecordKeyError
from pytdcr.runs._runs import OptimizeRecord, SampleRecord, SampleRunCounts, SampleSummary
from pytdcr.runs._solve import SolutionRecord, SolveRecord
from pytdcr.runtime import dump_json
from pytdcr.statics import SolvePath

GOLDEN = Path(__file__).resolve().parent / "golden"
#: what the golden baselines drop (tests/test_golden.py's VOLATILE, as it touches these records): times and
#: versions, the schema's included
VOLATILE = re.compile(r"second|time|version")


def _scrubbed(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _scrubbed(v) for k, v in data.items() if not VOLATILE.search(k)}
    if isinstance(data, list):
        return [_scrubbed(v) for v in data]
    return data


def _golden(name: str) -> Any:
    return json.loads((GOLDEN / f"{name}.json").read_text())["data"]


def _through_text(d: dict[str, Any]) -> dict[str, Any]:
    """``d`` as a file holds it: strict JSON text (non-finite numbers as null) read back."""
    return json.loads(dump_json(d))


SOLVE_CASES = [(f"{m}/{case}", v["result"]) for m in ("pcc", "pcc2", "sscr", "cosserat")
               for case, v in _golden(f"solve_{m}").items()]
SAMPLE_FILES = [(n, _golden(n)["files"]["sample_run.json"]) for n in ("sample", "sample_sscr")]
OPTIMIZE_FILES = [(f"{n}/{k}", v) for n in ("reproduce", "reproduce_demo") for k, v in _golden(n)["files"].items()
                  if re.fullmatch(r"optimize(_\w+)?\.json", k)]


# ---------------------------------------------------------------- the golden baselines load and write back
@pytest.mark.parametrize(("name", "data"), SOLVE_CASES, ids=[n for n, _ in SOLVE_CASES])
def test_every_golden_solve_result_reads_and_writes_back(name, data):
    rec = SolveRecord.from_json(data)
    assert _scrubbed(_through_text(rec.to_json())) == data, name
    sol = rec.solution
    assert rec.robot == data["robot"] and sol.converged == data["converged"] and sol.residual == data["residual"]
    assert sol.path == SolvePath(data["path"]) and sol.seconds == 0.0  # the baselines drop times
    assert sol.stable == data["stable"] and rec.compliance is None and rec.jacobians is None
    if data["converged"]:
        assert sol.tip_position.tolist() == data["tip_position"] and sol.q.tolist() == data["q"]
        assert sol.disk_positions.shape == (len(data["disk_positions"]), 3)
    if data["stability"] is not None:
        st = data["stability"]
        assert sol.stability.flutter_pairs == st["flutter_pairs"] and sol.stability.stable == st["stable"]
        pair = st["least_damped_pair"]
        assert (sol.stability.least_damped is None) == (pair is None)
        if pair is not None:
            assert [sol.stability.least_damped.real, sol.stability.least_damped.imag] == pair


def test_the_golden_solve_results_hold_flutter_and_every_model():
    assert {n.split("/")[0] for n, _ in SOLVE_CASES} == {"pcc", "pcc2", "sscr", "cosserat"}
    assert any(d["stability"] and d["stability"]["least_damped_pair"] for _, d in SOLVE_CASES)


@pytest.mark.parametrize(("name", "data"), SAMPLE_FILES, ids=[n for n, _ in SAMPLE_FILES])
def test_every_golden_sample_run_json_reads_and_writes_back(name, data):
    rec = SampleRecord.from_json(data)
    assert _scrubbed(rec.to_json()) == data, name
    assert rec.counts.converged == data["converged"] and rec.counts.unstable == data["unstable"]
    assert rec.counts.stability_test == data["stability_test"] and rec.counts.reach_max_m == data["reach_max_m"]
    assert rec.solved == data["solved"] and rec.complete is data["complete"] and list(rec.files) == data["files"]
    assert rec.inputs == data["inputs"] and rec.seconds == 0.0


def test_the_golden_optimize_result_reads_and_writes_back():
    data = _golden("optimize")["result"]
    res = ReachResult.from_json(data)
    assert _scrubbed(res.to_json()) == data
    _same_reach(res, data)


@pytest.mark.parametrize(("name", "data"), OPTIMIZE_FILES, ids=[n for n, _ in OPTIMIZE_FILES])
def test_every_golden_optimize_json_reads_and_writes_back(name, data):
    rec = OptimizeRecord.from_json(data)
    assert _scrubbed(rec.to_json()) == data, name
    assert rec.inputs == data["inputs"] and list(rec.files) == data["files"]
    _same_reach(rec.result, data["result"])
    assert rec.result.ga_settings.pop_size == data["inputs"]["pop"]


def test_the_golden_baselines_hold_optimize_files():
    assert len(OPTIMIZE_FILES) >= 2


def _same_reach(res: ReachResult, data: dict[str, Any]) -> None:
    """``res`` holds ``data``'s numbers, read by attribute."""
    assert res.tensions.tolist() == data["tensions"] and res.reach == data["reach"] and res.stable == data["stable"]
    assert res.stop_reason == data["stop_reason"] and res.generations == data["generations"]
    assert res.ga.reach == data["ga"]["reach"] and res.ga.tensions.tolist() == data["ga"]["tensions"]
    assert res.polish.message == data["polish"]["message"] and res.polish_evaluations == data["polish"]["evaluations"]
    h = res.per_generation
    assert h.best.tolist() == data["history"]["best"] and list(h.evaluations) == data["history"]["evaluations"]
    assert res.ga_settings == GASettings(*(data["settings"][k] for k in ("pop_size", "tol", "window", "max_gen",
                                                                          "polish", "local_search",
                                                                          "local_search_runs")))
    assert res.settings == data["settings"] and res.seconds == 0.0


# ---------------------------------------------------------------- fresh runs
@pytest.fixture(scope="module")
def solve_run():
    from pytdcr.runs import SolveSettings, run_solve

    return run_solve(SolveSettings(tensions=(3.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0)), compliance=True,
                     jacobians=True)


def test_a_fresh_solve_round_trips_exactly_with_its_derivatives(solve_run):
    text = dump_json(solve_run.to_json())
    rec = SolveRecord.from_json(json.loads(text))
    assert dump_json(rec.to_json()) == text  # key order and times included
    d = json.loads(text)
    assert list(d)[:3] == ["schema_version", "robot", "converged"] and list(d)[-2:] == ["compliance", "jacobians"]
    assert d["schema_version"] == 1 and solve_run.to_dict() == solve_run.to_json()
    sol = solve_run.solution
    assert rec.solution.converged and np.array_equal(rec.solution.tip_position, sol.tip_position)
    assert np.array_equal(rec.solution.tip_rotation, sol.tip_rotation) and rec.solution.seconds == sol.seconds
    assert np.array_equal(rec.compliance.matrix, solve_run.compliance.matrix)
    assert np.array_equal(rec.jacobians.disk_positions, solve_run.jacobians.disk_positions)
    assert rec.solution.stability == sol.stability


def _before_the_record(run: Any) -> dict[str, Any]:
    """What ``SolveRun.to_dict`` printed before the typed record: the robot's name, the solution's dictionary, the
    compliance's and the Jacobians' when computed."""
    out = {"robot": run.robot.name, **run.solution.to_dict()}
    if run.compliance is not None:
        out["compliance"] = run.compliance.to_dict()
    if run.jacobians is not None:
        out["jacobians"] = run.jacobians.to_dict()
    return out


def test_the_record_prints_what_the_solution_printed_before(solve_run):
    """The same keys, order and values as before the record, plus each tendon's pull-in (issue 48)."""
    from pytdcr import pulled_in

    d = solve_run.to_json()
    assert d.pop("schema_version") == 1
    assert d.pop("pulled_in_m") == pulled_in(solve_run.robot, solve_run.solution).tolist()
    assert dump_json(d) == dump_json(_before_the_record(solve_run))  # keys, order and values


def test_a_live_solve_that_did_not_converge_prints_as_before_and_round_trips():
    from pytdcr import Loads, paper_robot, solve
    from pytdcr.runs import SolveRun
    from pytdcr.statics import SolverOptions, get_model

    robot = paper_robot()
    loads = Loads(np.array([6.8, 0, 9.7, 12.2, 1.9, 4.8, 16.1, 16.8]), tip_force=np.array([0.1, 0.1, -0.1]))
    sol = solve(robot, loads, options=SolverOptions(max_iter=1, step_iter=1, load_stepping="never"))
    assert not sol.converged
    run = SolveRun(robot, loads, get_model("pcc"), sol)
    text = dump_json(run.to_json())
    d = json.loads(text)
    assert d.pop("schema_version") == 1 and dump_json(d) == dump_json(_before_the_record(run))
    rec = SolveRecord.from_json(json.loads(text))
    assert dump_json(rec.to_json()) == text and rec.solution.tip_position is None and rec.solution.q is None
    assert rec.solution.residual == sol.residual > sol.atol and rec.solution.path == sol.path


def test_a_solve_that_did_not_converge_round_trips_with_its_shape_absent():
    data = copy.deepcopy(SOLVE_CASES[0][1])
    data.update(converged=False, failure="the backbone passes through itself", stable=None, stability=None,
                residual=None, path="self-contact",
                **dict.fromkeys(("tip_position", "tip_rotation", "disk_positions", "q", "tensions")))
    rec = SolveRecord.from_json(data)
    assert rec.solution.tip_position is None and rec.solution.stability is None
    assert math.isnan(rec.solution.residual) and rec.solution.path is SolvePath.SELF_CONTACT
    assert _scrubbed(_through_text(rec.to_json())) == data


def test_tdcr_solve_json_prints_the_record():
    from pytdcr.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["solve", "--tensions", "3,0,0,0,2,0,0,0", "--json", "--compliance"])
    d = json.loads(buf.getvalue())
    rec = SolveRecord.from_json(d)
    assert code == 0 and d["schema_version"] == 1 and rec.compliance is not None
    assert rec.to_json() == d


#: the counts of a sample run, in the files' order (as written before the typed record)
COUNTS = ["converged", "not_converged", "unstable", "stability_test", "stability_untested", "reach_max_m"]


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory):
    from pytdcr.runs import SampleSettings, run_sample

    out = tmp_path_factory.mktemp("sample") / "s"
    return run_sample(SampleSettings(n=6, seed=2, n_shapes=1), out), out


def test_a_fresh_sample_run_json_loads_and_round_trips(sample_run):
    run, out = sample_run
    text = (out / "sample_run.json").read_text()
    data = json.loads(text)
    rec = SampleRecord.from_json(data)
    assert rec.to_json() == data and data["schema_version"] == 1
    assert list(data) == ["schema_version", "inputs", "solved", "complete", *COUNTS, "seconds", "files"]
    assert rec.counts == run.counts == SampleRunCounts.of(run.samples, run.model)
    assert rec.solved == 6 and rec.complete and rec.seconds == run.samples.seconds and rec.seconds > 0
    assert list(rec.files) == run.files and rec.inputs["n"] == 6
    assert rec.counts.converged + rec.counts.not_converged == 6
    assert rec.counts.reach_max_m == float(np.nanmax(run.samples.reach))


def test_the_counts_count_only_the_converged_samples_and_know_an_untested_model():
    """A row that did not converge is never unstable (its 0 is not a tested state); a model without the test
    has no unstable count (None), every converged sample untested."""
    from types import SimpleNamespace

    ok = np.array([True, True, False, False])
    tips = np.array([[0.1, 0.0, 0.2], [0.3, 0.0, 0.1], [np.nan] * 3, [np.nan] * 3])
    samples = SimpleNamespace(converged=ok, stable=np.array([0.0, 1.0, 0.0, np.nan]),
                              reach=np.linalg.norm(tips, axis=1))
    c = SampleRunCounts.of(samples, "pcc")
    assert (c.converged, c.not_converged, c.unstable, c.stability_untested, c.stability_test) == (2, 2, 1, 0, "run")
    assert c.reach_max_m == float(np.linalg.norm(tips[1]))
    untested = SimpleNamespace(converged=ok, stable=np.full(4, np.nan), reach=samples.reach)
    u = SampleRunCounts.of(untested, "cosserat")  # no stability test: the solver leaves NaN
    assert u.unstable is None and u.stability_test == "untested" and u.stability_untested == 2
    none = SampleRunCounts.of(SimpleNamespace(converged=np.zeros(4, dtype=bool), stable=np.full(4, np.nan),
                                              reach=np.full(4, np.nan)), "pcc")
    assert none.converged == 0 and none.reach_max_m is None
    assert SampleRunCounts.from_json(json.loads(json.dumps(u.to_json()))) == u


def test_a_sample_runs_summary_round_trips(sample_run):
    run, _ = sample_run
    text = json.dumps(run.to_json())
    summary = SampleSummary.from_json(json.loads(text))
    assert json.dumps(summary.to_json()) == text and summary == run.summary
    assert run.to_dict() == run.to_json() and summary.robot == run.robot.name and summary.seed == 2
    assert list(json.loads(text)) == ["schema_version", "robot", "solved", "seed", *COUNTS, "seconds", "files"]


@pytest.fixture(scope="module")
def optimize_run(tmp_path_factory):
    from pytdcr.runs import OptimizeSettings, run_optimize

    out = tmp_path_factory.mktemp("optimize") / "o"
    return run_optimize(OptimizeSettings(pop=4, max_gen=2, window=1, seed=1), out), out


def test_a_fresh_optimize_json_loads_and_round_trips(optimize_run):
    run, out = optimize_run
    text = (out / "optimize.json").read_text()
    data = json.loads(text)
    rec = OptimizeRecord.from_json(data)
    assert rec.to_json() == data and data["schema_version"] == 1 and data["result"]["schema_version"] == 1
    assert list(data) == ["schema_version", "inputs", "result", "files"]
    res = rec.result
    assert np.array_equal(res.tensions, run.result.tensions) and res.reach == run.result.reach
    assert res.seconds == run.result.seconds > 0 and res.history == run.result.history
    assert res.settings == run.result.settings and res.polish == run.result.polish
    assert res.ga_settings.pop_size == 4 and res.ga_settings.max_gen == 2
    assert list(rec.files) == run.files[:-1] and run.files[-1] == "optimize.json"
    history = (out / "history.csv").read_text().splitlines()
    assert len(history) == 1 + res.generations == 1 + len(res.per_generation.best)


def test_an_optimize_run_and_its_result_round_trip(optimize_run):
    run, _ = optimize_run
    text = dump_json(run.to_json())
    again = OptimizeRecord.from_json(json.loads(text))
    assert dump_json(again.to_json()) == text and again.inputs is None and "inputs" not in json.loads(text)
    assert run.to_dict() == run.to_json() and run.result.to_dict() == run.result.to_json()
    one = dump_json(run.result.to_json())
    assert dump_json(ReachResult.from_json(json.loads(one)).to_json()) == one


def test_a_polish_alone_round_trips_its_empty_history_and_unknown_start(optimize_run):
    """A polish alone has no history, no GA settings and a start whose tip is unknown (NaN, null in JSON)."""
    from pytdcr.optimize import polish_reach

    run, out = optimize_run
    res = polish_reach(run.problem, run.result.ga.tensions, max_iter=2, restarts=0)
    d = json.loads(dump_json(res.to_json()))
    assert d["history"] == {} and d["ga"]["tip_position"] == [None, None, None] and d["seed"] is None
    again = ReachResult.from_json(d)
    assert np.all(np.isnan(again.ga.tip_position)) and math.isnan(again.ga.reach) and again.ga_settings is None
    assert again.per_generation.best.size == 0 and again.to_json() == d
    with pytest.raises(ValueError, match="polish alone"):
        from pytdcr.runs import write_optimize

        write_optimize(res, run.problem, out)


def test_an_optimum_reads_back():
    o = Optimum(np.array([1.0, -0.0]), np.array([0.1, 0.2, np.nan]), 0.3, 3.3, None)
    d = json.loads(dump_json(o.to_dict()))
    back = Optimum.from_json(d)
    assert back.to_dict() == d and back.stable is None and math.isnan(back.tip_position[2])


# ---------------------------------------------------------------- refusals
def _solve_data() -> dict[str, Any]:
    return copy.deepcopy(next(d for n, d in SOLVE_CASES if d["stability"] and d["stability"]["least_damped_pair"]))


def _sample_data() -> dict[str, Any]:
    return copy.deepcopy(SAMPLE_FILES[0][1])


def _optimize_data() -> dict[str, Any]:
    return copy.deepcopy(OPTIMIZE_FILES[0][1])


READERS = {"solve": (SolveRecord.from_json, _solve_data), "sample": (SampleRecord.from_json, _sample_data),
           "optimize": (OptimizeRecord.from_json, _optimize_data)}


@pytest.mark.parametrize(("record", "path", "named"), [
    ("solve", ("residual",), "residual"),
    ("solve", ("robot",), "robot"),
    ("solve", ("tip_position",), "tip_position"),
    ("solve", ("stability", "flutter_pairs"), "stability.flutter_pairs"),
    ("sample", ("unstable",), "unstable"),
    ("sample", ("reach_max_m",), "reach_max_m"),
    ("sample", ("inputs",), "inputs"),
    ("sample", ("files",), "files"),
    ("optimize", ("result",), "result"),
    ("optimize", ("result", "reach"), "result.reach"),
    ("optimize", ("result", "polish", "message"), "result.polish.message"),
    ("optimize", ("result", "ga", "tip_position"), "result.ga.tip_position"),
    ("optimize", ("result", "rejected_unstable"), "result.rejected_unstable"),
    ("optimize", ("files",), "files"),
])
def test_a_renamed_key_is_refused_naming_it(record, path, named):
    read, make = READERS[record]
    data = make()
    part = data
    for key in path[:-1]:
        part = part[key]
    part[path[-1] + "_renamed"] = part.pop(path[-1])
    with pytest.raises(RecordKeyError) as info:
        read(data)
    assert info.value.key == named and repr(named) in str(info.value)


def test_a_reach_result_names_its_own_missing_key():
    data = _golden("optimize")["result"]
    data = {k: v for k, v in data.items() if k != "stop_reason"}
    with pytest.raises(RecordKeyError) as info:
        ReachResult.from_json(data)
    assert info.value.key == "stop_reason" and info.value.file == "reach result"


@pytest.mark.parametrize("record", list(READERS))
def test_another_schema_version_is_refused(record):
    read, make = READERS[record]
    data = make()
    read(data)  # without the key: version 1
    data["schema_version"] = 2
    with pytest.raises(ValueError, match="schema_version 2"):
        read(data)


def test_a_nested_result_of_another_schema_or_not_an_object_is_refused():
    data = _optimize_data()
    data["result"]["schema_version"] = SCHEMA_VERSION + 1
    with pytest.raises(ValueError, match=f"schema_version {SCHEMA_VERSION + 1}"):
        OptimizeRecord.from_json(data)
    data = _optimize_data()
    data["result"]["polish"] = "none"
    with pytest.raises(ValueError, match="polish must be a JSON object"):
        OptimizeRecord.from_json(data)
    data = _solve_data()
    data["stability"] = [1, 2]
    with pytest.raises(ValueError, match="stability must be a JSON object"):
        SolveRecord.from_json(data)
    with pytest.raises(ValueError, match="must be a JSON object"):
        SampleRecord.from_json([1])


def test_a_record_reads_its_parts_typed():
    rec = SampleRecord.from_json(_sample_data())
    assert isinstance(rec.counts, SampleRunCounts) and isinstance(rec.files, tuple)
    sol = SolveRecord.from_json(_solve_data()).solution
    assert isinstance(sol, SolutionRecord) and isinstance(sol.path, SolvePath) and sol.stability.least_damped.imag > 0

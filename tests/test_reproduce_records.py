"""``tdcr reproduce``'s result as typed records (issue 45): its parts round-trip through their JSON, a whole
``reproduce.json`` of a tiny real run reads back into a :class:`ReproduceRun` that writes the same file, an old
file without ``schema_version`` loads (as do the golden baselines' files), a missing key is named by its path
and a NaN reach survives."""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_golden import scrub

from pytdcr import Backbone, ConstantFriction, Robot, Segment, Tendon
from pytdcr.optimize import ReachResult
from pytdcr.records import RecordKeyError
from pytdcr.runs import PassiveSolveRecord, ReproduceRun, ReproduceSettings, SamplingRecord, run_reproduce
from pytdcr.runs._survival import ModelVerdict

GOLDEN = Path(__file__).resolve().parent / "golden"

#: the slow test's study (tests/test_workspace_optimize.py), one better model and the smallest workspace section:
#: about 10 s on 2 cores
TINY = ReproduceSettings(pops=(8, 10), n_samples=10, max_gen=3, bound_uppers=(5.0,), side_max_gen=2,
                         verdict_models=("pcc2",), workspace_n=16, workspace_budget=0)


def _text(d: object) -> str:
    """Strict JSON text, as ``write_json`` writes it (keys sorted: the comparison ignores their order)."""
    return json.dumps(d, allow_nan=False, sort_keys=True)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[ReproduceRun, dict]:
    """A tiny real study on a small robot: its result and its ``reproduce.json``."""
    robot = Robot(name="small", backbone=Backbone(youngs_modulus=54e9, poissons_ratio=0.3, outer_radius=0.7e-3),
                  segments=(Segment(length=0.12, n_disks=6, disk_mass=2e-4),),
                  tendons=tuple(Tendon(segment=1, radius=0.008, angle_deg=a) for a in (0, 90, 180, 270)),
                  friction=ConstantFriction(mu=0.1))
    out = tmp_path_factory.mktemp("reproduce") / "r"
    run = run_reproduce(robot, out, seed=0, settings=TINY)
    return run, json.loads((out / "reproduce.json").read_text())


# ---------------------------------------------------------------- the parts
def test_the_sampling_record_round_trips_and_keeps_todays_keys():
    rec = SamplingRecord.of(5, np.array([True, True, False, True, True]),
                            np.array([0.31, 0.12, np.nan, 0.3874, 0.0141]), 1.25)
    assert rec == SamplingRecord(5, 4, 1.25, 0.3874, 0.0141)
    d = rec.to_json()
    assert list(d) == ["n", "converged", "seconds", "reach_max", "reach_min"]
    assert SamplingRecord.from_json(json.loads(_text(d))) == rec


def test_a_nan_reach_survives_the_file():
    """No sample converged: the reach range is NaN (no numpy warning), written null and read back NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = SamplingRecord.of(3, np.zeros(3, dtype=bool), np.full(3, np.nan), 0.5)
    assert rec.converged == 0 and np.isnan(rec.reach_max) and np.isnan(rec.reach_min)
    text = _text(rec.to_json())
    assert '"reach_max": null' in text and '"reach_min": null' in text
    back = SamplingRecord.from_json(json.loads(text))
    assert back.n == 3 and np.isnan(back.reach_max) and np.isnan(back.reach_min)
    verdict = ModelVerdict("sscr", False, float("nan"), float("nan"), None, "re-optimisation failed")
    vback = ModelVerdict.from_json(json.loads(_text(verdict.to_json())))
    assert np.isnan(vback.reach) and np.isnan(vback.tip_shift) and vback.reoptimised is None
    assert vback.model == "sscr" and vback.converged is False and vback.method == "re-optimisation failed"


@pytest.mark.parametrize("rec", [PassiveSolveRecord(True, (0.1, -0.2, 0.3), 0.37416573867739417),
                                 PassiveSolveRecord(False)])
def test_the_passive_solve_record_round_trips(rec):
    assert list(rec.to_json()) == ["converged", "tip", "reach"]
    d = json.loads(_text(rec.to_json()))
    assert PassiveSolveRecord.from_json(d) == rec
    assert (d["tip"] is None) == (not rec.converged) and (d["reach"] is None) == (not rec.converged)


def test_a_passive_tip_of_other_than_3_numbers_is_refused():
    with pytest.raises(ValueError, match=r"passive\.tip must be a list of 3 numbers"):
        PassiveSolveRecord.from_json({"converged": True, "tip": [0.1, 0.2], "reach": 0.3})


def test_a_passive_solve_that_did_not_converge_keeps_no_tip():
    rec = PassiveSolveRecord.of(False, np.array([np.nan, np.nan, np.nan]), float("nan"))
    assert rec == PassiveSolveRecord(False, None, None)
    assert PassiveSolveRecord.of(True, np.array([0.0, 3.0, 4.0]), 5.0) == PassiveSolveRecord(True, (0.0, 3.0, 4.0), 5.0)


# ---------------------------------------------------------------- a whole reproduce.json
def test_the_run_writes_its_to_json_and_reads_back_into_the_same_types(tiny):
    run, data = tiny
    assert data["schema_version"] == 1
    assert _text(run.to_json()) == _text(data)
    back = ReproduceRun.from_json(data)
    assert _text(back.to_json()) == _text(data)
    assert back.sampling == run.sampling and back.passive == run.passive and back.workspace == run.workspace
    assert back.seed == 0 and back.files == run.files and back.files[-1] == "report.md"
    assert back.seconds == run.seconds and back.inputs == data["inputs"]
    assert sorted(back.ga) == [8, 10] and all(isinstance(r, ReachResult) for r in back.ga.values())
    assert np.array_equal(back.ga[8].tensions, run.ga[8].tensions) and back.payload.reach == run.payload.reach
    assert [hi for hi, _ in back.bounds_study] == [5.0]
    assert back.bounds_study[0][1].reach == run.bounds_study[0][1].reach
    assert [v.model for v in back.verdicts] == ["pcc2"] and back.verdicts[0].reach == run.verdicts[0].reach
    # today's keys and meanings: the summary is what summary() gives, the parts where they always were
    assert data["summary"] == run.summary() and run.to_dict() == {**run.summary(), "seconds": run.seconds}
    assert data["summary"]["sampling"]["n"] == 10 and data["summary"]["sampling"]["converged"] == run.sampling.converged
    assert data["bounds_study"][0]["upper"] == 5.0 and set(data["ga"]) == {"8", "10"}


def test_the_closing_lines_read_a_run_read_back_from_its_file(tiny):
    from pytdcr.cli.reproduce import closing_lines

    run, data = tiny
    assert closing_lines(ReproduceRun.from_json(data)) == closing_lines(run)


def test_a_reproduce_json_without_schema_version_loads_and_another_version_is_refused(tiny):
    _, data = tiny
    old = {k: v for k, v in data.items() if k != "schema_version"}
    assert _text(ReproduceRun.from_json(old).to_json()) == _text(data)
    with pytest.raises(ValueError, match=r"reproduce\.json: schema_version 2"):
        ReproduceRun.from_json({**data, "schema_version": 2})


@pytest.mark.parametrize(("edit", "named"), [
    (lambda d: d["summary"]["sampling"].pop("reach_max"), "summary.sampling.reach_max"),
    (lambda d: d["summary"]["passive"].pop("tip"), "summary.passive.tip"),
    (lambda d: d["summary"]["workspace"]["cases"][1].pop("volume_m3"), "summary.workspace.cases[1].volume_m3"),
    (lambda d: d["summary"].pop("files"), "summary.files"),
    (lambda d: d["ga"]["10"].pop("history"), "ga.10.history"),
    (lambda d: d["payload"]["polish"].pop("evaluations"), "payload.polish.evaluations"),
    (lambda d: d["bounds_study"][0].pop("upper"), "bounds_study[0].upper"),
    (lambda d: d["better_models"][0].pop("method"), "better_models[0].method"),
    (lambda d: d.pop("inputs"), "inputs"),
])
def test_a_missing_key_of_a_reproduce_json_is_named_by_its_path(tiny, edit, named):
    data = copy.deepcopy(tiny[1])
    edit(data)
    with pytest.raises(RecordKeyError) as info:
        ReproduceRun.from_json(data)
    assert info.value.key == named and info.value.file == "reproduce.json"


def test_a_missing_key_of_a_better_models_reoptimisation_is_named_by_its_path(tiny):
    data = copy.deepcopy(tiny[1])
    assert data["better_models"][0]["reoptimised"] is not None
    data["better_models"][0]["reoptimised"].pop("tensions")
    with pytest.raises(RecordKeyError) as info:
        ReproduceRun.from_json(data)
    assert info.value.key == "better_models[0].reoptimised.tensions"


@pytest.mark.parametrize("name", ["reproduce", "reproduce_demo"])
def test_the_golden_reproduce_files_read_and_write_back(name):
    """The baselines' files (written before ``schema_version``, times dropped) load; written back and their times
    dropped as the baselines drop them, they are the same."""
    data = json.loads((GOLDEN / f"{name}.json").read_text())["data"]["files"]["reproduce.json"]
    assert "schema_version" not in data and "seconds" not in data
    run = ReproduceRun.from_json(data)
    assert scrub(run.to_json()) == data
    assert run.sampling.n == data["summary"]["sampling"]["n"] and run.passive.converged is True
    assert sorted(run.ga) == sorted(int(p) for p in data["ga"])

"""Issue 44, class 3: a design study resumed in its ``--out`` reads its own earlier per-design files, which may have
been edited or replaced since. A design file that cannot be trusted (a FIFO, a link, garbage, a record whose
numbers are not finite numbers, whose design or values are another's, whose rows are not the study's) is
computed again, never an error, never a hang, never followed through a link; the final table equals an
uninterrupted run's.

The designs run in this process (the executor is swapped for one that evaluates each design as it is handed
over): what is tested is what the resume reads, and a design costs about a second here instead of a worker
process's start.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import stat
import threading
from concurrent.futures import Future
from pathlib import Path
from typing import ClassVar

import pytest

from pytdcr.designs import DesignsRunOptions, _run, evaluate_design, run_designs, study_from_dict
from pytdcr.designs._records import RecordShape
from pytdcr.runtime import dump_json

#: the design whose file is spoiled (an ok one: backbone 0.7 mm, routing 10 mm)
SPOILED = 1
#: how long one resumed run may take before it counts as hung (a FIFO opened for reading blocks) [s]
HANG_S = 120.0
VICTIM = b"a file of the user's that no run may touch\n"


def _study():
    """Four designs of two parameters (design 2 fails: its tendons inside its backbone), small budget."""
    return study_from_dict({
        "name": "t", "robot": "paper", "seed": 3, "bounds": [0.0, 10.0],
        "parameters": {"backbone_radius": {"values": [0.0007, 0.003]},
                       "routing_radius_2": {"values": [0.002, 0.01]}},
        "budget": {"samples": 16, "search": 0}, "loads": {"cases": ["no load"]}, "reference": False,
        "measures": {"directions": {"up": [0.0, 0.0, 1.0]}}})


class _InProcess:
    """An executor that evaluates each design in this process as it is submitted, noting its index."""

    computed: ClassVar[list[int]] = []

    def __init__(self, workers: int) -> None:
        self.name = "this process"

    def submit(self, *args):
        fut = Future()
        fut.set_result(evaluate_design(*args))
        _InProcess.computed.append(args[2])
        return fut

    def close(self, cancel: bool) -> None:
        pass


def _run_study(out: Path):
    """Run (or resume) the study into ``out`` in a thread, so that a hang fails the test instead of blocking it;
    returns the run and the designs computed."""
    study, robot = _study()
    _InProcess.computed = []
    got: dict = {}

    def target():
        try:
            got["run"] = run_designs(study, robot, out, options=DesignsRunOptions(workers=1, figures=False))
        except BaseException as err:  # handed to the test
            got["err"] = err

    th = threading.Thread(target=target, daemon=True)
    th.start()
    th.join(HANG_S)
    assert not th.is_alive(), "the resumed study hung on what sits at a design file's name"
    if "err" in got:
        raise got["err"]
    return got["run"], sorted(_InProcess.computed)


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """An uninterrupted run: its folder and its table."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_run, "_Local", _InProcess)
        out = tmp_path_factory.mktemp("baseline") / "out"
        run, computed = _run_study(out)
    assert computed == [0, 1, 2, 3] and list(run.table["status"]) == ["ok", "ok", "failed", "ok"]
    return out, run.table


@pytest.fixture
def resume(baseline, tmp_path, monkeypatch):
    """A copy of the finished folder to spoil, and a resume of it."""
    monkeypatch.setattr(_run, "_Local", _InProcess)
    out = tmp_path / "out"
    shutil.copytree(baseline[0], out, symlinks=True)
    return out, lambda: _run_study(out)


def _record(out: Path, index: int = SPOILED) -> dict:
    return json.loads((out / "designs" / f"{index:06d}.json").read_text())


def _untimed(rec: dict) -> dict:
    return {k: v for k, v in rec.items() if k != "timing"}


def _edit_measure(value: str):
    """A spoiler that writes ``value`` (raw JSON text) as the record's volume."""
    def spoil(path: Path, tmp: Path) -> None:
        rec = json.loads(path.read_text())
        rec["rows"][0]["volume_m3"] = "@@"
        path.write_text(json.dumps(rec).replace('"@@"', value))
    return spoil


def _fifo(path: Path, tmp: Path) -> None:
    path.unlink()
    os.mkfifo(path)


def _garbage(path: Path, tmp: Path) -> None:
    path.write_bytes(b"\x00{not json at all" * 20)


def _truncated(path: Path, tmp: Path) -> None:
    path.write_bytes(path.read_bytes()[:100])


def _folder(path: Path, tmp: Path) -> None:
    path.unlink()
    (path / "inside").mkdir(parents=True)


def _another_designs_record(path: Path, tmp: Path) -> None:
    """Design 0's record (its values) at design 1's name, its index changed to 1."""
    rec = json.loads((path.parent / "000000.json").read_text())
    rec["design"] = SPOILED
    path.write_text(json.dumps(rec))


def _index_a_bool(path: Path, tmp: Path) -> None:
    """Design 1's own record with ``"design": true`` (true == 1 in Python)."""
    rec = json.loads(path.read_text())
    rec["design"] = True
    path.write_text(json.dumps(rec))


def _param_edited(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["params"]["backbone_radius"] = 0.003
    path.write_text(json.dumps(rec))


def _param_a_string(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["params"]["backbone_radius"] = str(rec["params"]["backbone_radius"])
    path.write_text(json.dumps(rec))


def _a_row_too_many(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["rows"].append({**rec["rows"][0], "load_case": "paper wrench"})
    path.write_text(json.dumps(rec))


def _a_key_too_many(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["rows"][0]["colour"] = "red"
    path.write_text(json.dumps(rec))


def _tensions_edited(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["rows"][0]["reach_tensions_n"] = ["1"] * 8
    path.write_text(json.dumps(rec))


def _timing_edited(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["timing"]["injected"] = "=cmd|' /C calc'!A0"
    path.write_text(json.dumps(rec))


def _status_edited(path: Path, tmp: Path) -> None:
    rec = json.loads(path.read_text())
    rec["status"] = "great"
    path.write_text(json.dumps(rec))


@pytest.mark.parametrize("spoil", [
    _fifo, _garbage, _truncated, _folder, _edit_measure("NaN"), _edit_measure('"big"'), _edit_measure("true"),
    _edit_measure("1e400"), _edit_measure("-Infinity"), _edit_measure("1" + "0" * 400), _another_designs_record,
    _index_a_bool, _param_edited, _param_a_string, _a_row_too_many, _a_key_too_many, _tensions_edited,
    _timing_edited, _status_edited,
], ids=["fifo", "garbage", "truncated", "folder", "nan", "string", "bool", "1e400", "-inf", "huge-int",
        "another-design", "index-true", "param-edited", "param-string", "row-too-many", "key-too-many", "tensions",
        "timing", "status"])
def test_a_design_file_that_cannot_be_trusted_is_computed_again(spoil, baseline, resume, tmp_path):
    out, again = resume
    path = out / "designs" / f"{SPOILED:06d}.json"
    spoil(path, tmp_path)
    run, computed = again()
    assert computed == [SPOILED]
    assert run.table.equals(baseline[1])
    assert stat.S_ISREG(os.lstat(path).st_mode)
    assert _untimed(_record(out)) == _untimed(_record(baseline[0]))  # written whole again, the same record


def test_a_link_at_a_design_file_is_not_followed_nor_written_through(baseline, resume, tmp_path):
    """A link to a file elsewhere (here: the design's own whole record, so that following it would be believed)
    is not read; the design is computed again and its record replaces the link, the target untouched."""
    out, again = resume
    path = out / "designs" / f"{SPOILED:06d}.json"
    elsewhere = tmp_path / "elsewhere.json"
    elsewhere.write_bytes(path.read_bytes())
    kept = elsewhere.read_bytes()
    path.unlink()
    path.symlink_to(elsewhere)
    run, computed = again()
    assert computed == [SPOILED] and run.table.equals(baseline[1])
    assert elsewhere.read_bytes() == kept and not path.is_symlink()
    victim = tmp_path / "victim.txt"  # a link to a file of the user's: never overwritten with a record
    victim.write_bytes(VICTIM)
    path.unlink()
    path.symlink_to(victim)
    run, computed = again()
    assert computed == [SPOILED] and victim.read_bytes() == VICTIM and not path.is_symlink()


def test_a_designs_folder_that_is_a_link_is_neither_read_nor_written(baseline, resume, tmp_path):
    out, again = resume
    elsewhere = tmp_path / "elsewhere"
    shutil.move(out / "designs", elsewhere)
    before = {p.name: p.read_bytes() for p in elsewhere.iterdir()}
    (out / "designs").symlink_to(elsewhere, target_is_directory=True)
    run, computed = again()
    assert computed == [0, 1, 2, 3] and run.table.equals(baseline[1])
    assert {p.name: p.read_bytes() for p in elsewhere.iterdir()} == before
    assert (out / "designs").is_dir() and not (out / "designs").is_symlink()


def test_a_link_at_an_output_file_is_replaced_not_written_through(baseline, resume, tmp_path):
    out, again = resume
    victim = tmp_path / "victim.txt"
    victim.write_bytes(VICTIM)
    (out / "designs.csv").unlink()
    (out / "designs.csv").symlink_to(victim)
    _, computed = again()
    assert computed == [] and victim.read_bytes() == VICTIM
    assert (out / "designs.csv").read_bytes() == (baseline[0] / "designs.csv").read_bytes()


def test_a_missing_measure_is_written_as_null_and_read_back_as_nan(baseline, tmp_path):
    """Records are strict JSON: a measure a design could not compute (NaN) is null in its file and NaN again
    when resumed, so that a NaN in a file is never one this run wrote."""
    study, robot = _study()
    shape = RecordShape.of(study, robot)
    rec = _record(baseline[0])
    rec["rows"][0]["peak_stress_pa"] = math.nan
    rec["timing"]["seconds"] = math.nan
    text = dump_json(rec)
    assert "NaN" not in text
    (tmp_path / "designs").mkdir()
    (tmp_path / "designs" / f"{SPOILED:06d}.json").write_text(text)
    back = _run._reuse(tmp_path, SPOILED, rec["params"], shape)
    assert back is not None and math.isnan(back.rows[0].peak_stress_pa) and math.isnan(back.timing.seconds)
    assert back.rows[0].volume_m3 == rec["rows"][0]["volume_m3"]

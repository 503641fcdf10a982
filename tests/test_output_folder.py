"""The one output-folder rule, atomic writes, and cancellation (in process; real signals: test_signals.py)."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from pytdcr import Loads, TensionBounds
from pytdcr.runs import BoundsSpec, SampleSettings, run_sample
from pytdcr.runtime import MANIFEST, FolderError, RunInterrupted, output_folder, run_in_chunks, submit_in_context
from pytdcr.statics import Cancelled, cancellable, solve_batch
from pytdcr.workspace.sampling import SamplingConfig, SamplingInterrupted, sample_workspace


def manifest(path) -> dict:
    return json.loads((path / MANIFEST).read_text())


def leftovers(parent) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def test_new_folder_gets_a_complete_run(tmp_path):
    out = tmp_path / "new" / "run"
    with output_folder(out, "test", {"seed": 3}) as run:
        (run.staging / "a.txt").write_text("a")
        assert not out.exists()  # written aside until the end
    assert (out / "a.txt").read_text() == "a"
    m = manifest(out)
    assert m["status"] == "complete" and m["command"] == "test" and m["inputs"] == {"seed": 3}
    assert m["files"] == ["a.txt", MANIFEST] or m["files"] == ["a.txt"]
    assert {"pytdcr", "python", "started", "finished"} <= set(m)
    assert leftovers(out.parent) == []


def test_previous_run_is_replaced_as_a_whole(tmp_path):
    out = tmp_path / "run"
    with output_folder(out, "first") as run:
        (run.staging / "old_only.csv").write_text("1")
        (run.staging / "both.csv").write_text("first")
    with output_folder(out, "second") as run:
        (run.staging / "both.csv").write_text("second")
    assert sorted(p.name for p in out.iterdir()) == ["both.csv", MANIFEST]
    assert (out / "both.csv").read_text() == "second" and manifest(out)["command"] == "second"
    assert leftovers(tmp_path) == []


def test_failed_run_leaves_the_previous_one(tmp_path):
    out = tmp_path / "run"
    with output_folder(out, "first") as run:
        (run.staging / "x.csv").write_text("kept")
    with pytest.raises(ZeroDivisionError), output_folder(out, "second") as run:
        (run.staging / "x.csv").write_text("half")
        _ = 1 / 0
    assert (out / "x.csv").read_text() == "kept" and manifest(out)["command"] == "first"
    assert leftovers(tmp_path) == []


def test_interrupted_run_is_saved_and_marked(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RunInterrupted) as stop, output_folder(out, "cmd") as run:
        (run.staging / "part.csv").write_text("1")
        run.interrupted_note = "saved 1 of 9 rows"
        raise KeyboardInterrupt
    assert "saved 1 of 9 rows" in stop.value.message and str(out) in stop.value.message
    m = manifest(out)
    assert m["status"] == "interrupted" and m["interrupted"] == "saved 1 of 9 rows"
    # interrupted before writing anything: nothing saved, the previous run stays
    with pytest.raises(RunInterrupted, match=r"nothing saved; .* keeps the previous run"), output_folder(out, "c2"):
        raise KeyboardInterrupt
    assert manifest(out)["command"] == "cmd"
    assert leftovers(tmp_path) == []


def test_refuses_files_and_foreign_folders(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(FolderError, match="is a file, not a folder"), output_folder(tmp_path / "f", "c"):
        pass
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "data.txt").write_text("precious")
    with pytest.raises(FolderError, match=r"not part of a tdcr run \('data.txt'\)"), output_folder(
            tmp_path / "mine", "c"):
        pass
    assert (tmp_path / "mine" / "data.txt").read_text() == "precious"
    # a manifest.json of something else does not make a folder a tdcr run
    (tmp_path / "mine" / MANIFEST).write_text("{}")
    with pytest.raises(FolderError, match="not part of a tdcr run"), output_folder(tmp_path / "mine", "c"):
        pass
    assert (tmp_path / "mine" / "data.txt").read_text() == "precious"
    # nor does a run folder a user has added notes to
    with output_folder(tmp_path / "run", "c") as run:
        (run.staging / "r.txt").write_text("1")
    (tmp_path / "run" / "notes.txt").write_text("mine")
    with pytest.raises(FolderError, match=r"\('notes.txt'\)"), output_folder(tmp_path / "run", "c"):
        pass
    assert (tmp_path / "run" / "notes.txt").read_text() == "mine"


def test_an_existing_empty_folder_keeps_its_permissions(tmp_path):
    (tmp_path / "empty").mkdir(mode=0o750)
    os.chmod(tmp_path / "empty", 0o750)
    with output_folder(tmp_path / "empty", "c") as run:
        (run.staging / "r.txt").write_text("1")
    assert (tmp_path / "empty" / "r.txt").exists()
    assert (tmp_path / "empty").stat().st_mode & 0o777 == 0o750


def test_refuses_the_current_folder_and_mount_points(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x").write_text("mine")
    for where in (".", "", str(tmp_path.parent)):
        with pytest.raises(FolderError, match="is the current folder or holds it"), output_folder(where, "c"):
            pass
    assert (tmp_path / "x").read_text() == "mine"
    if os.path.ismount("/proc"):
        with pytest.raises(FolderError, match="is a mount point"), output_folder("/proc", "c"):
            pass


def test_a_symbolic_link_is_followed(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    for k in range(2):
        with output_folder(tmp_path / "link", "c") as run:
            (run.staging / "r.txt").write_text(str(k))
    assert (tmp_path / "link").is_symlink() and (tmp_path / "real" / "r.txt").read_text() == "1"
    assert leftovers(tmp_path) == []


def test_an_interrupted_run_never_replaces_a_complete_one(tmp_path):
    out = tmp_path / "run"
    with output_folder(out, "first") as run:
        (run.staging / "all.csv").write_text("complete")
    with pytest.raises(RunInterrupted, match=r"in .*run\.interrupted .*; the complete run in .*run is kept"), \
            output_folder(out, "second") as run:
        (run.staging / "all.csv").write_text("partial")
        raise KeyboardInterrupt
    assert (out / "all.csv").read_text() == "complete" and manifest(out)["status"] == "complete"
    aside = tmp_path / "run.interrupted"
    assert (aside / "all.csv").read_text() == "partial" and manifest(aside)["status"] == "interrupted"
    # an interrupted run does replace an interrupted one
    with pytest.raises(RunInterrupted), output_folder(aside, "third") as run:
        (run.staging / "all.csv").write_text("partial again")
        raise KeyboardInterrupt
    assert (aside / "all.csv").read_text() == "partial again"


_HOLDER = """
import sys, time
from pytdcr.runtime import output_folder
with output_folder(sys.argv[1], "holder") as run:
    print("locked", flush=True)
    time.sleep(float(sys.argv[2]))
"""


def test_live_lock_refused_and_stale_lock_taken_over(tmp_path):
    out = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", _HOLDER, str(out), "60"], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        busy = rf"in use by process {holder.pid} \(tdcr holder"
        with pytest.raises(FolderError, match=busy), output_folder(out, "c"):
            pass
    finally:
        holder.kill()  # killed outright: no clean-up of its own
        holder.wait()
    assert any(n.startswith(".run.partial-") for n in leftovers(tmp_path))  # what the killed run left
    with output_folder(out, "after") as run:  # its lock died with it: taken over, its leftovers cleaned
        (run.staging / "ok.txt").write_text("1")
    assert manifest(out)["command"] == "after"
    assert leftovers(tmp_path) == []


def _interrupt_third_block(monkeypatch) -> None:
    """Make the third block of a sampling run raise KeyboardInterrupt (as Ctrl-C would)."""
    import pytdcr.workspace.sampling as ws

    calls = {"n": 0}
    real = ws.solve_batch

    def flaky(*args, **kw):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real(*args, **kw)

    monkeypatch.setattr(ws, "solve_batch", flaky)


def test_sampling_interrupted_returns_the_finished_blocks(paper, monkeypatch):
    _interrupt_third_block(monkeypatch)
    bounds = TensionBounds.uniform(8, 0.0, 5.0)
    with pytest.raises(SamplingInterrupted) as stop:
        sample_workspace(paper, Loads(np.zeros(8)), bounds, 50, seed=1, config=SamplingConfig(block=10))
    part = stop.value.samples
    assert part.converged.size == 20 and stop.value.total == 50
    whole = sample_workspace(paper, Loads(np.zeros(8)), bounds, 50, seed=1, config=SamplingConfig(block=10))
    assert np.array_equal(part.tensions, whole.tensions[:20])
    assert np.array_equal(part.tip_position, whole.tip_position[:20])


def test_sampling_run_interrupted_saves_what_it_solved(paper, tmp_path, monkeypatch):
    import pytdcr.runs._runs as runs

    _interrupt_third_block(monkeypatch)
    real = runs.sample_workspace
    monkeypatch.setattr(runs, "sample_workspace",
                        lambda *a, config, **kw: real(*a, config=dataclasses.replace(config, block=10), **kw))
    out = tmp_path / "s"
    with pytest.raises(RunInterrupted, match="saved 20 of 50 samples"):
        run_sample(SampleSettings(bounds=BoundsSpec(0.0, 5.0), n=50, seed=1, n_shapes=0), out, robot=paper)
    assert len((out / "samples.csv").read_text().splitlines()) == 21
    info = json.loads((out / "sample_run.json").read_text())
    assert info["complete"] is False and info["solved"] == 20 and info["inputs"]["seed"] == 1
    assert manifest(out)["status"] == "interrupted"


def test_cancelled_scope_stops_work_in_worker_threads(paper):
    """Work in a cancelled scope stops at its next chunk, in this thread and in threads started in context."""
    T = np.random.default_rng(0).uniform(0, 5, size=(64, 8))
    with cancellable() as scope:
        scope.cancel()
        with pytest.raises(Cancelled):
            solve_batch(paper, T, threads=1)
        with pytest.raises(Cancelled):
            solve_batch(paper, T, threads=2)
    assert solve_batch(paper, T[:2], threads=1).converged.all()  # outside the scope: runs

    started = threading.Event()
    done: list[int] = []

    def slow_chunks(a: int, b: int) -> None:
        started.set()
        time.sleep(0.05)
        done.append(a)

    from concurrent.futures import ThreadPoolExecutor

    with cancellable() as scope, ThreadPoolExecutor(1) as pool:
        fut = submit_in_context(pool, run_in_chunks, slow_chunks, 1000, 1, 1)
        started.wait(5)
        scope.cancel()
        with pytest.raises(Cancelled):
            fut.result(timeout=5)
    assert 1 <= len(done) < 1000


def test_atomic_writes_leave_no_temporary_files(tmp_path, paper):
    out = tmp_path / "s"
    run_sample(SampleSettings(bounds=BoundsSpec(0.0, 3.0), n=4, seed=0, n_shapes=1), out, robot=paper)
    names = sorted(os.listdir(out))
    assert all(not n.startswith(".") for n in names)
    assert {"samples.csv", "sample_run.json", MANIFEST, "fig3a_samples.png"} <= set(names)

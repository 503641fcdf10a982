"""Ctrl-C and concurrent runs, with real processes: SIGINT ends every command with exit 130 and one line saying
what was saved; two runs into one folder never mix.

How long each command takes from SIGINT to exit is measured by ``bench/interrupt.py`` (not timed here).
"""

from __future__ import annotations

import codecs
import csv
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from pytdcr import TensionBounds
from pytdcr.io import write_robot
from pytdcr.paper import paper_robot

pytestmark = pytest.mark.slow

TDCR = [sys.executable, "-m", "pytdcr.cli"]
#: a run that has not ended this long after SIGINT is hung
HUNG_S = 60.0


class Proc:
    """A ``tdcr`` process whose stderr is collected as it comes."""

    def __init__(self, *args: str) -> None:
        env = {**os.environ, "PYTDCR_PROGRESS_SECONDS": "0"}  # stderr is a pipe: a progress line every step
        self.p = subprocess.Popen([*TDCR, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.err: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        # whatever has come, as it comes (a text read(64) would wait for 64 characters: a short progress line
        # would then be seen only with the next, and the test would interrupt later than it means to)
        fd, text = self.p.stderr.fileno(), codecs.getincrementaldecoder("utf-8")("replace")
        while chunk := os.read(fd, 4096):
            self.err.append(text.decode(chunk))

    def stderr(self) -> str:
        return "".join(self.err)

    def wait_for(self, pattern: str, at_least: int = 0, timeout: float = 120.0) -> None:
        """Until stderr shows ``pattern`` (its first group, if any, >= ``at_least``)."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            for m in re.finditer(pattern, self.stderr()):
                if not m.groups() or int(m.group(1)) >= at_least:
                    return
            if self.p.poll() is not None:
                pytest.fail(f"ended before {pattern!r}: {self.stderr()[-500:]}")
            time.sleep(0.05)
        pytest.fail(f"no {pattern!r} within {timeout} s")

    def interrupt(self) -> tuple[int, str]:
        self.p.send_signal(signal.SIGINT)
        try:
            self.p.wait(timeout=HUNG_S)
        except subprocess.TimeoutExpired:
            self.p.kill()
            pytest.fail("still running a minute after SIGINT")
        self.reader.join(5)
        lines = [ln for ln in re.split(r"[\r\n]", self.stderr()) if "tdcr:" in ln]
        assert "Traceback" not in self.stderr()
        return self.p.returncode, lines[-1][lines[-1].index("tdcr:"):] if lines else ""


def test_sigint_sample_saves_the_blocks_solved(tmp_path):
    out = tmp_path / "out"
    p = Proc("sample", "--n", "400000", "--out", str(out))
    p.wait_for(r"(\d+)/400000", at_least=1000)
    code, line = p.interrupt()
    assert code == 130
    m = re.fullmatch(r"tdcr: interrupted; saved (\d+) of 400000 samples in (.+) \(manifest status: interrupted\)",
                     line)
    assert m, line
    saved = int(m.group(1))
    assert saved >= 1000
    with open(out / "samples.csv") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) == saved + 1
    info = json.loads((out / "sample_run.json").read_text())
    assert info["complete"] is False and info["solved"] == saved
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"
    # the saved rows are the seed's first tension vectors
    T = TensionBounds.uniform(8, 0.0, 20.0).sample(400000, np.random.default_rng(info["inputs"]["seed"]))
    got = np.array([[float(x) for x in r[1:9]] for r in rows[1:]])
    assert np.allclose(got, T[:saved], rtol=1e-11, atol=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize(
    ("args", "ready"),
    [
        (["optimize", "--pop", "200", "--max-gen", "500", "--tol", "1e-15", "--window", "400"], r"GA: .*?(\d+)/500"),
        (["compare", "--n", "2000", "--models", "pcc,sscr"], r"(\d+)/2000"),
        (["accuracy", "--n", "50"], r"accuracy"),
    ],
)
def test_sigint_commands_that_save_nothing_midway(tmp_path, args, ready):
    out = tmp_path / "out"
    p = Proc(*args, "--out", str(out))
    p.wait_for(ready, at_least=3)
    code, line = p.interrupt()
    assert code == 130
    assert line == f"tdcr: interrupted; nothing saved; {out} was not created"
    assert list(tmp_path.iterdir()) == []  # no lock, no staging folder


def test_sigint_reproduce_keeps_finished_figures(tmp_path):
    out = tmp_path / "out"
    p = Proc("reproduce", "--out", str(out))
    p.wait_for(r"GA population 100: .*?(\d+)/", at_least=2)  # the demo's largest population
    code, line = p.interrupt()
    assert code == 130
    if out.exists():  # the parts finished before the signal, marked as such
        assert re.fullmatch(rf"tdcr: interrupted; saved \d+ files in {re.escape(str(out))} \(manifest status: "
                            r"interrupted\)", line), line
        man = json.loads((out / "manifest.json").read_text())
        assert man["status"] == "interrupted"
        assert sorted(man["files"]) == sorted(p.name for p in out.iterdir() if p.name != "manifest.json")
    else:
        assert line.startswith("tdcr: interrupted; nothing saved"), line
    assert [p.name for p in tmp_path.iterdir()] in ([], ["out"])


def test_sigint_workspace_keeps_the_samples_solved(tmp_path):
    out = tmp_path / "out"
    p = Proc("workspace", "--n", "256", "--budget", "1000000", "--directions", "0", "--out", str(out))
    p.wait_for(r"boundary search 1/3 \(budget\): (\d+)", at_least=512)
    code, line = p.interrupt()
    assert code == 130
    m = re.fullmatch(r"tdcr: interrupted; saved (\d+) solved samples \((\d+) converged\) in samples.npz, no "
                     rf"region in {re.escape(str(out))} \(manifest status: interrupted\)", line)
    assert m, line
    with np.load(out / "samples.npz") as z:
        assert z["tensions"].shape[0] == int(m.group(1)) and int(z["converged"].sum()) == int(m.group(2))
        assert np.sum(z["source"] == 0) == 256  # the Sobol points, then corners, edges (and any search rounds)
    man = json.loads((out / "manifest.json").read_text())
    assert man["status"] == "interrupted" and "no region" in man["interrupted"]
    assert not (out / "fsw.ply").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_sigint_designs_keeps_finished_designs_and_resumes(tmp_path):
    out = tmp_path / "out"
    example = str(Path(__file__).resolve().parents[1] / "examples" / "design_study_small.toml")
    p = Proc("designs", example, "--workers", "2", "--out", str(out))
    p.wait_for(r"designs:.*?(\d+)/5", at_least=2)  # 4 designs and the base robot
    code, line = p.interrupt()
    assert code == 130
    m = re.fullmatch(rf"tdcr: interrupted; saved (\d) of 4 designs( and the base robot)? in {re.escape(str(out))} "
                     r"\(run the same command again to compute the rest\)", line)
    assert m, line
    saved = int(m.group(1))
    assert 0 <= saved <= 4 and len(list((out / "designs").glob("0*.json"))) == saved
    assert (out / "designs" / "reference.json").exists() == bool(m.group(2)) and saved + bool(m.group(2)) >= 2
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"
    done = subprocess.run([*TDCR, "designs", example, "--out", str(out)], capture_output=True, text=True,
                          timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-1000:]
    assert f"{4 - saved} computed, {saved} reused" in done.stdout


def test_sigint_inside_one_long_solve(tmp_path):
    """A single solve of 1,000 disks (seconds in one compiled call): the command still leaves at once."""
    robot = tmp_path / "long.toml"
    write_robot(paper_robot().with_disks(500), robot)
    p = Proc("solve", "--robot", str(robot), "--tensions", "1,0,0,0,0,0,0,0")
    time.sleep(4.0)
    code, line = p.interrupt()
    assert code == 130 and line == "tdcr: interrupted; nothing saved"


def _wait_for_lock(out: Path, timeout: float = 60.0) -> None:
    lock = out.parent / f".{out.name}.lock"
    t0 = time.monotonic()
    while not (lock.exists() and lock.stat().st_size > 0):
        if time.monotonic() - t0 > timeout:
            pytest.fail("the first run never took its lock")
        time.sleep(0.02)


def test_two_runs_into_one_folder(tmp_path):
    """The second run, started while the first writes, is refused in one line; the folder holds the first run
    whole, its JSON's seed the one of its rows."""
    out = tmp_path / "out"
    first = Proc("sample", "--n", "3000", "--seed", "1", "--out", str(out))
    _wait_for_lock(out)
    second = subprocess.run([*TDCR, "sample", "--n", "3000", "--seed", "2", "--out", str(out)],
                            capture_output=True, text=True, check=False)
    assert second.returncode == 2, second.stderr
    assert re.search(rf"in use by process {first.p.pid} \(tdcr sample, started", second.stderr)
    assert first.p.wait(timeout=300) == 0
    _check_whole_run(out, 3000)
    assert json.loads((out / "sample_run.json").read_text())["inputs"]["seed"] == 1


def test_two_runs_started_together_never_mix(tmp_path):
    out = tmp_path / "out"
    procs = [subprocess.Popen([*TDCR, "sample", "--n", "2000", "--seed", str(s), "--out", str(out)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for s in (1, 2)]
    codes = [p.wait(timeout=300) for p in procs]
    assert sorted(codes) in ([0, 0], [0, 2])  # one after the other, or one refused: never both half
    _check_whole_run(out, 2000)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def _check_whole_run(out: Path, n: int) -> None:
    info = json.loads((out / "sample_run.json").read_text())
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    with open(out / "samples.csv") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) == n + 1 and all(len(r) == len(rows[0]) for r in rows)
    T = TensionBounds.uniform(8, 0.0, 20.0).sample(n, np.random.default_rng(info["inputs"]["seed"]))
    assert np.allclose(np.array([[float(x) for x in r[1:9]] for r in rows[1:]]), T, rtol=1e-11, atol=0)

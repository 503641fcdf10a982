"""Processes we start end with us: worker processes notice their parent's death, even by SIGKILL (no atexit, no
``finally`` runs then), and exit; while the parent lives they do not.

Each case starts the real thing in a subprocess (the pool ``tdcr designs`` makes, the ``tdcr designs`` command
itself, a Dask ``LocalCluster`` like the tests' and the benchmark's), waits until its workers exist, kills the
parent with SIGKILL and looks for every process it had started: none may be left after :data:`GONE_S`.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="SIGKILL is POSIX")

#: how long the workers of a killed parent may take to end [s] (they take a fraction of a second)
GONE_S = 10.0
#: how long a subprocess may take to start its workers [s] (spawned interpreters importing pytdcr, on a busy machine)
START_S = 120.0

#: a module the worker processes import (spawned interpreters import functions by module name)
_TASKS = '''
import os, time
from pathlib import Path

def busy(marker, seconds):
    """Say which worker took the task (a file named ``marker`` holding its pid), then work for ``seconds``."""
    Path(marker).write_text(str(os.getpid()))
    time.sleep(seconds)
    return os.getpid()
'''


def _alive(pid: int) -> bool:
    """The process ``pid`` runs (a zombie, ended but not yet reaped by its new parent, does not)."""
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def _survivors(pids: list[int], within: float = GONE_S) -> list[int]:
    """The processes of ``pids`` still running after ``within`` seconds (polled: an empty list as soon as all end)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < within:
        left = [p for p in pids if _alive(p)]
        if not left:
            return []
        time.sleep(0.1)
    return [p for p in pids if _alive(p)]


def _descendants(pid: int) -> list[int]:
    try:
        return [c.pid for c in psutil.Process(pid).children(recursive=True)]
    except psutil.NoSuchProcess:
        return []


def _end(pids: list[int]) -> None:
    """Kill what a failed case left behind (processes this test started, by pid)."""
    for p in pids:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


def _wait_until(check, what: str, proc: subprocess.Popen, within: float = START_S):
    t0 = time.monotonic()
    while time.monotonic() - t0 < within:
        got = check()
        if got:
            return got
        if proc.poll() is not None:
            raise AssertionError(f"the parent ended (status {proc.returncode}) before {what}: "
                                 f"{proc.stderr.read() if proc.stderr else ''}")
        time.sleep(0.1)
    raise AssertionError(f"no {what} within {within:.0f} s")


def _kill_and_check(proc: subprocess.Popen, workers: list[int]) -> None:
    """SIGKILL ``proc``; every process it had started (``workers`` and any other descendant) must end."""
    started = sorted(set(workers) | set(_descendants(proc.pid)))
    proc.kill()
    proc.wait(timeout=30)
    left = _survivors(started)
    try:
        assert left == [], (f"processes outlived their killed parent: "
                            f"{[(p, ' '.join(psutil.Process(p).cmdline())[:120]) for p in left]}")
    finally:
        _end(left)


@pytest.fixture
def tasks(tmp_path: Path) -> Path:
    (tmp_path / "lifeline_tasks.py").write_text(_TASKS)
    return tmp_path


def _busy_markers(folder: Path, n: int) -> list[int] | None:
    """The pids of the workers that took the ``n`` busy tasks, once all have started."""
    files = [folder / f"busy{k}" for k in range(n)]
    try:
        pids = [int(f.read_text()) for f in files]
    except (OSError, ValueError):
        return None
    return pids


# the pool `tdcr designs` makes, two workers each busy with a long task; its parent then killed outright
_DESIGNS_POOL = '''
import sys, time
sys.path.insert(0, sys.argv[1])
import lifeline_tasks
from pytdcr.designs._run import _Local

local = _Local(2)
futures = [local.pool.submit(lifeline_tasks.busy, f"{sys.argv[1]}/busy{k}", 120) for k in range(2)]
time.sleep(120)  # bounded: were this test killed, nothing it started outlives it long
'''


def test_the_design_pools_busy_workers_end_when_their_parent_is_killed(tasks):
    proc = subprocess.Popen([sys.executable, "-c", _DESIGNS_POOL, str(tasks)], stderr=subprocess.PIPE, text=True)
    try:
        workers = _wait_until(lambda: _busy_markers(tasks, 2), "busy workers", proc)
        assert len(set(workers)) == 2 and all(_alive(p) for p in workers)
        _kill_and_check(proc, workers)
    finally:
        _end([proc.pid])


# a pool whose workers are idle (waiting for work) when the parent is killed
_IDLE_POOL = '''
import os, sys, time
from pytdcr.runtime import process_pool

pool = process_pool(2)
pool.submit(os.getpid).result()  # a task has run: the pool's worker exists and waits for more
print(*pool._processes, flush=True)
time.sleep(120)  # bounded: were this test killed, nothing it started outlives it long
'''


def test_idle_workers_end_when_their_parent_is_killed():
    proc = subprocess.Popen([sys.executable, "-c", _IDLE_POOL], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        workers = [int(p) for p in proc.stdout.readline().split()]
        assert workers and all(_alive(p) for p in workers)
        _kill_and_check(proc, workers)
    finally:
        _end([proc.pid])


def test_a_worker_lives_while_its_parent_does_even_after_the_thread_that_started_it_ends(tasks):
    """The lifeline follows the parent process, not the thread that submitted (``prctl(PR_SET_PDEATHSIG)``
    would kill the worker when that thread ends): a worker started from a thread that has ended finishes a task
    of a few seconds, and then another."""
    sys.path.insert(0, str(tasks))
    try:
        import lifeline_tasks

        from pytdcr.runtime import process_pool

        pool = process_pool(1)
        first: list[int] = []
        starter = threading.Thread(target=lambda: first.append(pool.submit(os.getpid).result(timeout=START_S)))
        starter.start()
        starter.join()
        try:
            worker = first[0]
            assert worker != os.getpid()
            time.sleep(1.0)
            assert pool.submit(lifeline_tasks.busy, str(tasks / "busy0"), 3.0).result(timeout=START_S) == worker
            assert pool.submit(os.getpid).result(timeout=START_S) == worker
        finally:
            pool.shutdown(wait=True)
        assert _survivors([worker]) == []  # and an ordinary shutdown ends it
    finally:
        sys.path.remove(str(tasks))
        sys.modules.pop("lifeline_tasks", None)


# a process not started by multiprocessing that holds the lifeline: it watches its parent's pid
_CHILD = '''
import os, sys, time
from pytdcr.runtime import hold_lifeline

hold_lifeline(int(sys.argv[1]))
print("holding", flush=True)
time.sleep(120)  # bounded: were this test killed, nothing it started outlives it long
'''
_MIDDLE = '''
import os, subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c", sys.argv[1], str(os.getpid())], stdout=subprocess.PIPE, text=True)
child.stdout.readline()
print(child.pid, flush=True)
time.sleep(120)  # bounded: were this test killed, nothing it started outlives it long
'''


def test_a_process_outside_multiprocessing_that_holds_the_lifeline_ends_with_its_parent():
    proc = subprocess.Popen([sys.executable, "-c", _MIDDLE, _CHILD], stdout=subprocess.PIPE, text=True)
    try:
        child = int(proc.stdout.readline())
        assert _alive(child)
        time.sleep(0.5)  # it keeps running while its parent lives
        assert _alive(child)
        _kill_and_check(proc, [child])
    finally:
        _end([proc.pid])


def test_a_worker_whose_parent_is_already_gone_exits_at_once():
    from pytdcr.runtime import PARENT_GONE_EXIT

    code = "import sys; from pytdcr.runtime import hold_lifeline; hold_lifeline(int(sys.argv[1])); print('ran on')"
    done = subprocess.run([sys.executable, "-c", code, str(os.getpid() + 1)], capture_output=True, text=True,
                          timeout=START_S)
    assert done.returncode == PARENT_GONE_EXIT and "ran on" not in done.stdout


_STUDY = '''
name = "lifeline"
robot = "paper"
seed = 1
bounds = [0.0, 10.0]
model = "pcc"
reference = false

[designs]
method = "grid"

[parameters]
routing_radius_2 = { values = [0.004, 0.005, 0.006, 0.007, 0.008, 0.009, 0.010, 0.011] }

[budget]
samples = 500
search = 0

[loads]
cases = ["no load"]

[measures]
directions = { up = [0.0, 0.0, 1.0] }
'''


def test_tdcr_designs_killed_outright_leaves_no_worker(tmp_path):
    """The example of the issue: ``tdcr designs`` SIGKILLed (as the out-of-memory killer does) while its
    workers compute designs."""
    (tmp_path / "study.toml").write_text(_STUDY)
    env = {**os.environ, "PYTDCR_PROGRESS_SECONDS": "0"}
    proc = subprocess.Popen([sys.executable, "-m", "pytdcr.cli", "designs", str(tmp_path / "study.toml"), "--out",
                             str(tmp_path / "out"), "--workers", "2", "--no-figures"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env)

    def computing() -> list[int] | None:  # a design is saved: both workers are past starting, and at work
        if not any(tmp_path.glob("**/designs/0*.json")):
            return None
        kids = [psutil.Process(p) for p in _descendants(proc.pid)]
        return [k.pid for k in kids if "spawn_main" in " ".join(k.cmdline())]

    try:
        workers = _wait_until(computing, "a saved design", proc)
        assert len(workers) == 2
        _kill_and_check(proc, workers)
    finally:
        _end([proc.pid])


# a Dask LocalCluster (the tests' and the benchmark's) in a process then killed outright: distributed's worker
# processes hold a lifeline pipe of their own (distributed.process.AsyncProcess), and end too
_CLUSTER = '''
import time
from distributed import LocalCluster

if __name__ == "__main__":
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    print(cluster.scheduler_address, flush=True)
    time.sleep(120)  # bounded: were this test killed, nothing it started outlives it long
'''


def test_a_local_dask_cluster_ends_when_its_parent_is_killed(tmp_path):
    script = tmp_path / "cluster.py"
    script.write_text(_CLUSTER)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().startswith("tcp://")
        workers = _descendants(proc.pid)
        assert sum("spawn_main" in " ".join(psutil.Process(p).cmdline()) for p in workers) == 2
        _kill_and_check(proc, workers)
    finally:
        _end([proc.pid])

"""Compiled kernels: the cache folder keyed by version and sources, private to the user, and the one line a
first use prints while it compiles (never when the kernels load from the cache)."""

from __future__ import annotations

import ast
import os
import shutil
import stat
import subprocess
import sys
import sysconfig
from pathlib import Path

import numba
import numpy as np
import pytest

from pytdcr.runtime import _jit, announce_compiling, kernel_key, set_compile_notice

SRC = Path(__file__).resolve().parents[1] / "src" / "pytdcr"
ROOT = SRC.parents[1]


def _module_path(name: str) -> Path:
    rel = Path(*name.split("."))
    return (SRC / rel).with_suffix(".py") if (SRC / rel).with_suffix(".py").exists() else SRC / rel / "__init__.py"


def _pytdcr_imports(path: Path) -> set[Path]:
    """The files of the pytdcr modules ``path`` imports (relative imports resolved), but the runtime package."""
    pkg = list(path.relative_to(SRC).with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = pkg[: len(pkg) - node.level + 1]
            mod = ".".join([*base, node.module] if node.module else base)
            if mod.split(".")[0] == "runtime":
                continue
            out.add(_module_path(mod))
            out |= {_module_path(f"{mod}.{a.name}") for a in node.names if _module_path(f"{mod}.{a.name}").exists()}
    return {p for p in out if p.exists()}


def _sources() -> set[Path]:
    return {p for pattern in _jit.KERNEL_SOURCES for p in SRC.glob(pattern)}


def test_kernel_sources_hold_every_kernel_and_what_it_compiles_in() -> None:
    """The key's digest covers every module with a compiled kernel and every module those import (a constant
    or a function compiled into a kernel from there changes the compiled code)."""
    kernels = {p for p in SRC.rglob("*.py") if "njit" in p.read_text() and p.parent.name != "runtime"}
    assert kernels, "no kernel module found"
    sources = _sources()
    assert kernels <= sources, f"kernel modules missing from KERNEL_SOURCES: {sorted(map(str, kernels - sources))}"
    for path in kernels:
        missing = _pytdcr_imports(path) - sources
        assert not missing, f"{path.name} compiles in modules missing from KERNEL_SOURCES: {sorted(map(str, missing))}"


def _copy_sources(to: Path) -> None:
    for path in _sources():
        dest = to / path.relative_to(SRC)
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, dest)


def test_key_changes_with_a_source_or_the_version(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A cache of another version, or of kernels before an edit (also of a module they only read constants
    from), sits in another folder: it is never loaded."""
    _copy_sources(tmp_path)
    monkeypatch.setattr(_jit, "_PACKAGE", tmp_path)
    key = kernel_key()
    assert key == kernel_key() and key.startswith(f"{_jit.__version__}-")
    options = tmp_path / "statics" / "options.py"
    text = options.read_text()
    options.write_text(text + "\n# edited\n")
    assert kernel_key() != key
    options.write_text(text)
    assert kernel_key() == key
    monkeypatch.setattr(_jit, "__version__", "99.0.0")
    assert kernel_key() != key


def _choose(monkeypatch: pytest.MonkeyPatch, folder: str) -> Path | None:
    monkeypatch.delenv("PYTDCR_KERNEL_CACHE_DIR", raising=False)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", folder)
    return _jit._choose()


@pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX permissions")
def test_kernel_folder_of_its_own(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """PYTDCR_KERNEL_CACHE_DIR puts the kernels apart from the rest of the cache (as the tests do)."""
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(tmp_path / "rest"))
    monkeypatch.setenv("PYTDCR_KERNEL_CACHE_DIR", str(tmp_path / "kernels"))
    where = _jit._choose()
    assert where == tmp_path / "kernels" / kernel_key()
    assert stat.S_IMODE(where.stat().st_mode) == 0o700
    assert not (tmp_path / "rest").exists()
    monkeypatch.setenv("PYTDCR_KERNEL_CACHE_DIR", "")
    assert _jit._choose() is None  # set empty: numba's own places


@pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX permissions")
def test_cache_folder_is_private_and_keyed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    where = _choose(monkeypatch, str(tmp_path / "cache"))
    assert where == tmp_path / "cache" / "kernels" / kernel_key()
    assert stat.S_IMODE(where.stat().st_mode) == 0o700
    assert _choose(monkeypatch, "") is None  # the cache folder off: numba's own places
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o777)
    shared.chmod(0o777)
    assert _choose(monkeypatch, str(shared)) is None  # writable by others: never pointed numba at


def test_old_key_folders_are_pruned_links_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    kernels = tmp_path / "kernels"
    kernels.mkdir(parents=True, mode=0o700)
    tmp_path.chmod(0o700)
    old = []
    for k in range(4):
        folder = kernels / f"0.0.{k}-{k:016x}"
        (folder / "sub").mkdir(parents=True)
        os.utime(folder, (1e9 + k, 1e9 + k))
        old.append(folder)
    outside = tmp_path / "outside"
    outside.mkdir()
    (kernels / "link").symlink_to(outside, target_is_directory=True)
    where = _choose(monkeypatch, str(tmp_path))
    kept = {p.name for p in kernels.iterdir()}
    assert kept == {where.name, old[3].name, old[2].name, "link"}
    assert outside.is_dir()


@pytest.fixture
def fresh_notices(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(_jit, "_said", set())
    set_compile_notice(True)
    yield
    set_compile_notice(True)


def _new_function():
    """A function numba has never compiled in this process."""
    return numba.njit(lambda x: x + 1.0)


def test_first_compile_says_so_once(fresh_notices: None, capsys: pytest.CaptureFixture[str]) -> None:
    with announce_compiling("the test model", 31.0):
        assert _new_function()(1.0) == 2.0
        assert _new_function()(2.0) == 3.0
    with announce_compiling("the test model", 31.0):
        _new_function()(1.0)
    err = capsys.readouterr().err
    assert err.count("compiling") == 1
    assert "pytdcr: compiling the test model for first use, about 30 s, once" in err


def test_no_notice_without_compile_quiet_or_outside(fresh_notices: None, capsys: pytest.CaptureFixture[str]) -> None:
    f = _new_function()
    f(1.0)  # compiled outside any announced call: nothing said
    with announce_compiling("a compiled model", 5.0):
        f(2.0)  # already compiled: no compile event
    set_compile_notice(False)
    with announce_compiling("a quiet model", 5.0):
        _new_function()(1.0)
    assert "compiling" not in capsys.readouterr().err


def test_a_compile_is_said_under_its_own_threads_label(fresh_notices: None,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """A thread inside an announced call that compiles nothing lends its label to no other thread's compile (the
    demo once said the pcc solver compiled while another thread compiled the workspace's step kernel)."""
    import threading

    inside, done = threading.Event(), threading.Event()

    def idle() -> None:
        with announce_compiling("the idle model", 60.0):
            inside.set()
            done.wait(30.0)

    t = threading.Thread(target=idle)
    t.start()
    try:
        assert inside.wait(30.0)
        _new_function()(1.0)  # outside any call of this thread: nothing to say
        with announce_compiling("the working model", 10.0):
            _new_function()(1.0)
    finally:
        done.set()
        t.join()
    err = capsys.readouterr().err
    assert "idle model" not in err
    assert err.count("compiling") == 1 and "compiling the working model for first use" in err


def test_quiet_flag_silences_the_notice() -> None:
    from pytdcr.cli._progress import set_quiet

    set_quiet(True)
    assert not _jit._notice["on"]
    set_quiet(False)
    assert _jit._notice["on"]


_FIRST_SOLVE = """
import sys
import numpy as np
import pytdcr
from pytdcr import paper_loads, paper_robot, solve
from pytdcr.robot import NoFriction
sol = solve(paper_robot(), paper_loads(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0])))
on = solve(paper_robot(), paper_loads(np.array([4.0, 0, 0, 0, 3.0, 0, 0, 0])), start=sol)
_ = sol.stability
print(pytdcr.__file__)
print(repr(bool(sol.converged)), *(repr(float(x)) for x in sol.tip_position))
print(bool(on.converged))
print("-- the cosserat model --", file=sys.stderr, flush=True)
rod = solve(paper_robot().with_friction(NoFriction()), paper_loads(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0])),
            model="cosserat")
print(bool(rod.converged))
"""


@pytest.mark.slow
def test_first_use_from_a_read_only_install(tmp_path: Path) -> None:
    """A non-editable install into a read-only folder, an empty cache: the first pcc solve, its continuation
    and its stability test, and the cosserat model's first solve, run in the compiled core built at install, so
    they compile nothing, write no kernel anywhere and say nothing, and answer as this checkout does."""
    from pytdcr import paper_loads, paper_robot, solve

    target, cache = tmp_path / "site", tmp_path / "cache"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--target", str(target), str(ROOT)], check=True, capture_output=True)
    for path in [target, *target.rglob("*")]:
        path.chmod(path.stat().st_mode & ~0o222)
    # the installed copy and this environment's other packages, without the site hook of this checkout's
    # editable install (-S: no .pth file runs, so nothing redirects `import pytdcr` to the checkout)
    packages = dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(target), *packages]), "PYTDCR_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTDCR_KERNEL_CACHE_DIR", None)
    try:
        runs = [subprocess.run([sys.executable, "-S", "-c", _FIRST_SOLVE], env=env, capture_output=True,
                               text=True, check=True, cwd=tmp_path) for _ in range(2)]
    finally:
        for path in [target, *target.rglob("*")]:
            path.chmod(path.stat().st_mode | 0o200)
    first = runs[0]
    assert first.stdout.splitlines()[0].startswith(str(target))  # the installed copy, not this checkout
    assert "-- the cosserat model --" in first.stderr
    for run in runs:  # the compiled core: nothing to compile at first use, nothing said
        assert "compiling" not in run.stderr, run.stderr
        assert run.stdout.splitlines()[2:] == ["True", "True"]  # the continuation and the rod converged
    expected = solve(paper_robot(), paper_loads(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0])))
    for run in runs:
        converged, *tip = run.stdout.splitlines()[1].split()
        assert converged == "True"
        assert np.array_equal(np.array(tip, dtype=float), expected.tip_position)  # the same compiled code
    assert not list(cache.rglob("*.nb[ic]")), "a kernel compiled into the user cache folder"
    assert not list(target.rglob("*.nb[ic]")), "kernels cached inside the installed package"
    print(f"first use from an empty cache, read-only install: stderr {first.stderr.strip()!r}")

"""Never destroy what is not ours: files that are not regular files, links, sub-folders, design studies and the
folders of live runs (issue 25, first class). Each rule is tried on several members of its class."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from pytdcr.runtime import (
    MANIFEST,
    FileRefused,
    FolderError,
    atomic_write,
    atomic_write_text,
    output_folder,
    resumable_folder,
    writable_file,
    write_csv,
    write_json,
)


def _specials(tmp: Path) -> dict[str, Path]:
    """A folder, a FIFO, a socket and (as root) a character device, each a path no file may replace."""
    import socket

    out = {"folder": tmp / "folder", "fifo": tmp / "fifo"}
    out["folder"].mkdir()
    os.mkfifo(out["fifo"])
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(tmp / "sock"))
    out["socket"] = tmp / "sock"
    try:
        os.mknod(tmp / "null", stat.S_IFCHR | 0o666, os.makedev(1, 3))
        out["device"] = tmp / "null"
    except PermissionError:  # not root: the device case is skipped
        pass
    return out


WRITERS = {
    "text": lambda p: atomic_write_text(p, "x"),
    "json": lambda p: write_json(p, {"a": 1}),
    "csv": lambda p: write_csv(p, ["a"], [[1]]),
    "bytes": lambda p: atomic_write(p, lambda tmp: tmp.write_bytes(b"x")),
}


@pytest.mark.parametrize("writer", list(WRITERS))
def test_no_writer_replaces_anything_but_a_regular_file(tmp_path, writer):
    for kind, path in _specials(tmp_path).items():
        before = os.lstat(path)
        with pytest.raises(FileRefused, match="give the name of a regular file"):
            WRITERS[writer](path)
        after = os.lstat(path)
        assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino), kind
        assert not any(p.name.startswith(f".{path.name}.tmp") for p in tmp_path.iterdir()), kind


def test_links_are_followed_to_the_file_they_name(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    os.chmod(target, 0o600)
    link = tmp_path / "link.json"
    link.symlink_to(target)
    write_json(link, {"a": 1})
    assert link.is_symlink() and json.loads(target.read_text()) == {"a": 1}
    assert stat.S_IMODE(target.stat().st_mode) == 0o600  # the file keeps its permissions
    dangling = tmp_path / "new.csv"
    dangling.symlink_to(tmp_path / "made.csv")
    write_csv(dangling, ["a"], [[2]])
    assert dangling.is_symlink() and (tmp_path / "made.csv").read_text().startswith("a")
    chain = tmp_path / "chain"
    chain.symlink_to(link)
    atomic_write_text(chain, "via two links")
    assert target.read_text() == "via two links" and chain.is_symlink() and link.is_symlink()


def test_a_link_to_a_device_or_folder_is_refused(tmp_path):
    for kind, path in _specials(tmp_path).items():
        link = tmp_path / f"to_{kind}"
        link.symlink_to(path)
        with pytest.raises(FileRefused, match="a link to"):
            atomic_write_text(link, "x")
        assert link.is_symlink() and os.readlink(link) == str(path)
    with pytest.raises(FileRefused, match="does not exist"):
        writable_file(tmp_path / "no" / "such" / "file.txt", "--out")


def _tdcr(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytdcr.cli", *args], cwd=cwd, capture_output=True, text=True,
                          check=False, env={**os.environ, "MPLBACKEND": "Agg"})


def test_the_command_line_refuses_to_write_a_robot_over_a_device_or_fifo(tmp_path):
    specials = _specials(tmp_path)
    for kind, path in specials.items():
        out = _tdcr("robot", "--out", str(path), cwd=tmp_path)
        assert out.returncode == 2 and out.stderr.count("\n") == 1, (kind, out.stderr)
        assert "regular file" in out.stderr or "is a folder" in out.stderr, (kind, out.stderr)
    link = tmp_path / "robot.toml"
    link.symlink_to(tmp_path / "target.toml")
    assert _tdcr("robot", "--out", str(link), cwd=tmp_path).returncode == 0
    assert link.is_symlink() and "[backbone]" in (tmp_path / "target.toml").read_text()


def test_sub_folders_of_a_run_are_checked_at_every_depth(tmp_path):
    out = tmp_path / "run"
    with output_folder(out, "first") as run:
        (run.staging / "case" / "deeper").mkdir(parents=True)
        (run.staging / "case" / "deeper" / "data.csv").write_text("1")
        (run.staging / "top.json").write_text("{}")
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["files"] == ["case/deeper/data.csv", "top.json"]
    with output_folder(out, "second") as run:  # a run of ours, whole: replaced
        (run.staging / "x.txt").write_text("2")
    with output_folder(out, "third") as run:
        (run.staging / "case").mkdir()
        (run.staging / "case" / "a.txt").write_text("3")
    for extra in ("case/notes.txt", "case/new/notes.txt", "case/.hidden"):
        p = out / extra
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("mine")
        with pytest.raises(FolderError, match="not part of a tdcr run"), output_folder(out, "fourth"):
            pass
        assert p.read_text() == "mine"
        p.unlink()
    link = out / "case" / "link"
    link.symlink_to(tmp_path)
    with pytest.raises(FolderError, match="not part of a tdcr run"), output_folder(out, "fifth"):
        pass
    assert link.is_symlink()


def test_a_file_in_a_load_case_sub_folder_survives_another_command(tmp_path):
    # as the issue found it: tdcr workspace --compare-loads writes one sub-folder per load case
    out = tmp_path / "cl"
    with output_folder(out, "workspace --compare-loads") as run:
        for case in ("no_load", "paper_wrench"):
            (run.staging / case).mkdir()
            (run.staging / case / "workspace.json").write_text("{}")
    notes = out / "no_load" / "notes.txt"
    notes.write_text("my notes")
    res = _tdcr("sample", "--n", "2", "--out", str(out), cwd=tmp_path)
    assert res.returncode == 2 and "no_load/notes.txt" in res.stderr
    assert notes.read_text() == "my notes"


def test_a_design_study_folder_is_refused_by_every_other_command(tmp_path):
    out = tmp_path / "study"
    with resumable_folder(out, "designs", {"n": 1}, "digest-1", layout=("designs", "summary.json")) as run:
        (run.path / "designs").mkdir()
        (run.path / "designs" / "design_000000.json").write_text("{}")
        atomic_write_text(run.path / "summary.json", "{}")
    for command in ("sample", "workspace"):
        with pytest.raises(FolderError, match="holds a design study"), output_folder(out, command):
            pass
    res = _tdcr("sample", "--n", "2", "--out", str(out), cwd=tmp_path)
    assert res.returncode == 2 and "design study" in res.stderr
    assert (out / "designs" / "design_000000.json").exists()
    with resumable_folder(out, "designs", {"n": 1}, "digest-1", layout=("designs", "summary.json")):
        pass  # the study itself resumes


_LIVE = textwrap.dedent("""
    import sys, time
    from pytdcr.runtime import output_folder
    with output_folder(sys.argv[1], "live") as run:
        print("locked", flush=True)
        time.sleep(30)
""")


def test_a_folder_inside_a_live_run_is_refused(tmp_path):
    outer = tmp_path / "outer"
    proc = subprocess.Popen([sys.executable, "-c", _LIVE, str(outer)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "locked"
        staging = next(p for p in tmp_path.iterdir() if p.name.startswith(".outer.partial-"))
        for inner in (outer / "inner", outer / "a" / "b", staging / "inner"):
            with pytest.raises(FolderError, match=r"inside .*the folder of a live run"), output_folder(inner, "c"):
                pass
        with output_folder(tmp_path / "beside", "c") as run:  # a folder beside it is fine
            (run.staging / "x").write_text("1")
    finally:
        proc.kill()
        proc.wait()
    time.sleep(0.05)
    with output_folder(outer / "inner", "c") as run:  # the run is gone: its folder's inside is free again
        (run.staging / "x").write_text("1")


def test_solve_refuses_a_figure_over_a_device_or_fifo_before_solving(tmp_path):
    specials = _specials(tmp_path)
    for kind, path in specials.items():
        if kind == "folder":
            continue
        link = tmp_path / f"{kind}.png"
        link.symlink_to(path)  # the suffix is a figure's; what it names is not a file
        res = _tdcr("solve", "--tensions", "1,0,0,0,0,0,0,0", "--plot", str(link), cwd=tmp_path)
        assert res.returncode == 2 and res.stdout == "" and "--plot" in res.stderr, (kind, res.stderr)
        assert link.is_symlink() and not stat.S_ISREG(os.stat(path).st_mode), kind

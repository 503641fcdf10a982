"""Issue 44, class 3: another run's folder is input (:mod:`pytdcr.runtime._readback`).

One small ``tdcr workspace`` run is made; each case copies its folder, edits one thing, and checks that
``tdcr inverse --workspace`` exits 2 with one line naming ``--workspace`` and the field (before any solve), or
that :func:`pytdcr.explore.read_workspace` refuses it (a SettingsError naming ``workspace`` and the field). The
untouched copy still loads: no false refusals.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from pytdcr.cli import main
from pytdcr.explore import read_workspace
from pytdcr.runs import read_workspace_pool
from pytdcr.runtime import RunDoc, RunFolder, output_folder
from pytdcr.validate import SettingsError

TARGET = "0.1,0.05,0.3"


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run") / "ws"
    assert main(["workspace", "--n", "64", "--budget", "60", "--directions", "0", "--out", str(out), "-q"]) in (0, 1)
    return out


@pytest.fixture
def copy(run_folder, tmp_path) -> Path:
    dest = tmp_path / "edited"
    shutil.copytree(run_folder, dest, symlinks=True)
    return dest


def _edit_json(folder: Path, change: Callable[[dict], None]) -> None:
    path = folder / "workspace.json"
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def _replace_text(folder: Path, old: str, new: str) -> None:
    path = folder / "workspace.json"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def _inverse_refuses(folder: Path, capsys, *words: str) -> str:
    code = main(["inverse", "--workspace", str(folder), "--target", TARGET])
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tdcr: error: --workspace "), err
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def _set(path: str, value) -> Callable[[dict], None]:
    def change(d: dict) -> None:
        keys = path.split(".")
        for k in keys[:-1]:
            d = d[int(k)] if isinstance(d, list) else d[k]
        d[keys[-1]] = value
    return change


def _drop(path: str) -> Callable[[dict], None]:
    def change(d: dict) -> None:
        keys = path.split(".")
        for k in keys[:-1]:
            d = d[k]
        del d[keys[-1]]
    return change


JSON_CASES = [
    ("release is the string 'false'", _set("inputs.loads.release", "false"), "inputs.loads.release"),
    ("release is 0", _set("inputs.loads.release", 0), "inputs.loads.release"),
    ("a string where a number goes", _set("inputs.bounds.upper", ["20"] * 8), "inputs.bounds.upper"),
    ("a bool where a number goes", _set("inputs.loads.tip_force", [True, 0, 0]), "inputs.loads.tip_force"),
    ("a float where an int goes", _set("inputs.loads.point_loads", [{"disk": 3.0, "force": [0, 0, 0],
                                                                     "moment": [0, 0, 0]}]),
     "inputs.loads.point_loads[0].disk"),
    ("a disk beyond the robot", _set("inputs.loads.point_loads", [{"disk": 10**6, "force": [0, 0, 0],
                                                                    "moment": [0, 0, 0]}]),
     "inputs.loads.point_loads[0].disk"),
    ("a vector one short", _set("inputs.bounds.lower", [0.0] * 7), "inputs.bounds.lower"),
    ("a vector one long", _set("inputs.loads.tip_moment", [0.0] * 4), "inputs.loads.tip_moment"),
    ("a missing key", _drop("inputs.solver.model"), "inputs.solver.model"),
    ("a missing section", _drop("inputs.loads"), "inputs.loads"),
    ("an unknown model", _set("inputs.solver.model", "no-such-model"), "inputs.solver.model"),
    ("a model that is not a string", _set("inputs.solver.model", ["pcc"]), "inputs.solver.model"),
    ("lower above upper", _set("inputs.bounds.lower", [30.0] * 8), "inputs.bounds"),
    ("a robot field of the wrong type", _set("inputs.robot.segments", "two"), "inputs.robot"),
    ("the robot not a table", _set("inputs.robot", 3), "inputs.robot"),
    ("the inputs a list", _set("inputs", []), "inputs.robot"),
]


@pytest.mark.parametrize(("what", "change", "field"), JSON_CASES, ids=[c[0] for c in JSON_CASES])
def test_an_edited_workspace_json_is_refused_naming_the_field(what, change, field, copy, capsys):
    _edit_json(copy, change)
    _inverse_refuses(copy, capsys, "workspace.json", field)


@pytest.mark.parametrize(("old", "new", "field"), [
    ('"tip_force": [0.0,', '"tip_force": [NaN,', "inputs.loads.tip_force"),
    ('"tip_moment": [0.0,', '"tip_moment": [1e400,', "inputs.loads.tip_moment"),
    ('"upper": [20.0,', '"upper": [Infinity,', "inputs.bounds.upper"),
])
def test_non_finite_numbers_are_refused_naming_the_field(old, new, field, copy, capsys):
    _edit_json(copy, lambda d: None)  # compact separators: one known spelling to edit
    _replace_text(copy, old.replace(" ", "").replace(":", ": "), new)
    _inverse_refuses(copy, capsys, field)


def test_a_workspace_json_that_is_not_json_or_not_an_object(copy, capsys):
    (copy / "workspace.json").write_text("[1, 2, 3]")
    _inverse_refuses(copy, capsys, "workspace.json", "JSON object")
    (copy / "workspace.json").write_bytes(b"{\"inputs\": \xff}")
    _inverse_refuses(copy, capsys, "workspace.json", "not strict JSON")


def test_a_fifo_for_workspace_json_is_refused_without_waiting(copy, capsys):
    (copy / "workspace.json").unlink()
    os.mkfifo(copy / "workspace.json")
    _inverse_refuses(copy, capsys, "finished `tdcr workspace` run")


def _npz_with(folder: Path, **changes) -> None:
    with np.load(folder / "samples.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    (folder / "samples.npz").write_bytes(buf.getvalue())


def _samples(folder: Path) -> dict[str, np.ndarray]:
    with np.load(folder / "samples.npz") as z:
        return {k: z[k] for k in z.files}


SAMPLE_CASES = [
    ("tensions of the wrong width", lambda s: {"tensions": s["tensions"][:, :7]}, "samples.npz: tensions"),
    ("tips of the wrong width", lambda s: {"tip": s["tip"][:, :2]}, "samples.npz: tip"),
    ("a row missing", lambda s: {"stable": s["stable"][:-1]}, "samples.npz: stable"),
    ("a pickled object array", lambda s: {"tensions": np.array([object()] * 3, dtype=object)},
     "samples.npz: tensions"),
    ("NaN tips where converged", lambda s: {"tip": np.full_like(s["tip"], np.nan)}, "samples.npz: tip"),
    ("infinite tensions", lambda s: {"tensions": np.full_like(s["tensions"], np.inf)}, "samples.npz: tensions"),
    ("tensions outside the bounds", lambda s: {"tensions": s["tensions"] + 100.0}, "samples.npz: tensions"),
    ("stable neither 0, 1 nor NaN", lambda s: {"stable": np.full_like(s["stable"], 0.5)}, "samples.npz: stable"),
    ("converged as strings", lambda s: {"converged": s["converged"].astype(str)}, "samples.npz: converged"),
    ("stable as strings", lambda s: {"stable": s["stable"].astype(str)}, "samples.npz: stable"),
]


@pytest.mark.parametrize(("what", "change", "field"), SAMPLE_CASES, ids=[c[0] for c in SAMPLE_CASES])
def test_an_edited_samples_npz_is_refused_naming_the_array(what, change, field, copy, capsys):
    _npz_with(copy, **change(_samples(copy)))
    _inverse_refuses(copy, capsys, field)


def test_a_samples_npz_that_is_garbage_or_missing_an_array(copy, capsys):
    arrays = _samples(copy)
    del arrays["tip"]
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    (copy / "samples.npz").write_bytes(buf.getvalue())
    _inverse_refuses(copy, capsys, "samples.npz: tip: missing")
    (copy / "samples.npz").write_bytes(b"PK\x03\x04 truncated")
    _inverse_refuses(copy, capsys, "samples.npz", "not a whole .npz file")


def test_the_untouched_copy_is_read_as_written(run_folder, copy, capsys):
    """No false refusals: the run's own folder, copied, gives its FSW's samples and a reached
    target, and the explorer reads its meshes and its largest-reach pose."""
    pool = read_workspace_pool(copy)
    s = _samples(run_folder)
    keep = s["converged"] & (s["stable"] != 0.0)  # the FSW's samples: stable, or untested
    assert np.array_equal(pool.tensions, s["tensions"][keep]) and np.array_equal(pool.tips, s["tip"][keep])
    assert pool.loads.release is False and pool.model == "pcc"
    assert main(["inverse", "--workspace", str(copy), "--target", TARGET, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["reachable"]
    view = read_workspace(copy)
    assert view.vertices is not None and view.faces.shape[0] == view.faces_total > 0
    assert view.realisable is not None and view.reach is not None and view.reach.disks is not None


def test_untested_samples_are_the_runs_fsw_and_no_sample_is_refused(copy, capsys):
    """A run under a model without a stability test records ``stable`` NaN: its FSW (every converged sample) is
    what inverse statics starts from, as the run that wrote it says; a run whose samples were all found unstable
    has none."""
    s = _samples(copy)
    _npz_with(copy, stable=np.full_like(s["stable"], np.nan))
    pool = read_workspace_pool(copy)
    assert np.array_equal(pool.tips, s["tip"][s["converged"]])
    _npz_with(copy, stable=np.zeros_like(s["stable"]))
    _inverse_refuses(copy, capsys, "samples.npz: no converged sample not found unstable")


def test_release_true_is_read_as_true(copy):
    _edit_json(copy, _set("inputs.loads.release", True))
    assert read_workspace_pool(copy).loads.release is True


# the explorer: the files workspace.json names, and what it reads besides the inputs

def _explore_refuses(folder: Path, *words: str) -> str:
    with pytest.raises(SettingsError) as info:
        read_workspace(folder)
    text = info.value.worded({"workspace": "--workspace"})
    assert info.value.field == "workspace" and text.startswith("--workspace ") and "\n" not in text
    for w in words:
        assert w in text, text
    return text


@pytest.mark.parametrize(("field", "value"), [
    ("mesh", "../../etc/passwd"), ("mesh", "/etc/passwd"), ("mesh", 3), ("mesh", "sub/../../x.ply"),
    ("realisable.mesh", "../fsw.ply"), ("realisable.mesh", "/etc/hostname"),
])
def test_a_mesh_path_outside_the_folder_is_refused(field, value, copy):
    _edit_json(copy, _set(field, value))
    _explore_refuses(copy, "workspace.json", field)


def test_a_mesh_that_is_a_link_out_of_the_folder_is_refused(copy, tmp_path):
    outside = tmp_path / "outside.ply"
    shutil.copy(copy / "fsw.ply", outside)
    (copy / "fsw.ply").unlink()
    (copy / "fsw.ply").symlink_to(outside)
    _explore_refuses(copy, "workspace.json: mesh", "leads out of the run's folder")


def test_a_link_inside_the_folder_is_followed(copy):
    (copy / "fsw.ply").rename(copy / "boundary.ply")
    (copy / "fsw.ply").symlink_to("boundary.ply")
    assert read_workspace(copy).vertices is not None


def test_a_mesh_that_is_not_a_mesh_or_holds_bad_numbers_is_refused(copy):
    (copy / "fsw.ply").write_bytes(b"ply\nformat garbage\n")
    _explore_refuses(copy, "fsw.ply", "cannot read the boundary mesh")
    import trimesh

    good = trimesh.load(copy / "fsw_realisable.ply", force="mesh")
    for name, mesh in (("nan", trimesh.Trimesh(np.where(np.arange(good.vertices.shape[0])[:, None] == 0, np.nan,
                                                        good.vertices), good.faces, process=False)),
                       ("far", trimesh.Trimesh(good.vertices * 1e6, good.faces, process=False))):
        (copy / "fsw.ply").write_bytes(mesh.export(file_type="ply"))
        _explore_refuses(copy, "fsw.ply", "vertices must be finite")
        assert name


def test_a_missing_or_special_mesh_file_is_refused(copy):
    (copy / "fsw.ply").unlink()
    _explore_refuses(copy, "mesh", "cannot read it")
    os.mkfifo(copy / "fsw.ply")
    _explore_refuses(copy, "mesh", "not a regular file")


@pytest.mark.parametrize(("field", "value", "words"), [
    ("largest_reach.tensions", "15,6,15", "largest_reach.tensions"),
    ("largest_reach.tensions", [1.0] * 7, "largest_reach.tensions"),
    ("largest_reach.tensions", [1e9] * 8, "inside the run's bounds"),
    ("largest_reach.tip", [0.0, 0.0], "largest_reach.tip"),
    ("largest_reach.tip", [0.0, 0.0, 1e300], "largest_reach.tip"),
    ("realisable", "fsw_realisable.ply", "realisable"),
])
def test_the_largest_reach_record_is_read_strictly(field, value, words, copy):
    _edit_json(copy, _set(field, value))
    _explore_refuses(copy, "workspace.json", words)


def test_explore_refuses_the_inputs_as_inverse_does(copy):
    _edit_json(copy, _set("inputs.loads.release", "false"))
    _explore_refuses(copy, "workspace.json: inputs.loads.release")


def test_run_folder_paths_stay_inside(tmp_path):
    run = RunFolder(tmp_path)
    (tmp_path / "a.txt").write_text("x")
    assert run.read_bytes("a.txt", 10) == b"x"
    for bad in ("../a.txt", "/etc/passwd", "", "a\\..\\b", "x/../../a.txt"):
        with pytest.raises(SettingsError):
            run.path(bad, "f")
    with pytest.raises(SettingsError, match="larger than"):
        run.read_bytes("a.txt", 0)


def test_a_design_study_manifest_is_read_strictly(tmp_path):
    """The manifest a resumed or replaced run reads (:mod:`pytdcr.runtime._folders`): a FIFO or a manifest of
    the wrong shape is no run's (the folder is refused, never replaced), and reading it never blocks."""
    from pytdcr.runtime import FolderError

    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "manifest.json")
    with pytest.raises(FolderError, match="not part of a tdcr run"), output_folder(out, "test"):
        pass
    (out / "manifest.json").unlink()
    (out / "manifest.json").write_text(json.dumps({"command": "x", "status": "complete", "pytdcr": "0",
                                                   "files": [["nested"]]}))
    with pytest.raises(FolderError, match="not part of a tdcr run"), output_folder(out, "test"):
        pass


# review of issue 44: numbers beyond a float, array headers, point loads, mesh loaders, links, the bounds rule

@pytest.mark.parametrize(("field", "value"), [
    ("inputs.loads.tip_force", [10**400, 0, 0]),
    ("inputs.bounds.upper", [10**400] * 8),
    ("inputs.loads.point_loads", [{"disk": 3, "force": [0, -(10**400), 0], "moment": [0, 0, 0]}]),
])
def test_an_integer_beyond_a_float_is_refused_naming_the_field(field, value, copy, capsys):
    """A JSON integer of 400 digits is no float: refused by name, never an OverflowError."""
    _edit_json(copy, _set(field, value))
    line = _inverse_refuses(copy, capsys, "workspace.json", field)
    assert "internal error" not in line and "Overflow" not in line


def test_read_float_refuses_an_integer_beyond_a_float(tmp_path):
    doc = RunDoc(RunFolder(tmp_path), "x.json", {"a": 10**400, "b": -(10**400), "c": 2, "d": True})
    for path in ("a", "b", "d"):
        with pytest.raises(SettingsError, match=rf"x\.json: {path} = .*must be a finite number"):
            doc.read_float(path)
    assert doc.read_float("c", 0.0, 3.0) == 2.0
    with pytest.raises(SettingsError, match=r"c = 2: must be a finite number in \[0, 1\]"):
        doc.read_float("c", 0.0, 1.0)


@pytest.mark.parametrize(("what", "value"), [("force", [0.0, 0.0, 1e7]), ("moment", [2e6, 0.0, 0.0])])
def test_a_point_load_beyond_the_safe_range_is_refused_naming_the_field(what, value, copy, capsys):
    load = {"disk": 3, "force": [0.0, 0.0, 0.0], "moment": [0.0, 0.0, 0.0], what: value}
    _edit_json(copy, _set("inputs.loads.point_loads", [load]))
    _inverse_refuses(copy, capsys, "workspace.json", f"inputs.loads.point_loads[0].{what}", "within +/-1e+06")


def _claiming(arrays: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> bytes:
    """An .npz of ``arrays`` whose member ``key`` has a float64 header declaring ``shape`` over 8 bytes of data."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for k, a in arrays.items():
            member = io.BytesIO()
            if k == key:
                np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": shape})
                member.write(b"\x00" * 8)
            else:
                np.lib.format.write_array(member, a)
            zf.writestr(f"{k}.npy", member.getvalue())
    return buf.getvalue()


@pytest.mark.parametrize("shape", [(2**40,), (2**20, 2**20), (1000,), (-1,)])
def test_an_array_header_declaring_more_than_it_holds_is_refused_unread(shape, copy, capsys):
    """A header claiming 2**40 items (8 TiB) is refused from its few bytes, never a MemoryError."""
    (copy / "samples.npz").write_bytes(_claiming(_samples(copy), "tensions", shape))
    _inverse_refuses(copy, capsys, "samples.npz: tensions", "header declares")


def test_npz_arrays_reads_what_numpy_reads(copy):
    """The one .npz reader answers exactly as numpy.load, Fortran order and all."""
    from pytdcr.runtime._readback import npz_arrays

    s = _samples(copy)
    s["fortran"] = np.asfortranarray(np.arange(12.0).reshape(3, 4))
    buf = io.BytesIO()
    np.savez_compressed(buf, **s)
    got = npz_arrays(buf.getvalue(), 2**30)
    assert set(got) == set(s)
    for k, a in s.items():
        assert got[k].dtype == a.dtype and np.array_equal(got[k], a, equal_nan=a.dtype.kind == "f")
        assert got[k].flags.f_contiguous == a.flags.f_contiguous
    assert set(npz_arrays(buf.getvalue(), 2**30, ["tip", "nothing"])) == {"tip"}


def test_the_sample_shapes_are_named_by_their_rows(copy, capsys):
    s = _samples(copy)
    _npz_with(copy, converged=np.stack([s["converged"]] * 2))
    line = _inverse_refuses(copy, capsys, "samples.npz: converged", "not (M,)")
    assert "-1" not in line.split("samples.npz: ", 1)[1]  # the tmp folder's name may hold "-1"
    _npz_with(copy, converged=s["converged"], tensions=s["tensions"][:, :7])
    _inverse_refuses(copy, capsys, "samples.npz: tensions", "not (M, 8)")


@pytest.mark.parametrize(("field", "name"), [("mesh", "fsw.glb"), ("mesh", "fsw.obj"), ("mesh", "fsw"),
                                             ("realisable.mesh", "fsw_realisable.dae")])
def test_a_mesh_of_another_format_is_refused(field, name, copy):
    """Runs write PLY only: another suffix is refused by name, no other trimesh loader reached."""
    shutil.copy(copy / "fsw.ply", copy / name)
    _edit_json(copy, _set(field, name))
    _explore_refuses(copy, f"workspace.json: {field}", ".ply")


def test_a_ply_mesh_is_read_as_ply_whatever_its_contents(copy):
    """A .ply name holding another format is read as PLY (and refused as no PLY), never by its own loader."""
    import trimesh

    good = trimesh.load(copy / "fsw.ply", force="mesh")
    (copy / "fsw.ply").write_bytes(good.export(file_type="obj").encode())
    _explore_refuses(copy, "fsw.ply", "cannot read the boundary mesh")


def test_a_link_swapped_in_after_the_check_is_not_followed(tmp_path, monkeypatch):
    """The checked path is opened without following a link: a link put there between check and open (here: the
    check made to answer with one) is refused, never read through."""
    (tmp_path / "run").mkdir()
    secret = tmp_path / "secret.txt"
    secret.write_text("not the run's")
    run = RunFolder(tmp_path / "run")
    (run.root / "a.txt").symlink_to(secret)
    monkeypatch.setattr(RunFolder, "path", lambda self, name, what: self.root / name)  # as if swapped since
    with pytest.raises(SettingsError, match=r"a\.txt: not a regular file"):
        run.read_bytes("a.txt", 100)


def test_one_rule_for_tensions_inside_the_bounds():
    from pytdcr import TensionBounds
    from pytdcr.runs._inverse import BOUNDS_SLACK, inside_bounds

    bounds = TensionBounds.uniform(2, 0.0, 20.0)
    slack = BOUNDS_SLACK * 20.0  # relative to the upper bound
    assert inside_bounds(np.array([-0.5 * slack, 20.0 + 0.5 * slack]), bounds)
    assert inside_bounds(np.array([[0.0, 3.0]] * 4), bounds)
    assert not inside_bounds(np.array([0.0, 20.0 + 2 * slack]), bounds)
    assert not inside_bounds(np.array([-2 * slack, 1.0]), bounds)
    assert not inside_bounds(np.array([np.nan, 1.0]), bounds)
    small = TensionBounds.uniform(2, 0.0, 0.5)  # at least 1 N times BOUNDS_SLACK
    assert inside_bounds(np.array([0.5 + 0.5 * BOUNDS_SLACK, 0.0]), small)
    assert not inside_bounds(np.array([0.5 + 2 * BOUNDS_SLACK, 0.0]), small)

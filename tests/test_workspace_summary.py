"""The workspace study's numbers as one typed result (issue 45): :class:`WorkspaceSummary` reads every
``workspace.json`` the golden baselines hold, writes it back key for key, is read by attribute, and refuses a
file whose keys were renamed, naming the key."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pytdcr.records import RecordKeyError
from pytdcr.workspace import WorkspaceSettings, WorkspaceSummary, workspace_study
from pytdcr.workspace._volume import RegionDimension
from pytdcr.workspace.parts import RegionNumbers, VolumeEstimate

GOLDEN = Path(__file__).resolve().parent / "golden"
#: the keys a run adds to the study's numbers in ``workspace.json``
RUN_KEYS = ("inputs", "warnings", "files")
#: the golden baselines drop times (tests/test_golden.py's VOLATILE): compared without them
TIMES = re.compile(r"second|time")


def _without_times(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _without_times(v) for k, v in data.items() if not TIMES.search(k)}
    if isinstance(data, list):
        return [_without_times(v) for v in data]
    return data


def _workspace_files(data: Any, where: str = "") -> list[tuple[str, dict[str, Any]]]:
    """Every ``workspace.json`` held in a golden record, with where."""
    out = []
    if isinstance(data, dict):
        for k, v in data.items():
            if k == "workspace.json" or k.endswith("/workspace.json"):
                out.append((f"{where}/{k}", v))
            else:
                out += _workspace_files(v, f"{where}/{k}")
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out += _workspace_files(v, f"{where}[{i}]")
    return out


GOLDEN_FILES = [(f"{p.stem}{w}", d) for p in sorted(GOLDEN.glob("*.json"))
                for w, d in _workspace_files(json.loads(p.read_text())["data"])]


def test_the_golden_baselines_hold_workspace_files():
    assert any(name.startswith("workspace/") for name, _ in GOLDEN_FILES)


@pytest.mark.parametrize(("name", "data"), GOLDEN_FILES, ids=[n for n, _ in GOLDEN_FILES])
def test_every_golden_workspace_json_reads_and_writes_back(name, data):
    s = WorkspaceSummary.from_json(data)
    numbers = {k: v for k, v in data.items() if k not in RUN_KEYS}
    written = _without_times(s.to_json(meshes=True))
    assert written.pop("schema_version") == 1  # the golden baselines drop it (a version key), as times
    assert written == numbers, name
    without_meshes = s.to_json()
    assert "mesh" not in without_meshes and "mesh" not in without_meshes["realisable"]
    # read by attribute: the same numbers
    assert s.fsw.volume_m3 == data["volume_m3"] and s.realisable.volume_m3 == data["realisable"]["volume_m3"]
    assert s.fsw.largest_reach_m == data["largest_reach_m"] and s.fsw.mesh == data["mesh"]
    assert s.counts.converged == data["counts"]["converged"]
    assert s.counts.by_source == data["counts"]["by_source"]
    assert s.fsw.volume.scales[-1].n_base == data["volume"]["scales"][-1]["n_base"]
    if data["boundary_search"] is not None:
        assert s.boundary_search is not None and s.boundary_search.solves == data["boundary_search"]["solves"]
        assert [r.voxels for r in s.boundary_search.rounds] == [r["voxels"] for r in data["boundary_search"]["rounds"]]
    if data["support"] is not None:
        assert s.support is not None and s.support.h.tolist() == data["support"]["h"]
        assert s.support.tensions.shape == (len(data["support"]["h"]), len(data["inputs"]["robot"]["tendons"]))
    if data["largest_reach"] is not None:
        assert s.largest_reach is not None and s.largest_reach.tip_position.tolist() == data["largest_reach"]["tip"]
    if data["multistability"] is not None:
        assert s.multistability is not None and s.multistability.distinct == data["multistability"]["distinct"]


def test_the_run_warnings_are_worded_from_the_typed_numbers():
    """The warnings a run writes follow from the summary alone: recomputed from a golden file, they are its."""
    from pytdcr.runs._workspace_report import _warnings

    name, data = next((n, d) for n, d in GOLDEN_FILES if n.startswith("workspace/"))
    assert [w.text for w in _warnings(WorkspaceSummary.from_json(data))] == data["warnings"], name


@pytest.fixture(scope="module")
def study():
    from pytdcr import Loads, paper_robot
    from pytdcr.paper import paper_bounds

    settings = WorkspaceSettings(n=16, seed=3, budget=40, directions=2, multistability=4)
    return workspace_study(paper_robot(), Loads(np.zeros(8)), paper_bounds(), settings)


def test_a_study_assembles_its_numbers_once_and_they_round_trip_exactly(study):
    s = study.summary
    assert study.summary is s  # assembled once
    assert study.to_dict() == s.to_json()
    text = json.dumps(s.to_json())
    again = WorkspaceSummary.from_json(json.loads(text))
    assert json.dumps(again.to_json()) == text  # times included, key order included
    assert s.fsw.volume_m3 == study.region.fsw.volume_m3 and s.fsw.points == int(study.samples.feasible.sum())
    assert s.counts.solved == study.samples.converged.size
    assert s.fsw.largest_reach_m == study.largest_reach.reach
    assert s.realisable.largest_reach_m == study.realisable_reach
    assert s.voxel_m == study.region.voxel and s.equilibria == study.region.equilibria


def _trimmed() -> dict[str, Any]:
    """A copy of the golden ``tdcr workspace`` run's ``workspace.json``."""
    return copy.deepcopy(next(d for n, d in GOLDEN_FILES if n.startswith("workspace/")))


def test_a_file_without_the_optional_keys_reads():
    data = _trimmed()
    for key in ("root", "boundary_search", "support", "largest_reach", "multistability", "seconds_sampling",
                "mesh"):
        data.pop(key, None)
    data["realisable"].pop("mesh")
    s = WorkspaceSummary.from_json(data)
    assert s.root is None and s.boundary_search is None and s.support is None and s.largest_reach is None
    assert s.multistability is None and s.fsw.mesh is None and s.seconds_sampling == 0.0
    out = s.to_json()
    assert out["boundary_search"] is None and out["multistability"] is None and out["root"] is None


@pytest.mark.parametrize(("path", "named"), [
    (("volume_m3",), "volume_m3"),
    (("realisable", "points"), "realisable.points"),
    (("counts", "converged"), "counts.converged"),
    (("warm_start", "mode"), "warm_start.mode"),
    (("boundary_search", "stop"), "boundary_search.stop"),
    (("support", "h"), "support.h"),
    (("largest_reach", "tip"), "largest_reach.tip"),
    (("multistability", "distinct"), "multistability.distinct"),
    (("volume", "error_m3"), "volume.error_m3"),
])
def test_a_renamed_key_is_refused_naming_it(path, named):
    data = _trimmed()
    part = data
    for key in path[:-1]:
        part = part[key]
    part[path[-1] + "_renamed"] = part.pop(path[-1])
    with pytest.raises(RecordKeyError) as info:
        WorkspaceSummary.from_json(data)
    assert info.value.key == named and repr(named) in str(info.value)


def test_a_part_that_is_not_an_object_or_another_schema_is_refused():
    data = _trimmed()
    data["counts"] = [1, 2]
    with pytest.raises(ValueError, match="counts must be a JSON object"):
        WorkspaceSummary.from_json(data)
    data = _trimmed()
    data["schema_version"] = 2
    with pytest.raises(ValueError, match="schema_version 2"):
        WorkspaceSummary.from_json(data)


def test_a_planar_region_writes_and_needs_its_area():
    dim = RegionDimension(2, (0.3, 0.2, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
                          area_m2=0.05, area_err_m2=0.004)
    region = RegionNumbers.of(VolumeEstimate(0.0, 0.0, 0.0, 0.0, 1.0, (), 0.0, dim), 40, 0.35, "a rule")
    d = region.to_json()
    assert list(d)[:6] == ["volume_m3", "volume_err_m3", "dimension", "measure", "area_m2", "area_err_m2"]
    assert "length_m" not in d and region.measure == "area" and not region.meshable
    assert RegionNumbers.from_json(d) == region
    assert region.measure_words() == "planar (dimension 2, volume 0): area 500.0 ± 40.0 cm²"
    del d["area_m2"]
    with pytest.raises(KeyError, match="area_m2"):
        RegionNumbers.from_json(d)

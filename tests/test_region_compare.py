"""Regions compared (issue 27, item 5): the Hausdorff distance between boundaries and the share of each region
inside the other, on shapes of known answer, and ``tdcr workspace --compare-models``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pytdcr.runs._workspace_records import WorkspaceComparison
from pytdcr.workspace import region_overlap
from pytdcr.workspace._grid import region_from_points

VOXEL = 0.01


def _ball(centre: tuple[float, float, float], radius: float, n: int = 60_000, seed: int = 0) -> np.ndarray:
    """``n`` uniform points in a ball [m]."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-radius, radius, (3 * n, 3))
    p = p[np.linalg.norm(p, axis=1) <= radius][:n]
    return p + np.asarray(centre)


def test_a_region_compared_with_itself_is_the_same():
    a = region_from_points(_ball((0, 0, 0), 0.1), VOXEL)
    o = region_overlap(a, a)
    assert o.hausdorff_m == 0.0 and o.a_in_b == 1.0 and o.b_in_a == 1.0 and o.voxels_a == o.voxels_b > 0


def test_a_shifted_ball_is_as_far_as_its_shift():
    """Two balls of 0.1 m, one moved 0.04 m along x: their boundaries lie 0.04 m apart at most (the poles of
    the shift), to the resolution of the voxels; each holds the same share of the other, the lens of the two
    balls (closed form: 1 - 3/4 s/r + 1/16 (s/r)^3 of a ball)."""
    r, shift = 0.1, 0.04
    a = region_from_points(_ball((0, 0, 0), r), VOXEL)
    b = region_from_points(_ball((shift, 0, 0), r, seed=1), VOXEL)
    o = region_overlap(a, b)
    assert abs(o.hausdorff_m - shift) <= VOXEL
    assert abs(o.a_to_b_m - o.b_to_a_m) <= VOXEL
    x = shift / r
    lens = 1 - 0.75 * x + x**3 / 16
    assert o.a_in_b == pytest.approx(lens, abs=0.05) and o.b_in_a == pytest.approx(lens, abs=0.05)


def test_a_ball_inside_another_lies_wholly_in_it():
    small = region_from_points(_ball((0.02, 0, 0), 0.05), VOXEL)
    big = region_from_points(_ball((0, 0, 0), 0.12, seed=2), VOXEL)
    o = region_overlap(small, big)
    assert o.a_in_b == 1.0
    # the shares count voxels, each region's boundary layer included: about half a voxel on each radius
    assert o.b_in_a == pytest.approx(((0.05 + VOXEL / 2) / (0.12 + VOXEL / 2)) ** 3, rel=0.1)
    # the farthest point of the big boundary from the small one: the big ball's far side from the small centre
    assert o.hausdorff_m == pytest.approx(0.12 + 0.02 - 0.05, abs=VOXEL)


def test_regions_on_different_voxels_are_refused():
    p = _ball((0, 0, 0), 0.1, n=5000)
    with pytest.raises(ValueError, match="one voxel edge"):
        region_overlap(region_from_points(p, VOXEL), region_from_points(p, 2 * VOXEL))


def test_tdcr_workspace_compare_models(capsys, tmp_path):
    from pytdcr.cli import main

    out = tmp_path / "models"
    code = main(["workspace", "--bounds", "0,3", "--n", "64", "--seed", "2", "--no-gravity", "--budget", "100",
                 "--directions", "0", "--compare-models", "pcc,pcc2", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert "  pcc:" in text and "  pcc2:" in text
    data = json.loads((out / "comparison.json").read_text())
    assert [r["case"] for r in data["cases"]] == [r["model"] for r in data["cases"]] == ["pcc", "pcc2"]
    for kind in ("pcc", "pcc2"):
        summary = json.loads((out / kind / "workspace.json").read_text())
        assert summary["inputs"]["solver"]["model"] == kind
    (pair,) = data["pairs"]
    assert pair["a"] == "pcc" and pair["b"] == "pcc2"
    # two models of one robot at low tension: regions within a few centimetres of each other, overlapping
    assert 0 <= pair["hausdorff_m"] < 0.05 and 0 < pair["a_in_b"] <= 1 and 0 < pair["b_in_a"] <= 1
    assert max(pair["a_to_b_m"], pair["b_to_a_m"]) == pair["hausdorff_m"] and pair["voxels_a"] > 0
    assert "Hausdorff" in (out / "comparison.md").read_text()
    record = WorkspaceComparison.from_json(data)  # the file, typed: the same numbers by attribute
    assert record.to_json() == data and record.pairs[0].overlap.hausdorff_m == pair["hausdorff_m"]
    assert [c.case for c in record.cases] == ["pcc", "pcc2"] and record.failed == ()
    for bad, says in ((["--compare-models", "pcc,pcc"], "two or more distinct"),
                      (["--compare-models", "pcc,nope"], "two or more distinct"),
                      (["--compare-models", "pcc"], "two or more distinct"),
                      (["--compare-models", "pcc,pcc2", "--compare-loads"], "choose one comparison"),
                      (["--compare-models", "pcc,cosserat", "--friction", "none", "--equilibria", "continuation"],
                       "cannot continue")):
        code = main(["workspace", *bad, "--out", str(tmp_path / "no")])
        err = capsys.readouterr().err
        assert code == 2 and "--" in err and says in err, (bad, err)
        assert not (tmp_path / "no").exists()


@pytest.mark.slow
def test_the_reproduce_workspace_section_compares_the_models(tmp_path):
    """``tdcr reproduce --full``'s workspace section with models (here a small budget and two): per model a
    volume, per pair the overlap, the slices written and the report's table."""
    from pytdcr.paper import paper_bounds, paper_robot
    from pytdcr.runs import ReproduceSettings
    from pytdcr.runs._workspace import workspace_section
    from pytdcr.runs._workspace_report import workspace_text

    s = ReproduceSettings(workspace_n=16, workspace_budget=0, workspace_voxels=10, workspace_models=("pcc", "pcc2"),
                          models_n=32, models_voxels=10)
    files: list[str] = []
    ws = workspace_section(paper_robot(), paper_bounds(), s, tmp_path, files, seed=1)
    models = ws.models
    assert models is not None
    assert [r.model for r in models.cases] == ["pcc", "pcc2"] and all(r.volume_m3 > 0 for r in models.cases)
    (pair,) = models.pairs
    assert pair.a == "pcc" and pair.b == "pcc2" and pair.overlap.hausdorff_m is not None
    assert "workspace_models_slices.png" in files and (tmp_path / "workspace_models_slices.png").is_file()
    text = "\n".join(workspace_text(ws, s))
    assert "### The workspace by model" in text and "| pcc2 |" in text and "Hausdorff" in text
    # the models' searches stop at folds (an sscr search that snaps through them takes hours)
    from pytdcr.runs._workspace import _section_cases

    loads_cases, model_cases = _section_cases(paper_robot(), s, 1)
    assert {v[2].folds for v in model_cases.values()} == {"stop"}
    assert {v[2].folds for v in loads_cases.values()} == {"snap"}
    assert workspace_section(paper_robot(), paper_bounds(), ReproduceSettings(workspace_n=16, workspace_budget=0,
                                                                          workspace_voxels=10),
                             tmp_path, [], seed=1).models is None


def test_a_comparisons_progress_names_each_case(tmp_path):
    """Every stage a comparison shows carries its case's name (the bars of one case are told from the next)."""
    from pytdcr.paper import paper_bounds, paper_loads, paper_robot
    from pytdcr.runs import WorkspaceRunOptions, run_workspace_compare
    from pytdcr.workspace import WorkspaceSettings

    seen: list[str] = []

    def progress(stage: str, total: int | None):
        seen.append(stage)
        return lambda done: None

    robot = paper_robot()
    cases = {"pcc": (robot, paper_loads(), None, "pcc", None), "pcc2": (robot, paper_loads(), None, "pcc2", None)}
    settings = WorkspaceSettings(n=16, seed=1, search=False, directions=0, multistability=0, reach="samples")
    run_workspace_compare(robot, cases, paper_bounds(), settings, tmp_path / "out",
                          run_options=WorkspaceRunOptions(progress=progress))
    assert seen and all(s.startswith(("pcc: ", "pcc2: ")) for s in seen)
    assert any(s.startswith("pcc2: ") for s in seen)

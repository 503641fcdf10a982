"""Design studies: the study file's validation, the choice of designs, and runs on local processes and on a real
Dask LocalCluster that give the same table, resume, refuse a changed study and record failed designs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pytdcr.designs import (
    MEASURES,
    DesignsRunOptions,
    StudyError,
    apply_parameters,
    choose_designs,
    evaluate_design,
    from_unit,
    load_study,
    objective_matrix,
    pareto_front,
    read_parameter,
    run_designs,
    study_from_dict,
)
from pytdcr.paper import paper_robot
from pytdcr.runtime import FolderError


def _study(**over):
    data = {"name": "t", "robot": "paper", "seed": 3, "bounds": [0.0, 10.0],
            "parameters": {"backbone_radius": {"values": [0.0007, 0.003]},
                           "routing_radius_2": {"values": [0.002, 0.01]}},
            "budget": {"samples": 24}, "loads": {"cases": ["no load"]},
            "measures": {"directions": {"up": [0.0, 0.0, 1.0]}}}
    data.update(over)
    return data


@pytest.mark.parametrize(("change", "says"), [
    ({"colour": "red"}, "colour: unknown key"),
    ({"seed": "7"}, "seed"),
    ({"parameters": {"routing_radius_3": {"values": [0.01]}}}, "routing_radius_3: the robot has segments 1 to 2"),
    ({"parameters": {"wing_span": {"values": [1.0]}}}, "unknown parameter 'wing_span'"),
    ({"parameters": {"backbone_radius": {"range": [0.001, 0.2]}}}, "parameters.backbone_radius = 0.2"),
    ({"parameters": {"disks_1": {"values": [10.5]}}}, "must be a whole number"),
    ({"parameters": {"disks": {"range": [5, 3]}}}, "lo must not exceed hi"),
    ({"designs": {"method": "sobol"}}, "needs count"),
    ({"bounds": [5.0, 1.0]}, "bounds = [5.0, 1.0]"),
    ({"parameters": {"disks": {"range": [1, 10000], "steps": 10000},
                     "segment_length": {"range": [0.1, 0.3], "steps": 10000}}}, "the grid holds 100,000,000 designs"),
    ({"loads": {"cases": ["on the moon"]}}, "loads.cases"),
    ({"model": "fem"}, "unknown model 'fem'"),
    ({"measures": {"directions": {"up": [0.0, 0.0, 0.0]}}}, "direction 'up' is zero"),
    ({"designs": {"method": "optimize", "population": 8}}, "needs generations"),
    ({"designs": {"method": "optimize", "population": 8, "generations": 2, "count": 5}}, "count goes with"),
    ({"designs": {"method": "grid", "population": 8}}, "population goes with method = 'optimize'"),
    ({"designs": {"method": "optimize", "population": 2, "generations": 2}}, "designs.population"),
    ({"objectives": [{"measure": "beauty", "goal": "max"}]}, "objectives.0.measure = 'beauty'"),
    ({"objectives": [{"measure": "h_side_m", "goal": "max"}]}, "objectives.0.measure = 'h_side_m'"),
    ({"objectives": [{"measure": "volume_m3", "goal": "most"}]}, "objectives.0.goal"),
    ({"objectives": [{"measure": "volume_m3", "goal": "max", "load_case": "paper wrench"}]},
     "objectives.0.load_case = 'paper wrench'"),
    ({"objectives": [{"measure": "volume_m3", "goal": "max"}, {"measure": "volume_m3", "goal": "min"}]},
     "the same measure and load case twice"),
    ({"budget": {"samples": 24, "voxel": 0.0}}, "budget.voxel"),
    ({"budget": {"samples": 24, "folds": "bounce"}}, "budget.folds"),
])
def test_a_bad_study_is_refused_naming_the_key(change, says):
    with pytest.raises(StudyError) as err:
        study_from_dict(_study(**change), "s.toml")
    assert says in str(err.value) and str(err.value).startswith("s.toml: ")


def test_designs_are_a_grid_or_seeded_sobol_points():
    study, _ = study_from_dict(_study())
    grid = choose_designs(study.parameters, "grid", None, seed=0)
    assert grid == [{"backbone_radius": a, "routing_radius_2": b} for a in (0.0007, 0.003) for b in (0.002, 0.01)]
    study, _ = study_from_dict(_study(parameters={"segment_length_1": {"range": [0.1, 0.3]},
                                                  "disks": {"values": [5, 10, 20]}}))
    a = choose_designs(study.parameters, "sobol", 16, seed=5)
    assert a == choose_designs(study.parameters, "sobol", 16, seed=5) != choose_designs(study.parameters, "sobol", 16,
                                                                                            seed=6)
    assert all(0.1 <= d["segment_length_1"] <= 0.3 and d["disks"] in (5, 10, 20) for d in a)
    assert {d["disks"] for d in a} == {5, 10, 20}


def test_a_design_whose_robot_is_impossible_fails_with_its_reason():
    study, robot = study_from_dict(_study())
    rec = evaluate_design(study.model_dump(), robot.model_dump(), 3, {"backbone_radius": 0.003,
                                                                      "routing_radius_2": 0.002})
    assert rec.status == "failed" and "must exceed backbone.outer_radius" in rec.reason and rec.rows == ()


def test_the_small_example_is_valid():
    study, robot, text = load_study("examples/design_study_small.toml")
    assert robot.name == paper_robot().name and "design" in text and len(choose_designs(
        study.parameters, study.designs.method, study.designs.count, seed=study.seed)) == 4


@pytest.mark.parametrize(("name", "designs"), [("design_study_routing.toml", 200),
                                               ("design_study_optimize.toml", 40)])
def test_the_other_examples_are_valid(name, designs):
    study, _, _ = load_study(f"examples/{name}")
    assert (study.designs.count or study.designs.total) == designs


@pytest.mark.slow
def test_local_and_dask_runs_give_one_table_and_resume(tmp_path):
    from distributed import LocalCluster

    study, robot = study_from_dict(_study())
    local = run_designs(study, robot, tmp_path / "local", options=DesignsRunOptions(workers=2))
    t = local.table
    assert list(t["design"]) == [-1, 0, 1, 2, 3] and local.summary.reference == "ok"
    ref = t[t["design"] == -1].iloc[0]  # the base robot, measured like a design
    assert (ref["backbone_radius"], ref["routing_radius_2"]) == (0.0007, 0.01) and ref["status"] == "ok"
    t = t[t["design"] >= 0]
    failed = t[t["status"] == "failed"]
    assert list(failed["design"]) == [2] and "must exceed" in failed["reason"].iloc[0]  # (0.003, 0.002)
    ok = t[t["status"] == "ok"]
    # the 3 mm backbone bends by about 0.01 rad at 10 N: its tips span less than a voxel, so it has no volume
    thin = ok["backbone_radius"] == 0.0007
    assert np.all(ok[thin]["volume_m3"] > 0) and np.all(ok[thin]["fsw_dimension"] == 3)
    assert np.all(ok[~thin]["volume_m3"] == 0) and np.all(ok[~thin]["fsw_dimension"] < 3)
    assert np.all(ok["largest_reach_m"] <= ok["arc_length_m"] + 1e-12)
    assert np.all(ok["h_up_m"] <= ok["largest_reach_m"] + 1e-12) and np.all(ok["peak_stress_pa"] > 0)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = run_designs(study, robot, tmp_path / "dask",
                             options=DesignsRunOptions(scheduler=cluster.scheduler_address))
    assert "Dask" in remote.summary.executor
    assert (tmp_path / "local" / "designs.csv").read_text() == (tmp_path / "dask" / "designs.csv").read_text()
    # run again: everything reused, the same table
    again = run_designs(study, robot, tmp_path / "local", options=DesignsRunOptions(workers=1))
    assert again.summary.designs_reused == 4 and again.summary.designs_computed == 0
    assert again.table.equals(local.table)
    # a missing design file is computed again, alone
    (tmp_path / "local" / "designs" / "000001.json").unlink()
    part = run_designs(study, robot, tmp_path / "local", options=DesignsRunOptions(workers=1))
    assert (part.summary.designs_reused, part.summary.designs_computed) == (3, 1)
    assert (tmp_path / "local" / "designs.csv").read_text() == (tmp_path / "dask" / "designs.csv").read_text()
    summary = json.loads((tmp_path / "local" / "summary.json").read_text())
    assert summary["designs_reused"] == 3 and summary["seed"] == 3
    # another study into the same folder is refused, or restarted when asked
    other, _ = study_from_dict(_study(seed=4))
    with pytest.raises(FolderError, match="a run of other inputs"):
        run_designs(other, robot, tmp_path / "local")
    # the same study on a changed base robot (its file edited) is another study too
    heavier = robot.model_copy(update={"backbone": robot.backbone.model_copy(update={"youngs_modulus": 1e11})})
    with pytest.raises(FolderError, match="a run of other inputs"):
        run_designs(study, heavier, tmp_path / "local")
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "notes.txt").write_text("mine")
    with pytest.raises(FolderError, match="not part of a tdcr run"):
        run_designs(study, robot, tmp_path / "x")
    best = tmp_path / "local" / "best"
    assert len(list(best.glob("design_*.toml"))) == 1


@pytest.mark.slow
def test_tdcr_designs_runs_the_small_example(tmp_path, capsys):
    from pytdcr.cli import main

    out = tmp_path / "small"
    code = main(["designs", "examples/design_study_small.toml", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert "4 designs, 4 computed, 0 reused, 0 failed" in text
    import pandas as pd

    t = pd.read_parquet(out / "designs.parquet")
    assert len(t) == 5 and set(t["load_case"]) == {"paper wrench"} and (t["status"] == "ok").all()
    assert {"h_up_m", "h_side_m", "peak_stress_pa", "volume_err_m3", "pareto", "generation"} <= set(t.columns)
    assert pd.read_csv(out / "designs.csv")["design"].tolist() == [-1, 0, 1, 2, 3]
    for stem in ("pareto", "measures", "best_designs"):
        assert (out / f"{stem}.png").stat().st_size > 10_000 and (out / f"{stem}.pdf").exists()
    report = (out / "report.md").read_text()
    assert "Against the base robot 'paper'" in report and "![pareto.png](pareto.png)" in report
    assert "(search steps snapping through at folds)" in report  # the example leaves the default rule
    assert (out / "study.toml").read_text() == open("examples/design_study_small.toml").read()
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    code = main(["designs", "examples/design_study_small.toml", "--out", str(out)])
    assert code == 0 and "0 computed, 4 reused" in capsys.readouterr()[0]


def test_a_parameter_reads_back_from_the_robot_it_sets():
    robot = paper_robot()
    for name, value in (("routing_radius_2", 0.007), ("segment_length_1", 0.18), ("disks", 12),
                        ("backbone_radius", 0.0009), ("youngs_modulus", 60e9)):
        assert read_parameter(apply_parameters(robot, {name: value}), name) == pytest.approx(value)
    mixed = apply_parameters(robot, {"routing_radius_2": 0.007})
    assert np.isnan(read_parameter(mixed, "routing_radius"))  # the segments differ: no one value
    assert read_parameter(robot, "tendon_angle_offset_1") == 0.0


def test_a_unit_point_maps_onto_the_ranges_and_values():
    study, _ = study_from_dict(_study(parameters={"segment_length_1": {"range": [0.1, 0.3]},
                                                  "disks": {"values": [5, 10, 20]}}))
    assert from_unit(np.array([0.0, 0.0]), study.parameters) == {"segment_length_1": 0.1, "disks": 5}
    assert from_unit(np.array([1.0, 1.0]), study.parameters) == {"segment_length_1": 0.3, "disks": 20}
    assert from_unit(np.array([0.5, 0.5]), study.parameters) == {"segment_length_1": pytest.approx(0.2), "disks": 10}


def test_the_pareto_front_is_the_set_no_design_dominates():
    rng = np.random.default_rng(1)
    for _ in range(20):
        F = rng.integers(0, 6, size=(30, 2)).astype(float)  # ties and duplicates on purpose
        ok = rng.random(30) > 0.2
        front = pareto_front(F, ok)
        assert not np.any(front & ~ok)
        for i in np.flatnonzero(ok):
            beaten = any(np.all(F[j] <= F[i]) and np.any(F[j] < F[i]) for j in np.flatnonzero(ok))
            assert front[i] == (not beaten)


def test_objectives_are_minimised_and_a_failed_design_has_none():
    study, _ = study_from_dict(_study(objectives=[{"measure": "volume_m3", "goal": "max"},
                                                  {"measure": "peak_stress_pa", "goal": "min"}]))
    from pytdcr.designs._records import CaseRow, DesignRecord, Timing

    def rec(status: str, case: str = "no load", **measures: float) -> DesignRecord:
        row = CaseRow(case, **{**dict.fromkeys(MEASURES, float("nan")), **measures}, h_m={}, reach_tensions_n=None)
        return DesignRecord(0, {}, status, "", (row,) if status == "ok" else (), Timing(1.0, "h", 1))

    good = rec("ok", volume_m3=2.0, peak_stress_pa=5.0)
    nan = rec("ok", volume_m3=float("nan"), peak_stress_pa=5.0)
    bad = rec("failed")
    elsewhere = rec("ok", "gravity only", volume_m3=2.0, peak_stress_pa=5.0)  # no row of the objectives' case
    F, ok = objective_matrix(study, [good, nan, bad, elsewhere])
    assert F[0].tolist() == [-2.0, 5.0] and ok.tolist() == [True, False, False, False] and not F[1:].any()


@pytest.mark.slow
def test_an_optimised_study_is_the_same_on_any_executor_and_resumes(tmp_path):
    from distributed import LocalCluster

    study, robot = study_from_dict(_study(
        designs={"method": "optimize", "population": 4, "generations": 3},
        parameters={"routing_radius_2": {"range": [0.004, 0.012]}, "disks_1": {"range": [6, 12]}},
        budget={"samples": 16}, objectives=[{"measure": "largest_reach_m", "goal": "max"},
                                            {"measure": "peak_stress_pa", "goal": "min"}]))
    local = run_designs(study, robot, tmp_path / "local", options=DesignsRunOptions(workers=1, figures=False))
    t = local.table
    assert list(t["design"]) == list(range(-1, len(t) - 1)) and set(t["generation"]) == {-1, 0, 1, 2}
    assert 4 < local.summary.designs <= 12 and local.summary.designs_failed == 0
    assert t["routing_radius_2"].between(0.004, 0.012).all() and t["disks_1"].isin(range(6, 13)).all()
    assert t[t["design"] >= 0].drop_duplicates(["routing_radius_2", "disks_1"]).shape[0] == local.summary.designs
    assert t["pareto"].any() and not t.loc[t["design"] == -1, "pareto"].any()
    # "best" follows the first objective (the largest reach here), in best/, the summary and the report
    best = local.summary.best[0]
    designs = t[t["design"] >= 0]
    assert best.measure == "largest_reach_m" and best.design == designs.loc[designs["largest_reach_m"].idxmax(),
                                                                            "design"]
    assert (tmp_path / "local" / best.robot_file).is_file() and best.error is None
    assert "(max largest_reach_m, the first objective)" in (tmp_path / "local" / "report.md").read_text()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        run_designs(study, robot, tmp_path / "dask",
                    options=DesignsRunOptions(scheduler=cluster.scheduler_address, figures=False))
    assert (tmp_path / "local" / "designs.csv").read_text() == (tmp_path / "dask" / "designs.csv").read_text()
    # the optimiser replays its generations from the files: nothing computed again
    (tmp_path / "local" / "designs" / "000005.json").unlink()
    again = run_designs(study, robot, tmp_path / "local", options=DesignsRunOptions(workers=1, figures=False))
    assert (again.summary.designs_computed, again.summary.designs_reused) == (1, local.summary.designs - 1)
    assert (tmp_path / "local" / "designs.csv").read_text() == (tmp_path / "dask" / "designs.csv").read_text()


def test_the_report_warns_when_volume_errors_exceed_the_margins():
    import pandas as pd

    from pytdcr.designs._report import _screening_note

    def table(err: float) -> pd.DataFrame:
        return pd.DataFrame({"design": [-1, 0, 1, 2], "load_case": ["c"] * 4,
                             "volume_m3": [0.03, 0.05, 0.04, 0.02], "volume_err_m3": [err] * 4})

    study, _ = study_from_dict(_study())  # ranked by volume (the default first objective)
    assert _screening_note(study, table(0.002), "c", 0, "best/design_000000.toml") == []
    note = " ".join(_screening_note(study, table(0.02), "c", 0, "best/design_000000.toml"))
    assert "screening index" in note and "--robot best/design_000000.toml" in note
    assert "best design's error (20000 cm³) exceeds its margin over the next design (10000 cm³)" in note
    assert "and the median error is 58 % of the volume" in note  # both reasons, each in its own words
    note = " ".join(_screening_note(study, table(0.011), "c", 0, "f.toml"))
    assert "exceeds its margin" in note and "median error" not in note  # 32 % of the volume: not said
    # errors larger than half the volumes but under the margin: only that is said
    wide = pd.DataFrame({"design": [-1, 0, 1], "load_case": ["c"] * 3, "volume_m3": [0.01, 0.05, 0.01],
                         "volume_err_m3": [0.008, 0.03, 0.008]})
    note = " ".join(_screening_note(study, wide, "c", 0, "f.toml"))
    assert "the median error is 80 % of the volume" in note and "exceeds its margin" not in note
    # a ranking by a measure without an error has nothing to warn about
    reach, _ = study_from_dict(_study(objectives=[{"measure": "largest_reach_m", "goal": "max"}]))
    assert _screening_note(reach, table(0.02), "c", 0, "f.toml") == []


def test_the_comparison_with_the_base_robot_shows_no_change_it_cannot_compute():
    import pandas as pd

    from pytdcr.designs._report import _versus_reference

    study, _ = study_from_dict(_study())
    row = {"load_case": "c", "volume_m3": 0.02, "volume_err_m3": 0.001, "realisable_volume_m3": 0.01,
           "realisable_volume_err_m3": 0.001, "largest_reach_m": 0.3, "peak_stress_pa": 1e9, "arc_length_m": 0.4,
           "h_up_m": 0.2}
    ok = pd.DataFrame([{"design": -1, **row, "h_up_m": float("nan")}, {"design": 0, **row, "volume_m3": 0.03}])
    lines = _versus_reference(study, ok, "c", 0)
    assert "nan" not in " ".join(lines).lower()
    assert any(line.startswith("| h_up_m |") and line.endswith("| — |") for line in lines)
    assert any(line.startswith("| volume_m3 |") and "+50 %" in line for line in lines)


def test_integer_ranges_give_each_whole_number_its_share_and_a_grid_has_no_twins():
    study, _ = study_from_dict(_study(parameters={"disks": {"range": [3, 5], "steps": 4}}))
    assert choose_designs(study.parameters, "grid", None, seed=0) == [{"disks": 3}, {"disks": 4}, {"disks": 5}]
    study, _ = study_from_dict(_study(parameters={"disks_1": {"range": [6, 14]}}, designs={"method": "sobol",
                                                                                            "count": 9}))
    p = study.parameters
    assert [from_unit(np.array([x]), p)["disks_1"] for x in (0.0, 0.11, 0.112, 0.5, 0.888, 0.89, 1.0)] == \
        [6, 6, 7, 10, 13, 14, 14]
    values = [from_unit(np.array([x]), p)["disks_1"] for x in (np.arange(9000) + 0.5) / 9000]
    assert np.bincount(values)[6:].tolist() == [1000] * 9  # each of 6..14 the same share, the ends too


@pytest.mark.parametrize(("change", "says"), [
    ({"parameters": {"routing_radius": {"values": [0.01]}, "routing_radius_2": {"values": [0.01]}}},
     "routing_radius and routing_radius_2 set the same field"),
    ({"parameters": {"disks_1": {"values": [5]}, "disks_01": {"values": [6]}}}, "disks_1 and disks_01"),
    ({"designs": {"method": "sobol", "count": 4}, "parameters": {"disks": {"range": [3, 5], "steps": 3}}},
     "parameters.disks.steps goes with method = 'grid'"),
    ({"loads": {"custom": {" ": {"tip_force": [0.0, 0.0, -0.1]}}}}, "custom load case name ' '"),
    ({"loads": {"custom": {"a|b": {}}}}, "without | or `"),
])
def test_an_ambiguous_study_is_refused(change, says):
    with pytest.raises(StudyError) as err:
        study_from_dict(_study(**change), "s.toml")
    assert says in str(err.value) and str(err.value).startswith("s.toml: ")


def test_the_largest_reach_is_at_least_every_direction_s_support():
    """With directions and the reach search, the largest reach keeps the farthest of both (|tip| >= d.tip)."""
    study, robot = study_from_dict(_study(budget={"samples": 32, "reach_search": True}, measures={"directions": {
        "up": [0.0, 0.0, 1.0], "side": [1.0, 0.0, 0.0], "out": [1.0, 1.0, 0.3], "down": [0.0, 0.0, -1.0]}}))
    rec = evaluate_design(study.model_dump(), robot.model_dump(), 0, {"backbone_radius": 0.0007,
                                                                      "routing_radius_2": 0.01})
    row = rec.rows[0]
    assert rec.status == "ok", rec.reason
    assert row.largest_reach_m >= max(row.h_m[k] for k in ("up", "side", "out", "down")) - 1e-12
    assert row.largest_reach_m <= row.arc_length_m + 1e-12


def test_a_design_that_kills_its_dask_workers_is_recorded_as_failed():
    from concurrent.futures import Future

    from distributed import KilledWorker

    from pytdcr.designs._records import DesignRecord, Timing
    from pytdcr.designs._run import _wait

    dead, good = Future(), Future()
    from types import SimpleNamespace

    dead.set_exception(KilledWorker("evaluate_design-1", SimpleNamespace(address="tcp://10.0.0.7:40000"), 3))
    good.set_result(DesignRecord(0, {"disks": 4}, "ok", "", (), Timing(1.0, "h", 1)))
    got = []
    _wait(None, {dead: (1, {"disks": 5}), good: (0, {"disks": 4})}, got.append)
    rec = {r.design: r for r in got}
    assert rec[0].status == "ok" and rec[1].status == "failed" and rec[1].params == {"disks": 5}
    assert "KilledWorker" in rec[1].reason and "out of memory" in rec[1].reason and rec[1].rows == ()


@pytest.mark.slow
def test_a_local_worker_that_dies_stops_the_run_saved_and_resumable(tmp_path, monkeypatch):
    """A worker process killed (as the out-of-memory killer would) breaks the local pool: the run stops with
    WorkersLost naming what is saved, leaves no process behind, and the same call resumes."""
    import multiprocessing
    import threading
    import time

    from pytdcr.designs import WorkersLost, _run

    study, robot = study_from_dict(_study(budget={"samples": 16}, reference=False))
    made = []
    real = _run._Local.__init__

    def spy(self, workers):
        real(self, workers)
        made.append(self)

    def killer():
        for _ in range(600):  # the pool exists once the first design is submitted; kill its first worker
            procs = list(getattr(made[0].pool, "_processes", {}).values()) if made else []
            if procs:
                procs[0].kill()
                return
            time.sleep(0.05)

    monkeypatch.setattr(_run._Local, "__init__", spy)
    threading.Thread(target=killer, daemon=True).start()
    with pytest.raises(WorkersLost, match=r"saved \d of 4 designs in .*run the same command again"):
        run_designs(study, robot, tmp_path / "out", options=DesignsRunOptions(workers=2, figures=False))
    monkeypatch.undo()
    assert multiprocessing.active_children() == []
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["status"] == "interrupted"
    again = run_designs(study, robot, tmp_path / "out", options=DesignsRunOptions(workers=2, figures=False))
    assert again.summary.designs == 4 and again.summary.designs_computed + again.summary.designs_reused == 4


def test_tdcr_designs_exits_75_when_the_compute_goes_away(tmp_path, capsys, monkeypatch):
    """The command line's side of WorkersLost: one line saying what is saved, exit 75 (try again), no traceback."""
    from pytdcr import designs
    from pytdcr.cli import main

    def lost(*args, **kwargs):
        raise designs.WorkersLost("the compute stopped under the run; saved 3 of 4 designs in DIR: run the same "
                                  "command again")

    monkeypatch.setattr(designs, "run_designs", lost)
    code = main(["designs", "examples/design_study_small.toml", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 75 and err[-1].startswith("tdcr: the compute stopped") and "saved 3 of 4" in err[-1]
    assert "Traceback" not in "\n".join(err)


def test_planar_designs_name_no_best_by_volume_and_leak_no_warnings(tmp_path, capfd):
    """Every design's region planar (tendons at 0 and 180 deg in both segments: volume 0): no design is named
    best by the volume (report, output, summary; no robot file), the figures draw none as best by it, and no
    NumPy warning (e.g. "Mean of empty slice") reaches the terminal, from this process or its workers."""
    import warnings

    from pytdcr.cli import main
    from pytdcr.io import write_robot
    from pytdcr.robot import Tendon

    paper = paper_robot()
    tendons = tuple(Tendon(segment=s, radius=0.01, angle_deg=a) for s in (1, 2) for a in (0.0, 180.0))
    write_robot(paper.model_copy(update={"tendons": tendons, "name": "planar"}), tmp_path / "planar.toml")
    (tmp_path / "study.toml").write_text('name = "planar"\nrobot = "planar.toml"\nseed = 1\nbounds = [0.0, 10.0]\n'
                                         '[parameters]\nrouting_radius_2 = { values = [0.006, 0.010] }\n'
                                         '[budget]\nsamples = 16\nsearch = 0\n[loads]\ncases = ["no load"]\n')
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        code = main(["designs", str(tmp_path / "study.toml"), "--workers", "1", "--out", str(out)])
    text, err = capfd.readouterr()
    assert code == 0, err
    assert "Warning" not in err and "Mean of empty slice" not in err
    summary = json.loads((out / "summary.json").read_text())
    import pandas as pd

    t = pd.read_csv(out / "designs.csv")
    assert (t["volume_m3"] == 0.0).all() and (t["fsw_dimension"] == 2).all()  # the case is what it claims
    assert summary["best"] == [] and not (out / "best").exists()
    [u] = summary["unranked"]
    assert u["load_case"] == "no load" and u["measure"] == "volume_m3" and "volume_m3 is 0" in u["reason"]
    assert "FSW dimension 2" in u["reason"]
    assert "no load: no best by max volume_m3: every design's volume_m3 is 0" in text and "best by max" not in (
        text.replace("no best by max", ""))
    report = (out / "report.md").read_text()
    assert "## No best under 'no load' (max volume_m3, the first objective)" in report
    assert "## Best under" not in report and "Best: design" not in report


def test_the_volume_error_warning_skips_regions_without_volume():
    """A ranking by volume where some designs are planar (volume 0): the median relative error is taken over
    the designs with a volume (no 0/0 and no warning)."""
    import warnings

    import pandas as pd

    from pytdcr.designs import measures_nothing
    from pytdcr.designs._report import _screening_note

    study, _ = study_from_dict(_study())
    t = pd.DataFrame({"design": [-1, 0, 1, 2], "load_case": ["c"] * 4, "volume_m3": [0.0, 0.05, 0.0, 0.04],
                      "volume_err_m3": [0.0, 0.03, 0.0, 0.03]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        note = " ".join(_screening_note(study, t, "c", 0, "f.toml"))
    assert "the median error is 68 % of the volume" in note  # (0.6 + 0.75) / 2 over the two with a volume
    assert measures_nothing([0.0, 0.0, np.nan]) and not measures_nothing([0.0, 1e-9])
    assert not measures_nothing([np.nan])  # nothing measured is not "0 for every design"

"""The ``tdcr`` command: JSON equals the Python API, errors are one line, exit codes honest."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from pytdcr import Loads, NoFriction, solve
from pytdcr.cli import main
from pytdcr.io import write_robot


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_json_matches_python_api(capsys, paper):
    code, out, _ = run(capsys, "solve", "--tensions", "4,0,0,0,2,0,0,0", "--tip-force", "0.01,0,-0.02",
                       "--tip-moment", "-0.001,0.002,0", "--json")
    assert code == 0
    data = json.loads(out)
    sol = solve(paper, Loads(np.array([4.0, 0, 0, 0, 2, 0, 0, 0]), tip_force=[0.01, 0, -0.02],
                             tip_moment=[-0.001, 0.002, 0]))
    assert data["converged"] is True
    for key in ("residual", "iterations", "tip_position", "tip_rotation", "disk_positions", "q", "tensions"):
        assert key in data
    assert np.allclose(data["tip_position"], sol.tip_position, atol=1e-15)
    assert np.allclose(data["tip_rotation"], sol.tip_rotation, atol=1e-15)
    assert np.allclose(data["q"], sol.q, atol=0)
    assert np.shape(data["disk_positions"]) == (21, 3)
    assert np.allclose(data["tensions"], sol.tensions)


def test_model_options(capsys, tmp_path, paper):
    code, out, _ = run(capsys, "solve", "--tensions", "4,0,0,0,2,0,0,0", "--no-gravity", "--friction", "none",
                       "--json")
    ref = solve(paper.with_gravity(None).with_friction(NoFriction()), Loads(np.array([4.0, 0, 0, 0, 2, 0, 0, 0])))
    assert code == 0 and np.allclose(json.loads(out)["tip_position"], ref.tip_position)
    code, out, _ = run(capsys, "solve", "--tensions", "4,0,0,0,2,0,0,0", "--friction", "0.1", "--release", "--json")
    t = json.loads(out)["tensions"]
    assert code == 0 and t[0][9] > 4.0  # tension rises towards the anchor when releasing
    path = tmp_path / "r.toml"
    write_robot(paper, path)
    code, out2, _ = run(capsys, "solve", "--robot", str(path), "--tensions", "4,0,0,0,2,0,0,0", "--friction", "0.1",
                        "--release", "--json")
    assert code == 0 and json.loads(out2)["tip_position"] == json.loads(out)["tip_position"]


def test_human_summary_and_plot(capsys, tmp_path):
    png = tmp_path / "robot.png"
    code, out, _ = run(capsys, "solve", "--robot", "rao", "--tensions", "4,0,0,0,2,0", "--plot", str(png))
    assert code == 0
    assert "converged" in out and "0.127542" in out
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--tensions", "1,2"], ["--tensions", "8 tendons", "got 2"]),
        (["--tensions", "1,2,3,4,5,6,7,-8"], ["tendon 8", "must be finite and >= 0"]),
        (["--tensions", "1,2,3,4,5,6,7,nan"], ["finite"]),
        (["--tensions", "1,2,3,4,5,6,7,x"], ["value 8 is not a number", "'x'"]),
        (["--tensions", "0,0,0,0,0,0,0,0", "--tip-force", "1,2"], ["--tip-force", "3"]),
        (["--tensions", "0,0,0,0,0,0,0,0", "--friction", "-1"], ["--friction", "[0, 10]"]),
        (["--tensions", "0,0,0,0,0,0,0,0", "--robot", "nope.toml"], ["nope.toml", "cannot read"]),
    ],
)
def test_bad_input_is_one_line_exit_2(capsys, args, words):
    code, out, err = run(capsys, "solve", *args)
    assert code == 2
    assert out == ""
    line = err.strip()
    assert "\n" not in line and line.startswith("tdcr: error:")
    for w in words:
        assert w in line


def test_bad_robot_file(capsys, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\nwheels = 4\n')
    code, _, err = run(capsys, "solve", "--robot", str(path), "--tensions", "1")
    assert code == 2 and "wheels: unknown key" in err


@pytest.mark.parametrize("model", ["pcc", "pcc2"])
def test_not_converged_exit_status(capsys, model):
    code, out, _ = run(capsys, "solve", "--model", model, "--tensions", "19.2,14.5,10.8,5.5,3.2,19.4,10.3,2.3",
                       "--tip-force", "1000,0,-1000", "--tip-moment", "50,0,0", "--json")  # no equilibrium
    data = json.loads(out)
    assert code == 1 and data["converged"] is False
    # what was not obtained is null, never the last iterate's numbers; what happened is said
    for key in ("tip_position", "tip_rotation", "disk_positions", "q", "tensions", "stable", "stability"):
        assert data[key] is None, key
    assert data["residual"] > 0 and data["iterations"] > 0 and data["path"]


def test_console_script_no_traceback():
    proc = subprocess.run([sys.executable, "-m", "pytdcr.cli", "solve", "--tensions", "-1,0"],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr


def test_robot_command_round_trips(capsys, tmp_path, paper):
    code, out, _ = run(capsys, "robot", "--robot", "paper")
    assert code == 0 and "youngs_modulus" in out
    path = tmp_path / "p.toml"
    path.write_text(out)
    from pytdcr.io import read_robot

    assert read_robot(path) == paper


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--bounds", "5,1"], ["--bounds", "lower 5.0 > upper 1.0"]),
        (["--bounds", "-1,3"], ["--bounds", "lower[0] (tendon 1) must be finite and >= 0"]),
        (["--bounds", "0,inf"], ["--bounds", "finite"]),
        (["--bounds", "1"], ["--bounds", "expected 2"]),
    ],
)
def test_bad_bounds(capsys, args, words, tmp_path):
    for cmd in ("sample", "optimize"):
        code, out, err = run(capsys, cmd, "--robot", "rao", *args, "--out", str(tmp_path / "out"))
        assert code == 2 and out == ""
        for w in words:
            assert w in err


def test_bounds_file_errors(capsys, tmp_path):
    f = tmp_path / "b.toml"
    f.write_text("lower = [0, 0]\nupper = [1, 1]\n")
    code, _, err = run(capsys, "sample", "--robot", "rao", "--bounds-file", str(f), "--out", str(tmp_path / "out"))
    assert code == 2 and "has 6 tendons" in err
    f.write_text("lower = [0, 0, 0, 0, 0, 0]\nupper = [1, 1, 1, 1, 1, 1]\nstep = 2\n")
    code, _, err = run(capsys, "sample", "--robot", "rao", "--bounds-file", str(f), "--out", str(tmp_path / "out"))
    assert code == 2 and "unknown key" in err
    f.write_text("lower = [0, 0, ")
    code, _, err = run(capsys, "sample", "--robot", "rao", "--bounds-file", str(f), "--out", str(tmp_path / "out"))
    assert code == 2 and "not valid TOML" in err


def test_sample_and_optimize_commands(capsys, tmp_path):
    code, out, _ = run(capsys, "sample", "--robot", "rao", "--n", "6", "--bounds", "0,3", "--seed", "2",
                       "--out", str(tmp_path / "s"))
    assert code == 0 and "6 samples" in out
    assert (tmp_path / "s" / "fig3a_samples.png").exists() and (tmp_path / "s" / "fig4_configurations.pdf").exists()
    code, out, _ = run(capsys, "optimize", "--robot", "rao", "--pop", "6", "--max-gen", "2", "--bounds", "0,3",
                       "--tip-force", "0,0.02,0", "--json", "--no-polish")
    data = json.loads(out)
    assert code == 0
    for key in ("tensions", "tip_position", "reach", "cost", "generations", "evaluations", "nonconverged",
                "rejected_unstable", "seconds", "seed", "history"):
        assert key in data
    assert "unstable" not in data  # the count of refused individuals, never read beside the optimum's "stable"
    assert data["reach"] <= 0.4 and len(data["history"]["best"]) == data["generations"]


def test_solve_with_the_cosserat_model_matches_the_api(capsys, rao):
    from pytdcr import CosseratOptions

    code, out, _ = run(capsys, "solve", "--robot", "rao", "--tensions", "4,0,0,0,2,0", "--model", "cosserat",
                       "--shear-extension", "--json")
    assert code == 0
    data = json.loads(out)
    sol = solve(rao, Loads([4.0, 0, 0, 0, 2, 0]), model="cosserat", options=CosseratOptions(shear_extension=True))
    assert data["model"] == "cosserat" and data["converged"] is True
    assert np.allclose(data["tip_position"], sol.tip_position, atol=1e-15)
    assert np.shape(data["q"]) == (3,)


def test_cosserat_refuses_friction_in_one_line(capsys):
    code, _, err = run(capsys, "solve", "--tensions", "1,0,0,0,0,0,0,0", "--model", "cosserat")
    assert code == 2
    assert "--friction none" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, "solve", "--tensions", "1,0,0,0,0,0,0,0", "--shear-extension")
    assert code == 2 and "--shear-extension" in err and "model 'pcc'" in err


def test_compare_writes_table_and_figure(capsys, tmp_path):
    out = tmp_path / "cmp"
    code, text, _ = run(capsys, "compare", "--robot", "rao", "--n", "3", "--bounds", "0,4", "--seed", "2",
                        "--out", str(out))
    assert code == 0 and "every model converged on 3" in text
    rows = (out / "compare.csv").read_text().strip().splitlines()
    assert len(rows) == 4
    header = rows[0].split(",")
    for key in ("pcc_x_m", "cosserat_z_m", "cosserat_difference_mm", "cosserat_difference_pct_length", "pcc_ms",
                "cosserat_ms"):
        assert key in header
    diff = [float(r.split(",")[header.index("cosserat_difference_mm")]) for r in rows[1:]]
    assert all(0.0 <= d < 0.015 * 400 for d in diff)  # within the tendon-only bound (mm)
    md = (out / "compare.md").read_text()
    assert md.count("\n| ") >= 4 and "median" in md
    data = json.loads((out / "compare.json").read_text())
    assert data["summary"]["all_converged"] == 3 and data["inputs"]["seed"] == 2
    assert (out / "fig_compare.png").stat().st_size > 10_000


def test_compare_reads_cases_and_rejects_bad_ones(capsys, tmp_path):
    good = tmp_path / "cases.csv"
    good.write_text("T1,T2,T3,T4,T5,T6\n4,0,0,0,2,0\n1,1,0,0,0,0\n")
    code, text, _ = run(capsys, "compare", "--robot", "rao", "--cases", str(good), "--out", str(tmp_path / "o"))
    assert code == 0 and "2 cases" in text
    for body, msg in (("4,0,0\n", "has 6 tendons"), ("4,0,0,0,-2,0\n", ">= 0"), ("4,0,x,0,2,0\n1,2,3,4,5,6\n", "")):
        bad = tmp_path / "bad.csv"
        bad.write_text("1,1,1,1,1,1\n" + body)
        code, _, err = run(capsys, "compare", "--robot", "rao", "--cases", str(bad), "--out", str(tmp_path / "o"))
        assert code == 2 and "--cases" in err and msg in err
    code, _, err = run(capsys, "compare", "--robot", "rao", "--friction", "paper", "--out", str(tmp_path / "o"))
    assert code == 2 and "does not support tendon friction" in err


def test_sample_and_optimize_take_the_model_option(capsys, tmp_path):
    code, text, _ = run(capsys, "sample", "--robot", "rao", "--model", "cosserat", "--n", "4", "--bounds", "0,3",
                        "--out", str(tmp_path / "s"))
    assert code == 0 and "4 converged" in text
    data = json.loads((tmp_path / "s" / "sample_run.json").read_text())
    assert data["inputs"]["solver"]["model"] == "cosserat"
    code, out, _ = run(capsys, "optimize", "--robot", "rao", "--model", "cosserat", "--pop", "6", "--max-gen", "2",
                       "--bounds", "0,3", "--json")
    assert code == 0
    res = json.loads(out)
    assert res["ga"]["reach"] <= 0.4 and res["evaluations"] >= 12
    # the polished optimum is the straight rod, whose RK4 integration hits the length up to roundoff
    assert res["reach"] <= 0.4 * (1 + 1e-12)


def test_accuracy_writes_the_table_and_the_order_study(capsys, tmp_path):
    out = tmp_path / "acc"
    code, text, _ = run(capsys, "accuracy", "--robot", "rao", "--n", "3", "--bounds", "0,3", "--order-cases", "1",
                        "--disks", "5,10", "--out", str(out))
    assert code == 0 and "against sscr" in text
    rows = list(csv.DictReader(open(out / "accuracy.csv")))
    models = {r["model"] for r in rows}
    assert {"pcc", "pcc2", "sscr", "cosserat"} <= models
    groups = {r["group"] for r in rows}
    assert groups == {"tendons", "+gravity", "+tip wrench", "+payload 10 g"}
    for r in rows:  # every model converges on these light cases; the reference's own model is closest to it
        assert r["unsupported"] == "" and int(r["converged"]) == int(r["reference_converged"]) == 3
    by = {(r["group"], r["model"]): float(r["median_error_mm"]) for r in rows}
    assert by[("+tip wrench", "sscr")] < by[("+tip wrench", "pcc2")] < by[("+tip wrench", "pcc")]
    md = (out / "accuracy.md").read_text()
    assert "## Order of convergence" in md and "| +tip wrench | pcc2 |" in md
    data = json.loads((out / "accuracy.json").read_text())
    orders = {o["group"]: o["order"] for o in data["summary"]["orders"]}
    assert orders["+tip wrench"]["pcc2"] > orders["+tip wrench"]["pcc"] + 0.5  # second order against first
    assert (out / "fig_order.png").stat().st_size > 10_000


def test_accuracy_refuses_what_it_cannot_do(capsys, tmp_path):
    code, _, err = run(capsys, "accuracy", "--models", "pcc,prbm", "--out", str(tmp_path / "out"))
    assert code == 2 and "prbm" in err
    code, _, err = run(capsys, "accuracy", "--disks", "5,x", "--out", str(tmp_path / "out"))
    assert code == 2 and "--disks" in err
    code, _, err = run(capsys, "accuracy", "--tip-force", "0,0,1", "--out", str(tmp_path / "out"))
    assert code == 2 and "load groups" in err


def test_version_names_pytdcr_and_the_libraries_results_depend_on(capsys):
    from pytdcr import __version__
    from pytdcr.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and f"pytdcr) {__version__}" in out
    assert all(name in out for name in ("numpy", "scipy", "numba", "pymoo"))


def test_every_manifest_names_the_versions_the_results_depend_on(tmp_path, capsys):
    import json
    from importlib.metadata import version

    from pytdcr.cli import main

    assert main(["sample", "--n", "3", "--seed", "1", "--out", str(tmp_path / "s")]) == 0
    manifest = json.loads((tmp_path / "s" / "manifest.json").read_text())
    assert manifest["versions"] == {n: version(n) for n in ("numpy", "scipy", "numba", "llvmlite", "pymoo")}


def test_solve_writes_every_disks_pose_as_csv(tmp_path, capsys):
    import csv

    from pytdcr import Loads, paper_robot, solve
    from pytdcr.cli import main

    out = tmp_path / "shape.csv"
    assert main(["solve", "--tensions", "3,0,0,0,2,0,0,0", "--tip-force", "0.1,0.1,-0.1", "--csv", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    robot = paper_robot()
    sol = solve(robot, Loads(np.array([3.0, 0, 0, 0, 2, 0, 0, 0]), tip_force=(0.1, 0.1, -0.1)))
    assert len(rows) == robot.n_disks + 1 and [int(r["disk"]) for r in rows] == list(range(robot.n_disks + 1))
    pos = np.array([[float(r[k]) for k in ("x_m", "y_m", "z_m")] for r in rows])
    rot = np.array([[float(r[f"R{i}{j}"]) for i in range(1, 4) for j in range(1, 4)] for r in rows]).reshape(-1, 3, 3)
    np.testing.assert_allclose(pos, sol.disk_positions, atol=1e-12)
    np.testing.assert_allclose(rot, sol.disk_rotations, atol=1e-12)
    capsys.readouterr()
    for bad in (str(tmp_path), str(tmp_path / "shape.txt")):
        assert main(["solve", "--tensions", "3,0,0,0,2,0,0,0", "--csv", bad]) == 2
        assert "--csv" in capsys.readouterr().err


def test_loads_on_any_disk_from_the_command_line(capsys):
    """--disk-force and --disk-moment put point loads on disks, as PointLoad does in Python (repeated options
    add up); a disk the robot does not have, or a malformed value, is refused with the option's name."""
    import json

    from pytdcr import Loads, PointLoad, paper_robot, solve
    from pytdcr.cli import main

    t = "3,0,0,0,2,0,0,0"
    assert main(["solve", "--tensions", t, "--disk-force", "10:0,0,-0.05", "--disk-force", "10:0.01,0,0",
                 "--disk-moment", "20:0,0.01,0", "--json"]) == 0
    tip = np.array(json.loads(capsys.readouterr().out)["tip_position"])
    loads = Loads(np.array([3.0, 0, 0, 0, 2, 0, 0, 0]),
                  point_loads=(PointLoad(10, force=[0.01, 0.0, -0.05]), PointLoad(20, moment=[0.0, 0.01, 0.0])))
    np.testing.assert_allclose(tip, solve(paper_robot(), loads).tip_position, atol=1e-9)
    for bad, says in ((["--disk-force", "21:0,0,1"], "has disks 1 to 20"), (["--disk-force", "0:0,0,1"], "from 1"),
                      (["--disk-moment", "3:0,0"], "3 comma-separated"), (["--disk-force", "3:0,0,nan"], "finite")):
        assert main(["solve", "--tensions", t, *bad]) == 2
        err = capsys.readouterr().err
        assert bad[0] in err and says in err, err


def test_solve_cases_solves_every_row_with_one_model(tmp_path, capsys):
    """--cases: one CSV row per case, each the library's solve of that row; --csv writes the table; options
    that solve one case are refused, and a file whose rows do not fit the robot names --cases."""
    import csv

    from pytdcr import Loads, paper_robot, solve
    from pytdcr.cli import main

    cases = tmp_path / "cases.csv"
    cases.write_text("T1,T2,T3,T4,T5,T6,T7,T8\n3,0,0,0,2,0,0,0\n# a comment\n10,0,5,0,0,20,0,0\n")
    out = tmp_path / "out" / "table.csv"
    assert main(["solve", "--cases", str(cases), "--tip-force", "0.1,0.1,-0.1", "--csv", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [r["case"] for r in rows] == ["1", "2"] and all(r["converged"] == "1" for r in rows)
    robot = paper_robot()
    for r in rows:
        t = np.array([float(r[f"T{c}_N"]) for c in range(1, 9)])
        tip = solve(robot, Loads(t, tip_force=(0.1, 0.1, -0.1))).tip_position
        np.testing.assert_allclose([float(r[k]) for k in ("tip_x_m", "tip_y_m", "tip_z_m")], tip, atol=1e-9)
    capsys.readouterr()
    assert main(["solve", "--cases", str(cases)]) == 0
    printed = list(csv.reader(capsys.readouterr().out.splitlines()))
    assert printed[0][0] == "case" and len(printed) == 3
    assert main(["solve", "--cases", str(cases), "--compliance"]) == 2
    assert "--compliance solves one case" in capsys.readouterr().err
    cases.write_text("1,2,3\n")
    assert main(["solve", "--cases", str(cases)]) == 2
    assert "--cases" in capsys.readouterr().err


@pytest.mark.parametrize("quiet", [False, True])
def test_progress_on_a_pipe_is_plain_timestamped_lines_and_quiet_silences_it(tmp_path, quiet):
    import subprocess
    import sys

    args = [sys.executable, "-m", "pytdcr.cli", "optimize", "--pop", "6", "--max-gen", "2", "--seed", "1",
            *(["--quiet"] if quiet else [])]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0 and "GA (population 6" in proc.stdout
    if quiet:
        assert proc.stderr == ""
    else:
        assert "\r" not in proc.stderr and "\x1b" not in proc.stderr
        import re

        # a kernel this command is the first to compile says so in its own line (the compile notice), apart
        progress = "".join(line for line in proc.stderr.splitlines(keepends=True)
                           if not re.fullmatch(r"pytdcr: compiling .+ for first use, about .+, once\n", line))
        assert re.fullmatch(r"\[\d\d:\d\d:\d\d\] GA: 2/2 gen, best reach \d+\.\d mm, done in \d+ s\n",
                            progress), proc.stderr


def test_concurrent_stages_are_rows_of_one_live_block(monkeypatch):
    """Stages on several threads share one live block on a terminal; a GA capped at 30 generations that stops
    at 6 ends full at 6; the row shows the reach in mm, not the cost; nothing is left running."""
    import io
    import threading

    from pytdcr.cli import _progress

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    monkeypatch.setenv("COLUMNS", "120")
    blocks: set[int] = set()

    def ga(name: str, gens: int) -> None:
        step = bars.generations(name, 30)
        for g in range(gens):
            step(g, 1.0 / 0.3925, 0.0)
            blocks.add(id(_progress._LIVE.progress))
        step.close()

    with _progress.Bars() as bars:
        step = bars("workspace, paper wrench: sampling", 448)
        step(1)
        threads = [threading.Thread(target=ga, args=(f"GA, population {p}", n)) for p, n in ((50, 6), (100, 9))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        step(447)
        blocks.add(id(_progress._LIVE.progress))
    out = sys.stderr.getvalue()
    assert len(blocks) == 1 and _progress._LIVE.progress is None and _progress._LIVE.open == 0
    last = out.rsplit("\x1b[2K", 1)[-1]  # the block's last frame (each frame clears the one before)
    for row in ("GA, population 50", "6/6 gen, best reach 392.5 mm", "GA, population 100", "9/9 gen", "448/448 solve"):
        assert row in last, row
    assert "/30 gen" not in last and "best=" not in out and "2.547" not in out


def test_reproduce_closes_with_its_key_results():
    """The closing lines carry the run's own numbers (constructed results, no run)."""
    from types import SimpleNamespace

    from pytdcr.cli.reproduce import closing_lines
    from pytdcr.runs import SamplingRecord

    opt = SimpleNamespace(reach=0.3929, stable=True)
    bad = SimpleNamespace(reach=0.3941, stable=False)
    res = SimpleNamespace(sampling=SamplingRecord(n=100, converged=98, seconds=1.5, reach_max=0.3874,
                                                  reach_min=0.0141),
                          ga={100: opt, 50: bad}, payload=opt, bounds_study=[(20.0, opt), (40.0, bad)],
                          verdicts=[SimpleNamespace(model="sscr", converged=True, reach=0.3887, tip_shift=0.0591)],
                          workspace=SimpleNamespace(cases=[
                              SimpleNamespace(case="paper wrench", volume_m3=0.011782, volume_err_m3=0.01102,
                                              largest_reach_m=None),
                              SimpleNamespace(case="no load", volume_m3=0.018176, volume_err_m3=0.026816,
                                              largest_reach_m=0.39),
                              SimpleNamespace(case="converged", volume_m3=0.04977, volume_err_m3=0.00892,
                                              largest_reach_m=0.39)]))
    lines = closing_lines(res)
    assert lines[0] == "samples: 98 of 100 converged, reach 14.1 to 387.4 mm"
    assert lines[1] == "GA under the paper's load, population 50: largest reach 394.1 mm (flagged UNSTABLE)"
    assert lines[2] == "GA under the paper's load, population 100: largest reach 392.9 mm (stable)"
    assert "20 N: 392.9 mm (stable); 40 N: 394.1 mm (flagged UNSTABLE)" in lines[4]
    assert lines[5] == "the paper's optimum under sscr: reach 388.7 mm, tip 59.1 mm from pcc's"
    # an error above a quarter of the value: a screening estimate, said on its line
    assert lines[6] == ("workspace, paper wrench: screening estimate 11,782 +- 11,020 cm3 (error 94 %, above 25 %: "
                        "a modest budget; tdcr reproduce --full measures it), largest reach none")
    # an error bar larger than the value: no volume shown as a result
    assert lines[7] == ("workspace, no load: volume not measured at this budget (its error, 26,816 cm3, exceeds the "
                        "estimate; tdcr reproduce --full), largest reach 390.0 mm")
    assert lines[8] == "workspace, converged: 49,770 +- 8,920 cm3, largest reach 390.0 mm"

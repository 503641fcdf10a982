"""Tendon displacement (issue 48, item 1, the Python API): the pulled-in length of every tendon against closed
forms, Hooke's law for the stretch, the displacement-tension round trip, slack, an antagonist that locks the
segment, the complementarity solver against enumeration, and bad input named."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pytdcr.loads import Loads
from pytdcr.paper import RAO_BACKBONE, paper_robot
from pytdcr.robot import NoFriction, Robot, Segment, Tendon
from pytdcr.statics import solve
from pytdcr.statics.displacement import (
    DisplacementOptions,
    lcp,
    pulled_in,
    solve_displacements,
    tendon_stiffness,
)

ANGLES = (0.0, 90.0, 180.0, 270.0)


def one_segment(n_disks: int = 10, gravity=(0.0, 0.0, 0.0)) -> Robot:
    """One 0.2 m segment, four tendons at 10 mm and 0/90/180/270 deg, massless disks, no friction."""
    return Robot(name="one", backbone=RAO_BACKBONE, segments=(Segment(length=0.2, n_disks=n_disks),),
                 tendons=tuple(Tendon(segment=1, radius=0.01, angle_deg=a) for a in ANGLES), gravity=gravity,
                 friction=NoFriction())


def test_a_straight_robot_has_pulled_in_nothing():
    r = paper_robot()
    sol = solve(r.with_gravity(None), Loads(np.zeros(8)))
    assert np.allclose(pulled_in(r, sol), 0.0, atol=1e-15)


@pytest.mark.parametrize("model", ["pcc", "pcc2"])
def test_pulled_in_matches_the_arc_closed_form(model):
    """A frictionless segment bent by one tendon, no gravity: every subsegment has the curvature κ = θ/L (θ the
    tip's bending angle), and the hole at radius r, at angle φ from the bending direction, runs along chords of
    length 2 (1/κ − r cos φ) sin(κ l / 2) between disks l apart."""
    r = one_segment()
    sol = solve(r, Loads(np.array([3.0, 0.0, 0.0, 0.0])), model=model)
    theta = np.arccos(np.clip(sol.tip_rotation[2, 2], -1.0, 1.0))
    kappa, l = theta / 0.2, 0.02
    phi = np.radians(ANGLES)  # bent towards tendon 0, in the +x direction
    chords = 2.0 * (1.0 / kappa - 0.01 * np.cos(phi)) * np.sin(kappa * l / 2.0)
    expected = 0.2 - 10 * chords
    assert theta > 0.3  # a real bend
    assert np.allclose(pulled_in(r, sol), expected, atol=1e-9)
    assert pulled_in(r, sol)[0] > 0 > pulled_in(r, sol)[2]


def test_the_stretch_obeys_hookes_law():
    """No friction: the tension is uniform, each piece of length ℓ is ℓ / (1 + T / (k L0)) unstretched, so a
    stiffness k adds Σℓ T / (k L0 + T) to the pull-in."""
    r = one_segment()
    T = np.array([4.0, 0.0, 1.5, 0.0])
    sol = solve(r, Loads(T))
    stiff = pulled_in(r, sol)
    length = 0.2 - stiff  # the tendons' lengths in the robot (inextensible pull-in: L0 − Σℓ)
    for k in (2e3, 3.5e4):
        stretch = pulled_in(r, sol, k) - stiff
        assert np.allclose(stretch, length * T / (k * 0.2 + T), rtol=1e-12, atol=1e-15)
    assert np.allclose(pulled_in(r, sol, [None, 5e3, None, np.inf]), stiff, rtol=0, atol=1e-15)  # tendon 1 at 0 N


def test_friction_makes_the_stretch_follow_the_piece_tensions():
    r = paper_robot()
    sol = solve(r, Loads(np.array([6.0, 0, 0, 0, 3.0, 0, 0, 0])))
    k = 1e4
    pieces = sol.tensions
    assert pieces[0, 0] > pieces[0, 9] > 0  # friction lowers the tension along the tendon
    uniform_bound = pulled_in(r, sol, k) - pulled_in(r, sol)
    assert 0 < uniform_bound[0] < 6.0 / k  # less than the stretch the base tension alone would give


@pytest.mark.parametrize(("model", "loads"), [
    ("pcc2", Loads(np.zeros(8))),  # gravity and the paper's friction
    ("pcc2", Loads(np.zeros(8), tip_force=(0.1, 0.1, -0.1))),
    ("pcc", Loads(np.zeros(8), tip_force=(0.1, 0.1, -0.1))),
    ("sscr", Loads(np.zeros(8), tip_force=(0.1, 0.1, -0.1))),
])
def test_displacements_give_back_the_tensions_that_made_them(model, loads):
    """Tensions → equilibrium → pull-ins → a displacement-driven solve: the same tensions and equilibrium (the
    zero-tension tendons given 0.5 mm less than they take up, so that they are clearly slack)."""
    r = paper_robot()
    rng = np.random.default_rng(7)
    for _ in range(3 if model != "sscr" else 1):
        T = rng.uniform(0, 10, 8) * (rng.random(8) < 0.5)
        ref = solve(r, loads.with_tensions(T), model=model)
        d = pulled_in(r, ref, 3.5e4) - 5e-4 * (T == 0)
        got = solve_displacements(r, loads, list(d), stiffness=3.5e4, model=model)
        assert got.converged, got.message
        assert got.residual <= 1e-7
        assert np.allclose(got.tensions, T, atol=2e-3)
        assert np.array_equal(got.slack, T == 0)
        assert np.abs(got.solution.tip_position - ref.tip_position).max() < 1e-5
        # the answer is the tension-driven equilibrium of the tensions it found, to the solver's tolerance (a
        # residual of 1e-9 N m moves this tip by about 1e-8 m)
        again = solve(r, loads.with_tensions(got.tensions), model=model)
        assert np.abs(again.tip_position - got.solution.tip_position).max() < 1e-7


def test_mixed_control_keeps_the_given_tensions():
    r = paper_robot()
    loads = Loads(np.array([0, 3.0, 0, 0, 0, 0, 2.0, 0]))
    ref = solve(r, loads.with_tensions(np.array([5.0, 3.0, 0, 0, 0, 0, 2.0, 0])), model="pcc2")
    d = pulled_in(r, ref)
    got = solve_displacements(r, loads, [d[0], None, None, None, None, None, None, None], model="pcc2")
    assert got.converged, got.message
    assert got.tensions[1] == 3.0 and got.tensions[6] == 2.0
    assert got.tensions[0] == pytest.approx(5.0, abs=1e-3)
    assert np.array_equal(got.driven, [True] + [False] * 7)
    assert np.allclose(got.pulled_in, d, atol=1e-6)


@pytest.mark.parametrize("model", ["pcc", "pcc2", "sscr"])
def test_pulling_one_tendon_leaves_its_paid_out_opposite_slack(model):
    r = one_segment()
    got = solve_displacements(r, Loads(np.zeros(4)), [0.005, None, -0.006, None], model=model)
    assert got.converged, got.message
    assert got.tensions[0] > 1.0 and got.tensions[2] == 0.0
    assert got.slack.tolist() == [False, True, True, True]
    assert got.pulled_in[0] == pytest.approx(0.005, abs=1e-7)
    assert got.pulled_in[2] > -0.006  # the shape takes up more than was paid out: the tendon hangs loose


def test_a_held_antagonist_locks_the_segment():
    """A tip force across the segment: with both motors of the bending plane held (Δ = 0), the tendon on the
    far side takes the load and the tip moves far less than with free tendons; a softer tendon, more."""
    r = one_segment()
    force = Loads(np.zeros(4), tip_force=(0.2, 0.0, 0.0))
    free = solve(r, force, model="pcc2").tip_position[0]
    tips = []
    for k in (None, 3.5e4, 3e3):
        got = solve_displacements(r, force, [0.0, None, 0.0, None], stiffness=k, model="pcc2")
        assert got.converged, got.message
        assert got.tensions[2] > 1.0 and got.tensions[0] == 0.0
        tips.append(got.solution.tip_position[0])
    assert 0 < tips[0] < tips[1] < tips[2] < 0.5 * free


def test_a_solve_that_does_not_converge_says_so():
    r = paper_robot()
    got = solve_displacements(r, Loads(np.zeros(8)), [0.02, None, None, None, 0.03, None, None, None],
                              model="pcc2", drive=DisplacementOptions(max_iterations=1))
    assert not got.converged
    assert got.residual > 1e-7 and got.message


def _brute_force_lcp(M, q):
    n = q.size
    for basic in itertools.product([False, True], repeat=n):
        b = np.array(basic)
        z = np.zeros(n)
        if b.any():
            z[b] = np.linalg.solve(M[np.ix_(b, b)], -q[b])
        w = q + M @ z
        if np.all(z >= -1e-12) and np.all(w >= -1e-12):
            return z
    return None


def test_lcp_matches_enumeration_on_p_matrices():
    rng = np.random.default_rng(3)
    for n in (1, 3, 6, 8):
        for _ in range(20):
            a = rng.normal(size=(n, n))
            M = a @ a.T + n * np.eye(n) + 0.5 * (a - a.T)  # positive definite part: a P-matrix
            q = rng.normal(size=n)
            z = lcp(M, q)
            assert z is not None
            w = q + M @ z
            assert np.all(z >= 0) and np.all(w >= -1e-12) and abs(z @ w) < 1e-10
            assert np.allclose(z, _brute_force_lcp(M, q), atol=1e-10)


def test_bad_input_is_named():
    r = paper_robot()
    with pytest.raises(ValueError, match="displacements must give one value"):
        solve_displacements(r, Loads(np.zeros(8)), [0.01, None])
    with pytest.raises(ValueError, match="displacements: value 1 = inf m must be finite"):
        solve_displacements(r, Loads(np.zeros(8)), [np.inf] + [None] * 7)
    with pytest.raises(ValueError, match=r"max_tension must be in \(0, 1e4\] N"):
        DisplacementOptions(max_tension=0.0)
    with pytest.raises(ValueError, match="stiffness must be > 0"):
        tendon_stiffness(r, -1.0)
    with pytest.raises(ValueError, match="stiffness must give one value or one per tendon"):
        tendon_stiffness(r, [1e4, 1e4])


# ---------------------------------------------------------------- the command line and the records

def _tdcr(capsys, *args: str) -> tuple[int, str, str]:
    from pytdcr.cli import main

    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_tdcr_solve_reports_pull_ins_and_drives_by_displacement(capsys):
    import json

    code, text, _ = _tdcr(capsys, "solve", "--tensions", "4,0,0,0,2,0,0,0", "--tip-force=0.1,0.1,-0.1",
                          "--tendon-stiffness", "35000", "--json")
    assert code == 0
    asked = json.loads(text)
    pull = asked["pulled_in_m"]
    assert len(pull) == 8 and "drive" not in asked
    drive = f"{pull[0]!r},-,-,-,{pull[4]!r},-,-,-"
    code, text, _ = _tdcr(capsys, "solve", "--displacements", drive, "--tip-force=0.1,0.1,-0.1",
                          "--tendon-stiffness", "35000", "--json")
    assert code == 0
    got = json.loads(text)
    assert got["drive"]["converged"] and got["drive"]["residual_m"] <= 1e-7
    assert np.allclose(got["drive"]["tensions_n"], [4, 0, 0, 0, 2, 0, 0, 0], atol=2e-3)
    assert got["drive"]["displacements_m"][1] is None and got["drive"]["stiffness_n_per_m"] == [35000.0] * 8
    assert np.allclose(got["tip_position"], asked["tip_position"], atol=1e-5)
    code, text, _ = _tdcr(capsys, "solve", "--displacements", drive, "--tip-force=0.1,0.1,-0.1",
                          "--tendon-stiffness", "35000")
    assert code == 0 and "displacements met" in text and "slack: tendons 2, 3, 4, 6, 7, 8" in text
    assert "stability: stable (with the tensions held; not tested with the displacements held)" in text


def test_a_solve_record_reads_back_its_drive(capsys):
    import json

    from pytdcr.runs import SolveRecord

    _, text, _ = _tdcr(capsys, "solve", "--displacements", "0.005,-,-0.006,-,-,-,-,-", "--json")
    record = SolveRecord.from_json(json.loads(text))
    assert record.drive is not None and record.drive.converged
    assert np.isinf(record.drive.stiffness).all() and np.isnan(record.drive.displacements[1])
    assert record.to_json() == json.loads(text)
    old = json.loads(text)
    del old["pulled_in_m"], old["drive"]  # a result written before displacements existed
    assert SolveRecord.from_json(old).drive is None


def test_a_displacement_beyond_max_tension_is_not_met():
    got = solve_displacements(one_segment(), Loads(np.zeros(4)), [0.01, None, None, None], model="pcc2",
                              drive=DisplacementOptions(max_tension=1.0))
    assert not got.converged and "more than max_tension = 1 N" in got.message


def test_unmet_displacements_exit_1_and_say_why(capsys, monkeypatch):
    import functools

    import pytdcr.runs._solve as runs_solve

    monkeypatch.setattr(runs_solve, "solve_displacements",
                        functools.partial(solve_displacements, drive=DisplacementOptions(max_tension=1.0)))
    code, text, _ = _tdcr(capsys, "solve", "--displacements", "0.01,-,-,-,-,-,-,-", "--model", "pcc2")
    assert code == 1
    assert "NOT converged: the displacements are not met" in text and "max_tension = 1 N" in text
    assert "tip position" not in text


@pytest.mark.parametrize(("args", "words"), [
    (["--displacements", "0.01,-,-"], "--displacements: robot 'paper' has 8 tendons, got 3 values"),
    (["--displacements", "2,-,-,-,-,-,-,-"], "--displacements: value 1 = 2.0 must be a finite number in [-1, 1] m"),
    (["--displacements", "0.5,-,-,-,-,-,-,-"], "--displacements: value 1 = 0.5 m must be finite and within ±0.4 m"),
    (["--displacements", "0.01,x,-,-,-,-,-,-"], "--displacements: value 2 is not a number"),
    (["--displacements", "-,-,-,-,-,-,-,-"], "--displacements: give at least one tendon a displacement"),
    (["--displacements", "0.01,-,-,-,-,-,-,-", "--tendon-stiffness", "1,-3"],
     "--tendon-stiffness: value 2 = -3.0 must be a finite number in (0, inf] N/m"),
    (["--displacements", "0.01,-,-,-,-,-,-,-", "--tendon-stiffness", "1,2"],
     "--tendon-stiffness: robot 'paper' has 8 tendons, got 2 values (or give one for all)"),
    (["--displacements", "0.01,-,-,-,-,-,-,-", "--cases", "x.csv"], "--displacements solves one case"),
    ([], "give --tensions, --displacements or --cases"),
])
def test_bad_displacement_input_is_one_line_exit_2(capsys, args, words):
    code, _, err = _tdcr(capsys, "solve", *args)
    assert code == 2
    assert words in err and err.count("\n") == 1


def test_the_robot_file_carries_each_tendons_stiffness(tmp_path):
    """A tendon's ``stiffness`` in the robot is the default of every displacement computation, survives a
    TOML round trip, and a value out of range is refused naming the field."""
    import pydantic

    from pytdcr import Loads, paper_robot, pulled_in, solve
    from pytdcr.io import read_robot, write_robot
    from pytdcr.statics.displacement import tendon_stiffness

    plain = paper_robot()
    stiff = plain.model_copy(update={"tendons": tuple(
        t.model_copy(update={"stiffness": 2e4 if k < 4 else None}) for k, t in enumerate(plain.tendons))})
    assert tendon_stiffness(stiff, None).tolist() == [2e4] * 4 + [np.inf] * 4
    sol = solve(stiff, Loads(np.array([5.0, 0, 0, 0, 3.0, 0, 0, 0])))
    np.testing.assert_array_equal(pulled_in(stiff, sol), pulled_in(plain, sol, [2e4] * 4 + [None] * 4))
    assert pulled_in(stiff, sol)[0] > pulled_in(plain, sol)[0]  # the motor also takes up the stretch
    write_robot(stiff, tmp_path / "r.toml")
    assert read_robot(tmp_path / "r.toml").tendons[0].stiffness == 2e4
    with pytest.raises(pydantic.ValidationError, match="stiffness"):
        plain.tendons[0].model_validate({**plain.tendons[0].model_dump(), "stiffness": 0.0})


def test_motors_moved_from_a_solved_state_reach_the_loading_paths_equilibrium_and_hold_a_co_contraction():
    """``start``: the motors moved from a solved equilibrium (loads held) reach the same equilibrium as from rest
    where that is unique; and a co-contracted pose (antagonists 1 and 3 both taut, inextensible), which the path
    from rest cannot reach (the straight robot cannot take both pull-ins in), is held with its tensions."""
    from pytdcr import pulled_in, solve_displacements

    robot = paper_robot()
    a = solve(robot, Loads(np.array([3.0, 0, 0, 0, 1.0, 0, 0, 0])))
    b_tensions = np.array([6.0, 0, 0, 0, 2.0, 0, 0, 0])
    b = solve(robot, Loads(b_tensions))
    pulls = np.where(b_tensions > 0, pulled_in(robot, b), pulled_in(robot, b) - 5e-4)
    moved = solve_displacements(robot, Loads(np.zeros(8)), list(pulls), start=a)
    rest = solve_displacements(robot, Loads(np.zeros(8)), list(pulls))
    assert moved.converged and rest.converged
    assert np.linalg.norm(moved.solution.tip_position - rest.solution.tip_position) < 1e-6
    np.testing.assert_allclose(moved.tensions, b_tensions, atol=1e-3)
    t = np.array([6.0, 10.0, 0.3, 0, 0, 4.0, 0, 0])
    held = solve(robot, Loads(t))
    pulls = np.where(t > 0, pulled_in(robot, held), pulled_in(robot, held) - 5e-4)
    assert not solve_displacements(robot, Loads(np.zeros(8)), list(pulls)).converged
    kept = solve_displacements(robot, Loads(np.zeros(8)), list(pulls), start=held)
    assert kept.converged and np.linalg.norm(kept.solution.tip_position - held.tip_position) < 1e-6
    np.testing.assert_allclose(kept.tensions, t, atol=1e-6)

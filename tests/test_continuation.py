"""Continuation from a solved state: ``solve(..., start=solution)`` and ``solve_batch(..., start=batch)``."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pytdcr import Loads, SolverOptions, solve, solve_batch
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT, paper_loads
from pytdcr.statics import UnsupportedFeatureError
from pytdcr.statics.pcc import PCC

PAPER_LOAD = {"tip_force": PAPER_TIP_FORCE, "tip_moment": PAPER_TIP_MOMENT}
#: two cold solves of one tension vector agree to this [m] (each converged to ~1e-9 N m)
SAME_TIP = 1e-6

# One tension vector, two stable equilibria under the paper load: the robot reaches one from rest (the
# loading path) and the other when its tensions come from FAR_SIDE (found by a search over random pairs).
BISTABLE = np.array([13.18, 14.16, 17.09, 16.97, 11.38, 19.27, 10.38, 18.73])
FAR_SIDE = np.array([1.2, 5.55, 4.59, 1.25, 10.83, 8.84, 0.5, 3.12])


def _step(rng: np.random.Generator, t: np.ndarray, size: float) -> np.ndarray:
    """``t`` moved ``size`` [N] in a random direction, kept in [0, 20] N."""
    d = rng.normal(size=t.size)
    return np.clip(t + size * d / np.linalg.norm(d), 0.0, 20.0)


@pytest.mark.parametrize("model", ["pcc", "pcc2", "sscr"])
def test_small_loads_continue_to_the_loading_paths_equilibrium(paper, model):
    """Where the branch is unique (small tensions, no wrench), continuing reaches the equilibrium of a cold
    solve, whatever the start."""
    rng = np.random.default_rng(1)
    t = rng.uniform(0.0, 3.0, paper.n_tendons)
    sol = solve(paper, Loads(t), model=model)
    for _ in range(3):
        t2 = np.clip(_step(rng, t, 1.5), 0.0, 3.0)
        cont = solve(paper, Loads(t2), model=model, start=sol)
        cold = solve(paper, Loads(t2), model=model)
        assert cont.converged and cold.converged and cont.path == "continued"
        assert np.linalg.norm(cont.tip_position - cold.tip_position) < SAME_TIP
        assert cont.loads is not None and np.array_equal(cont.loads.tensions, t2)
        sol, t = cont, t2


def test_every_load_moves_along_the_path(paper):
    """The tip wrench and the tensions both change along one continuation (gravity is the robot's, the same at
    both ends): from the robot under gravity alone to the paper load, the answer is the loading path's."""
    rest = solve(paper, Loads(np.zeros(paper.n_tendons)), options=SolverOptions())
    t = np.array([2.0, 0.0, 1.0, 0.5, 0.0, 1.0, 0.0, 0.5])
    target = Loads(t, **PAPER_LOAD)
    cont = solve(paper, target, start=rest)
    cold = solve(paper, target)
    assert cont.converged and np.linalg.norm(cont.tip_position - cold.tip_position) < SAME_TIP


def test_two_newton_away_steps_converge_and_follow_the_branch(paper):
    """Steps of 2 N from solved states under the paper load: every one converges, and a step there and back
    returns to the state it left (the branch is followed, not jumped)."""
    rng = np.random.default_rng(7)
    loads = paper_loads()
    starts = solve_batch(paper, rng.uniform(0.0, 20.0, (24, paper.n_tendons)), loads)
    ok = starts.converged
    T2 = np.array([_step(rng, t, 2.0) for t in starts.tensions])
    there = solve_batch(paper, T2, loads, start=starts)
    assert np.all(there.converged[ok]), there.path[ok & ~there.converged]
    assert set(there.path[ok]) <= {"continued", "snap"}
    back = solve_batch(paper, starts.tensions, loads, start=there)
    unfolded = ok & (there.path == "continued") & (back.path == "continued")
    assert unfolded.sum() >= 18
    gap = np.linalg.norm(back.tip_position[unfolded] - starts.tip_position[unfolded], axis=1)
    assert np.all(gap < SAME_TIP), gap.max()


def test_a_bistable_tension_vector_keeps_its_history(paper):
    """One tension vector, two stable equilibria: reached from rest and from FAR_SIDE, each is an equilibrium
    within its tolerance, and each is followed (not left) by a small further change of the tensions."""
    loads = paper_loads(BISTABLE)
    from_rest = solve(paper, loads)
    far = solve(paper, paper_loads(FAR_SIDE))
    from_far = solve(paper, loads, start=far)
    for s in (from_rest, from_far):
        assert s.converged and s.residual <= s.atol and s.stable
    assert np.linalg.norm(from_rest.tip_position - from_far.tip_position) > 0.01
    nudged = paper_loads(BISTABLE + 0.05)
    for s in (from_rest, from_far):
        moved = solve(paper, nudged, start=s)
        assert moved.path == "continued"
        assert np.linalg.norm(moved.tip_position - s.tip_position) < 2e-3


def test_a_start_at_the_same_loads_stays_put(paper):
    sol = solve(paper, paper_loads(np.full(paper.n_tendons, 4.0)))
    again = solve(paper, sol.loads, start=sol)
    assert again.converged and again.iterations == 0
    assert np.array_equal(again.q, sol.q)


def test_the_residual_is_affine_in_the_path_parameter(paper):
    """The predictor's dr/dlam = r(q, 1) - r(q, 0) is exact because every load enters the residual linearly:
    along the loading path and between two load sets (the kernels' blend)."""
    rng = np.random.default_rng(3)
    q = rng.normal(0.0, 2.0, 3 * paper.n_disks)
    eq = PCC.equations(paper, Loads(rng.uniform(0, 20, paper.n_tendons), **PAPER_LOAD))
    r0, r1, rs = (eq.evaluate(q, s).residual for s in (0.0, 1.0, 0.37))
    assert np.allclose(rs, r0 + 0.37 * (r1 - r0), rtol=0, atol=1e-12 * np.abs(r1).max())
    other = PCC.equations(paper, Loads(rng.uniform(0, 20, paper.n_tendons), tip_force=[0.0, 0.2, 0.0]))
    m = eq.n_unknowns
    out = {}
    for s in (0.0, 0.37, 1.0):
        r, _, _ = eq.kernel_model.blend(other.kernel_model, s).evaluate(q, 1.0, False)
        assert r.shape == (m,)
        out[s] = r
    assert np.array_equal(out[0.0], r1)
    assert np.allclose(out[0.37], r1 + 0.37 * (out[1.0] - r1), rtol=0, atol=1e-12 * np.abs(r1).max())


def test_batch_rows_are_the_single_continuations_whatever_the_threads(paper):
    rng = np.random.default_rng(11)
    loads = paper_loads()
    starts = solve_batch(paper, rng.uniform(0.0, 20.0, (6, paper.n_tendons)), loads)
    T2 = np.array([_step(rng, t, 2.0) for t in starts.tensions])
    one = solve_batch(paper, T2, loads, start=starts, threads=1)
    two = solve_batch(paper, T2, loads, start=starts, threads=2)
    assert np.array_equal(one.q, two.q, equal_nan=True) and list(one.path) == list(two.path)
    for b in np.flatnonzero(starts.converged):
        start = solve(paper, paper_loads(starts.tensions[b]))
        single = solve(paper, paper_loads(T2[b]), start=start)
        assert np.array_equal(single.q, one.q[b])


def test_rows_without_a_start_are_not_solved(paper):
    loads = paper_loads()
    T = np.full((2, paper.n_tendons), 3.0)
    starts = solve_batch(paper, T, loads)
    broken = starts.rows(np.array([0, 1]))
    object.__setattr__(broken, "converged", np.array([True, False]))
    out = solve_batch(paper, T + 0.5, loads, start=broken)
    assert out.converged.tolist() == [True, False]
    assert out.path.tolist() == ["continued", "no start"] and np.isnan(out.residual[1])


def test_continuation_refuses_what_it_cannot_continue(paper, rao):
    sol = solve(paper, paper_loads(np.full(paper.n_tendons, 2.0)))
    with pytest.raises(ValueError, match="start: solved by model 'pcc', not 'sscr'"):
        solve(paper, paper_loads(), model="sscr", start=sol)
    with pytest.raises(ValueError, match="not both"):
        solve(paper, paper_loads(), q0=sol.q, start=sol)
    with pytest.raises(ValueError, match="release"):
        solve(paper, paper_loads(release=True), start=sol)
    with pytest.raises(ValueError, match="start: not an equilibrium"):
        solve(paper, paper_loads(), start=pickle.loads(pickle.dumps(sol)).__class__(
            **{**{f: getattr(sol, f) for f in sol.__dataclass_fields__}, "loads": paper_loads()}))
    failed = solve(paper, Loads(np.array([19.2, 14.5, 10.8, 5.5, 3.2, 19.4, 10.3, 2.3]), **PAPER_LOAD),
                   options=SolverOptions(max_iter=1, load_stepping="never"))
    assert not failed.converged
    with pytest.raises(ValueError, match="did not converge"):
        solve(paper, paper_loads(), start=failed)
    rao_sol = solve(rao, Loads(np.ones(rao.n_tendons)), model="cosserat")
    with pytest.raises(UnsupportedFeatureError, match="continuation"):
        solve(rao, Loads(np.full(rao.n_tendons, 2.0)), model="cosserat", start=rao_sol)
    with pytest.raises(TypeError, match="start must be"):
        solve(paper, paper_loads(), start="solution")


def test_solutions_keep_their_loads_through_pickling(paper):
    sol = solve(paper, paper_loads(np.full(paper.n_tendons, 2.0)))
    back = pickle.loads(pickle.dumps(sol))
    assert np.array_equal(back.loads.tensions, sol.loads.tensions)
    cont = solve(paper, paper_loads(np.full(paper.n_tendons, 2.5)), start=back)
    assert cont.converged and cont.path == "continued"


def test_a_continuation_through_a_fold_snaps_through(paper):
    """A 2 N step whose branch folds under the paper load (issue 26): the solver used to report it unconverged
    (path 'continued'); following the branch to its fold and relaxing just past it finds the stable equilibrium
    the robot snaps to."""
    start = solve(paper, paper_loads(np.array([9.5875, 10.9816, 5.8682, 9.1316, 0.9143, 16.1904, 18.15, 15.053])))
    assert start.converged and start.stable
    out = solve(paper, paper_loads(np.array([10.1782, 9.771, 6.1484, 10.0499, 1.0268, 15.7501, 18.92, 14.3715])),
                start=start)
    assert out.converged and out.path == "snap" and out.residual <= out.atol and out.stable


def test_a_point_load_at_a_middle_disk_moves_along_the_path(paper):
    """A wrench at disk 10 (not the tip) appears along a continuation: the answer is the cold solve's (a small
    load, a unique branch)."""
    from pytdcr import PointLoad

    t = np.full(paper.n_tendons, 1.0)
    start = solve(paper, Loads(t))
    target = Loads(t, point_loads=[PointLoad(disk=10, force=np.array([0.05, 0.0, 0.0]))])
    cont = solve(paper, target, start=start)
    cold = solve(paper, target)
    assert cont.converged and cont.path == "continued"
    assert np.linalg.norm(cont.tip_position - cold.tip_position) < SAME_TIP
    assert np.linalg.norm(cont.tip_position - start.tip_position) > 1e-3  # the point load moved the tip


def test_a_batch_start_must_be_in_balance_for_this_robot(paper):
    """A batch solved for a stiffer robot (same disks, same unknowns) is refused row by row, not continued
    into a false history; an empty start continues to an empty batch."""
    stiff = paper.model_copy(update={"backbone": paper.backbone.model_copy(
        update={"youngs_modulus": 4 * paper.backbone.youngs_modulus})})
    T = np.full((2, paper.n_tendons), 3.0)
    other = solve_batch(stiff, T, paper_loads())
    with pytest.raises(ValueError, match="start: row 0 is not an equilibrium"):
        solve_batch(paper, T + 0.5, paper_loads(), start=other)
    empty = solve_batch(paper, np.zeros((0, paper.n_tendons)), paper_loads())
    out = solve_batch(paper, np.zeros((0, paper.n_tendons)), paper_loads(), start=empty)
    assert out.converged.shape == (0,)

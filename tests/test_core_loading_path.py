"""The compiled core's loading-path solver (src/cpp/loading_path.hpp, src/cpp/linalg.hpp) against numpy and the numba
solver (pytdcr.statics.kernels.loading_path) on the paper robot.

The C++ LU stands in for numba's LAPACK, so the two solvers agree to round-off, not bit for bit: a case may then
take another branch where the path passes near a fold. The agreement tests print their counts of disagreements
(``pytest -s``).
"""

from __future__ import annotations

import threading
import time
from functools import cache
from typing import NamedTuple

import numpy as np
import pytest

from pytdcr import Loads, NoFriction, paper_robot
from pytdcr import _core as core
from pytdcr.robot import Robot
from pytdcr.statics.compiled import case_tolerances, kernel_settings
from pytdcr.statics.kernels import loading_path as SV
from pytdcr.statics.options import FOLDS, STEP_CONTINUE, SolverOptions
from pytdcr.statics.pcc import PCC

#: random tension vectors per agreement test, uniform in [0, MAX_TENSION] N
CASES = 200
MAX_TENSION = 20.0
#: how far a continuation's start tensions are from its end's [N] (Euclidean)
CONTINUATION_STEP = 2.0
#: agreement of q where both solvers converged on the same path [rad]: each subsegment's bend (|d(beta, gamma)|
#: times its length) and twist
Q_AGREE = 1e-8
#: share of cases whose converged flags must agree
FLAGS_AGREE = 0.99
#: the paper's tip wrench of the loaded case [N], [N m]
TIP_FORCE = (0.1, 0.1, -0.1)
TIP_MOMENT = (-0.1, 0.1, 0.1)


# ------------------------------------------------------------------ linalg.hpp against numpy
@pytest.mark.parametrize("n", [1, 2, 3, 7, 60, 61])
def test_lu_matches_numpy(n: int) -> None:
    """Solve (by the factors of a and of its transpose) and slogdet of random (n, n) matrices agree with LAPACK's
    to round-off."""
    rng = np.random.default_rng(n)
    for _ in range(5):
        a = rng.normal(size=(n, n)) + (0.0 if n > 2 else 0.5) * np.eye(n)
        b = rng.normal(size=n)
        cond = np.linalg.cond(a)
        for solve in (core._lu_solve, core._lu_solve_by_transpose):
            x = solve(a, b)
            assert x is not None
            assert np.allclose(x, np.linalg.solve(a, b), rtol=0.0, atol=1e-13 * cond * np.max(np.abs(x)))
        sign, logdet = core._lu_slogdet(a)
        want_sign, want_logdet = np.linalg.slogdet(a)
        assert sign == want_sign
        assert logdet == pytest.approx(want_logdet, rel=1e-12, abs=1e-12 * n)


def test_lu_pivots() -> None:
    """A zero on the diagonal is pivoted past; the permutation's sign enters the determinant's."""
    a = np.array([[0.0, 2.0], [3.0, 0.0]])
    assert np.array_equal(core._lu_solve(a, np.array([2.0, 3.0])), [1.0, 1.0])
    assert np.array_equal(core._lu_solve_by_transpose(a, np.array([2.0, 3.0])), [1.0, 1.0])
    sign, logdet = core._lu_slogdet(a)
    assert sign == -1.0
    assert logdet == pytest.approx(np.log(6.0), rel=1e-15)


def test_lu_refuses_singular_and_non_finite() -> None:
    """Where np.linalg raises (an exactly singular or a non-finite matrix), the LU gives None; slogdet of a
    singular matrix is (0, -inf), as numpy's."""
    singular = np.array([[1.0, 2.0], [2.0, 4.0]])
    assert core._lu_solve(singular, np.ones(2)) is None
    assert core._lu_solve_by_transpose(singular, np.ones(2)) is None
    assert core._lu_slogdet(singular) == (0.0, -np.inf)
    assert np.linalg.slogdet(singular)[0] == 0.0
    bad = np.array([[1.0, np.nan], [0.0, 1.0]])
    assert core._lu_solve(bad, np.ones(2)) is None
    assert core._lu_solve_by_transpose(bad, np.ones(2)) is None
    assert core._lu_solve_by_transpose(np.eye(2), np.array([np.nan, 1.0])) is None
    assert core._lu_solve(np.eye(2), np.array([1.0, np.inf])) is None
    with pytest.raises(ValueError):
        core._lu_solve(np.ones((2, 3)), np.ones(2))


def test_the_rods_jacobian_is_block_lower_hessenberg_and_solved_as_such() -> None:
    """The subsegment rod's Jacobian at a loaded, bent equilibrium is zero above its first superdiagonal 6 x 6
    block (disk i's balance depends on the base wrenches of subsegments 1..i+1 only): the structure that makes the
    solver's LU of J^T cheap. Solving with it agrees with numpy's."""
    from pytdcr import paper_loads, solve
    from pytdcr.statics.registry import resolve

    robot = paper_robot()
    loads = paper_loads().with_tensions(np.array([12.0, 0.0, 3.0, 0.0, 0.0, 7.0, 0.0, 1.0]))
    sol = solve(robot, loads, model="sscr")
    assert sol.converged
    model, opts = resolve("sscr", robot, loads, None)
    eq = model.equations(robot, loads, opts)
    _, J, _ = eq.kernel_model.evaluate(np.ascontiguousarray(sol.q.ravel()), 1.0, True)
    n = J.shape[0]
    block = np.arange(n) // 6
    above = block[None, :] > block[:, None] + 1
    assert np.all(J[above] == 0.0) and np.count_nonzero(J[~above]) > 0.9 * np.count_nonzero(~above)
    b = np.random.default_rng(3).normal(size=n)
    x = core._lu_solve_by_transpose(J, b)
    assert np.allclose(J @ x, b, rtol=0.0, atol=1e-10 * np.abs(J).max() * np.abs(x).max())
    assert np.allclose(x, np.linalg.solve(J, b), rtol=1e-8, atol=1e-8 * np.abs(x).max())


# ------------------------------------------------------------------ the solver against numba's
class Problem(NamedTuple):
    """One robot under one set of loads, its packed equations and its random tension vectors."""

    robot: Robot
    loads: Loads
    packed: object  # the numba model (pytdcr.statics.kernels.pcc.Packed)
    tensions: np.ndarray  # (CASES, nt) [N]


class Outputs(NamedTuple):
    """The output arrays of one solve_range."""

    q: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    load_steps: np.ndarray
    path: np.ndarray


def empty_outputs(nb: int, m: int) -> Outputs:
    """Output arrays for nb cases of m unknowns."""
    return Outputs(np.full((nb, m), np.nan), np.zeros(nb, dtype=np.bool_), np.full(nb, np.nan),
                   np.zeros(nb, dtype=np.int64), np.zeros(nb, dtype=np.int64), np.full(nb, -1, dtype=np.int64))


@cache
def problem(loaded: bool) -> Problem:
    """The paper robot under the paper's load (gravity, the paper's friction, a tip wrench) or under none (no
    gravity, no friction, no tip wrench), with CASES random tension vectors (a fixed seed)."""
    rng = np.random.default_rng(20261207)
    tensions = rng.uniform(0.0, MAX_TENSION, size=(CASES, 8))
    if loaded:
        robot = paper_robot()
        loads = Loads(np.zeros(8), tip_force=TIP_FORCE, tip_moment=TIP_MOMENT)
    else:
        robot = paper_robot(friction=NoFriction()).with_gravity(None)
        loads = Loads(np.zeros(8))
    packed = PCC.equations(robot, loads, SolverOptions()).packed
    return Problem(robot, loads, packed, tensions)


def settings_for(fold: str, continuation: bool) -> SV.Settings:
    """The library's default settings (the loading path from the straight robot) with fold handling ``fold``; a
    continuation's stepping code if ``continuation``."""
    settings = kernel_settings(SolverOptions(fold=fold))
    return settings._replace(stepping=STEP_CONTINUE) if continuation else settings


def run_numba(pb: Problem, settings: SV.Settings, q0: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> Outputs:
    """The numba solve_range over every row."""
    tols = case_tolerances(pb.robot, pb.loads, t1, settings.atol)
    out = empty_outputs(t1.shape[0], q0.shape[1])
    SV.solve_range(q0, pb.packed, pb.packed, t0, t1, settings, tols, 0, t1.shape[0], *out)
    return out


def run_core(pb: Problem, settings: SV.Settings, q0: np.ndarray, t0: np.ndarray, t1: np.ndarray,
             start: int = 0, stop: int | None = None, out: Outputs | None = None) -> Outputs:
    """pytdcr._core.solve_range_pcc over rows start..stop (default all) into ``out`` (default new arrays)."""
    tols = case_tolerances(pb.robot, pb.loads, t1, settings.atol)
    out = empty_outputs(t1.shape[0], q0.shape[1]) if out is None else out
    model = core.PccModel.from_packed(pb.packed)
    core.solve_range_pcc(q0, model, model, t0, t1, settings, tols, start, t1.shape[0] if stop is None else stop,
                         *out)
    return out


def angle_difference(qa: np.ndarray, qb: np.ndarray, sub: np.ndarray) -> np.ndarray:
    """Per row of qa, qb (B, 3N): the largest change of one subsegment's bend (|d(beta, gamma)| times its length)
    or twist between them [rad], shape (B,)."""
    d = (qa - qb).reshape(qa.shape[0], -1, 3)
    bend = np.hypot(d[..., 0], d[..., 1]) * sub[:, 0]
    return np.max(np.maximum(bend, np.abs(d[..., 2])), axis=1)


@cache
def continuation_starts(loaded: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start states of the continuations: each case's tensions moved CONTINUATION_STEP N in a random direction
    (clipped to [0, MAX_TENSION]), solved there by the numba solver. Returns (rows whose start converged, their
    start q (b, m), their start tensions (b, nt))."""
    pb = problem(loaded)
    rng = np.random.default_rng(7)
    step = rng.normal(size=pb.tensions.shape)
    step *= CONTINUATION_STEP / np.linalg.norm(step, axis=1, keepdims=True)
    t0 = np.ascontiguousarray(np.clip(pb.tensions + step, 0.0, MAX_TENSION))
    m = 3 * pb.packed.sub.shape[0]
    out = run_numba(pb, settings_for("relax", False), np.zeros((CASES, m)), t0, t0)
    rows = np.flatnonzero(out.converged)
    return rows, np.ascontiguousarray(out.q[rows]), np.ascontiguousarray(t0[rows])


@cache
def compare(loaded: bool, continuation: bool, fold: str) -> dict:
    """Both solvers on one problem and mode; the counts of disagreements and the largest q difference."""
    pb = problem(loaded)
    settings = settings_for(fold, continuation)
    m = 3 * pb.packed.sub.shape[0]
    if continuation:
        rows, q0, t0 = continuation_starts(loaded)
        t1 = np.ascontiguousarray(pb.tensions[rows])
    else:
        q0, t0 = np.zeros((CASES, m)), pb.tensions
        t1 = pb.tensions
    start = time.perf_counter()
    ref = run_numba(pb, settings, q0, t0, t1)
    mid = time.perf_counter()
    got = run_core(pb, settings, q0, t0, t1)
    end = time.perf_counter()
    same_flag = ref.converged == got.converged
    same_path = ref.path == got.path
    both = ref.converged & got.converged & same_path
    diff = angle_difference(ref.q, got.q, pb.packed.sub)
    return {
        "cases": int(t1.shape[0]),
        "converged numba": int(ref.converged.sum()),
        "converged core": int(got.converged.sum()),
        "flags differ": int((~same_flag).sum()),
        "paths differ": int((~same_path).sum()),
        "paths numba": np.bincount(ref.path, minlength=6).tolist(),
        "paths core": np.bincount(got.path, minlength=6).tolist(),
        "q beyond": int((diff[both] > Q_AGREE).sum()),
        "max dq": float(np.max(diff[both])) if both.any() else 0.0,
        "differing rows": np.flatnonzero(~same_flag | ~same_path | (both & (diff > Q_AGREE))).tolist(),
        "seconds numba": mid - start,
        "seconds core": end - mid,
    }


@pytest.mark.slow
@pytest.mark.parametrize("fold", list(FOLDS))
@pytest.mark.parametrize("continuation", [False, True], ids=["solve", "continuation"])
@pytest.mark.parametrize("loaded", [True, False], ids=["paper-load", "no-load"])
def test_agrees_with_numba(loaded: bool, continuation: bool, fold: str) -> None:
    """Converged flags agree on >= 99 % of the cases, and where both converged on the same path q agrees to
    Q_AGREE rad."""
    c = compare(loaded, continuation, fold)
    print(f"\n{'paper load' if loaded else 'no load'}, {'continuation' if continuation else 'solve'}, fold {fold}: "
          + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in c.items()))
    assert c["flags differ"] <= (1.0 - FLAGS_AGREE) * c["cases"]
    assert c["q beyond"] == 0, c


def first_rows(rows: int) -> tuple[Problem, SV.Settings, np.ndarray, np.ndarray]:
    """The loaded problem, the default settings (relax at folds), its first ``rows`` tension vectors and the
    straight robot's unknowns for each."""
    pb = problem(True)
    t = np.ascontiguousarray(pb.tensions[:rows])
    return pb, settings_for("relax", False), t, np.zeros((rows, 3 * pb.packed.sub.shape[0]))


def test_threads_split_the_batch() -> None:
    """Two Python threads solving the two halves of a batch (the GIL released) give exactly the answer of one
    call over the whole batch; the calling thread keeps running meanwhile."""
    pb, settings, t, q0 = first_rows(40)
    rows = t.shape[0]
    whole = run_core(pb, settings, q0, t, t)
    split = empty_outputs(rows, q0.shape[1])
    threads = [threading.Thread(target=run_core, args=(pb, settings, q0, t, t, a, b, split))
               for a, b in ((0, rows // 2), (rows // 2, rows))]
    start = time.perf_counter()
    for th in threads:
        th.start()
    gaps, last = [], time.perf_counter()
    while any(th.is_alive() for th in threads):
        now = time.perf_counter()
        gaps.append(now - last)
        last = now
    for th in threads:
        th.join()
    seconds = time.perf_counter() - start
    for a, b in zip(whole, split, strict=True):
        assert np.array_equal(a, b)
    # with the GIL held for the whole computation, this thread would stall for most of it
    assert max(gaps) < 0.5 * seconds


def test_refuses_wrong_shapes() -> None:
    """Arrays of the wrong shape, or a range outside the batch, raise ValueError before any work."""
    pb = problem(True)
    settings = settings_for("relax", False)
    t = np.ascontiguousarray(pb.tensions[:2])
    q0 = np.zeros((2, 3 * pb.packed.sub.shape[0]))
    with pytest.raises(ValueError):
        run_core(pb, settings, q0[:, :-1], t, t)
    with pytest.raises(ValueError):
        run_core(pb, settings, q0, t, t, 0, 3)
    with pytest.raises(ValueError):
        run_core(pb, settings, q0, t[:, :-1], t[:, :-1])


@pytest.mark.parametrize("timed", [True, False])
def test_the_profile_counts_the_work_of_the_same_solves(timed: bool) -> None:
    """_profile_range_pcc (bench/solve_phases.py) solves as solve_range_pcc does, bit for bit, and counts each
    case's work: at least the one Jacobian of the path's first tangent and one factorisation per Jacobian taken
    by Newton, load steps as solve_range reports them; the phases' seconds add up to at most the case's own."""
    pb, settings, t, q0 = first_rows(12)
    ref = run_core(pb, settings, q0, t, t)
    model = core.PccModel.from_packed(pb.packed)
    tols = case_tolerances(pb.robot, pb.loads, t, settings.atol)
    q, res, counts, seconds = core._profile_range_pcc(q0, model, model, t, t, settings, tols, timed)
    assert np.array_equal(q, ref.q)
    assert np.array_equal(res >= 0.0, ref.converged)
    assert np.array_equal(np.where(ref.converged, ref.residual, -ref.residual - 1.0), res)
    assert np.array_equal(counts[:, 3], ref.load_steps) and np.array_equal(counts[:, 4], ref.path)
    assert np.all(counts[:, 1] >= 1) and np.all(counts[:, 2] >= counts[:, 1] - 1) and np.all(counts[:, 0] >= 1)
    if timed:
        assert np.all(seconds[:, 3] > 0.0)
        assert np.all(seconds[:, :3].sum(axis=1) <= seconds[:, 3])
    else:
        assert not np.any(seconds)
    with pytest.raises(ValueError, match="tols must be"):
        core._profile_range_pcc(q0, model, model, t, t, settings, tols[:-1], timed)

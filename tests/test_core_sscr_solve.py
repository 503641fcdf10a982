"""The compiled core's solver on the subsegment Cosserat rod (``pytdcr._core.solve_range_sscr``:
src/cpp/loading_path.hpp on src/cpp/sscr.hpp) against numba's
(:func:`pytdcr.statics.kernels.loading_path.solve_range` on the numba ``SSCRPacked``), and the library's sscr
solves, batches and tip gradients (now the core's) end to end.

The residual and Jacobian are numba's to the bit (tests/test_core_sscr.py); the solver's dense factorisation is
linalg.hpp's LU where numba calls LAPACK, so the two solvers agree to round-off, not bit for bit, and a case may then
take another branch where its path passes near a fold. Where the two disagree on a path, both answers must be
equilibria at full load. The agreement tests print their counts (``pytest -s``). The paper robot under the paper's
load throughout: gravity and the paper's friction (the robot's), the paper's tip wrench (``pytdcr.paper_loads``),
random tension vectors uniform in [0, 20] N.
"""

from __future__ import annotations

import time
from functools import cache
from typing import NamedTuple

import numpy as np
import pytest
from test_core_loading_path import Outputs, empty_outputs

import pytdcr
from pytdcr import _core
from pytdcr.statics.compiled import case_tolerances, kernel_settings
from pytdcr.statics.kernels import loading_path as SV
from pytdcr.statics.options import FOLDS, STEP_CONTINUE, SSCROptions
from pytdcr.statics.sscr import SSCREquations

#: random tension vectors of the slow agreement tests (the fast ones take the first FAST_CASES), uniform in
#: [0, MAX_TENSION] N
CASES = 100
FAST_CASES = 40
MAX_TENSION = 20.0
#: how far a continuation's start tensions are from its end's [N] (Euclidean)
CONTINUATION_STEP = 2.0
#: agreement of q where both solvers converged on the same path: max |difference| of the base wrenches [N m]
Q_AGREE = 1e-8
#: share of the cases whose converged flags may differ (a path near a fold may go either way on round-off)
FLAGS_DIFFER = 0.025
#: agreement of the tip [m] of the library's solves with numba's, where both converged on the same path
TIP_AGREE = 1e-9


class Problem(NamedTuple):
    """The paper robot under the paper's load, its numba packed equations and the random tension vectors."""

    robot: pytdcr.Robot
    loads: pytdcr.Loads
    eq: SSCREquations
    tensions: np.ndarray  # (CASES, nt) [N]


@cache
def problem() -> Problem:
    """The paper robot (gravity, the paper's friction) under the paper's tip wrench, the default rod, and CASES
    random tension vectors (a fixed seed)."""
    robot = pytdcr.paper_robot()
    loads = pytdcr.paper_loads(np.zeros(robot.n_tendons))
    eq = SSCREquations.build(robot, loads, SSCROptions())
    tensions = np.random.default_rng(20261207).uniform(0.0, MAX_TENSION, size=(CASES, robot.n_tendons))
    return Problem(robot, loads, eq, tensions)


def settings_for(fold: str, continuation: bool) -> SV.Settings:
    """The sscr model's default settings (the loading path from the straight robot) with fold handling ``fold``; a
    continuation's stepping code if ``continuation``."""
    settings = kernel_settings(SSCROptions(fold=fold))
    return settings._replace(stepping=STEP_CONTINUE) if continuation else settings


def run(solver: str, settings: SV.Settings, q0: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> Outputs:
    """numba's solve_range (``solver="numba"``, on the packed named tuple) or the core's (``"core"``, on
    ``eq.kernel_model``) over every row."""
    pb = problem()
    tols = case_tolerances(pb.robot, pb.loads, t1, settings.atol)
    out = empty_outputs(t1.shape[0], q0.shape[1])
    if solver == "numba":
        SV.solve_range(q0, pb.eq.packed, pb.eq.packed, t0, t1, settings, tols, 0, t1.shape[0], *out)
    else:
        model = pb.eq.kernel_model
        _core.solve_range_sscr(q0, model, model, t0, t1, settings, tols, 0, t1.shape[0], *out)
    return out


def largest_residuals(q: np.ndarray, tensions: np.ndarray) -> np.ndarray:
    """max |residual| [N m] at full load of each row of q (B, 6N) at the tensions (B, nt) [N] (NaN rows: NaN)."""
    out = np.empty(q.shape[0])
    rows = np.arange(q.shape[0], dtype=np.int64)
    _core.largest_residuals_sscr(np.ascontiguousarray(q), problem().eq.kernel_model, np.ascontiguousarray(tensions),
                                 rows, out)
    return out


@cache
def continuation_starts(cases: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start states of the continuations of the first ``cases`` cases: each case's tensions moved
    CONTINUATION_STEP N in a random direction (clipped to [0, MAX_TENSION]), solved there (by the core: the start
    is any solved state; both solvers then continue from the same one). Returns (rows whose start converged, their
    start q (b, m), their start tensions (b, nt))."""
    pb = problem()
    rng = np.random.default_rng(7)
    step = rng.normal(size=(cases, pb.tensions.shape[1]))
    step *= CONTINUATION_STEP / np.linalg.norm(step, axis=1, keepdims=True)
    t0 = np.ascontiguousarray(np.clip(pb.tensions[:cases] + step, 0.0, MAX_TENSION))
    out = run("core", settings_for("arclength", False), np.zeros((cases, pb.eq.n_unknowns)), t0, t0)
    rows = np.flatnonzero(out.converged)
    return rows, np.ascontiguousarray(out.q[rows]), np.ascontiguousarray(t0[rows])


@cache
def solves(solver: str, cases: int, continuation: bool, fold: str) -> tuple[Outputs, np.ndarray, float]:
    """One solver on the first ``cases`` cases in one mode: its outputs, the end tensions (b, nt) [N] (a
    continuation's: the rows whose start converged) and its time [s]."""
    pb = problem()
    settings = settings_for(fold, continuation)
    if continuation:
        rows, q0, t0 = continuation_starts(cases)
        t1 = np.ascontiguousarray(pb.tensions[:cases][rows])
    else:
        q0, t0 = np.zeros((cases, pb.eq.n_unknowns)), np.ascontiguousarray(pb.tensions[:cases])
        t1 = t0
    start = time.perf_counter()
    out = run(solver, settings, q0, t0, t1)
    return out, t1, time.perf_counter() - start


@cache
def compare(cases: int, continuation: bool, fold: str) -> dict:
    """Both solvers on the first ``cases`` cases in one mode: the counts of disagreements, the largest q
    difference [N m] where both converged on the same path, and, where both converged on different paths, each
    answer's residual at full load over its case's tolerance."""
    pb = problem()
    ref, t1, seconds_numba = solves("numba", cases, continuation, fold)
    got, _, seconds_core = solves("core", cases, continuation, fold)
    same_path = (ref.converged == got.converged) & (ref.path == got.path)
    both = ref.converged & got.converged & same_path
    diff = np.max(np.abs(ref.q - got.q), axis=1)
    other = np.flatnonzero(ref.converged & got.converged & (ref.path != got.path))
    tols = case_tolerances(pb.robot, pb.loads, t1, SSCROptions().atol)[:, 0]
    return {
        "cases": int(t1.shape[0]),
        "converged numba": int(ref.converged.sum()),
        "converged core": int(got.converged.sum()),
        "flags differ": int((ref.converged != got.converged).sum()),
        "paths differ": int((ref.path != got.path).sum()),
        "paths numba": np.bincount(ref.path, minlength=6).tolist(),
        "paths core": np.bincount(got.path, minlength=6).tolist(),
        "q beyond": int((diff[both] > Q_AGREE).sum()),
        "max dq": float(np.max(diff[both])) if both.any() else 0.0,
        "max rel dq": float(np.max(diff[both] / np.max(np.abs(ref.q[both]), axis=1))) if both.any() else 0.0,
        "differing rows": np.flatnonzero(~same_path | (both & (diff > Q_AGREE))).tolist(),
        "other branch rows": other.tolist(),
        "other branch residual/tol numba": (largest_residuals(ref.q[other], t1[other]) / tols[other]).tolist(),
        "other branch residual/tol core": (largest_residuals(got.q[other], t1[other]) / tols[other]).tolist(),
        "seconds numba": seconds_numba,
        "seconds core": seconds_core,
    }


def check_agreement(c: dict) -> None:
    """Print the counts; then: where both converged on the same path, q agrees to Q_AGREE; the converged flags
    differ on at most FLAGS_DIFFER of the cases; where both converged on different paths (another branch after a
    fold), both answers are equilibria at full load (max |residual| within the case's tolerance)."""
    print("\n" + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in c.items()))
    assert c["q beyond"] == 0, c
    assert c["flags differ"] <= FLAGS_DIFFER * c["cases"], c
    for name in ("numba", "core"):
        assert all(r <= 1.0 for r in c[f"other branch residual/tol {name}"]), c


# ------------------------------------------------------------------ fast: the default fold handling
@pytest.mark.slow
@pytest.mark.parametrize("continuation", [False, True], ids=["solve", "continuation"])
def test_agrees_with_numba(continuation: bool) -> None:
    """FAST_CASES solves (or continuations from a solved state 2 N away) with the model's default fold handling
    (arclength): the same flags and paths as numba's solver, q to Q_AGREE where both converged on one path."""
    check_agreement(compare(FAST_CASES, continuation, SSCROptions().fold))


@pytest.mark.slow
@pytest.mark.parametrize("fold", list(FOLDS))
@pytest.mark.parametrize("continuation", [False, True], ids=["solve", "continuation"])
def test_agrees_with_numba_on_many_cases(continuation: bool, fold: str) -> None:
    """CASES solves or continuations, each fold handling."""
    check_agreement(compare(CASES, continuation, fold))


# ------------------------------------------------------------------ the library's sscr, end to end
#: cases of the end-to-end tests (the first of the fast agreement test's)
E2E_CASES = 8


def numba_tips(q: np.ndarray) -> np.ndarray:
    """Tips (B, 3) [m] of the rows of q (B, 6N) (the core's record_shape: numba's to the bit, test_core_sscr)."""
    model = problem().eq.kernel_model
    return np.array([model.record_shape(row)[0][-1] for row in q])


@pytest.mark.slow
def test_solve_and_continue_end_to_end() -> None:
    """pytdcr.solve(..., model="sscr") (the core's now) gives numba's solver's converged flag, path and tip; a
    continuation (``start=``) gives numba's continuation from the same start."""
    pb = problem()
    ref, _, _ = solves("numba", FAST_CASES, False, SSCROptions().fold)
    tips = numba_tips(ref.q[:E2E_CASES])
    for b in range(E2E_CASES):
        sol = pytdcr.solve(pb.robot, pytdcr.paper_loads(pb.tensions[b]), model="sscr")
        assert sol.converged == ref.converged[b] and sol.path.code == ref.path[b], b
        assert np.abs(sol.tip_position - tips[b]).max() <= TIP_AGREE, b
    # continuations from the core's solve of row 0 to rows 1-3: numba's solve_range from the same q
    start = pytdcr.solve(pb.robot, pytdcr.paper_loads(pb.tensions[0]), model="sscr")
    t0 = np.ascontiguousarray(np.repeat(pb.tensions[:1], 3, axis=0))
    t1 = np.ascontiguousarray(pb.tensions[1:4])
    q0 = np.ascontiguousarray(np.repeat(start.q.reshape(1, -1), 3, axis=0))
    ref = run("numba", settings_for(SSCROptions().fold, True), q0, t0, t1)
    tips = numba_tips(ref.q)
    for k in range(3):
        sol = pytdcr.solve(pb.robot, pytdcr.paper_loads(t1[k]), model="sscr", start=start)
        assert sol.converged == ref.converged[k] and sol.path.code == ref.path[k], k
        assert np.abs(sol.tip_position - tips[k]).max() <= TIP_AGREE, k


@pytest.mark.slow
def test_solve_batch_end_to_end() -> None:
    """pytdcr.solve_batch(..., model="sscr") on two threads gives numba's solver's flags, paths and tips row by row,
    and its stability test runs (the core's tangent stiffness)."""
    pb = problem()
    ref, _, _ = solves("numba", FAST_CASES, False, SSCROptions().fold)
    T = np.ascontiguousarray(pb.tensions[:E2E_CASES])
    batch = pytdcr.solve_batch(pb.robot, T, pb.loads, model="sscr", threads=2)
    assert np.array_equal(batch.converged, ref.converged[:E2E_CASES])
    assert [p.code for p in batch.path] == ref.path[:E2E_CASES].tolist()
    ok = batch.converged
    assert np.abs(batch.tip_position[ok] - numba_tips(ref.q[:E2E_CASES][ok])).max() <= TIP_AGREE
    assert all(s is not None for s in np.asarray(batch.stable)[ok])


@pytest.mark.slow
def test_tip_gradient_is_the_central_difference_of_solves() -> None:
    """pytdcr.tip_gradient(..., model="sscr") (the core's tip_gradient_range_sscr) is numba's
    tip_gradient_range to round-off and the central difference of warm-started solves at T +- H e_c."""
    from pytdcr.statics.kernels.stiffness import tip_gradient_range

    pb = problem()
    T = np.array([4.0, 1.0, 2.0, 0.5, 3.0, 0.5, 1.5, 1.0])
    sol = pytdcr.solve(pb.robot, pytdcr.paper_loads(T), model="sscr")
    assert sol.converged
    _, g = pytdcr.tip_gradient(pb.robot, pytdcr.paper_loads(T), sol, model="sscr")
    ref = np.full((1, 3, T.size), np.nan)
    tip_gradient_range(np.ascontiguousarray(sol.q.reshape(1, -1)), pb.eq.packed, T[None, :].copy(), 0, 1, ref)
    assert np.abs(g - ref[0]).max() <= 1e-12 * np.abs(ref).max()
    h = 1e-3  # [N]
    fd = np.empty_like(g)
    for c in range(T.size):
        tips = []
        for sign in (1.0, -1.0):
            t = T.copy()
            t[c] += sign * h
            other = pytdcr.solve(pb.robot, pytdcr.paper_loads(t), model="sscr", q0=sol.q,
                                 options=SSCROptions(atol=1e-12))
            assert other.converged
            tips.append(other.tip_position)
        fd[:, c] = (tips[0] - tips[1]) / (2.0 * h)
    err = np.abs(g - fd).max()
    print(f"\ntip gradient: max |g| {np.abs(g).max():.3e} m/N, max |g - central difference| {err:.3e} m/N")
    assert err <= 1e-6 * np.abs(g).max()

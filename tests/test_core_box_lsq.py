"""The workspace's boundary-search step in the compiled core (``pytdcr._core.box_least_squares``,
src/cpp/box_lsq.hpp), against scipy's bounded least squares and the closed form inside the bounds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from pytdcr import _core


def problems(seed: int, count: int):
    """Random problems as the search makes them: 3 rows, 1 to 8 unknowns, bounds around 0 (some at 0, some
    pinned: lower = upper = 0)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        k = int(rng.integers(1, 9))
        A = rng.normal(size=(3, k)) * 10.0 ** rng.uniform(-4, -2)
        y = rng.normal(size=3) * 1e-3
        lower = -rng.uniform(0.0, 2.0, k) * (rng.random(k) < 0.8)
        upper = rng.uniform(0.0, 2.0, k) * (rng.random(k) < 0.8)
        yield A, y, 1e-3 * np.abs(A).max(), lower, upper


def objective(A, y, damp, x):
    return float(np.sum((A @ x - y) ** 2) + damp**2 * np.sum(x**2))


def test_the_minimiser_is_scipys_bounded_least_squares() -> None:
    """The same minimiser as scipy's lsq_linear on the damped problem [A; damp I] x = [y; 0] (strictly convex),
    inside the bounds, and no other feasible point found by scipy is better."""
    for A, y, damp, lower, upper in problems(1, 300):
        x = _core.box_least_squares(A, y, damp, lower, upper)
        assert np.all(x >= lower) and np.all(x <= upper)
        k = A.shape[1]
        pinned_open = np.where(upper > lower, upper, lower + 1e-300)  # scipy wants lower < upper
        ref = lsq_linear(np.vstack([A, damp * np.eye(k)]), np.concatenate([y, np.zeros(k)]),
                         bounds=(lower, pinned_open), method="bvls", tol=1e-14).x
        scale = max(float(np.abs(ref).max()), float(np.max(upper - lower)), 1e-12)
        assert np.abs(x - ref).max() <= 1e-8 * scale, (x, ref)
        assert objective(A, y, damp, x) <= objective(A, y, damp, np.clip(ref, lower, upper)) * (1 + 1e-10) + 1e-30


def test_inside_the_bounds_it_is_the_damped_least_squares_solution() -> None:
    A = np.array([[1.0, 2.0, 0.5], [0.0, 1.0, -1.0], [2.0, 0.0, 1.0]]) * 1e-3
    y = np.array([1e-4, -2e-4, 3e-4])
    damp = 1e-6
    x = _core.box_least_squares(A, y, damp, np.full(3, -10.0), np.full(3, 10.0))
    want = np.linalg.solve(A.T @ A + damp**2 * np.eye(3), A.T @ y)
    assert np.allclose(x, want, rtol=1e-12, atol=0)


def test_bad_arguments_are_refused() -> None:
    A, y = np.ones((3, 2)), np.ones(3)
    lo, hi = -np.ones(2), np.ones(2)
    with pytest.raises(ValueError, match="damp"):
        _core.box_least_squares(A, y, 0.0, lo, hi)
    with pytest.raises(ValueError, match="lower <= 0 <= upper"):
        _core.box_least_squares(A, y, 1.0, np.ones(2), hi)
    with pytest.raises(ValueError, match="y must be"):
        _core.box_least_squares(A, np.ones(2), 1.0, lo, hi)
    with pytest.raises(ValueError, match="lower and upper"):
        _core.box_least_squares(A, y, 1.0, lo[:1], hi)

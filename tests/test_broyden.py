"""The quasi-Newton's inverse Jacobian kept as an LU factorisation and rank-one update pairs."""

from __future__ import annotations

import numpy as np

from pytdcr.statics.kernels import broyden as B


def _dense_broyden(H: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    Hy = H @ y
    return H + np.outer(s - Hy, s @ H) / (s @ Hy)


def test_lu_applies_the_inverse_and_its_transpose():
    rng = np.random.default_rng(0)
    for n in (1, 3, 60):
        J = rng.normal(size=(n, n)) + n * np.eye(n) * rng.choice([-1, 1], size=n)  # pivoting needed
        J = J[rng.permutation(n)]
        H = B.make_inverse(n)
        assert B.factor(H, J)
        b = rng.normal(size=n)
        out = np.empty(n)
        B.apply(H, b, out)
        assert np.allclose(J @ out, b, rtol=0, atol=1e-12 * np.abs(b).max() * n)
        B.apply_t(H, b, out)
        assert np.allclose(J.T @ out, b, rtol=0, atol=1e-12 * np.abs(b).max() * n)


def test_updates_equal_the_dense_broyden_formula():
    rng = np.random.default_rng(1)
    n = 12
    J = rng.normal(size=(n, n)) + 4 * np.eye(n)
    H = B.make_inverse(n)
    B.factor(H, J)
    dense = np.linalg.inv(J)
    Hy, d, out = np.empty(n), np.empty(n), np.empty(n)
    for _ in range(5):
        s, y = rng.normal(size=n), rng.normal(size=n)
        B.apply(H, y, Hy)
        B.apply_t(H, s, d)
        assert B.push(H, s, Hy, d)
        dense = _dense_broyden(dense, s, y)
    b = rng.normal(size=n)
    B.apply(H, b, out)
    assert np.allclose(out, dense @ b, rtol=1e-10, atol=1e-12)
    B.apply_t(H, b, out)
    assert np.allclose(out, dense.T @ b, rtol=1e-10, atol=1e-12)
    assert H.k[0] == 5


def test_a_singular_jacobian_gives_the_zero_operator():
    n = 4
    J = np.ones((n, n))
    H = B.make_inverse(n)
    assert not B.factor(H, J)
    out = np.full(n, 7.0)
    B.apply(H, np.ones(n), out)
    assert np.all(out == 0.0)
    assert not B.push(H, np.ones(n), np.ones(n), np.ones(n))
    assert not B.factor(H, np.eye(n) + np.diag([np.nan, 0, 0, 0]))

"""The compiled core's kinematics (``pytdcr._core``, src/cpp/kinematics.hpp) against the numba kernels it twins:
the same operations in the same order, so the same bits."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import _core
from pytdcr.kinematics import frames, subsegment


def _cases(rng: np.random.Generator, count: int) -> list[tuple[float, float, float, float]]:
    """(beta, gamma, eps, length): straight, nearly straight (the series branch), moderate and strong bends."""
    cases = [(0.0, 0.0, 0.0, 0.01), (0.0, 0.0, 0.3, 0.02), (1e-9, -1e-9, 0.0, 0.015)]
    for scale in (1e-3, 1.0, 30.0):
        b, g, e = rng.normal(scale=scale, size=(3, count))
        cases += [(float(x), float(y), float(z), float(rng.uniform(0.005, 0.05))) for x, y, z in zip(b, g, e,
                                                                                                    strict=True)]
    return cases


@pytest.mark.slow
def test_a_subsegment_is_the_numba_kernels_to_the_bit() -> None:
    rng = np.random.default_rng(7)
    R, d, pg = np.empty((3, 3)), np.empty(3), np.empty(3)
    for beta, gamma, eps, length in _cases(rng, 200):
        subsegment(beta, gamma, eps, length, R, d, pg)
        Rc, dc, pgc = _core.subsegment(beta, gamma, eps, length)
        assert np.array_equal(Rc, R) and np.array_equal(dc, d) and np.array_equal(pgc, pg), (beta, gamma, eps)


@pytest.mark.slow
def test_the_frames_chain_is_the_numba_kernels_to_the_bit() -> None:
    rng = np.random.default_rng(8)
    n = 20
    sub = np.zeros((n, 5))
    sub[:, 0] = rng.uniform(0.005, 0.02, n)
    q = rng.normal(scale=[5.0, 5.0, 0.2] * n)
    pos, rot = np.empty((n + 1, 3)), np.empty((n + 1, 3, 3))
    frames(q, sub, pos, rot)
    pos_c, rot_c = _core.frames(q, sub)
    assert np.array_equal(pos_c, pos) and np.array_equal(rot_c, rot)
    # and the chain is a chain of rotations: orthonormal to round-off after 20 products
    np.testing.assert_allclose(rot_c @ rot_c.transpose(0, 2, 1), np.broadcast_to(np.eye(3), rot_c.shape), atol=1e-13)


def test_the_frames_chain_refuses_mismatched_shapes() -> None:
    with pytest.raises(ValueError, match=r"q must be \(3N,\) and sub \(N, 5\)"):
        _core.frames(np.zeros(5), np.zeros((2, 5)))


@pytest.mark.slow
def test_the_subsegment_derivatives_are_the_numba_kernels_to_round_off() -> None:
    """Within 2 ulp of the unit entries: numba multiplies the 3 x 3 matrices of E = I + A K + B K^2 and its
    derivatives through its own matrix product, whose sums are ordered otherwise than the C++ loops."""
    from pytdcr.kinematics import subsegment_derivatives

    rng = np.random.default_rng(9)
    dR, dd = np.empty((3, 3, 3)), np.empty((3, 3))
    for beta, gamma, eps, length in _cases(rng, 200):
        subsegment_derivatives(beta, gamma, eps, length, dR, dd)
        dRc, ddc = _core.subsegment_derivatives(beta, gamma, eps, length)
        np.testing.assert_allclose(dRc, dR, rtol=0, atol=2.3e-16)  # entries of R and its derivatives are <= 1
        np.testing.assert_allclose(ddc, dd, rtol=0, atol=2.3e-16 * max(1.0, float(np.max(np.abs(dd)))))

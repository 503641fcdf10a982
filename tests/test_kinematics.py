"""Subsegment transforms: exact and smooth at zero curvature, orthonormal, on the arc."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr.kinematics import backbone_curve, forward_kinematics, subsegment_transform


def test_straight_is_exact():
    R, d = subsegment_transform(0.0, 0.0, 0.3, 0.02)
    c, s = np.cos(0.3), np.sin(0.3)
    assert np.array_equal(d, [0.0, 0.0, 0.02])
    assert np.allclose(R, [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-15)


@pytest.mark.parametrize("direction", [0.0, 0.7, 2.0, -2.5])
def test_closed_form_arc(direction):
    """Eq. 1 and Eq. 4 of the paper: R = Rz(phi) Ry(theta) Rz(eps - phi), d on the arc."""
    k, ell, eps = 7.0, 0.03, 0.2
    beta, gamma = k * np.cos(direction), k * np.sin(direction)
    R, d = subsegment_transform(beta, gamma, eps, ell)
    th, ph = k * ell, direction

    def rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])

    ry = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    assert np.allclose(R, rz(ph) @ ry @ rz(eps - ph), atol=1e-14)
    expect = np.array([np.cos(ph) * (1 - np.cos(th)), np.sin(ph) * (1 - np.cos(th)), np.sin(th)]) / k
    assert np.allclose(d, expect, atol=1e-15)


def test_smooth_across_the_series_switch():
    """The series branch (small theta) and the closed form agree where they meet."""
    ell = 0.02
    ks = np.sqrt(1e-2) / ell * np.array([0.999999, 1.000001])
    (R1, d1), (R2, d2) = (subsegment_transform(k, 0.0, 0.0, ell) for k in ks)
    # the two points differ by 2e-6 in curvature: first-order change only
    assert np.allclose(d1, d2, atol=1e-10)
    assert np.allclose(R1, R2, atol=1e-7)
    for k in np.geomspace(1e-9, 100, 40):
        R, d = subsegment_transform(k * 0.6, -k * 0.8, 0.1, ell)
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-14)
        assert np.isclose(np.linalg.det(R), 1.0, atol=1e-14)
        # chord length of a circular arc: 2 sin(theta/2) / k
        chord = ell if k * ell < 1e-8 else 2 * np.sin(k * ell / 2) / k
        assert np.isclose(np.linalg.norm(d), chord, rtol=1e-12)


def test_backbone_length_is_preserved():
    rng = np.random.default_rng(3)
    lengths = np.full(12, 0.025)
    q = rng.normal(0.0, 15.0, (12, 3))
    curve = backbone_curve(q, lengths, points_per_subsegment=400)
    arc = np.sum(np.linalg.norm(np.diff(curve, axis=0), axis=1))
    assert arc == pytest.approx(lengths.sum(), rel=1e-5)
    pos, rot = forward_kinematics(q, lengths)
    assert np.allclose(pos[-1], curve[-1], atol=1e-14)
    assert np.all(np.linalg.norm(np.diff(pos, axis=0), axis=1) <= lengths + 1e-15)
    assert np.allclose(np.einsum("nij,nkj->nik", rot, rot), np.eye(3), atol=1e-13)

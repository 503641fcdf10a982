"""The Cosserat rod's shooting integration in the compiled core (``pytdcr._core.cosserat_shoot``,
src/cpp/cosserat.hpp) against the numba kernel it replaces (:func:`pytdcr.statics.kernels.cosserat.shoot`): the
same operations in the same order, but for the re-orthonormalisation's 3 x 3 products, which numba hands to BLAS
(its own summation and fused multiply-adds) and the core sums in order; so the two agree to round-off. The
model's physics is tested in tests/test_cosserat.py."""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import Loads, _core, paper_robot
from pytdcr.robot import NoFriction
from pytdcr.statics.options import CosseratOptions


def problems():
    """The paper robot without friction, with and without gravity, a tip wrench, shear and extension."""
    from pytdcr.statics.cosserat import CosseratShooting

    rng = np.random.default_rng(4)
    robot = paper_robot(friction=NoFriction())
    for ext in (False, True):
        for gravity in (True, False):
            r = robot if gravity else robot.with_gravity(None)
            loads = Loads(rng.uniform(0, 15, 8), tip_force=rng.normal(0, 0.1, 3), tip_moment=rng.normal(0, 0.02, 3))
            yield CosseratShooting.build(r, loads, CosseratOptions(shear_extension=ext, steps_per_subsegment=3))


@pytest.mark.slow
def test_the_shot_is_the_numba_kernels_to_round_off() -> None:
    from pytdcr.statics.kernels import cosserat as CK

    rng = np.random.default_rng(5)
    for model in problems():
        p = model.packed
        n = p.sub.shape[0]
        rod = CK.Rod(p.sub[:, 0], model.stiff, float(model.mpl), p.sub[:, 3], model.holes, p.anchor, p.tension,
                     p.grav, p.pforce, p.pmoment, bool(model.shear_extension), int(model.nsub))
        for _ in range(5):
            m0 = rng.normal(0.0, 0.05, 3)
            lam = float(rng.uniform(0.2, 1.0))
            out = (np.empty((n + 1, 3)), np.empty((n + 1, 3, 3)), np.empty((n * model.nsub + 1, 3)))
            res = np.empty(6)
            ok_ref = CK.shoot(m0, lam, rod, True, *out, res)
            shot = model.shoot(m0, lam, record=True)
            assert ok_ref == bool(np.all(np.isfinite(shot.residual)))
            if not ok_ref:
                continue
            assert np.allclose(shot.residual, res[:3], rtol=0, atol=1e-12 * max(1.0, np.abs(res[:3]).max()))
            assert np.allclose(shot.tip_position, res[3:], rtol=0, atol=1e-13)
            for mine, ref in zip((shot.positions, shot.rotations, shot.curve), out, strict=True):
                assert np.allclose(mine, ref, rtol=0, atol=1e-12)


def test_a_shot_with_no_load_is_the_straight_rod() -> None:
    """No tension, no weight, no wrench, zero base moment: the straight rod, the tip at its length, no residual."""
    from pytdcr.statics.cosserat import CosseratShooting

    robot = paper_robot(friction=NoFriction()).with_gravity(None)
    shot = CosseratShooting.build(robot, Loads(np.zeros(8))).shoot(np.zeros(3), 1.0, record=True)
    length = float(np.sum(robot.subsegment_lengths)) if hasattr(robot, "subsegment_lengths") else shot.tip[2]
    assert np.allclose(shot.tip_position, [0.0, 0.0, length], atol=1e-15)
    assert np.array_equal(shot.residual, np.zeros(3))
    assert np.allclose(shot.rotations, np.eye(3), atol=1e-15)


def test_bad_shapes_are_refused() -> None:
    model = next(iter(problems()))
    args = [*model._core_rod[:6], np.ascontiguousarray(model.packed.tension), *model._core_rod[6:]]
    _core.cosserat_shoot(np.zeros(3), 1.0, *args, False, 2, False)
    with pytest.raises(ValueError, match="m0 must be"):
        _core.cosserat_shoot(np.zeros(2), 1.0, *args, False, 2, False)
    with pytest.raises(ValueError, match="nsub must be"):
        _core.cosserat_shoot(np.zeros(3), 1.0, *args, False, 0, False)
    bad = list(args)
    bad[6] = np.zeros(3)
    with pytest.raises(ValueError, match="tension must be"):
        _core.cosserat_shoot(np.zeros(3), 1.0, *bad, False, 2, False)

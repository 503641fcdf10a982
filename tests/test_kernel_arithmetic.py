"""A division by zero inside a kernel is a non-finite number the solver rejects, never an exception.

The kernels are compiled with NumPy's error model (``runtime/_flags.py``). Under numba's default, a trial Newton
step that overflowed a tendon chord's length (its unit direction then 0 / inf = 0) divided zero by zero in the
friction law's derivative and raised ``ZeroDivisionError`` out of ``solve_batch``: seen with the subsegment rod at
one Runge-Kutta step per subsegment on a random tension vector.
"""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import paper_loads, paper_robot, solve_batch
from pytdcr.runtime import njit
from pytdcr.statics import configure
from pytdcr.statics.kernels.pcc import tendon_unit_load_jvp


def _unit_load_py(d, hn, fric, out, dout):
    """One tendon's unit load on a disk at ``d`` (not turned) with the next hole at ``hn``, with one tangent lane."""
    R = np.eye(3)
    dR = np.zeros((1, 3, 3))
    dR[0, 0, 1] = 1.0
    tendon_unit_load_jvp(R, d, hn, dR, np.zeros((1, 3)), np.zeros((1, 3)), 1, 0.001, 0.0, False, fric, out, dout)


_unit_load = njit(_unit_load_py)


@pytest.mark.slow
def test_an_overflowed_chord_gives_nan_not_an_exception() -> None:
    out, dout = np.empty(7), np.empty((7, 1))
    paper_friction = np.array([2.0, 0.2, 0.5, 1.0])
    # both chords' squared lengths overflow: their unit directions are 0 / inf = 0, the deflection's derivative 0 / 0
    _unit_load(np.array([1e155, 0.0, 0.0]), np.array([0.0, 0.0, 2e155]), paper_friction, out, dout)
    assert not np.all(np.isfinite(dout))
    # a straight subsegment 10 mm long: finite
    _unit_load(np.array([0.0, 0.0, 0.01]), np.array([0.0, 0.0, 0.01]), paper_friction, out, dout)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(dout))


def test_the_solve_that_divided_by_zero_ends_with_an_answer() -> None:
    robot = paper_robot()
    tensions = np.random.default_rng(1).uniform(0.0, 20.0, (2, robot.n_tendons))[1:]
    batch = solve_batch(robot, tensions, paper_loads(), model="sscr",
                        options=configure("sscr", steps_per_subsegment=1), threads=1)
    assert batch.converged.shape == (1,)
    assert not batch.converged[0] or batch.residual[0] <= batch.atol[0]

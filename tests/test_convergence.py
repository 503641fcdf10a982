"""Convergence where the loading path meets a fold (issue 26, item 2; bench/convergence.py measures the rates).

Tension vectors that the solver used to leave unconverged under the paper's load (rows of
``numpy.random.default_rng(0).uniform(0, 20, (200, 8))``): without friction and with a constant mu the
branch the loading path follows ends at a fold short of full load, and relaxing at full load from its last
equilibrium circled instead of settling. Each must now converge, and every converged answer must be an
equilibrium of its robot and loads within its tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest

from pytdcr import ConstantFriction, NoFriction, paper_loads, paper_robot, solve_batch
from pytdcr.statics.kernels import pcc as K
from pytdcr.statics.pcc import PCCEquations

ROWS = np.random.default_rng(0).uniform(0.0, 20.0, (200, 8))
LAWS = {"paper": None, "none": NoFriction(), "constant": ConstantFriction(mu=0.1)}

#: (model, friction law, rows that failed before the fold handling followed the branch to its fold)
CASES = [("pcc", "none", (2, 8, 9, 21)), ("pcc", "constant", (4, 8, 25)), ("pcc2", "none", (2, 4, 6)),
         ("pcc2", "constant", (1, 2, 4)), ("pcc2", "paper", (75, 157))]


@pytest.mark.parametrize(("model", "law", "rows"), CASES)
def test_folds_of_the_loading_path_converge(model, law, rows):
    robot, loads = paper_robot(LAWS[law]), paper_loads()
    T = ROWS[list(rows)]
    b = solve_batch(robot, T, loads, model=model, threads=1)
    assert b.converged.all(), (model, law, b.path, b.residual)
    balance = K.BALANCE_MIDPOINT if model == "pcc2" else K.BALANCE_BASE
    for i, t in enumerate(T):
        assert b.residual[i] <= b.atol[i]
        eq = PCCEquations.build(robot, loads.with_tensions(t), balance)
        assert np.max(np.abs(eq.evaluate(b.q[i].reshape(-1)).residual)) <= b.atol[i]
        assert b.stability[i] is not None and b.stability[i].stable, (model, law, rows[i], b.stability[i])


@pytest.mark.slow
@pytest.mark.parametrize("law", ["none", "constant"])
def test_every_converged_answer_is_in_balance(law):
    """Over 40 random vectors, converged or not: nothing out of balance is reported converged."""
    robot, loads = paper_robot(LAWS[law]), paper_loads()
    T = ROWS[:40]
    b = solve_batch(robot, T, loads, model="pcc2", threads=1)
    for i in np.flatnonzero(b.converged):
        eq = PCCEquations.build(robot, loads.with_tensions(T[i]), K.BALANCE_MIDPOINT)
        assert np.max(np.abs(eq.evaluate(b.q[i].reshape(-1)).residual)) <= b.atol[i]
    assert not np.isfinite(b.tip_position[~b.converged]).any()

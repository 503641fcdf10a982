"""Results depend on the inputs alone, bit for bit: not on what else the process solved before, nor on the
order in which compiled kernels were loaded (each model in a fresh interpreter, after each other model)."""

from __future__ import annotations

import subprocess
import sys

import pytest

_RUN = r"""
import hashlib, sys
import numpy as np
from pytdcr import ConstantFriction, Loads, paper_loads, paper_robot, rao_robot, solve, solve_batch

def run(model):
    r = paper_robot()
    out = []
    for robot, loads in ((r, paper_loads(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0]))),
                         (paper_robot(ConstantFriction(mu=0.1)), Loads(np.array([5, 0, 2, 0, 6, 1, 0, 0.0]),
                                                                        release=True))):
        s = solve(robot, loads, model=model)
        out += [s.q.tobytes(), s.disk_positions.tobytes()]
    b = solve_batch(r, np.array([[1.0, 2, 0, 0, 3, 0, 0, 1], [6.0, 0, 4, 1, 0, 0, 2, 0]]), paper_loads(),
                    model=model, threads=1)
    out += [b.q.tobytes(), b.tip_position.tobytes()]
    return hashlib.sha256(b"".join(out)).hexdigest()

first, model = sys.argv[1], sys.argv[2]
if first == "rao":
    solve(rao_robot(), Loads(np.ones(6)))
elif first != "none":
    run(first)
print(run(model))
"""

MODELS = ("pcc", "pcc2", "sscr")


def _digest(first: str, model: str) -> str:
    out = subprocess.run([sys.executable, "-c", _RUN, first, model], capture_output=True, text=True, check=True)
    return out.stdout.strip()


@pytest.mark.slow
@pytest.mark.parametrize("model", MODELS)
def test_a_models_results_do_not_depend_on_what_ran_before(model):
    alone = _digest("none", model)
    for first in (*[m for m in MODELS if m != model], "rao"):
        assert _digest(first, model) == alone, f"{model} after {first} differs from {model} alone"

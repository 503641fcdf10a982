"""Solve the paper robot under the paper's tip load and draw it.

Run: python examples/solve_paper_robot.py [OUT.png]
"""

import sys

import matplotlib

matplotlib.use("Agg")
import numpy as np

from pytdcr import paper_loads, paper_robot, solve
from pytdcr.plotting import plot_robot

robot = paper_robot()
loads = paper_loads(np.array([6.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0]))  # the paper's tip force and moment
sol = solve(robot, loads)
print(f"converged={sol.converged} residual={sol.residual:.2e} N m path={sol.path}")
if not sol.converged:
    sys.exit(1)
print("tip position [m]:", np.round(sol.tip_position, 6))
print("tension along tendon 1 [N]:", np.round(sol.tensions[0, :10], 3))
ax = plot_robot(robot, sol)
ax.figure.savefig(sys.argv[1] if len(sys.argv) > 1 else "paper_robot.png", dpi=120)

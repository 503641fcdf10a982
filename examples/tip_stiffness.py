"""How stiff is the tip, and how does the shape move with each tension? (exact derivatives of an equilibrium)

The paper robot under the paper's tip wrench, one pose: its tip compliance (6x6, tensions held fixed), the
stiffness along the softest and stiffest directions, a check of the compliance against a second solve under a
small added tip force, and how far the tip moves per newton of each tension.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pytdcr import equilibrium_jacobians, paper_loads, paper_robot, solve, tip_compliance

robot = paper_robot()
loads = paper_loads(np.array([4.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0]))
sol = solve(robot, loads)
print(f"tip at {np.round(sol.tip_position * 1e3, 1)} mm, stable: {sol.stable}")

c = tip_compliance(robot, loads, sol)
softest, stiffest, soft_dir, stiff_dir = c.stiffness_range()
print(f"tip stiffness to a force: softest {softest:.2f} N/m along {np.round(soft_dir, 2)}, "
      f"stiffest {stiffest:.1f} N/m along {np.round(stiff_dir, 2)}")

# the compliance predicts the tip's yield to a small added force; a second solve, continued, measures it
df = 1e-3 * soft_dir  # 1 mN along the softest direction
pushed = solve(robot, replace(loads, tip_force=loads.tip_force + df), start=sol)
predicted = c.matrix[:3, :3] @ df
print(f"1 mN along it: predicted {np.round(predicted * 1e6, 2)} um, solved "
      f"{np.round((pushed.tip_position - sol.tip_position) * 1e6, 2)} um")

jac = equilibrium_jacobians(robot, loads, sol)
for c_, g in enumerate(np.linalg.norm(jac.tip_position, axis=0)):
    print(f"  tendon {c_ + 1}: the tip moves {g * 1e3:.2f} mm per N")

"""Which tensions put the tip there? Inverse statics on the paper robot under the paper's tip wrench.

A target made by the forward model (so it is reachable) is solved back with each objective; the answer is
replayed from rest; a target out of reach gives the nearest point found; a short straight path is solved point
by point, each continued from the last.
"""

from __future__ import annotations

import numpy as np

from pytdcr import TensionBounds, TipTarget, inverse_path, inverse_statics, paper_loads, paper_robot, solve

robot = paper_robot()
loads = paper_loads()  # the paper's tip force and moment; the tensions are what we look for
bounds = TensionBounds.uniform(robot.n_tendons, 0.0, 20.0)

pulled = np.array([9.0, 3.0, 0.0, 1.0, 4.0, 0.0, 2.0, 6.0])
made = solve(robot, loads.with_tensions(pulled))
target = made.tip_position
print(f"target {np.round(target * 1e3, 2)} mm (the tip of tensions whose sum of squares is {pulled @ pulled:.1f} N^2)")
for objective in ("least-squares", "least-max", "least-total"):
    r = inverse_statics(robot, loads, target, bounds=bounds, objective=objective)
    print(f"  {objective:13s}: tensions {np.round(r.tensions, 2)} N, {objective} {r.objective_value:.2f}, "
          f"{r.distance_m:.1e} m off, {r.path}, {'stable' if r.stable else 'unstable'}, {r.evaluations} solves")

# the answer holds from rest: applying those tensions to the unloaded robot, loads ramped together
best = inverse_statics(robot, loads, target, bounds=bounds)
replay = solve(robot, loads.with_tensions(best.tensions))
print(f"replayed from rest: the tip lands {np.linalg.norm(replay.tip_position - target):.1e} m from the target")

# the tip's axis too (5 constraints for 8 tendons)
posed = inverse_statics(robot, loads, TipTarget(target, made.tip_rotation[:, 2]), bounds=bounds)
print(f"with the axis: {posed.reachable}, axis off by {np.linalg.norm(posed.tip_axis - made.tip_rotation[:, 2]):.1e}")

far = inverse_statics(robot, loads, [0.0, 0.0, 0.45], bounds=bounds)
print(f"out of reach (0.45 m above the base): reachable {far.reachable}; nearest point found "
      f"{np.round(far.tip_position * 1e3, 1)} mm, {far.distance_m * 1e3:.1f} mm away")

path = target + np.linspace(0.0, 1.0, 20)[:, None] * np.array([0.0, 0.02, 0.01])  # 2.2 cm straight
res = inverse_path(robot, loads, path, bounds=bounds)
jump = np.abs(np.diff([r.tensions for r in res], axis=0)).max()
print(f"a 20-point path: {sum(r.reachable for r in res)} reached, {sum(r.path == 'continued' for r in res)} "
      f"continued, largest tension change between neighbours {jump:.3f} N, {sum(r.seconds for r in res):.2f} s")

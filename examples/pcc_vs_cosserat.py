"""How far to trust the PCC model: compare it with the Cosserat rod on one robot, and watch it converge.

The PCC model (the paper's) bends each subsegment on an arc and lets the disks carry the tendon loads; the
Cosserat rod bends continuously with the tendons along it. With more disks over the same length, the PCC tip
approaches the Cosserat one. Friction is off: the Cosserat model has none.
"""

from __future__ import annotations

import numpy as np

from pytdcr import CosseratOptions, Loads, NoFriction, Segment, paper_robot, solve

tensions = np.array([2.0, 0.0, 0.0, 3.0, 1.0, 0.0, 0.0, 0.0])  # N
loads = Loads(tensions, tip_force=[0.02, 0.0, -0.02])  # a light tip load, base frame [N]

print("disks/segment  PCC tip [m]                      Cosserat tip [m]                 gap [mm]")
for n in (5, 10, 20, 40):
    robot = paper_robot(NoFriction()).model_copy(
        update={"segments": (Segment(length=0.2, n_disks=n, disk_mass=2e-3 / n),) * 2})
    pcc = solve(robot, loads)
    cr = solve(robot, loads, model="cosserat", options=CosseratOptions(shear_extension=False))
    gap = np.linalg.norm(pcc.tip_position - cr.tip_position) * 1e3
    print(f"{n:13d}  {np.array2string(pcc.tip_position, precision=5):32s} "
          f"{np.array2string(cr.tip_position, precision=5):32s} {gap:8.3f}")

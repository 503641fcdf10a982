"""A three-segment robot from a TOML description, and its reach under random tensions.

Run: python examples/custom_robot_workspace.py
"""

import tempfile
from pathlib import Path

import numpy as np

from pytdcr import Loads, TensionBounds
from pytdcr.io import read_robot
from pytdcr.workspace.sampling import sample_workspace

TOML = """
schema_version = 1
name = "three-segment"
gravity = [0.0, 0.0, -9.81]

[backbone]
youngs_modulus = 54e9
poissons_ratio = 0.3
outer_radius = 0.0007
mass_per_length = 0.0115

[friction]
law = "constant"
mu = 0.1

[[segments]]
length = 0.1
n_disks = 8
disk_mass = 0.0002

[[segments]]
length = 0.1
n_disks = 8
disk_mass = 0.0002

[[segments]]
length = 0.08
n_disks = 6
disk_mass = 0.0002
""" + "".join(
    f"\n[[tendons]]\nsegment = {s}\nradius = 0.008\nangle_deg = {a + 40 * (s - 1)}\n"
    for s in (1, 2, 3) for a in (0, 120, 240)
)

with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "robot.toml"
    path.write_text(TOML)
    robot = read_robot(path)

print(f"{robot.name}: {robot.n_disks} disks, {robot.n_tendons} tendons, length {robot.length} m")
samples = sample_workspace(robot, Loads(np.zeros(robot.n_tendons)), TensionBounds.uniform(robot.n_tendons, 0, 5),
                           n=200, seed=7)
ok = samples.converged
print(f"{ok.sum()} of {ok.size} converged; reach {np.nanmin(samples.reach):.3f} to {np.nanmax(samples.reach):.3f} m")
assert np.all(samples.reach[ok] <= robot.length)

"""The paper's case, defined once: its robot, its loads and the bounds of its study.

Jabari et al., "Feasible static workspace optimization of tendon driven
continuum robot based on Euclidean norm": a two-segment robot with eight
tendons, loaded at the tip by a force (0.1, 0.1, -0.1) N and a moment
(-0.1, 0.1, 0.1) N m (section 4). The paper gives no material values and no
tendon-force bounds; the choices made here are stated with each name. The
benchmark robot of Rao et al. 2021 (``rao``), whose geometry and materials the
paper robot shares, is defined here too.

The command line, the study, the benchmarks, the examples and the tests all
take the paper's case from this module.
"""

from __future__ import annotations

import numpy as np

from .bounds import TensionBounds
from .loads import Loads
from .robot import Backbone, ConstantFriction, ExponentialFriction, NoFriction, Robot, Segment, Tendon

__all__ = [
    "BUILTIN_ROBOTS",
    "DEFAULT_BOUNDS",
    "PAPER_TIP_FORCE",
    "PAPER_TIP_MOMENT",
    "PAYLOAD_MASS",
    "RAO_BACKBONE",
    "STANDARD_GRAVITY",
    "paper_bounds",
    "paper_loads",
    "paper_robot",
    "payload_gravity",
    "payload_loads",
    "rao_robot",
]

#: the paper's tip force of section 4, base frame [N]
PAPER_TIP_FORCE = (0.1, 0.1, -0.1)
#: the paper's tip moment of section 4, base frame [N m]
PAPER_TIP_MOMENT = (-0.1, 0.1, 0.1)
#: payload of the Fig. 6 study [kg]: 5 g, well below the straight robot's buckling load
PAYLOAD_MASS = 0.005
#: tendon-force bounds of the study [N] (the paper gives none): 0 to 20 N per tendon
DEFAULT_BOUNDS = (0.0, 20.0)

#: Backbone of the benchmark robot of Rao et al. 2021 (the paper gives no material values).
RAO_BACKBONE = Backbone(
    youngs_modulus=54e9, poissons_ratio=0.3, outer_radius=0.7e-3, inner_radius=0.0, mass_per_length=0.0115
)


def paper_robot(
    friction: NoFriction | ConstantFriction | ExponentialFriction | None = None,
) -> Robot:
    """The two-segment, eight-tendon robot of Jabari et al. (the ``paper`` robot).

    Two segments of 0.2 m with 10 disks of 0.2 g each; tendons at 10 mm, at
    0/90/180/270 deg (segment 1) and 45/135/225/315 deg (segment 2); gravity
    -9.81 m/s^2 along base z; the paper's exponential friction law by default.
    The paper gives no material values: the backbone (E = 54 GPa, nu = 0.3,
    solid, radius 0.7 mm, 0.0115 kg/m) is that of Rao et al. 2021's benchmark
    robot, whose geometry the paper shares.
    """
    seg = Segment(length=0.2, n_disks=10, disk_mass=0.2e-3)
    tendons = [Tendon(segment=1, radius=0.01, angle_deg=a) for a in (0.0, 90.0, 180.0, 270.0)]
    tendons += [Tendon(segment=2, radius=0.01, angle_deg=a) for a in (45.0, 135.0, 225.0, 315.0)]
    return Robot(
        name="paper",
        backbone=RAO_BACKBONE,
        segments=(seg, seg),
        tendons=tuple(tendons),
        gravity=(0.0, 0.0, -9.81),
        friction=friction if friction is not None else ExponentialFriction(),
    )


def rao_robot() -> Robot:
    """The two-segment benchmark robot of Rao et al. 2021 (three tendons per segment).

    Tendons at 90, -30 and 210 deg in both segments, 10 mm radius; no friction
    and no gravity (the setting of their published PCC regression values).
    """
    seg = Segment(length=0.2, n_disks=10, disk_mass=0.2e-3)
    tendons = [Tendon(segment=s, radius=0.01, angle_deg=a) for s in (1, 2) for a in (90.0, -30.0, 210.0)]
    return Robot(
        name="rao2021",
        backbone=RAO_BACKBONE,
        segments=(seg, seg),
        tendons=tuple(tendons),
        gravity=(0.0, 0.0, 0.0),
        friction=NoFriction(),
    )


#: built-in robots by the name the command line takes
BUILTIN_ROBOTS = {"paper": paper_robot, "rao": rao_robot}


def paper_loads(tensions: np.ndarray | None = None, *, release: bool = False) -> Loads:
    """The paper's tip wrench with ``tensions`` [N] (default: 8 zeros, the paper robot's tendons)."""
    t = np.zeros(8) if tensions is None else tensions
    return Loads(t, tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT, release=release)


#: gravity of a robot that has none, for its payloads and its loaded cases [m/s^2], base frame
STANDARD_GRAVITY = (0.0, 0.0, -9.81)


def payload_gravity(robot: Robot) -> np.ndarray:
    """The gravity a payload on ``robot`` hangs along (3,) [m/s^2], base frame: the robot's own, or
    :data:`STANDARD_GRAVITY` for a robot without gravity."""
    g = np.asarray(robot.gravity, dtype=float)
    return g if np.any(g) else np.asarray(STANDARD_GRAVITY)


def payload_loads(robot: Robot, mass: float = PAYLOAD_MASS) -> Loads:
    """A payload of ``mass`` [kg] hanging at the tip of ``robot``: the force ``mass`` g [N], base frame, along the
    robot's gravity (:func:`payload_gravity`: a robot mounted horizontally gets its payload across its axis)."""
    return Loads(np.zeros(robot.n_tendons), tip_force=float(mass) * payload_gravity(robot))


def paper_bounds(n_tendons: int = 8) -> TensionBounds:
    """The study's tension bounds, :data:`DEFAULT_BOUNDS`, for each of ``n_tendons`` tendons [N]."""
    return TensionBounds.uniform(n_tendons, *DEFAULT_BOUNDS)


#: tip payloads of the workspace's load comparison [kg] (0 g: gravity alone)
COMPARE_PAYLOADS = (0.0, 0.005, 0.010, 0.020)


def workspace_load_cases(robot: Robot, given: Loads | None = None) -> dict[str, tuple[Robot, Loads]]:
    """The load cases ``tdcr workspace --compare-loads`` compares on ``robot``: no load (no gravity, no tip
    wrench); gravity with tip payloads of 0, 5, 10 and 20 g (force m g [N] along the robot's gravity,
    :func:`payload_loads`); the paper's tip wrench (with gravity); and ``given`` when it carries a tip wrench."""
    n = robot.n_tendons
    heavy = robot if np.any(np.asarray(robot.gravity)) else robot.with_gravity(STANDARD_GRAVITY)
    cases = {"no load": (robot.with_gravity((0.0, 0.0, 0.0)), Loads(np.zeros(n)))}
    for m in COMPARE_PAYLOADS:
        name = "gravity only" if m == 0 else f"payload {m * 1e3:g} g"
        cases[name] = (heavy, payload_loads(heavy, m) if m else Loads(np.zeros(n)))
    cases["paper wrench"] = (heavy, Loads(np.zeros(n), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT))
    if given is not None and (np.any(given.tip_force) or np.any(given.tip_moment) or given.point_loads):
        cases["given load"] = (robot, given.with_tensions(np.zeros(n)))
    return cases

"""The parameters a calibration can fit: what each one changes in the robot, the loads or the measurement frame,
its unit, its physical bounds and the scale the fit measures it in.

A parameter set is a tuple of :class:`Parameter`; :func:`parameters` builds one from names (``"youngs_modulus"``,
``"friction.mu0"``, ``"tendon_radius_3"``, ``"base_x"``, ...). :class:`Setting` applies a vector of values to a
robot and to a row's loads; the measurement frame's pose (``base_*``) maps the model's base-frame points into the
frame the measurements were taken in, ``p_measured = R(r) p_model + t`` with ``r`` a rotation vector [rad].
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..loads import MAX_TENSION
from ..paper import payload_gravity
from ..robot import (
    MAX_DECAY,
    MAX_FRICTION,
    MAX_MODULUS,
    MAX_TENDON_STIFFNESS,
    MIN_MODULUS,
    MIN_TENDON_STIFFNESS,
    ConstantFriction,
    ExponentialFriction,
    Robot,
)
from ..statics.displacement import tendon_stiffness
from ..validate import SettingsError

__all__ = ["PARAMETER_HELP", "Parameter", "Setting", "parameters"]

#: every parameter name the fit knows, with what it is (``K`` a 1-based tendon number)
PARAMETER_HELP = {
    "youngs_modulus": "the backbone's Young's modulus E [Pa]",
    "shear_modulus": "the backbone's shear modulus G [Pa] (fitted apart from E)",
    "friction.mu": "the constant friction law's coefficient [-]",
    "friction.mu0": "the exponential friction law's coefficient at zero deflection [-]",
    "friction.decay_per_deg": "the exponential friction law's decay [1/deg]",
    "tendon_radius": "every tendon's routing radius, one value [m]",
    "tendon_radius_K": "tendon K's routing radius [m]",
    "tendon_angle_K": "tendon K's routing angle [deg]",
    "pretension": "a tension added to every tendon's input, one value [N]",
    "pretension_K": "a tension added to tendon K's input (a zero offset of its sensor) [N]",
    "payload": "a mass hanging at the tip [kg], along the robot's gravity",
    "tendon_stiffness": "every tendon's axial stiffness, one value [N/m] (displacement-driven data)",
    "displacement_offset": "a pull-in added to every displacement-driven tendon's input, one value [m]",
    "displacement_offset_K": "a pull-in added to tendon K's input (a zero offset of its motor) [m]",
    "base_x": "the measurement frame's offset of the robot base along x [m] (also base_y, base_z)",
    "base_rx": "the measurement frame's turn of the robot base, a rotation vector's x [rad] (also base_ry, base_rz)",
}

_BASE = ("base_x", "base_y", "base_z", "base_rx", "base_ry", "base_rz")
#: every name a fit takes, as a user writes it (K a 1-based tendon number)
_KNOWN = ", ".join([*(n for n in PARAMETER_HELP if not n.startswith("base_")), *_BASE])
_INDEXED = re.compile(r"^(tendon_radius|tendon_angle|pretension|displacement_offset)_([0-9]+)$")


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity.

    Attributes
    ----------
    name : str
        Its name (:data:`PARAMETER_HELP`).
    unit : str
        Its unit.
    initial : float
        Its value in the robot (or 0 for offsets) before the fit.
    lower, upper : float
        Its physical bounds, in its unit.
    scale : float
        The size of a unit step of the fit's variable, in its unit (the initial magnitude, or a typical size for
        offsets): the fit works on ``(value - initial) / scale``.
    """

    name: str
    unit: str
    initial: float
    lower: float
    upper: float
    scale: float


def _modulus(name: str, value: float) -> Parameter:
    return Parameter(name, "Pa", value, MIN_MODULUS, MAX_MODULUS, value)


def _friction(robot: Robot, name: str) -> Parameter:
    law = robot.friction
    field = name.split(".", 1)[1]
    kinds = {"mu": ConstantFriction, "mu0": ExponentialFriction, "decay_per_deg": ExponentialFriction}
    if not isinstance(law, kinds[field]):
        want = "constant" if field == "mu" else "exponential"
        raise SettingsError("parameters", f": {name} needs the robot's friction law to be {want}, it is "
                            f"'{law.law}' (set [friction] law = \"{want}\" in the robot file)")
    value = float(getattr(law, field))
    if field == "decay_per_deg":
        return Parameter(name, "1/deg", value, 0.0, MAX_DECAY, max(value, 0.01))
    return Parameter(name, "-", value, 0.0, MAX_FRICTION, max(value, 0.1))


def _tendon(robot: Robot, kind: str, k: int | None) -> Parameter:
    name = kind if k is None else f"{kind}_{k}"
    if k is not None and not 1 <= k <= robot.n_tendons:
        raise SettingsError("parameters", f": {name} names tendon {k}, the robot has tendons 1 to {robot.n_tendons}")
    t = robot.tendons[(k or 1) - 1]
    if kind == "tendon_radius":
        if k is None and len({x.radius for x in robot.tendons}) > 1:
            raise SettingsError("parameters", ": tendon_radius fits one radius for every tendon, but the robot's "
                                "tendons have different radii: fit tendon_radius_K for each")
        # the routing circle lies outside the backbone and inside given disks (derived disks follow the tendons)
        low = robot.backbone.outer_radius * (1.0 + 1e-6) + 1e-9
        top = robot.disk_radius_given * (1.0 - 1e-6) if robot.disk_radius_given is not None else max(0.1, 5 * t.radius)
        return Parameter(name, "m", t.radius, low, top, t.radius)
    if kind == "tendon_angle":
        return Parameter(name, "deg", t.angle_deg, max(t.angle_deg - 90.0, -360.0), min(t.angle_deg + 90.0, 360.0), 1.0)
    if kind == "displacement_offset":
        return Parameter(name, "m", 0.0, -0.1 * robot.length, 0.1 * robot.length, 1e-4)
    return Parameter(name, "N", 0.0, -MAX_TENSION, MAX_TENSION, 0.1)


def _stiffness(stiffness: np.ndarray) -> Parameter:
    finite = stiffness[np.isfinite(stiffness)]
    if finite.size != stiffness.size or len(set(finite.tolist())) > 1:
        raise SettingsError("parameters", ": tendon_stiffness fits one stiffness for every tendon from a finite "
                                          "initial one: give the tendons' stiffness (one value, N/m) to start from")
    return Parameter("tendon_stiffness", "N/m", float(finite[0]), MIN_TENDON_STIFFNESS, MAX_TENDON_STIFFNESS,
                     float(finite[0]))


def _one(robot: Robot, name: str, stiffness: np.ndarray) -> Parameter:
    if name == "youngs_modulus":
        return _modulus(name, robot.backbone.youngs_modulus)
    if name == "shear_modulus":
        return _modulus(name, robot.backbone.shear)
    if name.startswith("friction."):
        if name.split(".", 1)[1] not in ("mu", "mu0", "decay_per_deg"):
            raise SettingsError("parameters", f": unknown friction parameter {name!r}; fit friction.mu (constant law), "
                                "friction.mu0 or friction.decay_per_deg (exponential law)")
        return _friction(robot, name)
    if name in ("tendon_radius", "pretension", "displacement_offset"):
        return _tendon(robot, name, None)
    if name == "tendon_stiffness":
        return _stiffness(stiffness)
    if name == "payload":
        return Parameter(name, "kg", 0.0, 0.0, 10.0, 0.01)
    if name in _BASE:
        unit, scale, limit = ("m", 1e-3, 1.0) if name[5] != "r" else ("rad", 0.01, math.pi)
        return Parameter(name, unit, 0.0, -limit, limit, scale)
    hit = _INDEXED.match(name)
    if hit:
        return _tendon(robot, hit.group(1), int(hit.group(2)))
    raise SettingsError("parameters", f": unknown parameter {name!r}; known: {_KNOWN}")


def parameters(robot: Robot, names: list[str] | tuple[str, ...],
               stiffness: np.ndarray | None = None) -> tuple[Parameter, ...]:
    """The parameters ``names`` of ``robot``, each with its initial value from the robot (and the tendons'
    axial ``stiffness`` (n_tendons,) [N/m], default the robot's own); SettingsError naming a name that is unknown,
    repeated, or that the robot cannot take, such as ``friction.mu`` on an exponential law, ``tendon_radius``
    with ``tendon_radius_K``, or ``tendon_stiffness`` of inextensible tendons."""
    k = tendon_stiffness(robot, None) if stiffness is None else np.asarray(stiffness, dtype=float)
    if not names:
        raise SettingsError("parameters", f": name at least one parameter to fit; known: {_KNOWN}")
    out = tuple(_one(robot, str(n).strip(), k) for n in names)
    seen = [p.name for p in out]
    for p in seen:
        if seen.count(p) > 1:
            raise SettingsError("parameters", f": {p} is named twice")
    for kind in ("tendon_radius", "pretension", "displacement_offset"):
        if kind in seen and any(s.startswith(kind + "_") for s in seen):
            raise SettingsError("parameters", f": {kind} (every tendon) and {kind}_K (one tendon) overlap; name one")
    return out


@dataclass(frozen=True)
class Setting:
    """A parameter set at values: the robot, each row's loads and the measurement frame they give.

    Attributes
    ----------
    params : tuple of Parameter
    values : ndarray, shape (n_params,)
        In each parameter's unit.
    """

    params: tuple[Parameter, ...]
    values: np.ndarray

    def value(self, name: str, default: float = 0.0) -> float:
        """The value of parameter ``name``, or ``default`` where it is not fitted."""
        for p, v in zip(self.params, self.values, strict=True):
            if p.name == name:
                return float(v)
        return default

    def robot(self, robot: Robot) -> Robot:
        """``robot`` with the fitted values of its own quantities (moduli, friction, routing)."""
        backbone = {}
        for name in ("youngs_modulus", "shear_modulus"):
            if any(p.name == name for p in self.params):
                backbone[name] = self.value(name)
        if "shear_modulus" in backbone:
            backbone["poissons_ratio"] = None
        update: dict[str, object] = {}
        if backbone:
            update["backbone"] = robot.backbone.model_copy(update=backbone)
        friction = {p.name.split(".", 1)[1]: self.value(p.name) for p in self.params if p.name.startswith("friction.")}
        if friction:
            update["friction"] = robot.friction.model_copy(update=friction)
        tendons = []
        for k, t in enumerate(robot.tendons, start=1):
            radius = self.value(f"tendon_radius_{k}", self.value("tendon_radius", t.radius))
            angle = self.value(f"tendon_angle_{k}", t.angle_deg)
            tendons.append(t if (radius, angle) == (t.radius, t.angle_deg)
                           else t.model_copy(update={"radius": radius, "angle_deg": angle}))
        k = self.value("tendon_stiffness", np.nan)
        if not np.isnan(k):
            tendons = [t.model_copy(update={"stiffness": k}) for t in tendons]
        if any(a is not b for a, b in zip(tendons, robot.tendons, strict=True)):
            update["tendons"] = tuple(tendons)
        return robot.model_copy(update=update) if update else robot

    def tensions(self, tensions: np.ndarray) -> np.ndarray:
        """The tensions the robot carries for the inputs ``tensions`` (..., n_tendons) [N]: each plus its
        pretension."""
        out = np.array(tensions, dtype=float)
        out += self.value("pretension")
        for k in range(out.shape[-1]):
            out[..., k] += self.value(f"pretension_{k + 1}")
        return out

    def displacements(self, displacements: np.ndarray) -> np.ndarray:
        """The pull-ins the motors make for the inputs ``displacements`` (n_tendons,) [m] (NaN: tension-driven):
        each plus its offset."""
        out = np.array(displacements, dtype=float) + self.value("displacement_offset")
        for k in range(out.shape[-1]):
            out[..., k] += self.value(f"displacement_offset_{k + 1}")
        return out

    def stiffness(self, stiffness: np.ndarray) -> np.ndarray:
        """The tendons' axial stiffness (n_tendons,) [N/m]: ``stiffness``, or the fitted one for every tendon."""
        k = self.value("tendon_stiffness", np.nan)
        return np.asarray(stiffness, dtype=float) if np.isnan(k) else np.full(len(stiffness), k)

    def tip_force(self, robot: Robot, force: np.ndarray) -> np.ndarray:
        """The tip force (3,) [N]: ``force`` plus the payload's weight along the robot's gravity."""
        return np.asarray(force, dtype=float) + self.value("payload") * payload_gravity(robot)

    def frame(self) -> tuple[np.ndarray, np.ndarray]:
        """The measurement frame's rotation (3, 3) and offset (3,) [m]: ``p_measured = R p_model + t``."""
        r = np.array([self.value(n) for n in _BASE[3:]])
        t = np.array([self.value(n) for n in _BASE[:3]])
        return Rotation.from_rotvec(r).as_matrix(), t

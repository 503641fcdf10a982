"""Robot description: backbone, segments, tendons, friction law, gravity.

Every class here is an immutable, validated model (pydantic, strict numbers:
an int is taken for a real number, a bool, a string or a list for a number is
refused). Construction from Python keywords and from a TOML file goes through
the same validation, so a bad value is reported the same way in both: the
field, the value and the allowed range with its reason. Unknown keys are errors.

All quantities are SI (m, kg, N, Pa, m/s^2) unless the name says otherwise
(``angle_deg`` is in degrees).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Mapping
from functools import cached_property
from typing import Annotated, Literal, TypeVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, SerializerFunctionWrapHandler, model_serializer, model_validator

from .validate import Count, Real, is_integer, ranged, show, show_number

__all__ = [
    "Backbone",
    "ConstantFriction",
    "ExponentialFriction",
    "FrictionLaw",
    "NoFriction",
    "Robot",
    "Segment",
    "Tendon",
]


#: a robot's derived arrays, computed once per robot object: id(robot) -> {name: read-only array}. Kept outside the
#: object (its __dict__ takes part in pydantic's equality, where arrays have no truth value, and in pickling);
#: an entry goes when its robot does
_DERIVED: dict[int, dict[str, np.ndarray]] = {}


def _derived(robot: Robot, name: str, make: Callable[[], np.ndarray]) -> np.ndarray:
    """``robot``'s derived array ``name``, computed by ``make`` on first use, read-only and shared by every caller."""
    slot = _DERIVED.get(id(robot))
    if slot is None:
        slot = _DERIVED.setdefault(id(robot), {})
        weakref.finalize(robot, _DERIVED.pop, id(robot), None)
    arr = slot.get(name)
    if arr is None:
        arr = make()
        arr.setflags(write=False)
        slot[name] = arr
    return arr


#: a model's own class (what :meth:`_Frozen.model_copy` returns)
_M = TypeVar("_M", bound="_Frozen")


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", ignored_types=(cached_property,))

    def model_copy(self: _M, *, update: Mapping[str, object] | None = None, deep: bool = False) -> _M:
        """A copy; with ``update``, a new object validated like any other (pydantic's own copy skips the checks)."""
        if not update:
            return super().model_copy(deep=deep)
        return type(self).model_validate({**self.model_dump(), **update})


#: the softest and the stiffest modulus accepted [Pa] (a softer one leaves the bending stiffness EI of a thin
#: backbone among the subnormal floats, whose reciprocal overflows)
MIN_MODULUS, MAX_MODULUS = 1e-3, 2e12
#: the thinnest wall of a hollow backbone [m]: thinner, r_o^4 - r_i^4 is lost to rounding
MIN_WALL = 1e-6
#: the physical ranges, each with its reason
Modulus = ranged(MIN_MODULUS, MAX_MODULUS, "Pa", "from far softer than any gel to diamond's 1.2e12 Pa")
Poisson = ranged(-1.0, 0.5, "", "the range of an isotropic elastic material", lo_open=True, hi_open=True)
Radius = ranged(1e-5, 0.1, "m", "a backbone from 10 micrometres to 10 centimetres")
Bore = ranged(0.0, 0.1, "m", "a hollow backbone's bore: 0 for a solid rod")
LinearDensity = ranged(0.0, 100.0, "kg/m", "heavier than a steel bar of 12 cm diameter is not a backbone")
Length = ranged(1e-3, 10.0, "m", "from a millimetre to ten metres")
Piece = ranged(1e-5, 10.0, "m", "a subsegment of at least 10 micrometres")
Mass = ranged(0.0, 10.0, "kg", "a disk of at most 10 kg")
#: the most disks one segment may have
MAX_DISKS_PER_SEGMENT = 10_000
#: the most tendons and segments a robot may have
MAX_TENDONS, MAX_SEGMENTS = 1000, 100
DiskCount = Annotated[Count, Field(ge=1, le=MAX_DISKS_PER_SEGMENT)]
Routing = ranged(0.0, 1.0, "m", "a routing radius up to a metre", lo_open=True)
Angle = ranged(-360.0, 360.0, "deg", "one turn either way; larger angles repeat a routing")
#: the softest and the stiffest tendon accepted [N/m] (over its length in the robot)
MIN_TENDON_STIFFNESS, MAX_TENDON_STIFFNESS = 1.0, 1e10
TendonStiffness = ranged(MIN_TENDON_STIFFNESS, MAX_TENDON_STIFFNESS, "N/m", "from a soft elastic cord to a steel "
                         "rod; leave it out for an inextensible tendon")
DiskRadius = ranged(1e-4, 1.0, "m", "disks from 0.1 mm to 1 m across the axis")
#: the largest friction coefficient and exponential decay accepted [-], [1/deg]
MAX_FRICTION, MAX_DECAY = 10.0, 10.0
Friction = ranged(0.0, MAX_FRICTION, "", "a friction coefficient")
Decay = ranged(0.0, MAX_DECAY, "1/deg", "the paper's law decays at 0.027 per degree")
#: the weakest gravity a robot may have [m/s^2] (else none, 0): a tenth of the residual acceleration on an orbiting
#: station (about 1e-5 m/s^2), so every real setting fits; below it gravity's weight is lost in the solvers'
#: tolerance, and a vector of subnormal components (5e-324) would still be taken for a direction of the payload
MIN_GRAVITY = 1e-6
#: the strongest gravity [m/s^2]: ten times the Earth's
MAX_GRAVITY = 100.0
#: a robot's name: printable (no control characters, line separators or bidirectional overrides)
_NAME = r"^[^\x00-\x1f\x7f-\x9f\u200e\u200f\u2028\u2029\u202a-\u202e\u2066-\u2069]*$"
#: a robot's disk radius when the file gives none: the largest routing radius times this
DISK_RADIUS_FACTOR = 1.2


class Backbone(_Frozen):
    """Elastic backbone rod (a round tube or a solid rod when ``inner_radius`` is 0).

    Give either ``poissons_ratio`` or ``shear_modulus``; the other follows from
    ``G = E / (2 (1 + nu))``.
    """

    youngs_modulus: Modulus = Field(description="Young's modulus E [Pa]")
    poissons_ratio: Poisson | None = Field(default=None, description="Poisson's ratio nu [-]")
    shear_modulus: Modulus | None = Field(default=None, description="shear modulus G [Pa]")
    outer_radius: Radius = Field(description="outer radius [m]")
    inner_radius: Bore = Field(default=0.0, description="inner radius [m]")
    mass_per_length: LinearDensity = Field(default=0.0, description="mass per unit length [kg/m]")

    @model_validator(mode="after")
    def _check(self) -> Backbone:
        if (self.poissons_ratio is None) == (self.shear_modulus is None):
            raise ValueError("backbone: give exactly one of poissons_ratio or shear_modulus")
        if self.inner_radius >= self.outer_radius:
            raise ValueError(
                f"backbone.inner_radius must be smaller than outer_radius={self.outer_radius}, "
                f"got {self.inner_radius}"
            )
        if self.outer_radius - self.inner_radius < MIN_WALL:
            raise ValueError(f"backbone.inner_radius = {self.inner_radius!r} m must leave a wall of at least "
                             f"{MIN_WALL:g} m inside outer_radius = {self.outer_radius!r} m (a thinner one's "
                             "bending stiffness is lost to rounding)")
        if self.poissons_ratio is not None and self.shear > MAX_MODULUS:  # G = E / (2 (1 + nu)): nu near -1
            raise ValueError(f"backbone.poissons_ratio = {self.poissons_ratio!r} gives a shear modulus "
                             f"E / (2 (1 + nu)) = {self.shear:g} Pa, above {MAX_MODULUS:g} Pa (no material is "
                             "that stiff)")
        return self

    @property
    def shear(self) -> float:
        """Shear modulus G [Pa]."""
        if self.shear_modulus is not None:
            return self.shear_modulus
        assert self.poissons_ratio is not None
        return self.youngs_modulus / (2.0 * (1.0 + self.poissons_ratio))

    @property
    def second_moment(self) -> float:
        """Second moment of area I = pi (r_o^4 - r_i^4) / 4 [m^4]."""
        return math.pi * (self.outer_radius**4 - self.inner_radius**4) / 4.0

    @property
    def bending_stiffness(self) -> float:
        """EI [N m^2]."""
        return self.youngs_modulus * self.second_moment

    @property
    def torsional_stiffness(self) -> float:
        """G J = 2 G I [N m^2] (J = 2 I is the polar moment of a round section)."""
        return self.shear * 2.0 * self.second_moment


class Segment(_Frozen):
    """One segment: a length of backbone carrying ``n_disks`` equally massive disks.

    Disk ``k`` of the segment (1-based) sits at the end of the ``k``-th subsegment.
    Subsegment lengths default to ``length / n_disks``.
    """

    length: Length = Field(description="segment arc length [m]")
    n_disks: DiskCount = Field(description="number of disks in the segment")
    disk_mass: Mass = Field(default=0.0, description="mass of one disk [kg]")
    subsegment_lengths: tuple[Piece, ...] | None = Field(
        default=None, description="backbone length before each disk [m]; sums to length"
    )

    @model_validator(mode="after")
    def _check(self) -> Segment:
        sl = self.subsegment_lengths
        if sl is not None:
            if len(sl) != self.n_disks:
                raise ValueError(
                    f"segment.subsegment_lengths must have n_disks={self.n_disks} entries, got {len(sl)}"
                )
            if abs(sum(sl) - self.length) > 1e-9 * max(1.0, self.length):
                raise ValueError(
                    f"segment.subsegment_lengths must sum to length={self.length}, got {sum(sl)}"
                )
        return self

    @property
    def lengths(self) -> np.ndarray:
        """Subsegment lengths, shape (n_disks,) [m]."""
        if self.subsegment_lengths is not None:
            return np.asarray(self.subsegment_lengths, dtype=float)
        return np.full(self.n_disks, self.length / self.n_disks)


class Tendon(_Frozen):
    """A tendon routed straight through the disk holes at (radius, angle).

    It passes through every disk before the last disk of segment ``segment``
    (1-based) and is anchored at that disk.
    """

    segment: Annotated[Count, Field(ge=1, le=MAX_SEGMENTS)] = Field(
        description="1-based index of the segment whose last disk anchors it")
    radius: Routing = Field(description="routing radius [m]")
    angle_deg: Angle = Field(description="routing angle about z [deg]")
    stiffness: TendonStiffness | None = Field(
        default=None, description="axial stiffness over its length in the robot [N/m] (EA / length); default "
        "inextensible. It changes no force: it sets the pull-in a tension needs, and the tension a pull-in makes")

    @property
    def angle(self) -> float:
        """Routing angle [rad]."""
        return math.radians(self.angle_deg)

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, object]:
        """The tendon's fields, ``stiffness`` left out when unset (inextensible): a robot's dump, and every digest
        and record made of it, is what it was before tendons had a stiffness."""
        out = handler(self)
        if out.get("stiffness", 0) is None:
            del out["stiffness"]
        return out


class NoFriction(_Frozen):
    """Frictionless tendon holes."""

    law: Literal["none"] = "none"

    @property
    def is_frictionless(self) -> bool:
        """Always True."""
        return True


class ConstantFriction(_Frozen):
    """Coulomb friction with a constant coefficient."""

    law: Literal["constant"] = "constant"
    mu: Friction = Field(description="friction coefficient [-]")

    @property
    def is_frictionless(self) -> bool:
        """True when mu = 0 (then the model equals :class:`NoFriction` exactly)."""
        return self.mu == 0.0


class ExponentialFriction(_Frozen):
    """The paper's law (Eq. 16): ``mu = mu0 * exp(-decay_per_deg * sigma_deg)``.

    ``sigma_deg`` is the local deflection angle of the tendon at the hole in
    degrees, ``180 - angle(u_prev, u_next)``: 0 for a straight tendon. The paper's
    Eq. 19 computes the angle between the two tendon directions itself (180 deg
    when straight) while its text calls sigma the local bending angle; MODEL.md
    reads it as the deflection, which keeps mu at 0.689 for a straight tendon
    and lets it fall as the tendon wraps more.
    """

    law: Literal["exponential"] = "exponential"
    mu0: Friction = Field(default=0.689, description="mu at sigma = 0")
    decay_per_deg: Decay = Field(default=0.027, description="decay rate [1/deg]")

    @property
    def is_frictionless(self) -> bool:
        """True when mu0 = 0."""
        return self.mu0 == 0.0


FrictionLaw = Annotated[
    NoFriction | ConstantFriction | ExponentialFriction, Field(discriminator="law")
]


class Robot(_Frozen):
    """A tendon-driven continuum robot.

    Frames: frame 0 is the base (world) frame; frame ``i`` is attached to disk
    ``i`` (i = 1..N, N the total number of disks), its z-axis along the
    backbone tangent.
    """

    model_config = ConfigDict(validate_by_alias=True, validate_by_name=False, serialize_by_alias=True)

    name: Annotated[str, Field(strict=True, min_length=1, max_length=200, pattern=_NAME)] = "robot"
    backbone: Backbone
    segments: tuple[Segment, ...] = Field(min_length=1, max_length=MAX_SEGMENTS)
    tendons: tuple[Tendon, ...] = Field(min_length=0, max_length=MAX_TENDONS)
    gravity: tuple[Real, Real, Real] = Field(
        default=(0.0, 0.0, -9.81), description="gravity in the base frame [m/s^2]; |g| 0 or in [1e-6, 100]"
    )
    friction: FrictionLaw = Field(default_factory=NoFriction)
    disk_radius_given: DiskRadius | None = Field(
        default=None, alias="disk_radius",
        description="radius of every disk [m]; default: 1.2 times the largest routing radius",
    )

    @model_validator(mode="after")
    def _check(self) -> Robot:
        g = math.hypot(*self.gravity)  # no overflow nor underflow: a subnormal vector has a non-zero length
        if not (g == 0.0 or MIN_GRAVITY <= g <= MAX_GRAVITY):  # NaN fails too
            raise ValueError(f"gravity: |g| = {show_number(g, MIN_GRAVITY, MAX_GRAVITY)} m/s^2 must be in "
                             f"[0, {MAX_GRAVITY:g}] m/s^2 (ten times the Earth's gravity), either 0 (no gravity) or "
                             f"at least {MIN_GRAVITY:g} m/s^2 (a weaker one is lost in the solvers' tolerance and "
                             "has no trustworthy direction)")
        rd = self.disk_radius
        for k, t in enumerate(self.tendons):
            if t.segment > len(self.segments):
                raise ValueError(
                    f"tendons.{k}.segment must be between 1 and {len(self.segments)}, got {t.segment}"
                )
            if t.radius <= self.backbone.outer_radius:
                raise ValueError(
                    f"tendons.{k}.radius must exceed backbone.outer_radius="
                    f"{self.backbone.outer_radius}, got {t.radius}"
                )
            if t.radius >= rd:
                raise ValueError(f"tendons.{k}.radius = {t.radius:g} m must be smaller than the disk radius "
                                 f"{rd:g} m (the holes lie on the disks)")
        seen: set[tuple[int, float, float]] = set()
        for k, t in enumerate(self.tendons):
            key = (t.segment, round(t.radius, 12), round(t.angle_deg % 360.0, 9))
            if key in seen:
                raise ValueError(f"tendons.{k} duplicates an earlier tendon of the same segment")
            seen.add(key)
        return self

    # ----------------------------------------------------------------- derived
    @property
    def disk_radius(self) -> float:
        """The disks' radius in use [m]: the one given (``Robot(disk_radius=...)``, kept as
        ``disk_radius_given``), or 1.2 times the largest routing radius (at least the backbone's radius plus
        1 mm when there are no tendons). Derived, so it follows the tendons when a design study moves them."""
        if self.disk_radius_given is not None:
            return float(self.disk_radius_given)
        if self.tendons:
            return DISK_RADIUS_FACTOR * max(t.radius for t in self.tendons)
        return self.backbone.outer_radius + 1e-3

    @property
    def n_disks(self) -> int:
        """Total number of disks N (= number of subsegments)."""
        return sum(s.n_disks for s in self.segments)

    @property
    def n_tendons(self) -> int:
        """Number of tendons."""
        return len(self.tendons)

    @property
    def length(self) -> float:
        """Total backbone length [m]."""
        return float(sum(s.length for s in self.segments))

    @property
    def subsegment_lengths(self) -> np.ndarray:
        """Arc length of every subsegment, shape (N,) [m] (read-only)."""
        return _derived(self, "lengths", lambda: np.concatenate([s.lengths for s in self.segments]))

    @property
    def disk_masses(self) -> np.ndarray:
        """Mass of every disk, shape (N,) [kg] (read-only)."""
        return _derived(self, "masses",
                        lambda: np.concatenate([np.full(s.n_disks, s.disk_mass) for s in self.segments]))

    @property
    def segment_end_disks(self) -> np.ndarray:
        """1-based index of the last disk of each segment, shape (M,)."""
        return np.cumsum([s.n_disks for s in self.segments])

    @property
    def anchor_disks(self) -> np.ndarray:
        """1-based index of the disk anchoring each tendon, shape (n_tendons,) (read-only)."""
        ends = self.segment_end_disks
        return _derived(self, "anchors", lambda: np.array([ends[t.segment - 1] for t in self.tendons], dtype=np.int64))

    @property
    def tendon_holes(self) -> np.ndarray:
        """Hole position of each tendon in its disk's frame, shape (n_tendons, 3) [m] (read-only)."""
        return _derived(self, "holes", self._tendon_holes)

    def _tendon_holes(self) -> np.ndarray:
        out = np.zeros((self.n_tendons, 3))
        for k, t in enumerate(self.tendons):
            out[k, 0] = t.radius * math.cos(t.angle)
            out[k, 1] = t.radius * math.sin(t.angle)
        return out

    def with_gravity(self, gravity: tuple[float, float, float] | None) -> Robot:
        """Copy with another gravity vector (``None`` or zeros: no gravity)."""
        g = (0.0, 0.0, 0.0) if gravity is None else gravity  # validated as the field is: strings are refused
        return Robot.model_validate({**self.model_dump(), "gravity": g})

    def with_friction(self, friction: NoFriction | ConstantFriction | ExponentialFriction) -> Robot:
        """Copy with another friction law."""
        return Robot.model_validate({**self.model_dump(), "friction": friction.model_dump()})

    def with_disks(self, per_segment: int) -> Robot:
        """Copy with ``per_segment`` equally spaced disks in every segment: same lengths, routing and total disk
        mass per segment (a finer or coarser discretisation of the same robot)."""
        if not is_integer(per_segment) or not 1 <= per_segment <= MAX_DISKS_PER_SEGMENT:
            raise ValueError(f"per_segment must be an integer in [1, {MAX_DISKS_PER_SEGMENT:,}], got "
                             f"{show(per_segment)}")
        n = int(per_segment)
        segments = [{"length": s.length, "n_disks": n, "disk_mass": s.disk_mass * s.n_disks / n}
                    for s in self.segments]
        return Robot.model_validate({**self.model_dump(), "segments": segments})

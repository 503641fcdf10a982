"""The design space: the robot fields a study may vary, how a set of values makes a robot, and how designs are
chosen (every combination of a grid, or scrambled Sobol points in the ranges)."""

from __future__ import annotations

import itertools
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict, cast

import numpy as np
from pydantic import ValidationError
from scipy.stats import qmc

from ..io import format_validation_error
from ..robot import Robot

if TYPE_CHECKING:
    from ._spec import Parameter

__all__ = ["PARAMETERS", "ParameterInfo", "apply_parameters", "choose_designs", "from_unit", "parameter_info",
           "read_parameter"]


@dataclass(frozen=True)
class ParameterInfo:
    """What a parameter name means: its base (``routing_radius``), the segment it is limited to (1-based, or
    None for all), its unit and whether it takes whole numbers."""

    base: str
    segment: int | None
    unit: str
    integer: bool
    doc: str


#: the parameters by base name: unit, whole numbers, meaning; ``<base>_<k>`` limits one to segment k
PARAMETERS: dict[str, tuple[str, bool, str]] = {
    "routing_radius": ("m", False, "the routing radius of the tendons (of segment k)"),
    "segment_length": ("m", False, "the arc length of every segment (of segment k); subsegments scale with it"),
    "disks": ("", True, "the disks per segment (of segment k), evenly spaced"),
    "tendon_angle_offset": ("deg", False, "added to the routing angles of the tendons (of segment k)"),
    "backbone_radius": ("m", False, "the backbone's outer radius (its bore is kept)"),
    "youngs_modulus": ("Pa", False, "the backbone's Young's modulus E (G follows from Poisson's ratio when given)"),
    "disk_radius": ("m", False, "the disks' radius (for the contact test)"),
}
_PER_SEGMENT = ("routing_radius", "segment_length", "disks", "tendon_angle_offset")


def parameter_info(name: str) -> ParameterInfo:
    """The meaning of a parameter name; ValueError naming the known ones."""
    m = re.fullmatch(r"([a-z_]+?)(?:_(\d+))?", name)
    base, seg = (m.group(1), m.group(2)) if m else (name, None)
    if base not in PARAMETERS or (seg is not None and base not in _PER_SEGMENT):
        known = ", ".join(f"{b}[_k]" if b in _PER_SEGMENT else b for b in PARAMETERS)
        raise ValueError(f"unknown parameter {name!r}; known: {known} (k: a segment, from 1)")
    unit, integer, doc = PARAMETERS[base]
    return ParameterInfo(base, int(seg) if seg is not None else None, unit, integer, doc)


class _TendonData(TypedDict):
    """A tendon as :meth:`Robot.model_dump` gives it."""

    segment: int
    radius: float
    angle_deg: float


class _SegmentData(TypedDict):
    """A segment as :meth:`Robot.model_dump` gives it."""

    length: float
    n_disks: int
    disk_mass: float
    subsegment_lengths: tuple[float, ...] | None


class _BackboneData(TypedDict):
    """The backbone as :meth:`Robot.model_dump` gives it."""

    youngs_modulus: float
    poissons_ratio: float | None
    shear_modulus: float | None
    outer_radius: float
    inner_radius: float
    mass_per_length: float


class _RobotData(TypedDict):
    """A robot as :meth:`Robot.model_dump` gives it (by alias: ``disk_radius`` is the one given), which
    :func:`apply_parameters` edits before validating the result as a whole."""

    name: str
    backbone: _BackboneData
    segments: tuple[_SegmentData, ...]
    tendons: tuple[_TendonData, ...]
    gravity: tuple[float, float, float]
    friction: dict[str, object]
    disk_radius: float | None


def _segments(n: int, seg: int | None, name: str) -> list[int]:
    """The indices (0-based) of the segments of ``n`` a parameter sets: segment ``seg`` (1-based) or, for
    None, all; ValueError naming the parameter ``name`` for a segment the robot does not have."""
    if seg is None:
        return list(range(n))
    if not 1 <= seg <= n:
        raise ValueError(f"{name}: the robot has segments 1 to {n}")
    return [seg - 1]


def _set(data: _RobotData, name: str, value: float) -> None:
    """Set parameter ``name`` to ``value`` in the robot's dump ``data`` (in place; validated later)."""
    info = parameter_info(name)
    segs = _segments(len(data["segments"]), info.segment, name)
    tendons = [t for t in data["tendons"] if t["segment"] - 1 in segs]
    if info.base == "routing_radius":
        for t in tendons:
            t["radius"] = float(value)
    elif info.base == "tendon_angle_offset":
        for t in tendons:
            t["angle_deg"] = float(t["angle_deg"]) + float(value)
    elif info.base == "segment_length":
        for k in segs:
            s = data["segments"][k]
            if s.get("subsegment_lengths") is not None:
                s["subsegment_lengths"] = tuple(float(x) * value / s["length"] for x in s["subsegment_lengths"])
            s["length"] = float(value)
    elif info.base == "disks":
        for k in segs:
            data["segments"][k]["n_disks"] = int(value)
            data["segments"][k]["subsegment_lengths"] = None
    elif info.base == "backbone_radius":
        data["backbone"]["outer_radius"] = float(value)
    elif info.base == "youngs_modulus":
        data["backbone"]["youngs_modulus"] = float(value)
        if data["backbone"].get("poissons_ratio") is not None:
            data["backbone"]["shear_modulus"] = None
    else:  # disk_radius
        data["disk_radius"] = float(value)


def apply_parameters(robot: Robot, values: dict[str, float]) -> Robot:
    """``robot`` with the parameters set, in the order given; ValueError when the robot it makes is invalid
    (naming the robot field and its range)."""
    data = cast(_RobotData, robot.model_dump())
    for name, value in values.items():
        _set(data, name, value)
    try:
        return Robot.model_validate(data)
    except ValidationError as err:
        raise ValueError(format_validation_error(err)) from None


def _levels(p: Parameter, integer: bool) -> list[float]:
    """A grid's values of parameter ``p``: its list, or ``steps`` (default 3) evenly spaced over its range;
    whole numbers rounded, each value once."""
    if p.values is not None:
        vals = list(p.values)
    else:
        lo, hi = p.range
        vals = list(np.linspace(lo, hi, p.steps or 3))
    # whole numbers: steps finer than 1 round onto the same value; a grid holds each design once
    return list(dict.fromkeys(int(np.rint(v)) if integer else float(v) for v in vals))


def choose_designs(parameters: Mapping[str, Parameter], method: str, count: int | None, *,
                   seed: int = 0) -> list[dict[str, float]]:
    """The designs: each a dict of parameter values, in a fixed order (the design's index is its place).

    ``grid``: every combination of the parameters' values (a range gives ``steps`` evenly spaced values, 3 by
    default; a value that comes twice, as whole numbers rounded from close steps do, is kept once), the first
    parameter varying slowest. ``sobol``: ``count`` scrambled Sobol points (``seed``);
    a range is sampled uniformly, a list of values by an even share of the unit interval each.
    """
    names = list(parameters)
    infos = [parameter_info(n) for n in names]
    if method == "grid":
        levels = [_levels(parameters[n], i.integer) for n, i in zip(names, infos, strict=True)]
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*levels)]
    with warnings.catch_warnings():  # a count that is not a power of two is less balanced, not wrong
        warnings.simplefilter("ignore", UserWarning)
        u = qmc.Sobol(len(names), scramble=True, seed=np.random.default_rng([seed, 0x5D])).random(count)
    return [from_unit(row, parameters) for row in u]


def from_unit(u: np.ndarray, parameters: Mapping[str, Parameter]) -> dict[str, float]:
    """The design at the point ``u`` (shape (n_parameters,), in [0, 1]) of the unit cube: a range is mapped
    linearly, a range of whole numbers and a list of values give each value an even share of the interval."""
    d: dict[str, float] = {}
    for x, n in zip(np.clip(np.asarray(u, dtype=float), 0.0, 1.0), parameters, strict=True):
        p, integer = parameters[n], parameter_info(n).integer
        if p.values is not None:
            v = p.values[min(int(x * len(p.values)), len(p.values) - 1)]
        elif integer:  # lo..hi each with a share 1/(hi - lo + 1): rounding would halve the ends' shares
            lo, hi = int(p.range[0]), int(p.range[1])
            v = min(lo + int(np.floor(x * (hi - lo + 1))), hi)
        else:
            v = p.range[0] + x * (p.range[1] - p.range[0])
        d[n] = int(v) if integer else float(v)
    return d


def read_parameter(robot: Robot, name: str) -> float:
    """The value ``robot`` has for parameter ``name`` (NaN where its segments or tendons differ; an angle
    offset is 0 for the robot itself)."""
    info = parameter_info(name)
    segs = _segments(len(robot.segments), info.segment, name)
    vals: list[float | None]
    if info.base == "routing_radius":
        vals = [t.radius for t in robot.tendons if t.segment - 1 in segs]
    elif info.base == "segment_length":
        vals = [robot.segments[k].length for k in segs]
    elif info.base == "disks":
        vals = [robot.segments[k].n_disks for k in segs]
    elif info.base == "tendon_angle_offset":
        vals = [0.0]
    elif info.base == "backbone_radius":
        vals = [robot.backbone.outer_radius]
    elif info.base == "youngs_modulus":
        vals = [robot.backbone.youngs_modulus]
    else:  # the radius given (none: it follows the tendons)
        vals = [robot.disk_radius_given]
    found = [float(v) for v in vals if v is not None]
    return found[0] if found and np.ptp(found) == 0.0 else float("nan")

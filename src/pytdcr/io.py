"""Robot files (TOML) and result files (JSON), with a schema version.

A robot file::

    schema_version = 1
    name = "paper"
    gravity = [0.0, 0.0, -9.81]          # m/s^2, base frame

    [backbone]                           # SI units
    youngs_modulus = 54e9
    poissons_ratio = 0.3                 # or shear_modulus
    outer_radius = 0.0007
    mass_per_length = 0.0115

    [friction]
    law = "exponential"                  # "none" | "constant" (with mu) | "exponential" (mu0, decay_per_deg)
    mu0 = 0.689
    decay_per_deg = 0.027

    [[segments]]
    length = 0.2
    n_disks = 10
    disk_mass = 0.0002

    [[tendons]]
    segment = 1
    radius = 0.01
    angle_deg = 0.0
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import tomli_w
from pydantic import ValidationError

from .paper import BUILTIN_ROBOTS
from .records import JsonDict, JsonObject
from .robot import Robot
from .runtime import atomic_write_text, to_jsonable
from .validate import escape_controls, is_integer, read_text_file, show, show_path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "BUILTIN_ROBOTS",
    "SCHEMA_VERSION",
    "RobotFileError",
    "format_validation_error",
    "load_robot",
    "read_robot",
    "read_toml",
    "robot_from_dict",
    "robot_to_dict",
    "to_jsonable",
    "write_robot",
]

SCHEMA_VERSION = 1


_LAW_TAGS = {"none", "constant", "exponential"}  # pydantic's union tags, not user keys


class RobotFileError(ValueError):
    """A robot file that cannot be read, parsed or validated."""


_TYPE_WORDS = {"float_type": "must be a real number", "int_type": "must be an integer",
               "string_type": "must be a string", "tuple_type": "must be a list", "bool_type": "must be true or false",
               "model_type": "must be a table", "dict_type": "must be a table",
               "float_parsing": "must be a real number", "int_parsing": "must be an integer"}


def format_validation_error(err: ValidationError) -> str:
    """Problems on one line, ``; ``-separated: ``field.path = value: what is allowed``.

    Values are shortened and their control characters escaped (:func:`pytdcr.validate.show`); at most three
    problems are listed.
    """
    parts = []
    errors = err.errors()
    # a list whose items all failed is also "too short": say only why the items failed
    locs = [tuple(e["loc"]) for e in errors]
    errors = [e for e in errors if not (e["type"] == "too_short" and any(
        len(other) > len(e["loc"]) and other[: len(e["loc"])] == tuple(e["loc"]) for other in locs))]
    # unknown keys first (often the cause of the rest), missing keys last
    errors.sort(key=lambda e: {"extra_forbidden": 0, "missing": 2}.get(e["type"], 1))
    for e in errors[:3]:
        loc = ".".join(show(str(x), 40)[1:-1] for x in e["loc"]
                       if x not in _LAW_TAGS and not str(x).startswith("function-"))
        msg = escape_controls(e["msg"].removeprefix("Value error, "))
        kind = e["type"]
        value = e.get("input")
        if kind in _TYPE_WORDS:
            msg = f"{_TYPE_WORDS[kind]}, not {type(value).__name__}"
        if kind == "extra_forbidden":
            parts.append(f"{loc}: unknown key")
        elif loc and "input" in e and not isinstance(value, dict):
            parts.append(f"{loc} = {show(value)}: {msg}")
        elif loc:
            parts.append(f"{loc}: {msg}")
        else:
            parts.append(msg)
    if len(errors) > 3:
        parts.append(f"and {len(errors) - 3} more")
    return "; ".join(parts)


def _drop_none(obj: object) -> object:
    if isinstance(obj, dict):
        return {k: _drop_none(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, (list, tuple)):
        return [_drop_none(v) for v in obj]
    return obj


def robot_to_dict(robot: Robot) -> JsonDict:
    """Plain dictionary of ``robot`` with ``schema_version`` (TOML-ready: no None)."""
    return {"schema_version": SCHEMA_VERSION, **_drop_none(robot.model_dump())}


def robot_from_dict(data: object, source: str = "robot") -> Robot:
    """Validate ``data``, a dictionary as read from TOML (anything else is refused), into a :class:`Robot`.

    Raises
    ------
    RobotFileError
        Naming each offending field, its value and the allowed range.
    """
    if not isinstance(data, dict):
        raise RobotFileError(f"{source}: a robot must be a table of keys, got {type(data).__name__}")
    data = dict(data)
    version = data.pop("schema_version", SCHEMA_VERSION)
    if not is_integer(version) or version != SCHEMA_VERSION:
        raise RobotFileError(f"{source}: schema_version = {show(version)}: only {SCHEMA_VERSION} is supported")
    try:
        return Robot.model_validate(data)
    except ValidationError as err:
        raise RobotFileError(f"{source}: {format_validation_error(err)}") from None


#: the deepest nesting of tables and arrays a file may have (robot, study and bounds files need 3 or 4)
MAX_NESTING = 32


def nesting_depth(data: object, most: int = MAX_NESTING) -> int:
    """How deeply dicts and lists (a file's tables and arrays, a JSON body's objects and lists) nest in ``data``
    (0 for a scalar, 1 for ``[]``), counted without recursion, so any depth is measured; the count stops once it
    passes ``most`` (the answer is then some depth beyond ``most``).

    Used by every reader that bounds nesting (TOML files here, the explorer's request bodies); not part of the
    public API.
    """
    deepest, stack = 0, [(data, 0)]
    while stack:
        obj, depth = stack.pop()
        if isinstance(obj, dict):
            stack += [(v, depth + 1) for v in obj.values()]
        elif isinstance(obj, list):
            stack += [(v, depth + 1) for v in obj]
        else:
            continue
        deepest = max(deepest, depth + 1)
        if deepest > most:
            break
    return deepest


#: the integers a TOML file may hold: 64-bit, as the TOML standard says (Python's reader takes any size)
_INT64 = (-(2**63), 2**63 - 1)


def _bad_number(data: object) -> tuple[str, object] | None:
    """The first number in ``data`` (nested tables and arrays) that no pytdcr field takes: an integer beyond 64 bits
    or a float that is not finite (TOML's ``inf``, ``nan``, or ``1e400`` read as inf); its key path and value."""
    stack: list[tuple[str, object]] = [("", data)]
    while stack:
        key, obj = stack.pop()
        if isinstance(obj, dict):
            stack += [(f"{key}.{k}" if key else str(k), v) for k, v in reversed(obj.items())]
        elif isinstance(obj, list):
            stack += [(f"{key}[{i}]", v) for i, v in reversed(list(enumerate(obj)))]
        elif (isinstance(obj, int) and not isinstance(obj, bool) and not _INT64[0] <= obj <= _INT64[1]) or (
                isinstance(obj, float) and not math.isfinite(obj)):
            return key, obj
    return None


def read_toml(path: str | Path, what: str) -> JsonObject:
    """A small TOML file as a dict; ValueError naming the file if it cannot be read, is too large, binary, not
    TOML, nests tables and arrays deeper than :data:`MAX_NESTING`, or holds a number no field takes (an integer
    beyond 64 bits, a float that is not finite: ``inf``, ``nan``, ``1e400``), naming its key."""
    text = read_text_file(path, what)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{what} {show_path(path)}: not valid TOML ({err})") from None
    except RecursionError:
        data = None
    except ValueError:  # an integer of more than 4300 digits, which Python refuses to convert
        raise ValueError(f"{what} {show_path(path)}: holds an integer of thousands of digits; an integer must fit "
                         "in 64 bits (as TOML says)") from None
    if data is None or nesting_depth(data) > MAX_NESTING:
        raise ValueError(f"{what} {show_path(path)}: tables and arrays nest deeper than {MAX_NESTING} levels; no "
                         "pytdcr file needs more than 4")
    bad = _bad_number(data)
    if bad is not None:
        key, value = bad
        rule = ("an integer must fit in 64 bits (as TOML says)" if isinstance(value, int) else
                "numbers must be finite (1e400 reads as inf)")
        raise ValueError(f"{what} {show_path(path)}: {show(key, 80)[1:-1]} = {show(value)}: {rule}")
    return data


def read_robot(path: str | Path) -> Robot:
    """Read a robot TOML file (at most 1 MB of UTF-8 text)."""
    try:
        data = read_toml(path, "robot file")
    except ValueError as err:
        raise RobotFileError(str(err)) from None
    return robot_from_dict(data, str(path))


def write_robot(robot: Robot, path: str | Path) -> None:
    """Write ``robot`` as TOML (round-trips through :func:`read_robot`); the file is whole or absent.

    Raises
    ------
    RobotFileError
        If ``path`` is a folder or its folder does not exist.
    """
    path = Path(path)
    if path.is_dir():
        raise RobotFileError(f"{show_path(path)}: is a folder; give a file name for the robot")
    if not path.parent.is_dir():
        raise RobotFileError(f"{show_path(path)}: its folder {show_path(path.parent)} does not exist")
    text = tomli_w.dumps(robot_to_dict(robot))
    atomic_write_text(path, text)  # whole or absent


def load_robot(spec: str) -> Robot:
    """A built-in robot by name (``paper``, ``rao``) or a TOML file path."""
    if spec in BUILTIN_ROBOTS:
        return BUILTIN_ROBOTS[spec]()
    if not spec.endswith(".toml") and not Path(spec).exists():
        raise RobotFileError(f"robot {show(spec)}: not a built-in robot ({', '.join(BUILTIN_ROBOTS)}) nor a file")
    return read_robot(spec)

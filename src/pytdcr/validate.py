"""The one validation layer: strict numbers, physical ranges with their reason, bounded file reads.

Every check here raises ``ValueError`` (or ``TypeError`` for a wrong type) with
one line that names the field, shows the value (shortened, control characters
escaped) and says what is allowed. The robot description (:mod:`pytdcr.robot`,
through pydantic in strict mode), the loads (:mod:`pytdcr.loads`), the robot
and bounds files (:mod:`pytdcr.io`) and the command line all use it.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, TypeGuard

import numpy as np
from numpy.typing import ArrayLike
from pydantic import AfterValidator, BeforeValidator, Strict

__all__ = ["MAX_FORCE_N", "MAX_MOMENT_NM", "MAX_POSITION_M", "MAX_SEED", "MAX_TEXT_FILE_BYTES", "MIN_DIRECTION",
           "PLAIN_SCALE", "SCREENING_ERROR", "Count", "Real", "SettingsError", "as_real_array", "check_count",
           "check_positions", "check_real", "check_real_vector", "direction_or_none", "escape_controls", "field_ref",
           "finite_real", "in_range", "is_integer", "measured", "number_text", "parse_numbers", "read_text_file",
           "screening", "show", "show_number", "show_numbers", "show_path", "unit_vector", "unit_vectors",
           "unmeasured_text"]

#: the largest robot, bounds, loads or cases file read [bytes]
MAX_TEXT_FILE_BYTES = 1_000_000
#: the largest random seed accepted (what ``--seed`` takes)
MAX_SEED = 2**32 - 1
#: the farthest from the base a position (a target, a point) may lie [m]: no robot is longer (at most 100
#: segments of at most 10 m)
MAX_POSITION_M = 1e3
#: the largest component of a force [N]: far beyond what any tendon-driven robot carries
MAX_FORCE_N = 1e6
#: the largest component of a moment [N m]
MAX_MOMENT_NM = 1e6
#: the smallest largest |component| of a direction: below it (the subnormal floats) a vector's components carry
#: too few bits for its direction to be the one written
MIN_DIRECTION = float(np.finfo(float).tiny)

#: what is never sent raw to a terminal: C0 and C1 controls, line and paragraph separators, bidirectional
#: overrides and isolates (they reorder what a message shows)
_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u200e\u200f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
_NUMBER = re.compile(r"^[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$")
_NONFINITE = re.compile(r"^[+-]?(?:inf|infinity|nan)$", re.IGNORECASE)


def escape_controls(text: str) -> str:
    """``text`` with its control characters written as ``\\xNN`` (never sent raw to a terminal)."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 256 else f"\\u{ord(m.group()):04x}",
                        text)


def show(value: object, limit: int = 60, *, tail: bool = False) -> str:
    """``value`` for a message: its repr (strings as typed), control characters escaped, at most ``limit`` chars
    (the end kept when ``tail``, as for a path)."""
    text = escape_controls(value if isinstance(value, str) else repr(value))
    if isinstance(value, str):
        text = f"'{text}'"
    if len(text) <= limit:
        return text
    return "'..." + text[-(limit - 4):] if tail else text[: limit - 3] + "..."


def show_path(path: object) -> str:
    """A file or folder path for a message: quoted, escaped, its end (the name) kept if it is long."""
    return show(str(path), 160, tail=True)


#: how a message refers to a field by name (:func:`field_ref`): NUL, never left raw in a shown value
_REF = re.compile("\x00([A-Za-z_][A-Za-z0-9_.]*)\x00")


def field_ref(name: str) -> str:
    """A reference to the setting ``name`` inside a :class:`SettingsError`'s text: it reads as the field's name
    in Python and as its option (``--name``) on the command line."""
    return f"\x00{name}\x00"


class SettingsError(ValueError):
    """A setting outside what is allowed: one line naming the field, the value and the allowed range.

    ``str(err)`` begins with the field's name (``n_shapes = -1: must be ...``); other fields the text names are
    written with :func:`field_ref`, so that :meth:`worded` can call every field by another name (the command
    line's options).

    Attributes
    ----------
    field : str
        The setting at fault.
    text : str
        What follows its name.
    """

    def __init__(self, field: str, text: str) -> None:
        self.field = field
        self.text = text
        super().__init__(self.worded())

    def worded(self, names: dict[str, str] | None = None) -> str:
        """The message with each field called by ``names[field]`` (default: its own name)."""
        names = names or {}
        return _REF.sub(lambda m: names.get(m.group(1), m.group(1)), field_ref(self.field) + self.text)

    @classmethod
    def about(cls, field: str, err: Exception) -> SettingsError:
        """``err`` (whose message names ``field`` first, as this module's checks do) as a SettingsError."""
        text = str(err)
        return cls(field, text[len(field):] if text.startswith(field) else f": {text}")


def _fmt(x: float) -> str:
    return f"{x:g}"


def show_number(x: float, *limits: float) -> str:
    """A number for a message: short (``%g``), but with every digit it needs to differ from each of ``limits``
    (a value just above a limit is never shown as the limit: 10000.000001, not 10000)."""
    x = float(x)
    text = f"{x:g}"
    if any(x != float(lim) and text == f"{float(lim):g}" for lim in limits):
        return repr(x)
    return text


def number_text(value: float, decimals: int = 3, width: int = 0) -> str:
    """``value`` for a table or a message, right-aligned in ``width`` characters: ``decimals`` decimals, or three
    significant digits (``.3g``) where the decimals would show a non-zero value as 0 (an error of 2e-4 mm is not
    "0.000"). Zero is written unsigned (-0.0 as 0); non-finite values as Python writes them (``nan``, ``inf``).

    The one rule for small non-zero numbers in the study's texts (``compare.md``, ``accuracy.md``, the
    reproduction's report) and the command line's messages (:func:`show_number` is the one for a value in an
    error message).
    """
    value = float(value) + 0.0  # -0.0 + 0.0 is +0.0
    text = f"{value:{width}.{decimals}f}"
    if value != 0.0 and float(text) == 0.0:
        return f"{value:{width}.3g}"
    return text


def measured(value: float, error: float) -> bool:
    """Whether a value with its error bar is a measurement worth showing: both finite and the error [same unit]
    below the value's magnitude. A number whose error bar is as large as itself is not shown as a result: the
    reports and the command line write :func:`unmeasured_text` in its place."""
    return math.isfinite(value) and math.isfinite(error) and 0.0 <= error < abs(value)


#: the largest relative error of a volume shown as converged; above it (and below 100 %, :func:`measured`) a
#: volume is a screening estimate and says so on its line
SCREENING_ERROR = 0.25


def screening(value: float, error: float) -> bool:
    """Whether a measured value (:func:`measured`) is only a screening estimate: its error [same unit] above
    :data:`SCREENING_ERROR` of its magnitude."""
    return measured(value, error) and error > SCREENING_ERROR * abs(value)


def unmeasured_text(error_text: str, advice: str = "") -> str:
    """The words that stand in for a value whose error (``error_text``, with its unit) exceeds it
    (:func:`measured`), with ``advice`` on how to measure it (a larger budget)."""
    tail = f"; {advice}" if advice else ""
    return f"not measured at this budget (its error, {error_text}, exceeds the estimate{tail})"


def in_range(lo: float | None, hi: float | None, unit: str, reason: str = "", *, lo_open: bool = False,
             hi_open: bool = False) -> Callable[[float], float]:
    """A check that a finite number lies in the interval, for pydantic's ``AfterValidator`` or direct use."""
    left = "-inf" if lo is None else _fmt(lo)
    right = "inf" if hi is None else _fmt(hi)
    interval = f"{'(' if lo_open or lo is None else '['}{left}, {right}{')' if hi_open or hi is None else ']'}"
    words = f"must be in {interval}{f' {unit}' if unit else ''}{f' ({reason})' if reason else ''}"

    def check(x: float) -> float:
        if not math.isfinite(x):
            raise ValueError(f"must be finite ({words.removeprefix('must be ')})")
        low_bad = lo is not None and (x <= lo if lo_open else x < lo)
        high_bad = hi is not None and (x >= hi if hi_open else x > hi)
        if low_bad or high_bad:
            raise ValueError(words)
        return x

    return check


def _real(x: object) -> object:
    """Any real number as a float (NumPy's too); bools, strings, complex numbers go on to be refused."""
    if isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)):
        try:
            return float(x)
        except OverflowError:
            raise ValueError(f"must be a real number of at most about 1.8e308, got {show(x)}") from None
    return x


def _integer(x: object) -> object:
    """Any integer as an int (NumPy's too); bools, floats (even 2.0) and strings go on to be refused."""
    if isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_)):
        return int(x)
    return x


#: a strict real number (any int or float, NumPy's too; a bool, a string or a complex number is refused)
Real = Annotated[float, BeforeValidator(_real), Strict()]
#: a strict integer (any int, NumPy's too; a float, a bool or a string is refused)
Count = Annotated[int, BeforeValidator(_integer), Strict()]


def is_integer(x: object) -> TypeGuard[numbers.Integral]:
    """True for an integer (Python's or NumPy's), False for a bool, a float (even 2.0) or anything else."""
    return isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))


def check_count(value: object, name: str, lo: int = 1, hi: int | None = None) -> int:
    """``value`` as an int in [lo, hi]; TypeError for a non-integer (a bool, 2.0), ValueError out of range."""
    if not is_integer(value):
        raise TypeError(f"{name} must be an integer, got {show(value)} ({type(value).__name__})")
    if value < lo or (hi is not None and value > hi):
        span = f"in [{lo:,}, {hi:,}]" if hi is not None else f">= {lo:,}"
        raise ValueError(f"{name} = {show(value)}: must be an integer {span}")
    return int(value)


def ranged(lo: float | None, hi: float | None, unit: str, reason: str = "", **kw: bool) -> object:
    """A strict real field checked to lie in the interval (see :func:`in_range`): the type
    ``Annotated[float, ...]``, for a pydantic field's annotation (returned as ``object``: a type form is no class,
    and Python's typing has no annotation for one)."""
    return Annotated[float, BeforeValidator(_real), Strict(), AfterValidator(in_range(lo, hi, unit, reason, **kw))]


def _has_non_real(items: list | tuple, depth: int = 0) -> bool:
    """A bool, complex number or string anywhere in nested lists (NumPy would turn True into 1.0)."""
    for x in items:
        if isinstance(x, (list, tuple)):
            if depth < 3 and _has_non_real(x, depth + 1):
                return True
        elif isinstance(x, (bool, np.bool_, complex, np.complexfloating, str, bytes)):
            return True
    return False


def as_real_array(value: ArrayLike, name: str) -> np.ndarray:
    """``value`` as a float64 array; TypeError for booleans, complex numbers, strings and other non-numbers."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be real numbers, got a string {show(value)}")
    if isinstance(value, (list, tuple)) and _has_non_real(value):
        raise TypeError(f"{name} must be real numbers, got {show(value)}")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):
        raise TypeError(f"{name} must be an array of real numbers, got {show(value)}") from None
    if arr.dtype.kind == "O":
        if any(isinstance(x, (bool, np.bool_, complex, str, bytes)) or not isinstance(x, (int, float, np.number))
               for x in arr.ravel()):
            raise TypeError(f"{name} must be real numbers, got {show(value)}")
        try:
            arr = arr.astype(float)
        except OverflowError:
            raise ValueError(f"{name}: a number too large for a float (at most about 1.8e308) in "
                             f"{show(value)}") from None
    if arr.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "strings"}.get(arr.dtype.kind,
                                                                                            arr.dtype.name)
        raise TypeError(f"{name} must be real numbers, got {kind}: {show(value)}")
    return np.array(arr, dtype=float, order="C")


def parse_numbers(text: str, name: str, count: int | None = None) -> np.ndarray:
    """Comma-separated finite numbers, e.g. ``0.1,0.1,-0.1``: no empty fields, no ``1_0``, nothing else."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"{name}: expected comma-separated numbers, got {show(text)}")
    fields = [f.strip() for f in text.split(",")]
    for k, f in enumerate(fields, 1):
        if f == "":
            raise ValueError(f"{name}: value {k} of {len(fields)} is empty in {show(text)}")
        if _NONFINITE.match(f):
            raise ValueError(f"{name}: value {k} is {show(f)}; values must be finite")
        if not _NUMBER.match(f):
            raise ValueError(f"{name}: value {k} is not a number: {show(f)}")
    if count is not None and len(fields) != count:
        raise ValueError(f"{name}: expected {count} comma-separated numbers, got {len(fields)}")
    vals = np.array([float(f) for f in fields])
    if not np.all(np.isfinite(vals)):  # e.g. 1e999
        raise ValueError(f"{name}: values must be finite, got {show(text)}")
    return vals


def show_numbers(value: object, limit: int = 8) -> str:
    """Numbers for a message: ``[0, 1e+200, -0.5]`` (``%g``, at most ``limit`` of them; not an array's repr);
    anything else as :func:`show` shows it."""
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        return show(value)
    more = ", ..." if arr.size > limit else ""
    return "[" + ", ".join(f"{x:g}" for x in arr[:limit]) + more + "]"


def _named_error(name: str, text: str) -> ValueError:
    """A :class:`SettingsError` for the field ``name`` (a ValueError naming it when it is no identifier)."""
    if name.replace(".", "_").isidentifier():
        return SettingsError(name, text)
    return ValueError(f"{name}{text}")


def check_real(value: object, name: str, lo: float | None, hi: float | None, unit: str, reason: str = "", *,
               lo_open: bool = False, hi_open: bool = False) -> float:
    """The safe-range rule for a scalar: ``value`` (a real number, not a bool or a string) as a finite float in
    the interval (:func:`in_range`'s words, with ``unit`` and the ``reason`` of the range), ``-0.0`` as ``0.0``.

    Raises TypeError for a non-number, :class:`SettingsError` (a ValueError) naming ``name``, the value and the
    allowed range otherwise (also for an integer too large for a float).
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {show(value)} ({type(value).__name__})")
    check = in_range(lo, hi, unit, reason, lo_open=lo_open, hi_open=hi_open)
    try:
        x = float(value)
    except OverflowError:  # an int beyond 1.8e308
        x = math.inf if value > 0 else -math.inf
    try:
        check(x)
    except ValueError as err:
        shown = show(value) if is_integer(value) else show_number(x, *(b for b in (lo, hi) if b is not None))
        raise _named_error(name, f" = {shown}: {err}") from None
    return x + 0.0


def finite_real(value: object) -> float | None:
    """``value`` as a finite float by :func:`check_real`'s rule (a real number, not a bool, not NaN or infinite,
    not an integer too large for a float), ``-0.0`` as ``0.0``; None for anything else. For input that is
    answered without an exception (a web request's field, a record read back), whose caller words the refusal."""
    try:
        return check_real(value, "value", None, None, "")
    except (TypeError, ValueError):
        return None


def check_real_vector(value: ArrayLike, name: str, size: int = 3, limit: float = MAX_FORCE_N, unit: str = "",
                      reason: str = "") -> np.ndarray:
    """The safe-range rule for a vector: ``value`` as a finite float64 array of shape (size,), each component
    within +/- ``limit`` (in ``unit``, for ``reason``), ``-0.0`` as ``0.0``.

    Raises TypeError for booleans, complex numbers or strings, ValueError (beginning with ``name``) for a wrong
    shape or value.
    """
    arr = as_real_array(value, name)
    if arr.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {show_numbers(value)}")
    if np.any(np.abs(arr) > limit):
        raise ValueError(f"{name} must be within +/-{limit:g}{f' {unit}' if unit else ''} in each component"
                         f"{f' ({reason})' if reason else ''}, got {show_numbers(arr)}")
    return arr + 0.0


def check_positions(value: ArrayLike, name: str, *, single: bool = False) -> np.ndarray:
    """The safe-range rule for positions: ``value`` as K >= 1 rows of 3 coordinates [m] (base frame), shape
    (K, 3), or one position, shape (3,), when ``single``; each coordinate finite and within
    +/- :data:`MAX_POSITION_M` (no robot reaches farther), ``-0.0`` as ``0.0``.

    Raises TypeError for booleans, complex numbers, strings; :class:`SettingsError` naming ``name`` otherwise.
    """
    try:
        arr = as_real_array(value, name)
    except ValueError:  # an integer too large for a float
        arr = np.full((1, 3), np.inf)
    if single:
        arr = arr.reshape(-1)
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise _named_error(name, f": give 3 finite numbers [m], got {show_numbers(value)}")
    elif arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0 or not np.all(np.isfinite(arr)):
        raise _named_error(name, f": give K >= 1 rows of 3 finite numbers [m], got shape {np.shape(value)}")
    if np.any(np.abs(arr) > MAX_POSITION_M):
        bad = np.argwhere(np.abs(arr) > MAX_POSITION_M)[0]
        where = "" if single else f" (row {bad[0] + 1})"
        raise _named_error(name, f"{where}: each coordinate must be within +/-{MAX_POSITION_M:g} m (no robot "
                           f"reaches farther: at most 100 segments of at most 10 m), got "
                           f"{show_numbers(arr if single else arr[bad[0]])}")
    return arr + 0.0


#: a row whose largest |component| lies strictly between these has a length whose square neither over- nor
#: underflows: it is divided by ``np.linalg.norm`` as it always was (the same bits for every ordinary direction)
PLAIN_SCALE = (1e-150, 1e150)


def _plain_rows(arr: np.ndarray) -> np.ndarray:
    """Which rows of ``arr`` (K, n) have their largest |component| inside :data:`PLAIN_SCALE`, shape (K,)."""
    big = np.max(np.abs(arr), axis=1)
    return (big > PLAIN_SCALE[0]) & (big < PLAIN_SCALE[1])


def _scaled_rows(arr: np.ndarray) -> np.ndarray:
    """Each row of the finite ``arr`` (K, n) (every row's largest |component| at least :data:`MIN_DIRECTION`)
    divided by its length, computed without overflow or underflow: scaled by its largest |component| first."""
    scaled = arr / np.max(np.abs(arr), axis=1, keepdims=True)
    return scaled / np.sqrt(np.sum(scaled * scaled, axis=1, keepdims=True)) + 0.0


def _refuse_non_directions(arr: np.ndarray, name: str, size: int) -> None:
    """Raise naming ``name`` unless ``arr`` is K >= 1 rows of ``size`` finite numbers, each with a direction."""
    if arr.ndim != 2 or arr.shape[1] != size or arr.shape[0] == 0:
        raise _named_error(name, f": give rows of {size} numbers, got shape {arr.shape}")
    for k, row in enumerate(arr):
        where = f" (row {k + 1})" if arr.shape[0] > 1 else ""
        if not (np.all(np.isfinite(row)) and np.any(row)):
            raise _named_error(name, f"{where}: give {size} finite numbers, not all zero, got {show_numbers(row)}")
        if float(np.max(np.abs(row))) < MIN_DIRECTION:
            raise _named_error(name, f"{where}: give {size} finite numbers, not all zero nor all below "
                               f"{MIN_DIRECTION:.3g} in magnitude (there rounding loses the direction; its scale "
                               f"is free: write it larger), got {show_numbers(row)}")


def unit_vectors(value: ArrayLike, name: str, size: int = 3) -> np.ndarray:
    """The one rule for directions: each row of ``value`` (K, size), K >= 1, as a unit vector.

    A row whose largest |component| lies in :data:`PLAIN_SCALE` is divided by its length exactly as it always
    was, ``d / np.linalg.norm(d, axis=1, keepdims=True)`` (the same bits: the workspace's h(d) along the
    directions given). A direction's scale is free: outside that interval ``(1e200, 1e200, 0)`` is
    ``(1, 1, 0) / sqrt(2)`` (the row is scaled by its largest |component| before it is normalised, so no length
    overflows or underflows; ``-0.0`` written ``0.0`` there). Refused, with one line naming ``name``: a row
    that is zero or not finite, and a row whose components are all subnormal (below :data:`MIN_DIRECTION`:
    there too few bits are left for the direction to be the one written).

    Raises
    ------
    TypeError
        Booleans, complex numbers, strings.
    SettingsError
        A ValueError naming ``name``, the row and what is allowed.
    """
    arr = as_real_array(value, name)
    _refuse_non_directions(arr, name, size)
    plain = _plain_rows(arr)
    unit = np.empty_like(arr)
    unit[plain] = arr[plain] / np.linalg.norm(arr[plain], axis=1, keepdims=True)
    unit[~plain] = _scaled_rows(arr[~plain])
    return unit


def unit_vector(value: ArrayLike, name: str, size: int = 3) -> np.ndarray:
    """``value`` (size numbers) as a unit vector, shape (size,), by :func:`unit_vectors`' rule; inside
    :data:`PLAIN_SCALE` exactly ``v / np.linalg.norm(v)``, as a single vector always was (NumPy computes a
    vector's length by another sum than a stack's rows', which may differ in the last bit)."""
    arr = as_real_array(value, name).reshape(-1)
    if arr.shape != (size,):
        raise _named_error(name, f": give {size} finite numbers, not all zero, got {show_numbers(value)}")
    _refuse_non_directions(arr[None], name, size)
    if _plain_rows(arr[None])[0]:
        return arr / np.linalg.norm(arr)
    return _scaled_rows(arr[None])[0]


def direction_or_none(value: ArrayLike, name: str, size: int = 3) -> np.ndarray | None:
    """The direction of a vector that may be too small to have one (a load to draw as an arrow, a gravity): its
    unit vector (:func:`unit_vector`), or None when every component is below :data:`MIN_DIRECTION` in magnitude
    (zero included) or one is not finite.

    Raises
    ------
    TypeError
        Booleans, complex numbers, strings.
    SettingsError
        Not ``size`` numbers.
    """
    arr = as_real_array(value, name).reshape(-1)
    if arr.shape == (size,) and not (np.all(np.isfinite(arr)) and float(np.max(np.abs(arr))) >= MIN_DIRECTION):
        return None
    return unit_vector(arr, name, size)


def read_text_file(path: str | Path, what: str, limit: int = MAX_TEXT_FILE_BYTES) -> str:
    """The text of a small UTF-8 file; ValueError naming the file when it cannot be read, is too large or binary."""
    p = Path(path)
    try:
        if p.is_dir():
            raise ValueError(f"{what} {show_path(p)}: is a folder, not a file")
        if p.exists() and not p.is_file():  # a FIFO would block, a device never end
            raise ValueError(f"{what} {show_path(p)}: not a regular file")
        with open(p, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as err:
        raise ValueError(f"{what} {show_path(p)}: cannot read ({err.strerror or err})") from None
    if len(data) > limit:
        raise ValueError(f"{what} {show_path(p)}: larger than {limit:,} bytes; not a {what}")
    if b"\x00" in data:
        raise ValueError(f"{what} {show_path(p)}: a binary file, not a text {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{what} {show_path(p)}: not UTF-8 text") from None

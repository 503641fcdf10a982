"""Measurements to fit: per row the inputs (tensions and any known tip wrench) and what was measured (the tip's
position, optionally its axis and other disks' positions), each with its uncertainty.

A CSV file (:func:`read_measurements`) has a header and one row per measurement, in SI units:

============================  ========  =====================================================================
column                        unit      meaning
============================  ========  =====================================================================
``T1_N`` ... ``Tn_N``         N         each tendon's tension (>= 0; required for a tendon without ``DK_m``)
``D1_m`` ... ``Dn_m``         m         a tendon's pull-in, for a tendon driven by displacement (|D| <= length)
``tip_x_m``, ``_y_``, ``_z_``  m         the tip's measured position (required), in the measurement frame
``sigma_m``                   m         its standard uncertainty per axis (default 1 mm)
``force_x_N`` ...             N         a known tip force, base frame (default 0)
``moment_x_Nm`` ...           N m       a known tip moment, base frame (default 0)
``axis_x`` ...                -         the tip's measured axis (a unit vector; optional)
``sigma_axis_rad``            rad       its uncertainty per component (default 0.01)
``diskK_x_m`` ...             m         disk K's measured position (optional, 1 <= K <= N)
============================  ========  =====================================================================

Blank lines and lines starting with ``#`` are skipped. Every refusal names the row (1-based, counting neither the
header nor skipped lines) and the column.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..loads import MAX_TENSION
from ..robot import Robot
from ..validate import MAX_FORCE_N, MAX_MOMENT_NM, SettingsError

__all__ = ["DEFAULT_SIGMA_AXIS", "DEFAULT_SIGMA_M", "Measurements", "read_measurements"]

#: a tip position's uncertainty where the data give none [m]
DEFAULT_SIGMA_M = 1e-3
#: a tip axis component's uncertainty where the data give none [-]
DEFAULT_SIGMA_AXIS = 0.01
#: a position farther than this many robot lengths from the base is taken for a unit slip (millimetres)
_FAR = 3.0
_XYZ = ("x", "y", "z")
_DISK = re.compile(r"^disk([0-9]+)_([xyz])_m$")


@dataclass(frozen=True, eq=False)
class Measurements:
    """Rows of measured poses and the inputs that produced them (B rows, n tendons).

    Attributes
    ----------
    tensions : ndarray, shape (B, n)
        Input tensions [N] (0 for a displacement-driven tendon).
    tip_force, tip_moment : ndarray, shape (B, 3)
        Known tip wrench [N], [N m], base frame.
    tip_position : ndarray, shape (B, 3)
        Measured tip position [m], measurement frame.
    sigma : ndarray, shape (B,)
        Its standard uncertainty per axis [m].
    tip_axis : ndarray, shape (B, 3), or None
        Measured tip axis (unit vectors).
    sigma_axis : ndarray, shape (B,), or None
    disks : tuple of (int, ndarray (B, 3))
        Other disks' measured positions [m], by disk number (1..N).
    displacements : ndarray, shape (B, n), or None
        Pull-ins of the displacement-driven tendons [m] (:func:`pytdcr.solve_displacements`), NaN for a
        tension-driven tendon; None when every tendon is driven by tension.
    source : str
        Where the rows came from (a file name, or ``"arrays"``).
    sha256 : str
        The hash of the file's bytes (of the arrays' bytes for arrays): a run records which data it fitted.
    """

    tensions: np.ndarray
    tip_force: np.ndarray
    tip_moment: np.ndarray
    tip_position: np.ndarray
    sigma: np.ndarray
    tip_axis: np.ndarray | None = None
    sigma_axis: np.ndarray | None = None
    disks: tuple[tuple[int, np.ndarray], ...] = ()
    displacements: np.ndarray | None = None
    source: str = "arrays"
    sha256: str = ""

    def __post_init__(self) -> None:
        for name in ("tensions", "tip_force", "tip_moment", "tip_position", "sigma", "tip_axis", "sigma_axis",
                     "displacements"):
            value = getattr(self, name)
            if value is not None:
                arr = np.array(value, dtype=float)
                arr.flags.writeable = False
                object.__setattr__(self, name, arr)
        if not self.sha256:
            h = hashlib.sha256()
            for arr in (self.tensions, self.tip_force, self.tip_moment, self.tip_position, self.sigma,
                        self.displacements):
                if arr is not None:
                    h.update(np.ascontiguousarray(arr).tobytes())
            object.__setattr__(self, "sha256", h.hexdigest())

    @property
    def n_rows(self) -> int:
        """B, the number of rows."""
        return int(self.tensions.shape[0])

    @classmethod
    def from_arrays(cls, robot: Robot, tensions: np.ndarray, tip_position: np.ndarray, *,
                    sigma: float | np.ndarray = DEFAULT_SIGMA_M, tip_force: np.ndarray | None = None,
                    tip_moment: np.ndarray | None = None, displacements: np.ndarray | None = None) -> Measurements:
        """Rows from arrays (B, n) [N] and (B, 3) [m], checked like a file's (SettingsError naming the row);
        ``displacements`` (B, n) [m] drives a tendon by its pull-in where its column is finite (the column must
        be finite in every row or in none; that tendon's tensions are then ignored)."""
        t = np.atleast_2d(np.asarray(tensions, dtype=float))
        b = t.shape[0]
        d = None if displacements is None else np.asarray(displacements, dtype=float).reshape(t.shape)
        driven = np.zeros(t.shape[1], bool) if d is None else ~np.isnan(d).all(axis=0)
        cols = {f"T{k + 1}_N": t[:, k] for k in range(t.shape[1]) if not driven[k]}
        cols.update({f"D{k + 1}_m": d[:, k] for k in np.flatnonzero(driven)} if d is not None else {})
        tips = np.asarray(tip_position, dtype=float).reshape(b, 3)
        cols.update({f"tip_{a}_m": tips[:, i] for i, a in enumerate(_XYZ)})
        cols["sigma_m"] = np.broadcast_to(np.asarray(sigma, dtype=float), (b,))
        for name, unit, value in (("force", "N", tip_force), ("moment", "Nm", tip_moment)):
            if value is not None:
                arr = np.broadcast_to(np.asarray(value, dtype=float), (b, 3))
                cols.update({f"{name}_{a}_{unit}": arr[:, i] for i, a in enumerate(_XYZ)})
        return _from_columns(robot, {k: np.asarray(v, dtype=float) for k, v in cols.items()}, "arrays", "")

    def subset(self, rows: np.ndarray) -> Measurements:
        """The rows ``rows`` (indices or a mask), in order."""
        def pick(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[rows]

        return Measurements(self.tensions[rows], self.tip_force[rows], self.tip_moment[rows], self.tip_position[rows],
                            self.sigma[rows], pick(self.tip_axis), pick(self.sigma_axis),
                            tuple((k, p[rows]) for k, p in self.disks), pick(self.displacements), self.source,
                            self.sha256 + f"[{len(self.sigma[rows])}]")


def _refuse(source: str, row: int | None, column: str, text: str) -> SettingsError:
    where = f"row {row + 1}, " if row is not None else ""
    return SettingsError("data", f" ({source}): {where}column {column}: {text}")


def _numbers(source: str, header: list[str], rows: list[list[str]]) -> dict[str, np.ndarray]:
    """The cells as floats by column, refusing a text, NaN or infinite cell by row and column."""
    out = {name: np.empty(len(rows)) for name in header}
    for r, row in enumerate(rows):
        if len(row) != len(header):
            raise SettingsError("data", f" ({source}): row {r + 1} has {len(row)} cells, the header {len(header)}")
        for name, cell in zip(header, row, strict=True):
            try:
                value = float(cell)
            except ValueError:
                raise _refuse(source, r, name, f"{cell.strip()!r} is not a number") from None
            if not math.isfinite(value):
                raise _refuse(source, r, name, f"{cell.strip()} is not a finite number (drop the row, or the "
                                               "column where nothing was measured)")
            out[name][r] = value
    return out


def _column(cols: dict[str, np.ndarray], name: str, b: int, default: float | None, source: str) -> np.ndarray:
    if name in cols:
        return cols[name]
    if default is None:
        raise _refuse(source, None, name, "missing (it is required)")
    return np.full(b, default)


def _check_range(source: str, cols: dict[str, np.ndarray], name: str, lo: float, hi: float, why: str) -> None:
    if name not in cols:
        return
    bad = np.flatnonzero((cols[name] < lo) | (cols[name] > hi))
    if bad.size:
        r = int(bad[0])
        raise _refuse(source, r, name, f"{cols[name][r]:g} must be in [{lo:g}, {hi:g}] ({why})")


def _check_positions(source: str, cols: dict[str, np.ndarray], robot: Robot) -> None:
    """Refuse a position column beyond :data:`_FAR` robot lengths: the mark of millimetres in a metres column."""
    far = _FAR * robot.length
    for name, values in cols.items():
        if name.endswith("_m") and name != "sigma_m" and (name.startswith("tip_") or _DISK.match(name)):
            bad = np.flatnonzero(np.abs(values) > far)
            if bad.size:
                r = int(bad[0])
                raise _refuse(source, r, name, f"{values[r]:g} m is beyond {_FAR:g} robot lengths ({far:g} m) from "
                                               "the base: is this column in millimetres? Positions are in metres")


def _known_columns(robot: Robot) -> set[str]:
    n = robot.n_tendons
    known = {f"T{k}_N" for k in range(1, n + 1)} | {f"D{k}_m" for k in range(1, n + 1)}
    known |= {"sigma_m", "sigma_axis_rad"}
    for a in _XYZ:
        known |= {f"tip_{a}_m", f"force_{a}_N", f"moment_{a}_Nm", f"axis_{a}"}
    return known


def _from_columns(robot: Robot, cols: dict[str, np.ndarray], source: str, sha: str) -> Measurements:
    known = _known_columns(robot)
    for name in cols:
        hit = _DISK.match(name)
        if name not in known and not (hit and 1 <= int(hit.group(1)) <= robot.n_disks):
            hint = (f" (disks are 1 to {robot.n_disks})" if hit else
                    "; give a pull-in as DK_m" if name.startswith("pulled_in") else "")
            n = robot.n_tendons
            raise _refuse(source, None, name, f"unknown{hint}; known columns: T1_N..T{n}_N, D1_m..D{n}_m, "
                                              "tip_[xyz]_m, sigma_m, force_[xyz]_N, moment_[xyz]_Nm, axis_[xyz], "
                                              "sigma_axis_rad, diskK_[xyz]_m")
    b = len(next(iter(cols.values()))) if cols else 0
    if b == 0:
        raise SettingsError("data", f" ({source}): no rows")
    for name, values in cols.items():  # a file's cells are checked as read; arrays' here
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            why = " (a tendon driven by its pull-in in one row is driven so in every row)" if name[0] == "D" else ""
            raise _refuse(source, int(bad[0]), name, f"{values[bad[0]]} is not a finite number{why}")
    _check_positions(source, cols, robot)
    for k in range(1, robot.n_tendons + 1):
        if f"D{k}_m" in cols and f"T{k}_N" in cols:
            raise _refuse(source, None, f"D{k}_m", f"tendon {k} has both a tension (T{k}_N) and a pull-in: drive it "
                                                   "by one of them")
        if f"D{k}_m" in cols:
            _check_range(source, cols, f"D{k}_m", -robot.length, robot.length, "a pull-in within the robot's length")
            continue
        _check_range(source, cols, f"T{k}_N", 0.0, MAX_TENSION, "a tension is >= 0 N")
        _column(cols, f"T{k}_N", b, None, source)
    for a in _XYZ:
        _check_range(source, cols, f"force_{a}_N", -MAX_FORCE_N, MAX_FORCE_N, "a force on a tendon-driven robot")
        _check_range(source, cols, f"moment_{a}_Nm", -MAX_MOMENT_NM, MAX_MOMENT_NM, "a moment on such a robot")
    _check_range(source, cols, "sigma_m", 1e-9, 1.0, "an uncertainty from a nanometre to a metre")
    _check_range(source, cols, "sigma_axis_rad", 1e-9, 2.0, "an uncertainty of a unit vector's component")
    def stack(fmt: str, default: float | None) -> np.ndarray:
        return np.column_stack([_column(cols, fmt.format(a), b, default, source) for a in _XYZ])

    axis = None
    if any(f"axis_{a}" in cols for a in _XYZ):
        axis = stack("axis_{}", None)
        norms = np.linalg.norm(axis, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 0.05)
        if bad.size:
            raise _refuse(source, int(bad[0]), "axis_x", f"the axis has length {norms[bad[0]]:.3g}; give a unit vector")
        axis = axis / norms[:, None]
    disks = sorted({int(h.group(1)) for h in map(_DISK.match, cols) if h})
    n = robot.n_tendons
    driven = [f"D{k}_m" in cols for k in range(1, n + 1)]
    return Measurements(
        tensions=np.column_stack([np.zeros(b) if driven[k - 1] else cols[f"T{k}_N"] for k in range(1, n + 1)]),
        tip_force=stack("force_{}_N", 0.0), tip_moment=stack("moment_{}_Nm", 0.0),
        tip_position=stack("tip_{}_m", None), sigma=_column(cols, "sigma_m", b, DEFAULT_SIGMA_M, source),
        tip_axis=axis,
        sigma_axis=None if axis is None else _column(cols, "sigma_axis_rad", b, DEFAULT_SIGMA_AXIS, source),
        disks=tuple((k, stack(f"disk{k}_{{}}_m", None)) for k in disks), source=source, sha256=sha,
        displacements=np.column_stack([cols[f"D{k}_m"] if driven[k - 1] else np.full(b, np.nan)
                                       for k in range(1, n + 1)]) if any(driven) else None)


def read_measurements(path: str | Path, robot: Robot) -> Measurements:
    """The measurements in the CSV file ``path`` for ``robot`` (the module's columns); SettingsError naming the
    row and the column of the first bad cell: text or NaN, a negative tension, a position beyond three robot
    lengths (millimetres in a metres column), an unknown column, a missing required one."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        why = err.strerror if isinstance(err, OSError) and err.strerror else "not a UTF-8 text file"
        raise SettingsError("data", f" ({path.name}): cannot be read: {why}") from None
    lines = [row for row in csv.reader(text.splitlines())
             if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")]
    if not lines:
        raise SettingsError("data", f" ({path.name}): empty; give a header and one row per measurement")
    header = [h.strip() for h in lines[0]]
    if "" in header:
        raise SettingsError("data", f" ({path.name}): the header has a column without a name (column "
                                    f"{header.index('') + 1}: a trailing comma?)")
    for name in header:
        if header.count(name) > 1:
            raise _refuse(path.name, None, name, "appears twice in the header")
    cols = _numbers(path.name, header, lines[1:])
    return _from_columns(robot, cols, path.name, hashlib.sha256(raw).hexdigest())

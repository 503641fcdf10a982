"""Loads applied to a robot: actuator tensions and external wrenches."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from .robot import MAX_DISKS_PER_SEGMENT, MAX_SEGMENTS
from .validate import MAX_FORCE_N, as_real_array, check_real, check_real_vector, is_integer, show, show_number

__all__ = ["MAX_TENSION", "Loads", "PointLoad", "check_tensions", "check_vector"]

#: the largest actuator tension accepted [N]
MAX_TENSION = 1e4
#: the most disks any robot has (a point load's disk is at most this)
MAX_DISKS = MAX_SEGMENTS * MAX_DISKS_PER_SEGMENT


def check_vector(value: ArrayLike, name: str, size: int = 3, limit: float = MAX_FORCE_N,
                 unit: str | None = None) -> np.ndarray:
    """``value`` as a finite float64 array of shape (size,) with entries within +/- ``limit`` (``-0.0`` as 0.0):
    the safe-range rule of :func:`pytdcr.validate.check_real_vector` for a force [N] or, when ``name`` says
    so (or ``unit`` is ``"N m"``), a moment [N m].

    Raises TypeError for booleans, complex numbers or strings, ValueError for a wrong shape or value.
    """
    if unit is None:
        unit = "N m" if "moment" in name else "N"
    return check_real_vector(value, name, size, limit, unit, "far beyond any load on a tendon-driven robot")


def check_tensions(value: ArrayLike, n_tendons: int | None = None, name: str = "tensions") -> np.ndarray:
    """The one tension validator: ``value`` as float64, finite and >= 0 [N].

    Parameters
    ----------
    value : array-like, shape (n_tendons,) or (B, n_tendons)
        One tension vector or one per row.
    n_tendons : int, optional
        Required length of each vector.
    name : str
        Name used in the error message.

    Returns
    -------
    ndarray
        A new, C-ordered float64 array of the same shape.

    Raises
    ------
    ValueError
        Naming the first offending entry, its value and the allowed range, or
        the shape that arrived.
    """
    arr = as_real_array(value, name)
    if arr.ndim not in (1, 2):
        raise ValueError(f"{name} must be a 1-D array (one per tendon) or 2-D (one row per case), "
                         f"got shape {arr.shape}")
    if n_tendons is not None and arr.shape[-1] != n_tendons:
        want = f"({n_tendons},)" if arr.ndim == 1 else f"(B, {n_tendons})"
        raise ValueError(f"{name} must have shape {want} (one per tendon), got shape {arr.shape}")
    for bad, rule in ((~np.isfinite(arr) | (arr < 0), "must be finite and >= 0 N"),
                      (arr > MAX_TENSION, f"must be at most {MAX_TENSION:g} N (a tendon, not a crane cable)")):
        if np.any(bad):
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            where = ", ".join(str(i) for i in idx)
            which = f"tendon {idx[-1] + 1}" if arr.ndim == 1 else f"case {idx[0] + 1}, tendon {idx[1] + 1}"
            raise ValueError(f"{name}[{where}] ({which}) {rule}, got {show_number(arr[idx], 0.0, MAX_TENSION)}")
    return arr + 0.0  # -0.0 as 0.0


def _frozen(arr: np.ndarray) -> np.ndarray:
    """``arr`` (a fresh array) made read-only: a validated object cannot be changed behind its checks."""
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class PointLoad:
    """A force and moment on disk ``disk`` (1-based; N is the tip), in the base frame.

    Parameters
    ----------
    disk : int
        Disk index, 1..N.
    force : array-like, shape (3,)
        Force in the base frame [N], acting at the disk's centre.
    moment : array-like, shape (3,)
        Moment in the base frame [N m].
    """

    disk: int
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    moment: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        if not is_integer(self.disk) or not 1 <= self.disk <= MAX_DISKS:
            raise ValueError(f"point load disk must be an integer >= 1 and <= {MAX_DISKS:,} (no robot has more "
                             f"disks), got {show(self.disk)}")
        object.__setattr__(self, "disk", int(self.disk))
        object.__setattr__(self, "force", _frozen(check_vector(self.force, "point load force")))
        object.__setattr__(self, "moment", _frozen(check_vector(self.moment, "point load moment")))


@dataclass(frozen=True)
class Loads:
    """Actuation and external loads for one static solve.

    Parameters
    ----------
    tensions : array-like, shape (n_tendons,), optional
        Actuator tension of each tendon [N], finite and >= 0. None (the default): none given, stored as an empty
        array: a solve takes every tendon slack (0 N), and where the tensions are chosen (sampling, searches,
        inverse statics) nothing is lost (``Loads(tip_force=...)`` describes the external loads alone).
    tip_force : array-like, shape (3,)
        External force at the tip in the base frame [N].
    tip_moment : array-like, shape (3,)
        External moment at the tip in the base frame [N m].
    point_loads : tuple of PointLoad
        Further wrenches on any disk (base frame).
    release : bool
        Friction direction: False (default) when the actuators pull (tension
        drops towards the tip), True when they release (it rises).
    """

    tensions: np.ndarray | None = None
    tip_force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tip_moment: np.ndarray = field(default_factory=lambda: np.zeros(3))
    point_loads: tuple[PointLoad, ...] = ()
    release: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.release, (bool, np.bool_)):
            raise TypeError(f"release must be True or False, got {show(self.release)}")
        t = np.zeros(0) if self.tensions is None else check_tensions(self.tensions)
        if t.ndim != 1:
            raise ValueError(f"tensions must be a 1-D array (one per tendon), got shape {t.shape}")
        object.__setattr__(self, "tensions", _frozen(t))
        object.__setattr__(self, "tip_force", _frozen(check_vector(self.tip_force, "tip_force")))
        object.__setattr__(self, "tip_moment", _frozen(check_vector(self.tip_moment, "tip_moment")))
        object.__setattr__(self, "point_loads", tuple(self.point_loads))
        for p in self.point_loads:
            if not isinstance(p, PointLoad):
                raise TypeError(f"point_loads must hold PointLoad objects, got {type(p).__name__}")

    def scaled(self, factor: float) -> Loads:
        """Every load here (tensions, tip wrench, point wrenches) times ``factor`` in [0, 1]: a point of the
        loading path.

        Gravity belongs to the robot (:meth:`pytdcr.Robot.with_gravity`).
        """
        f = check_real(factor, "factor", 0.0, 1.0, "", "a point of the loading path: from no load to the full one")
        points = tuple(PointLoad(p.disk, p.force * f, p.moment * f) for p in self.point_loads)
        return Loads(self.tensions * f, self.tip_force * f, self.tip_moment * f, points, self.release)

    def tensions_for(self, n_tendons: int) -> np.ndarray:
        """The actuator tensions for a robot of ``n_tendons`` tendons [N]: those given, or zeros where none were
        (shape (n_tendons,) either way when given for such a robot)."""
        return np.zeros(n_tendons) if self.tensions.size == 0 else self.tensions

    def with_tensions(self, tensions: np.ndarray) -> Loads:
        """The same external loads and friction direction with other actuator tensions [N]."""
        return Loads(tensions, self.tip_force, self.tip_moment, self.point_loads, self.release)

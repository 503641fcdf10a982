"""The groups of settings the runs share, declared once: :class:`RobotSpec` (which robot, its gravity and
friction), :class:`LoadSpec` (the tip wrench and the friction direction), :class:`ModelSpec` (the static model
and its options) and :class:`BoundsSpec` (the tension box).

Each is a frozen dataclass whose fields hold the defaults; ``__post_init__`` checks every field and raises
:class:`~pytdcr.validate.SettingsError` (a ValueError) naming the field, the value and the allowed range. What
needs the robot (a file's tendon count, the model's capabilities) is checked when the spec is built against
it, still before any work.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..bounds import TensionBounds
from ..io import load_robot, read_toml
from ..loads import Loads, PointLoad, check_vector
from ..paper import DEFAULT_BOUNDS
from ..robot import ConstantFriction, ExponentialFriction, NoFriction, Robot
from ..statics import Model, ModelOptions, configure, get_model, get_models, resolve
from ..validate import MAX_SEED, SettingsError, as_real_array, check_count, show, show_path

__all__ = ["MAX_FRICTION", "BoundsSpec", "LoadSpec", "ModelSpec", "RobotSpec", "RunInputs",
           "check_flag", "check_seed", "check_type", "count_setting"]

#: the largest constant friction coefficient accepted
MAX_FRICTION = 10.0
#: friction laws by name (``RobotSpec.friction``)
FRICTION_LAWS = {"none": NoFriction, "paper": ExponentialFriction}


def count_setting(value: object, name: str, lo: int = 1, hi: int | None = None) -> int:
    """``value`` as an int in [lo, hi] (:func:`pytdcr.validate.check_count`), a :class:`SettingsError` naming
    ``name`` when out of range."""
    try:
        return check_count(value, name, lo, hi)
    except ValueError as err:
        raise SettingsError.about(name, err) from None


def check_seed(seed: object) -> int:
    """A random seed: an integer in [0, :data:`MAX_SEED`]."""
    return count_setting(seed, "seed", 0, MAX_SEED)


def check_flag(value: object, name: str) -> bool:
    """``value`` as a bool (NumPy's too); TypeError for anything else."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {show(value)}")
    return bool(value)


def check_type(value: object, kind: type, name: str) -> None:
    """TypeError unless ``value`` is a ``kind`` (one of the settings' groups, say)."""
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be a pytdcr.runs.{kind.__name__}, got {type(value).__name__}")


@dataclass(frozen=True)
class RobotSpec:
    """Which robot, and what of its own to override.

    Attributes
    ----------
    robot : str, Path or Robot
        A built-in robot (``paper``, ``rao``), a robot TOML file, or a :class:`~pytdcr.Robot`.
    gravity : bool or None
        True: -9.81 m/s^2 along base z; False: no gravity; None: the robot's own.
    friction : str, float or None
        ``"none"``, ``"paper"`` (mu = 0.689 exp(-0.027 sigma_deg)) or a constant mu in [0, 10]; None: the
        robot's own law.
    """

    robot: str | Path | Robot = "paper"
    gravity: bool | None = None
    friction: str | float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.robot, (str, Path, Robot)):
            raise TypeError(f"robot must be a built-in robot's name, a TOML file or a pytdcr.Robot, got "
                            f"{type(self.robot).__name__}")
        if self.gravity is not None:
            object.__setattr__(self, "gravity", check_flag(self.gravity, "gravity"))
        f = self.friction
        if isinstance(f, str):
            if f.strip().lower() not in FRICTION_LAWS:
                raise SettingsError("friction", f": expected 'none', 'paper' or a constant mu in [0, "
                                    f"{MAX_FRICTION:g}], got {show(f)}")
            object.__setattr__(self, "friction", f.strip().lower())
        elif f is not None:
            if isinstance(f, (bool, np.bool_)) or not isinstance(f, numbers.Real):
                raise TypeError(f"friction must be a law's name or a real number, got {show(f)}")
            mu = float(f)
            if not 0.0 <= mu <= MAX_FRICTION:
                raise SettingsError("friction", f": constant mu must be in [0, {MAX_FRICTION:g}], got {mu}")
            object.__setattr__(self, "friction", mu)

    @property
    def explicit_friction(self) -> bool:
        """A friction law other than none was asked for."""
        return self.friction is not None and self.friction != "none"

    def build(self) -> Robot:
        """The robot (:class:`~pytdcr.io.RobotFileError` for a bad file), with the gravity and friction asked."""
        robot = self.robot if isinstance(self.robot, Robot) else load_robot(str(self.robot))
        if self.gravity is True:
            robot = robot.with_gravity((0.0, 0.0, -9.81))
        elif self.gravity is False:
            robot = robot.with_gravity(None)
        if isinstance(self.friction, str):
            robot = robot.with_friction(FRICTION_LAWS[self.friction]())
        elif self.friction is not None:
            robot = robot.with_friction(ConstantFriction(mu=self.friction))
        return robot


@dataclass(frozen=True)
class LoadSpec:
    """The external loads: a tip wrench, wrenches on any disks, and the friction direction (the tensions come
    from the run).

    Attributes
    ----------
    tip_force : 3 floats
        In the base frame [N], each within +/-1e6.
    tip_moment : 3 floats
        In the base frame [N m], each within +/-1e6.
    release : bool
        Friction for releasing actuators (default: pulling).
    disk_forces, disk_moments : tuple of (int, 3 floats)
        A force [N] or moment [N m] on a disk (1-based, N the tip; base frame, at the disk's centre), each
        within +/-1e6; a disk may appear more than once (they add up). The robot's disk count is checked when
        the loads are built.
    """

    tip_force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tip_moment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    release: bool = False
    disk_forces: tuple[tuple[int, tuple[float, float, float]], ...] = ()
    disk_moments: tuple[tuple[int, tuple[float, float, float]], ...] = ()

    def __post_init__(self) -> None:
        for name in ("tip_force", "tip_moment"):
            try:
                vector = check_vector(getattr(self, name), name)
            except ValueError as err:
                raise SettingsError.about(name, err) from None
            object.__setattr__(self, name, tuple(float(x) for x in vector))
        object.__setattr__(self, "release", check_flag(self.release, "release"))
        for name in ("disk_forces", "disk_moments"):
            object.__setattr__(self, name, tuple(_disk_wrench(item, name) for item in getattr(self, name)))

    @property
    def has_tip_wrench(self) -> bool:
        """A tip force or moment, or a wrench on a disk, is given."""
        return any(self.tip_force) or any(self.tip_moment) or bool(self.disk_forces) or bool(self.disk_moments)

    def build(self, robot: Robot) -> Loads:
        """The loads on ``robot``, its tensions zero (SettingsError for a disk the robot does not have)."""
        points = []
        for name, entries in (("disk_forces", self.disk_forces), ("disk_moments", self.disk_moments)):
            for disk, v in entries:
                if disk > robot.n_disks:
                    raise SettingsError(name, f" disk {disk}: robot '{robot.name}' has disks 1 to {robot.n_disks}")
                force, moment = (v, (0.0, 0.0, 0.0)) if name == "disk_forces" else ((0.0, 0.0, 0.0), v)
                points.append(PointLoad(disk, np.array(force), np.array(moment)))
        return Loads(np.zeros(robot.n_tendons), tip_force=np.array(self.tip_force),
                     tip_moment=np.array(self.tip_moment), point_loads=tuple(points), release=self.release)


def _disk_wrench(item: object, name: str) -> tuple[int, tuple[float, float, float]]:
    """A (disk >= 1, 3 finite numbers within +/-1e6) pair, checked (SettingsError naming ``name``)."""
    try:
        disk, vector = item
    except (TypeError, ValueError):
        raise SettingsError(name, f" = {show(item)}: each entry must be (disk, (x, y, z))") from None
    if isinstance(disk, bool) or not isinstance(disk, (int, np.integer)) or disk < 1:
        raise SettingsError(name, f": disk must be an integer >= 1, got {show(disk)}")
    try:
        v = check_vector(vector, name)
    except ValueError as err:
        raise SettingsError.about(name, err) from None
    return int(disk), (float(v[0]), float(v[1]), float(v[2]))


@dataclass(frozen=True)
class ModelSpec:
    """The static model, by its registered name, and its options.

    Attributes
    ----------
    name : str
        A registered model (:data:`pytdcr.statics.MODELS`).
    shear_extension : bool
        Let the backbone shear and stretch (models with that option).
    atol : float or None
        Convergence tolerance on max |residual| [N m], in [1e-14, 1e-4]; None: the model's default.
    """

    name: str = "pcc"
    shear_extension: bool = False
    atol: float | None = None

    def __post_init__(self) -> None:
        get_models([self.name], "model")
        object.__setattr__(self, "shear_extension", check_flag(self.shear_extension, "shear_extension"))
        self.options()

    @property
    def model(self) -> Model:
        """The registered model."""
        return get_model(self.name)

    def options(self) -> ModelOptions:
        """The model's default options with these overrides (SettingsError for an option it does not have)."""
        m = self.model
        overrides: dict[str, object] = {}
        if self.atol is not None:
            overrides["atol"] = self.atol
        if self.shear_extension:
            overrides["shear_extension"] = True
        known = {f.name for f in fields(m.options_type)}
        for key in overrides:
            if key not in known:
                raise SettingsError(key, f": model '{self.name}' has no such option")
        try:
            return configure(m, **overrides)
        except ValueError as err:  # an option's value out of its range: the option's own message, named
            key = next((k for k in overrides if str(err).startswith(k)), None)
            if key is None:
                raise
            raise SettingsError.about(key, err) from None

    def resolve(self, robot: Robot, loads: Loads | None = None) -> tuple[Model, ModelOptions]:
        """The model and its options, checked by the registry against ``robot`` and ``loads``
        (:func:`pytdcr.statics.resolve`)."""
        return resolve(self.model, robot, loads, self.options())


@dataclass(frozen=True)
class BoundsSpec:
    """The tension box: the same bounds for every tendon, one pair per tendon, or a TOML file.

    Attributes
    ----------
    lower, upper : float, sequence of float, or None
        [N], finite, 0 <= lower <= upper; a number for every tendon or one per tendon; None: 0 and 20 N.
    file : str, Path or None
        A TOML file with lists ``lower`` and ``upper``, one entry per tendon [N] (instead of lower and upper).
    """

    lower: float | tuple[float, ...] | None = None
    upper: float | tuple[float, ...] | None = None
    file: str | Path | None = None

    def __post_init__(self) -> None:
        if self.file is not None:
            if self.lower is not None or self.upper is not None:
                raise SettingsError("bounds_file", ": give either a bounds file or lower and upper bounds, not both")
            return
        for name in ("lower", "upper"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = as_real_array(value, f"bounds: {name}")
            if arr.ndim > 1 or arr.size == 0:
                raise SettingsError("bounds", f": {name} must be a number or one number per tendon, got {show(value)}")
            object.__setattr__(self, name, float(arr) if arr.ndim == 0 else tuple(float(x) for x in arr))
        self._box(1)

    def _box(self, n_tendons: int) -> TensionBounds:
        lo = np.atleast_1d(DEFAULT_BOUNDS[0] if self.lower is None else self.lower)
        hi = np.atleast_1d(DEFAULT_BOUNDS[1] if self.upper is None else self.upper)
        try:
            if lo.size == 1 and hi.size == 1:
                return TensionBounds.uniform(n_tendons, lo[0], hi[0])
            size = max(lo.size, hi.size)
            return TensionBounds(np.broadcast_to(lo, size) if lo.size == 1 else lo,
                                 np.broadcast_to(hi, size) if hi.size == 1 else hi)
        except ValueError as err:
            raise SettingsError.about("bounds", err) from None

    @property
    def field(self) -> str:
        """The setting the box comes from: ``bounds_file`` or ``bounds``."""
        return "bounds" if self.file is None else "bounds_file"

    def build(self, robot: Robot, varied: str = "") -> TensionBounds:
        """The bounds for ``robot``'s tendons (SettingsError naming ``bounds`` or ``bounds_file``, or ``robot``
        for a robot without tendons). ``varied``: what the run does with the tensions, said when every one is
        fixed (lower == upper), which it then refuses ("nothing to optimise"); empty: a fixed box is allowed."""
        if robot.n_tendons == 0:
            raise SettingsError("robot", f": robot '{robot.name}' has no tendons; a run over tension bounds needs at "
                                "least one")
        if self.file is not None:
            b = self._from_file(robot)
        else:
            b = self._box(robot.n_tendons)
            try:
                b.check_robot(robot)
            except ValueError as err:
                raise SettingsError.about("bounds", err) from None
        if varied and not np.any(b.free):
            where = f" {show_path(self.file)}" if self.file is not None else ""
            raise SettingsError(self.field, f"{where}: every tension is fixed (lower == upper); {varied}")
        return b

    def _from_file(self, robot: Robot) -> TensionBounds:
        nt = robot.n_tendons
        try:
            data = read_toml(self.file, "bounds_file")  # type: ignore[arg-type]
        except ValueError as err:
            raise SettingsError.about("bounds_file", err) from None
        unknown = set(data) - {"lower", "upper"}
        if unknown:
            raise SettingsError("bounds_file", f": unknown key(s) {show(sorted(unknown))}; allowed: lower, upper")
        if "lower" not in data or "upper" not in data:
            raise SettingsError("bounds_file", ": needs both 'lower' and 'upper' lists")
        try:
            lo = as_real_array(data["lower"], "bounds_file: lower").reshape(-1)
            hi = as_real_array(data["upper"], "bounds_file: upper").reshape(-1)
        except TypeError as err:
            raise SettingsError("bounds_file", f"{SettingsError.about('bounds_file', err).text}; 'lower' and "
                                "'upper' must be lists of numbers") from None
        except ValueError as err:
            raise SettingsError.about("bounds_file", err) from None
        if lo.size != nt or hi.size != nt:
            raise SettingsError("bounds_file", f": robot '{robot.name}' has {nt} tendons; lower has {lo.size} "
                                f"entries, upper {hi.size}")
        try:
            return TensionBounds(lo, hi)
        except ValueError as err:  # named after the file, not the --bounds option it stands in for
            text = str(err).removeprefix("bounds: ")
            raise SettingsError("bounds_file", f" {show_path(self.file)}: {text}") from None


@dataclass(frozen=True)
class RunInputs:
    """What a run's settings build: the robot, its external loads, the tension bounds and the resolved model.

    Attributes
    ----------
    robot : Robot
    loads : Loads
        External loads and friction direction (tensions zero).
    bounds : TensionBounds
    model : Model
    options : ModelOptions
        The model's options (its own options type).
    """

    robot: Robot
    loads: Loads
    bounds: TensionBounds
    model: Model
    options: ModelOptions


@dataclass(frozen=True)
class _Buildable:
    """Settings with the robot, loads, model and bounds groups, built by :meth:`build`."""

    robot: RobotSpec = field(default_factory=RobotSpec)
    loads: LoadSpec = field(default_factory=LoadSpec)
    model: ModelSpec = field(default_factory=ModelSpec)
    bounds: BoundsSpec = field(default_factory=BoundsSpec)

    def __post_init__(self) -> None:
        for name, kind in (("robot", RobotSpec), ("loads", LoadSpec), ("model", ModelSpec), ("bounds", BoundsSpec)):
            check_type(getattr(self, name), kind, name)

    #: what the run does with the tensions, when a box with every tension fixed is no run (:meth:`BoundsSpec.build`)
    varied: ClassVar[str] = ""

    def build(self, robot: Robot | None = None, loads: Loads | None = None,
              bounds: TensionBounds | None = None) -> RunInputs:
        """The run's inputs, each built from its spec unless given (in this order: robot, loads, bounds, then the
        model resolved against them)."""
        robot = robot if robot is not None else self.robot.build()
        loads = loads if loads is not None else self.loads.build(robot)
        bounds = bounds if bounds is not None else self.bounds.build(robot, self.varied)
        if not isinstance(bounds, TensionBounds):
            raise TypeError(f"bounds must be a pytdcr.TensionBounds, got {type(bounds).__name__}")
        model, options = self.model.resolve(robot, loads)
        return RunInputs(robot, loads, bounds, model, options)


"""Typed settings of each run (and of the ``tdcr`` command of the same name), the same for Python and the
command line.

Every setting is a frozen dataclass whose fields hold the defaults, with their ranges and units below;
``__post_init__`` checks each field and raises :class:`~pytdcr.validate.SettingsError` (a ValueError) naming the
field, the value and what is allowed, so that a Python caller and the command line accept exactly the same
inputs. The groups the runs share (:class:`RobotSpec`, :class:`LoadSpec`, :class:`ModelSpec`,
:class:`BoundsSpec`) are declared once, in :mod:`pytdcr.runs._specs`. :class:`ReproduceSettings` (the budget of
the paper's study) is in :mod:`pytdcr.runs._reproduce`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..accuracy import LoadGroup, default_groups
from ..compare import check_models
from ..loads import check_tensions
from ..optimize import MemeticGA, Termination
from ..records import JsonDict
from ..robot import Robot
from ..statics import MODELS, get_models
from ..validate import SettingsError, field_ref, is_integer, parse_numbers, read_text_file, show, show_path
from ._specs import (
    BoundsSpec,
    LoadSpec,
    ModelSpec,
    RobotSpec,
    _Buildable,
    check_flag,
    check_seed,
    check_type,
    count_setting,
)

__all__ = ["AccuracySettings", "CompareSettings", "OptimizeSettings", "SampleSettings", "SolveSettings",
           "read_cases", "read_targets"]


@dataclass(frozen=True)
class SolveSettings:
    """One static solve (``tdcr solve``).

    Attributes
    ----------
    tensions : sequence of float
        Actuator tension of each tendon [N], finite, in [0, 1e4]; one per tendon of the robot. Empty with
        ``displacements``: every tension-driven tendon at 0 N.
    robot, loads, model : RobotSpec, LoadSpec, ModelSpec
        The robot, its external loads and the static model.
    displacements : sequence of float or None, optional
        Drive tendons by displacement (:func:`pytdcr.solve_displacements`): per tendon its pull-in [m], within
        ±1 m, or None to drive it by its tension. None (the default): every tendon by tension.
    stiffness : sequence of float or None, optional
        The tendons' axial stiffness [N/m] (> 0, finite; None: inextensible): one value for every tendon or one
        per tendon. None (the default): inextensible. It sets the pull-ins reported and the tensions found.
    """

    tensions: tuple[float, ...]
    robot: RobotSpec = field(default_factory=RobotSpec)
    loads: LoadSpec = field(default_factory=LoadSpec)
    model: ModelSpec = field(default_factory=ModelSpec)
    displacements: tuple[float | None, ...] | None = None
    stiffness: tuple[float | None, ...] | None = None

    #: the largest pull-in or pay-out a displacement may ask [m]
    MAX_DISPLACEMENT: ClassVar[float] = 1.0

    def __post_init__(self) -> None:
        for name, kind in (("robot", RobotSpec), ("loads", LoadSpec), ("model", ModelSpec)):
            check_type(getattr(self, name), kind, name)
        try:
            t = check_tensions(self.tensions, name="tensions")
        except ValueError as err:
            raise SettingsError.about("tensions", err) from None
        if t.ndim != 1:
            raise SettingsError("tensions", f": give one tension per tendon, got shape {t.shape}")
        object.__setattr__(self, "tensions", tuple(float(x) for x in t))
        if self.displacements is not None:
            object.__setattr__(self, "displacements", _optional_values(
                self.displacements, "displacements", "m", -self.MAX_DISPLACEMENT, self.MAX_DISPLACEMENT))
            if all(v is None for v in self.displacements):
                raise SettingsError("displacements", ": give at least one tendon a displacement (None drives a "
                                    "tendon by its tension)")
        if self.stiffness is not None:
            object.__setattr__(self, "stiffness", _optional_values(self.stiffness, "stiffness", "N/m", 0.0, math.inf,
                                                                   open_low=True))

    def tensions_for(self, robot: Robot) -> np.ndarray:
        """The tensions, shape (n_tendons,) [N]; SettingsError unless there is one per tendon of ``robot``."""
        if robot.n_tendons == 0 and self.tensions:
            raise SettingsError("robot", f": robot '{robot.name}' has no tendons, so it takes no tensions (got "
                                f"{len(self.tensions)})")
        if not self.tensions and self.displacements is not None:
            return np.zeros(robot.n_tendons)
        if len(self.tensions) != robot.n_tendons:
            raise SettingsError("tensions", f": robot '{robot.name}' has {robot.n_tendons} tendons, got "
                                f"{len(self.tensions)} values")
        return np.array(self.tensions)

    def drive_for(self, robot: Robot) -> tuple[list[float | None] | None, list[float | None] | None]:
        """The displacements (one per tendon, None: by tension) and the stiffness (one per tendon, None:
        inextensible) for ``robot``; each None when not given. SettingsError naming the field unless each
        gives one value per tendon (the stiffness: or one for all)."""
        n = robot.n_tendons
        for name, values, one in (("displacements", self.displacements, False), ("stiffness", self.stiffness, True)):
            if values is not None and len(values) != n and not (one and len(values) == 1):
                raise SettingsError(name, f": robot '{robot.name}' has {n} tendons, got {len(values)} values"
                                    + (" (or give one for all)" if one else ""))
        stiffness = None if self.stiffness is None else list(self.stiffness) * (n if len(self.stiffness) == 1 else 1)
        return (None if self.displacements is None else list(self.displacements)), stiffness


def _optional_values(values: object, name: str, unit: str, low: float, high: float, *,
                     open_low: bool = False) -> tuple[float | None, ...]:
    """``values`` as a tuple of floats in [low, high] (``(low, high]`` with ``open_low``) or None; SettingsError
    naming ``name`` and the range otherwise."""
    if isinstance(values, str) or not hasattr(values, "__iter__"):
        raise SettingsError(name, f": give a sequence of numbers [{unit}] or None, got {show(values)}")
    out: list[float | None] = []
    for k, v in enumerate(values):  # type: ignore[union-attr]
        if v is None:
            out.append(None)
            continue
        x = float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan
        if not (low < x <= high if open_low else low <= x <= high) or not math.isfinite(x):
            bracket = "(" if open_low else "["
            raise SettingsError(name, f": value {k + 1} = {show(v)} must be a finite number in {bracket}{low:g}, "
                                f"{high:g}] {unit}")
        out.append(x)
    return tuple(out)


@dataclass(frozen=True)
class SampleSettings(_Buildable):
    """Random tension samples within the bounds (``tdcr sample``).

    Attributes
    ----------
    robot, loads, model, bounds : RobotSpec, LoadSpec, ModelSpec, BoundsSpec
    n : int
        Samples, >= 1.
    seed : int
        Random seed, in [0, 2**32 - 1].
    n_shapes : int
        Converged configurations drawn in Fig. 4, >= 0.
    """

    n: int = 100
    seed: int = 0
    n_shapes: int = 10

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "n", count_setting(self.n, "n"))
        object.__setattr__(self, "seed", check_seed(self.seed))
        object.__setattr__(self, "n_shapes", count_setting(self.n_shapes, "n_shapes", 0))


#: the settings' names of the GA's parameters, by the names :class:`MemeticGA` and :class:`Termination` use
_GA_FIELDS = {"pop_size": "pop", "tol": "tol", "window": "window", "max_gen": "max_gen"}


@dataclass(frozen=True)
class OptimizeSettings(_Buildable):
    """The reach search of the paper's Eq. 29 (``tdcr optimize``).

    Attributes
    ----------
    robot, loads, model, bounds : RobotSpec, LoadSpec, ModelSpec, BoundsSpec
    pop : int
        Population, >= 2.
    tol : float
        Stop when the best cost improves by less over ``window`` generations [1/m], finite and > 0.
    window, max_gen : int
        That window and the generation cap, >= 1.
    seed : int
        Random seed, in [0, 2**32 - 1].
    polish : bool
        The gradient polish of the GA's best.
    local_search : bool
        A gradient search on each new leader (the memetic GA); False: the plain GA.
    stable_only : bool
        An equilibrium that fails the static stability test is infeasible (models with the test).
    """

    pop: int = 50
    tol: float = 1e-6
    window: int = 5
    max_gen: int = 100
    seed: int = 0
    polish: bool = True
    local_search: bool = True
    stable_only: bool = False

    #: what the search does with the tensions (a box with every tension fixed is refused: :meth:`BoundsSpec.build`)
    varied: ClassVar[str] = "nothing to optimise"

    def __post_init__(self) -> None:
        super().__post_init__()
        try:
            self.algorithm()
            self.termination()
        except ValueError as err:
            name = str(err).split(" ", 1)[0]
            raise SettingsError(_GA_FIELDS.get(name, name), str(err)[len(name):]) from None
        object.__setattr__(self, "seed", check_seed(self.seed))
        for name in ("polish", "local_search", "stable_only"):
            object.__setattr__(self, name, check_flag(getattr(self, name), name))
        if self.stable_only and not self.model.model.capabilities.stability:
            tested = ", ".join(name for name, m in MODELS.items() if m.capabilities.stability)
            raise SettingsError("stable_only", f": model '{self.model.name}' has no static stability test, so no "
                                f"equilibrium can be refused as unstable (models with the test: {tested})")

    def algorithm(self) -> MemeticGA:
        """The memetic GA of these settings."""
        return MemeticGA(pop_size=self.pop, local_search=self.local_search, polish=self.polish)

    def termination(self) -> Termination:
        """When it stops."""
        return Termination(tol=self.tol, window=self.window, max_gen=self.max_gen)


@dataclass(frozen=True)
class CompareSettings:
    """Two or more models on the same cases (``tdcr compare``): the cases of a file, given, or ``n`` random
    tension vectors within ``bounds``.

    Attributes
    ----------
    robot, loads : RobotSpec, LoadSpec
    models : sequence of str
        Two or more distinct registered models; the first is the reference.
    shear_extension : bool
        Backbones shear and stretch (for the models with that option).
    cases : str, Path, array-like (B, n_tendons) or None
        A CSV file of tension vectors, one case per row [N] (:func:`read_cases`), or the tension vectors.
    n : int
        Random cases when no ``cases``, >= 1.
    bounds : BoundsSpec or None
        Their bounds (default: 0 to 20 N); not with ``cases``.
    seed : int
        Their random seed, in [0, 2**32 - 1].
    """

    robot: RobotSpec = field(default_factory=RobotSpec)
    loads: LoadSpec = field(default_factory=LoadSpec)
    models: tuple[str, ...] = ("pcc", "cosserat")
    shear_extension: bool = False
    cases: str | Path | np.ndarray | None = None
    n: int = 20
    bounds: BoundsSpec | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        check_type(self.robot, RobotSpec, "robot")
        check_type(self.loads, LoadSpec, "loads")
        if self.bounds is not None:
            check_type(self.bounds, BoundsSpec, "bounds")
        object.__setattr__(self, "models", tuple(m.name for m in check_models(tuple(self.models))))
        object.__setattr__(self, "shear_extension", check_flag(self.shear_extension, "shear_extension"))
        if self.cases is not None and self.bounds is not None:
            raise SettingsError("cases", f": give either {field_ref('cases')} or {field_ref('n')} with "
                                f"{field_ref('bounds')}, not both")
        if self.cases is not None and not isinstance(self.cases, (str, Path)):
            try:
                T = check_tensions(self.cases, name="cases")
            except ValueError as err:
                raise SettingsError.about("cases", err) from None
            if T.ndim != 2:
                raise SettingsError("cases", f": give one row of tensions per case, got shape {T.shape}")
            T.flags.writeable = False
            object.__setattr__(self, "cases", T)
        object.__setattr__(self, "n", count_setting(self.n, "n"))
        object.__setattr__(self, "seed", check_seed(self.seed))

    def model_specs(self) -> dict[str, ModelSpec]:
        """Each model's spec: ``shear_extension`` for those that have the option."""
        return {name: ModelSpec(name, shear_extension=self.shear_extension and _has_option(name, "shear_extension"))
                for name in self.models}

    def tensions(self, robot: Robot) -> tuple[np.ndarray, JsonDict]:
        """The cases, shape (B, n_tendons) [N], and what they are (a JSON-ready record of their source)."""
        if isinstance(self.cases, (str, Path)):
            return read_cases(self.cases, robot), {"cases": str(self.cases)}
        if self.cases is not None:
            return check_tensions(self.cases, robot.n_tendons, name="cases"), {
                "cases": f"{self.cases.shape[0]} given tension vectors"}
        bounds = (self.bounds or BoundsSpec()).build(robot)
        T = bounds.sample(self.n, np.random.default_rng(self.seed))
        return T, {"cases": f"{self.n} random within bounds, seed {self.seed}", "bounds": bounds.to_dict(),
                   "seed": self.seed}


def _has_option(model: str, option: str) -> bool:
    return option in get_models([model])[0].options_type.__dataclass_fields__


_NUMBER_FIELD = re.compile(r"[+-]?[\d.]+(?:[eE][+-]?\d+)?")


def _read_rows(path: str | Path, field: str, width: int, what: str) -> list[tuple[int, np.ndarray]]:
    """Rows of ``width`` finite numbers from a CSV file, with their line numbers: blank lines and ``#`` comments
    skipped; a first row with no number at all is a header; a row mixing numbers and words is an error, never a
    header; fields separated by commas only. SettingsError naming ``field``, the file and the line (``what``
    says what a line holds)."""
    try:
        lines = read_text_file(path, f"{field} file").splitlines()
    except ValueError as err:
        raise SettingsError.about(field, err) from None
    where = f" {show_path(path)}"
    rows: list[tuple[int, np.ndarray]] = []
    for k, line in enumerate(lines, 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        for sep in (";", "\t"):
            if sep in line and "," not in line:
                raise SettingsError(field, f"{where}: line {k}: values must be separated by commas, found "
                                    f"{show(sep)} in {show(line)}")
        fields = [f.strip() for f in line.split(",")]
        if not rows and all(not _NUMBER_FIELD.fullmatch(f) for f in fields):
            continue  # a header: no field is a number
        try:
            rows.append((k, parse_numbers(line, f"{field}{where}: line {k}", width)))
        except ValueError as err:
            raise SettingsError(field, f"{str(err)[len(field):]} ({what})") from None
    if not rows:
        raise SettingsError(field, f"{where}: no rows (each line: {what})")
    return rows


def read_cases(path: str | Path, robot: Robot) -> np.ndarray:
    """Tension vectors from a CSV file, shape (B, n_tendons) [N]: one row per case, one column per tendon
    (the file's rules: :func:`_read_rows`). SettingsError naming ``cases``, the file and the line."""
    what = f"robot '{robot.name}' has {robot.n_tendons} tendons"
    out = []
    for k, vals in _read_rows(path, "cases", robot.n_tendons, what):
        try:
            out.append(check_tensions(vals, robot.n_tendons, name=f"cases {show_path(path)}: line {k}: tensions"))
        except ValueError as err:
            raise SettingsError("cases", f"{str(err)[len('cases'):]} ({what})") from None
    return np.array(out, dtype=float)


def read_targets(path: str | Path) -> np.ndarray:
    """Tip targets from a CSV file, shape (K, 3) [m]: one row per target, ``x,y,z`` in the base frame (the
    file's rules: :func:`_read_rows`). SettingsError naming ``targets``, the file and the line."""
    return np.array([v for _, v in _read_rows(path, "targets", 3, "3 comma-separated coordinates x,y,z [m]")],
                    dtype=float)


@dataclass(frozen=True)
class AccuracySettings:
    """Which model to trust (``tdcr accuracy``): every model against ``sscr`` by load group, and the order study.

    Attributes
    ----------
    robot, bounds : RobotSpec, BoundsSpec
        The robot (the study sets its own load groups) and the bounds of the random tension vectors.
    n : int
        Random tension vectors, >= 1.
    seed : int
        Their random seed, in [0, 2**32 - 1].
    models : sequence of str or None
        Registered models to compare (None: every one).
    disks : sequence of int
        Disks per segment of the order study, each >= 1 (two or more different counts).
    order_cases : int
        Tension vectors of the order study, >= 0 (0: no order study).
    reference_steps : int
        Runge-Kutta steps per segment of the reference ``sscr``, >= 16.
    payload_g : float
        Payload of the last load group [g], in (0, 1000].
    """

    robot: RobotSpec = field(default_factory=RobotSpec)
    bounds: BoundsSpec = field(default_factory=BoundsSpec)
    n: int = 20
    seed: int = 0
    models: tuple[str, ...] | None = None
    disks: tuple[int, ...] = (5, 10, 20, 40)
    order_cases: int = 3
    reference_steps: int = 160
    payload_g: float = 10.0

    def __post_init__(self) -> None:
        check_type(self.robot, RobotSpec, "robot")
        check_type(self.bounds, BoundsSpec, "bounds")
        for name, lo in (("n", 1), ("order_cases", 0), ("reference_steps", 16)):
            object.__setattr__(self, name, count_setting(getattr(self, name), name, lo))
        p = self.payload_g
        real = not isinstance(p, bool) and isinstance(p, (int, float, np.number))
        if not (real and math.isfinite(p) and 0 < p <= 1000):
            raise SettingsError("payload_g", f" must be in (0, 1000] g, got {p}")
        object.__setattr__(self, "payload_g", float(p))
        if self.models is not None:
            object.__setattr__(self, "models", tuple(m.name for m in get_models(tuple(self.models))))
        disks = tuple(self.disks)
        if not all(is_integer(d) and d >= 1 for d in disks):
            raise SettingsError("disks", f": expected integers >= 1, got {show(list(disks))}")
        object.__setattr__(self, "disks", tuple(int(d) for d in disks))
        object.__setattr__(self, "seed", check_seed(self.seed))

    @property
    def order(self) -> bool:
        """The order study runs."""
        return self.order_cases > 0 and bool(self.disks)

    def groups(self) -> tuple[LoadGroup, ...]:
        """The load groups: tendons only, + gravity, + the paper's tip wrench, + the payload."""
        return default_groups(self.payload_g / 1e3)

    @property
    def steps(self) -> int:
        """Progress steps of the whole study: each group's reference and models, then the order study."""
        groups = len(self.groups())
        models = len(self.models) if self.models is not None else len(MODELS)
        return groups * (models + 1) + (len(self.disks) * groups if self.order_cases else 0)

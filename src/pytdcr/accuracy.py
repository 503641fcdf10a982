"""Which model to trust: every model against the subsegment Cosserat rod, by load group, and the order study.

The reference is ``sscr`` of the same robot with a fine integration between the
disks (``reference_steps`` Runge-Kutta steps per segment of the robot's most disks, at least 4 per
subsegment: :func:`reference_options`). Every registered
model solves the same tension vectors under cumulative load groups (tendons
only; + gravity; + the paper's tip wrench; + a payload); each model's tip error
is its distance from the reference's tip. A model that cannot honour a group
(e.g. the smeared Cosserat rod and tendon friction) is reported as unsupported,
with the reason, not dropped silently. The order study solves the same robot
with 5, 10, 20 and 40 disks per segment (same lengths, routing and total disk
mass) and fits the observed order of ``pcc`` and ``pcc2`` against ``sscr`` of
that same robot: the slope of log(error) against log(disk spacing).

The numbers of a study are one typed result, :class:`AccuracySummary` (an :class:`AccuracyRow` per model and
group, an :class:`OrderRecord` per order study, each with an :class:`OrderFit` per model), read by attribute;
JSON at one boundary: :meth:`AccuracySummary.to_json` is ``accuracy.json``'s ``summary``, key for key and in
order, and :meth:`AccuracySummary.from_json` reads it back (a missing key raises
:class:`~pytdcr.records.RecordKeyError` naming its path, ``rows[2].max_error_mm``). Non-finite numbers are
written null (strict JSON) and read back as NaN; a time may be absent (the golden baselines drop times): a
median time reads as NaN (not recorded), a wall time as 0.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from .loads import Loads, check_tensions
from .paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT, PAYLOAD_MASS, STANDARD_GRAVITY, payload_gravity
from .records import JsonDict, JsonObject, part
from .results import StaticSolution
from .robot import Robot
from .statics import (
    MODELS,
    Model,
    SSCROptions,
    UnsupportedFeatureError,
    check_resources,
    get_model,
    get_models,
    resolve,
)
from .validate import SettingsError

__all__ = ["AccuracyRow", "AccuracyStudy", "AccuracySummary", "LoadGroup", "ModelAccuracy", "OrderFit", "OrderRecord",
           "OrderStudy", "check_accuracy_plan", "default_groups", "model_accuracy", "order_study"]

#: the reference model
REFERENCE = "sscr"
#: the file these numbers are read from, as errors name them
_FILE = "accuracy.json"
_T = TypeVar("_T")


def _number(x: float | None) -> float:
    """A number of the file: null (a non-finite number, written strict) is NaN."""
    return float("nan") if x is None else float(x)


def _items(where: str, read: Callable[[JsonObject], _T], values: object) -> tuple[_T, ...]:
    """Each object of the JSON list ``values`` (at ``where``) read by ``read``; a missing key named with its
    index (``rows[2].max_error_mm``), ValueError for a list that is not one."""
    if not isinstance(values, list):
        raise ValueError(f"{_FILE}: {where} must be a JSON list, got {type(values).__name__}")
    return tuple(part(_FILE, f"{where}[{k}]", read, v) for k, v in enumerate(values))


@dataclass(frozen=True)
class LoadGroup:
    """External loads of one group (the tensions come from the study).

    Attributes
    ----------
    name : str
    gravity : bool
        Gravity on (the robot's own, or :data:`~pytdcr.paper.STANDARD_GRAVITY` if it has none) or off.
    tip_force, tip_moment : tuple of 3 floats
        Base frame [N], [N m].
    payload_kg : float
        A mass hanging at the tip [kg]: its weight along the robot's gravity
        (:func:`~pytdcr.paper.payload_gravity`) adds to ``tip_force``.
    """

    name: str
    gravity: bool
    tip_force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tip_moment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    payload_kg: float = 0.0

    def apply(self, robot: Robot) -> Robot:
        """The robot with this group's gravity."""
        if not self.gravity:
            return robot.with_gravity(None)
        if np.any(robot.gravity):
            return robot
        return robot.with_gravity(STANDARD_GRAVITY)

    def loads(self, tensions: np.ndarray, robot: Robot) -> Loads:
        """This group's loads with ``tensions`` [N] on ``robot`` (as :meth:`apply` made it: its gravity carries
        the payload)."""
        force = np.asarray(self.tip_force, dtype=float) + self.payload_kg * payload_gravity(robot)
        return Loads(tensions, tip_force=force, tip_moment=self.tip_moment)


def default_groups(payload_kg: float = 2 * PAYLOAD_MASS) -> tuple[LoadGroup, ...]:
    """Tendons only; + gravity; + the paper's tip wrench; + a payload of ``payload_kg`` instead of the wrench."""
    return (
        LoadGroup("tendons", gravity=False),
        LoadGroup("+gravity", gravity=True),
        LoadGroup("+tip wrench", gravity=True, tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT),
        LoadGroup(f"+payload {payload_kg * 1e3:g} g", gravity=True, payload_kg=payload_kg),
    )


def reference_options(per_segment: int, steps_per_segment: int = 160) -> SSCROptions:
    """The reference's options: about ``steps_per_segment`` Runge-Kutta steps over each segment (at least 4
    per subsegment)."""
    return SSCROptions(steps_per_subsegment=max(4, int(np.ceil(steps_per_segment / per_segment))))


def check_accuracy_plan(robot: Robot, *, models: Sequence[str | Model] | None = None,
                        disks: Sequence[int] = (5, 10, 20, 40), reference_steps: int = 160, order: bool = True) -> None:
    """Refuse, before any work, a study that cannot run: every robot it will build (``robot`` and, for the order
    study when ``order``, ``robot`` with each of ``disks`` per segment: two or more different counts), the
    reference's Runge-Kutta steps on each and every model's memory.

    Raises
    ------
    SettingsError
        Naming ``disks`` or ``reference_steps``.
    ResourceLimitError
        When a solve would need more memory than the budget.
    """
    chosen = get_models(models if models is not None else tuple(MODELS))
    disks = list(disks)
    if order and (len(set(disks)) < 2 or len(set(disks)) != len(disks)):
        raise SettingsError("disks", f": the order study needs two or more different disk counts, got {disks}")
    per = max(s.n_disks for s in robot.segments)
    for n in [per, *(disks if order else [])]:
        try:
            r = robot if n == per else robot.with_disks(n)
        except ValueError as err:
            raise SettingsError("disks", f": {err}") from None
        try:
            ref = reference_options(n, reference_steps)
        except ValueError:
            raise SettingsError("reference_steps", f" {reference_steps}: with {n} disks per segment that is "
                                f"{-(-reference_steps // n)} Runge-Kutta steps per subsegment, more than 1000"
                                ) from None
        for m in chosen:
            check_resources(m, r, m.default_options())
        check_resources(get_model(REFERENCE), r, ref)


@dataclass(frozen=True)
class ModelAccuracy:
    """One model under one load group, against the reference.

    Attributes
    ----------
    model, group : str
    cases : int
        Tension vectors solved.
    reference_converged : int
        Of them, where the reference converged (only those are compared).
    converged : int
        Of those, where this model converged.
    errors_mm : ndarray
        Tip distance from the reference [mm] where both converged.
    median_ms : float
        Median time of one of this model's solves [ms].
    unsupported : str
        Why the model could not take this group ("" if it could).
    """

    model: str
    group: str
    cases: int
    reference_converged: int
    converged: int
    errors_mm: np.ndarray
    median_ms: float
    unsupported: str = ""

    @property
    def converged_fraction(self) -> float:
        """Converged / reference-converged cases."""
        return self.converged / self.reference_converged if self.reference_converged else float("nan")

    def row(self) -> AccuracyRow:
        """Its row of the table: counts, error statistics [mm] (NaN without an error), median time [ms]."""
        e = self.errors_mm
        nan = float("nan")
        return AccuracyRow(self.model, self.group, self.cases, self.reference_converged, self.converged,
                           self.converged_fraction, float(np.median(e)) if e.size else nan,
                           float(np.percentile(e, 95)) if e.size else nan, float(np.max(e)) if e.size else nan,
                           self.median_ms, self.unsupported)


@dataclass(frozen=True)
class AccuracyRow:
    """One model under one load group against the reference: a row of ``accuracy.csv`` and of
    ``accuracy.json``'s ``summary.rows``.

    Attributes
    ----------
    model, group : str
    cases : int
        Tension vectors solved.
    reference_converged : int
        Of them, where the reference converged.
    converged : int
        Of those, where this model converged.
    converged_fraction : float
        ``converged / reference_converged`` (NaN when the reference converged nowhere).
    median_error_mm, p95_error_mm, max_error_mm : float
        The tip error's median, 95th percentile and largest value over the compared cases [mm] (NaN without
        one).
    median_ms : float
        Median time of one of this model's solves [ms] (NaN when unsupported, or not recorded).
    unsupported : str
        Why the model could not take this group ("" if it could).
    """

    model: str
    group: str
    cases: int
    reference_converged: int
    converged: int
    converged_fraction: float
    median_error_mm: float
    p95_error_mm: float
    max_error_mm: float
    median_ms: float
    unsupported: str = ""

    def to_json(self) -> JsonDict:
        """JSON- and CSV-ready form, the columns of ``accuracy.csv`` in order (non-finite numbers stay NaN: the
        JSON writer makes them null)."""
        return {"model": self.model, "group": self.group, "cases": self.cases,
                "reference_converged": self.reference_converged, "converged": self.converged,
                "converged_fraction": self.converged_fraction, "median_error_mm": self.median_error_mm,
                "p95_error_mm": self.p95_error_mm, "max_error_mm": self.max_error_mm, "median_ms": self.median_ms,
                "unsupported": self.unsupported}

    @classmethod
    def from_json(cls, d: JsonObject) -> AccuracyRow:
        """The row :meth:`to_json` wrote; KeyError naming a missing key (``median_ms`` may be absent: NaN)."""
        return cls(str(d["model"]), str(d["group"]), int(d["cases"]), int(d["reference_converged"]),
                   int(d["converged"]), _number(d["converged_fraction"]), _number(d["median_error_mm"]),
                   _number(d["p95_error_mm"]), _number(d["max_error_mm"]), _number(d.get("median_ms")),
                   str(d["unsupported"]))


@dataclass(frozen=True)
class OrderFit:
    """One model in an order study.

    Attributes
    ----------
    model : str
    errors_mm : tuple of float
        Its median tip error over the cases at each disk count [mm] (NaN where nothing converged).
    order : float
        The slope of log(error) on log(spacing) (NaN with fewer than two positive errors).
    """

    model: str
    errors_mm: tuple[float, ...]
    order: float


@dataclass(frozen=True)
class OrderRecord:
    """What a file holds of an order study (:class:`OrderStudy`): an object of ``accuracy.json``'s
    ``summary.orders``.

    Attributes
    ----------
    group : str
        The load group.
    disks : tuple of int
        Disks per segment.
    spacing_m : tuple of float
        Largest subsegment length at each disk count [m].
    fits : tuple of OrderFit
        Each model's errors and order, in the study's order.
    seconds : float
        Wall time [s] (0 when not recorded).
    """

    group: str
    disks: tuple[int, ...]
    spacing_m: tuple[float, ...]
    fits: tuple[OrderFit, ...]
    seconds: float = 0.0

    @classmethod
    def of(cls, study: OrderStudy) -> OrderRecord:
        """The record of ``study``."""
        return cls(study.group, tuple(study.disks), tuple(float(h) for h in study.spacing),
                   tuple(OrderFit(m, tuple(float(x) for x in e), float(study.order[m]))
                         for m, e in study.errors_mm.items()), float(study.seconds))

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``group``, ``disks``, ``spacing_m`` [m], ``errors_mm`` and ``order`` (objects keyed by
        model), ``seconds``."""
        return {"group": self.group, "disks": list(self.disks), "spacing_m": list(self.spacing_m),
                "errors_mm": {f.model: list(f.errors_mm) for f in self.fits},
                "order": {f.model: f.order for f in self.fits}, "seconds": self.seconds}

    @classmethod
    def from_json(cls, d: JsonObject) -> OrderRecord:
        """The record :meth:`to_json` wrote; KeyError naming a missing key (``order.pcc2``), ValueError when an
        error list's length is not the disk counts'."""
        disks = tuple(int(n) for n in d["disks"])
        errors, order = d["errors_mm"], d["order"]
        fits = []
        for m, e in errors.items():
            if len(e) != len(disks):
                raise ValueError(f"{_FILE}: errors_mm.{m} holds {len(e)} errors for {len(disks)} disk counts")
            if m not in order:
                raise KeyError(f"order.{m}")
            fits.append(OrderFit(str(m), tuple(_number(x) for x in e), _number(order[m])))
        return cls(str(d["group"]), disks, tuple(_number(h) for h in d["spacing_m"]), tuple(fits),
                   _number(d.get("seconds", 0.0)))


@dataclass(frozen=True)
class AccuracySummary:
    """The numbers of an accuracy study and its order studies (``accuracy.json``'s ``summary``).

    Attributes
    ----------
    rows : tuple of AccuracyRow
        One per model and load group.
    compared : int
        Tip errors computed, over every model and group (0: nothing could be compared).
    reference_steps_per_subsegment : int
        The reference's Runge-Kutta steps per subsegment, as used.
    seconds : float
        Wall time of the study [s] (0 when not recorded).
    orders : tuple of OrderRecord
        The order study of each group (empty without one).
    """

    rows: tuple[AccuracyRow, ...]
    compared: int
    reference_steps_per_subsegment: int
    seconds: float
    orders: tuple[OrderRecord, ...] = ()

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``rows``, ``compared``, ``reference_steps_per_subsegment``, ``seconds``, ``orders``."""
        return {"rows": [r.to_json() for r in self.rows], "compared": self.compared,
                "reference_steps_per_subsegment": self.reference_steps_per_subsegment, "seconds": self.seconds,
                "orders": [o.to_json() for o in self.orders]}

    @classmethod
    def from_json(cls, d: JsonObject) -> AccuracySummary:
        """The numbers :meth:`to_json` wrote: :class:`~pytdcr.records.RecordKeyError` naming the path of a
        missing key (``rows[2].max_error_mm``)."""
        return cls(_items("rows", AccuracyRow.from_json, d["rows"]), int(d["compared"]),
                   int(d["reference_steps_per_subsegment"]), _number(d.get("seconds", 0.0)),
                   _items("orders", OrderRecord.from_json, d["orders"]))


@dataclass(frozen=True)
class AccuracyStudy:
    """Every model under every load group (:func:`model_accuracy`)."""

    robot: Robot
    tensions: np.ndarray
    groups: tuple[LoadGroup, ...]
    models: tuple[str, ...]
    results: tuple[ModelAccuracy, ...]
    reference_steps: int
    seconds: float

    def rows(self) -> list[AccuracyRow]:
        """One row per model and group."""
        return [r.row() for r in self.results]

    def summary(self, orders: Sequence[OrderStudy] = ()) -> AccuracySummary:
        """Its numbers, with those of the ``orders`` studies, as one typed result."""
        return AccuracySummary(tuple(self.rows()), self.compared, self.reference_steps_per_subsegment, self.seconds,
                               tuple(OrderRecord.of(st) for st in orders))

    @property
    def compared(self) -> int:
        """Tip errors computed, over every model and group (0: nothing could be compared)."""
        return sum(r.errors_mm.size for r in self.results)

    @property
    def reference_steps_per_subsegment(self) -> int:
        """The reference's Runge-Kutta steps per subsegment, as used: ``reference_steps`` per segment of the
        robot's most disks, and at least 4 (:func:`reference_options`)."""
        per = max(s.n_disks for s in self.robot.segments)
        return reference_options(per, self.reference_steps).steps_per_subsegment

    def nothing_compared(self) -> str:
        """Why no tip error could be computed, in one line ("" when some was)."""
        if self.compared:
            return ""
        dead = [g.name for g in self.groups if all(r.reference_converged == 0 for r in self.results
                                                     if r.group == g.name)]
        live = [r for r in self.results if r.group not in dead]
        parts = []
        if dead:
            where = "any load group" if len(dead) == len(self.groups) else ", ".join(dead)
            parts.append(f"the reference sscr converged on none of the {len(self.tensions)} tension vectors under "
                         f"{where}")
        if live and all(r.unsupported for r in live):
            parts.append(f"every model is unsupported under {'the other groups' if dead else 'every load group'}")
        elif live:
            parts.append("no model converged where the reference did" + (" under the other groups" if dead else ""))
        return "; ".join(parts)


def _solve_all(model: Model, opts: object, robot: Robot, group: LoadGroup, T: np.ndarray) -> list[StaticSolution]:
    return [model.solve(robot, group.loads(t, robot), None, opts) for t in T]


def model_accuracy(robot: Robot, tensions: np.ndarray, *, groups: Sequence[LoadGroup] | None = None,
                   models: Sequence[str | Model] | None = None, reference_steps: int = 160,
                   progress: Callable[[str], None] | None = None) -> AccuracyStudy:
    """Solve the rows of ``tensions`` (B, n_tendons) [N] with every model under every group; errors vs ``sscr``.

    ``models`` defaults to every registered model (the reference's own model, ``sscr`` at its default
    integration, is one of them: its row shows the integration error). ``progress`` is called with a label
    after each model and group.
    """
    t0 = time.perf_counter()
    T = check_tensions(tensions, robot.n_tendons)
    if T.ndim != 2:
        raise ValueError(f"tensions must have shape (B, {robot.n_tendons}), got {T.shape}")
    groups = tuple(groups or default_groups())
    chosen = tuple(get_model(m) for m in (models or tuple(MODELS)))
    per = max(s.n_disks for s in robot.segments)
    ref_model, ref_opts = resolve(REFERENCE, robot, None, reference_options(per, reference_steps))
    results: list[ModelAccuracy] = []
    for group in groups:
        r = group.apply(robot)
        ref = _solve_all(ref_model, ref_opts, r, group, T)
        ok_ref = np.array([s.converged for s in ref])
        if progress is not None:
            progress(f"{group.name}: reference")
        for m in chosen:
            try:
                _, opts = resolve(m, r, group.loads(T[0], r))
            except UnsupportedFeatureError as err:
                results.append(ModelAccuracy(m.name, group.name, len(T), int(ok_ref.sum()), 0, np.zeros(0),
                                             float("nan"), unsupported=str(err)))
                continue
            sols = _solve_all(m, opts, r, group, T)
            ok = np.array([s.converged for s in sols]) & ok_ref
            err = np.array([np.linalg.norm(sols[k].tip_position - ref[k].tip_position) * 1e3
                            for k in np.flatnonzero(ok)])
            results.append(ModelAccuracy(m.name, group.name, len(T), int(ok_ref.sum()), int(ok.sum()), err,
                                         float(np.median([s.seconds for s in sols]) * 1e3)))
            if progress is not None:
                progress(f"{group.name}: {m.name}")
    return AccuracyStudy(robot=robot, tensions=T, groups=groups, models=tuple(m.name for m in chosen),
                         results=tuple(results), reference_steps=reference_steps, seconds=time.perf_counter() - t0)


@dataclass(frozen=True)
class OrderStudy:
    """Errors of ``pcc``-like models against ``sscr`` of the same robot as the disks multiply.

    Attributes
    ----------
    disks : tuple of int
        Disks per segment.
    spacing : ndarray, shape (len(disks),)
        Largest subsegment length [m].
    errors_mm : dict of str to ndarray, shape (len(disks),)
        Per model, the median tip error over the cases [mm] (NaN where nothing converged).
    order : dict of str to float
        Per model, the slope of log(error) on log(spacing), least squares.
    group : str
    """

    disks: tuple[int, ...]
    spacing: np.ndarray
    errors_mm: dict[str, np.ndarray]
    order: dict[str, float]
    group: str
    cases: int
    seconds: float = 0.0
    details: dict[str, Any] = field(default_factory=dict)


def order_study(robot: Robot, tensions: np.ndarray, group: LoadGroup, *, disks: Sequence[int] = (5, 10, 20, 40),
                models: Sequence[str] = ("pcc", "pcc2"), reference_steps: int = 160,
                progress: Callable[[str], None] | None = None) -> OrderStudy:
    """The observed order of each model against ``sscr`` of the same robot, with ``disks`` per segment."""
    t0 = time.perf_counter()
    T = check_tensions(np.atleast_2d(tensions), robot.n_tendons)
    errors = {m: np.full(len(disks), np.nan) for m in models}
    spacing = np.empty(len(disks))
    for j, n in enumerate(disks):
        r = group.apply(robot.with_disks(n))
        spacing[j] = float(np.max(r.subsegment_lengths))
        ref_model, ref_opts = resolve(REFERENCE, r, None, reference_options(n, reference_steps))
        ref = _solve_all(ref_model, ref_opts, r, group, T)
        for name in models:
            m, opts = resolve(name, r, group.loads(T[0], r))
            sols = _solve_all(m, opts, r, group, T)
            e = [np.linalg.norm(s.tip_position - q.tip_position) * 1e3
                 for s, q in zip(sols, ref, strict=True) if s.converged and q.converged]
            if e:
                errors[name][j] = float(np.median(e))
        if progress is not None:
            progress(f"order study: {n} disks per segment")
    order = {}
    for name, e in errors.items():
        ok = np.isfinite(e) & (e > 0)
        order[name] = float(np.polyfit(np.log(spacing[ok]), np.log(e[ok]), 1)[0]) if ok.sum() >= 2 else float("nan")
    return OrderStudy(disks=tuple(int(d) for d in disks), spacing=spacing, errors_mm=errors, order=order,
                      group=group.name, cases=len(T), seconds=time.perf_counter() - t0)

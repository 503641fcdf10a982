"""Cross-checking models: the same cases solved by two or more registered models.

The first model is the reference; every other model's tip is measured from it. The numbers of a comparison are
one typed result, :class:`ComparisonSummary` (a :class:`ModelSummary` per model), read by attribute; JSON at one
boundary: :meth:`ComparisonSummary.to_json` is ``compare.json``'s ``summary``, key for key and in order, and
:meth:`ComparisonSummary.from_json` reads it back from any file a run wrote (a missing key raises
:class:`~pytdcr.records.RecordKeyError` naming it; a median time may be absent, as the golden baselines drop
times: it reads as NaN, not recorded).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .loads import Loads, check_tensions
from .records import JsonDict, JsonObject
from .results import StaticSolution
from .robot import Robot
from .statics import Model, get_models, resolve
from .validate import SettingsError

__all__ = ["CaseDifference", "CaseSolve", "ComparisonCase", "ComparisonSummary", "ModelComparison", "ModelSummary",
           "check_models", "compare_models"]

#: the keys of a compared model's differences from the reference in ``compare.json``'s ``summary``
DIFFERENCE_KEYS = ("difference_median_mm", "difference_max_mm", "difference_median_pct_length")


def check_models(models: Sequence[str | Model]) -> tuple[Model, ...]:
    """The models of a comparison: two or more distinct registered models (names or objects), the first the
    reference; :class:`~pytdcr.validate.SettingsError` naming ``models`` otherwise."""
    resolved = get_models(models)
    names = [m.name for m in resolved]
    if len(names) < 2 or len(set(names)) != len(names):
        raise SettingsError("models", f": give two or more distinct models, got {names}")
    return resolved


@dataclass(frozen=True)
class ModelSummary:
    """One model of a comparison, over every case.

    Attributes
    ----------
    model : str
    not_converged : int
        Cases where it did not converge.
    ms_median : float
        Median solve time [ms].
    difference_median_mm, difference_max_mm : float or None
        Median and largest tip distance from the reference [mm] where both converged (None for the reference
        itself, or where no case converged for both).
    difference_median_pct_length : float or None
        The median as a percentage of the backbone length.
    """

    model: str
    not_converged: int
    ms_median: float
    difference_median_mm: float | None = None
    difference_max_mm: float | None = None
    difference_median_pct_length: float | None = None

    def to_json(self, reference: bool) -> JsonDict:
        """Its keys in ``compare.json``'s ``summary``, each prefixed by the model's name: failures and median
        time, then (unless it is the ``reference``) its differences from the reference."""
        out: dict[str, Any] = {f"{self.model}_not_converged": self.not_converged,
                               f"{self.model}_ms_median": self.ms_median}
        if not reference:
            out.update({f"{self.model}_{key}": getattr(self, key) for key in DIFFERENCE_KEYS})
        return out

    @classmethod
    def from_json(cls, model: str, d: JsonObject, reference: bool) -> ModelSummary:
        """The summary of ``model`` in ``d`` (``compare.json``'s ``summary``): KeyError naming a missing key; an
        absent median time (dropped, as the golden baselines drop times) reads as NaN."""
        ms = d.get(f"{model}_ms_median")
        diffs = {} if reference else {key: _optional_float(d[f"{model}_{key}"]) for key in DIFFERENCE_KEYS}
        return cls(model, int(d[f"{model}_not_converged"]), float("nan") if ms is None else float(ms), **diffs)


def _optional_float(x: float | None) -> float | None:
    return None if x is None else float(x)


@dataclass(frozen=True)
class ComparisonSummary:
    """The numbers of one comparison (``compare.json``'s ``summary``).

    Attributes
    ----------
    cases : int
        Tension vectors solved.
    all_converged : int
        Of them, those where every model converged.
    per_model : tuple of ModelSummary
        Each model's failures, median time and (but the reference's) tip difference from the reference, in the
        comparison's order: the reference first.
    """

    cases: int
    all_converged: int
    per_model: tuple[ModelSummary, ...]

    @property
    def models(self) -> tuple[str, ...]:
        """The models' names, the reference first."""
        return tuple(m.model for m in self.per_model)

    @property
    def reference(self) -> str:
        """The reference model's name."""
        return self.per_model[0].model

    @property
    def others(self) -> tuple[ModelSummary, ...]:
        """The summaries of the models measured against the reference."""
        return self.per_model[1:]

    def of(self, model: str) -> ModelSummary:
        """The summary of ``model``; KeyError naming it when it was not compared."""
        for m in self.per_model:
            if m.model == model:
                return m
        raise KeyError(model)

    def to_json(self) -> JsonDict:
        """JSON-ready form (``compare.json``'s ``summary``): the cases, the reference, the models, the cases every
        model converged on, then each model's failures and median time [ms] (``pcc_not_converged``,
        ``pcc_ms_median``), then each other model's differences from the reference (``cosserat_difference_median_mm``,
        ``cosserat_difference_max_mm``, ``cosserat_difference_median_pct_length``; null where no case converged
        for both)."""
        out: dict[str, Any] = {"cases": self.cases, "reference": self.reference, "models": list(self.models),
                               "all_converged": self.all_converged}
        for m in self.per_model:
            out.update(m.to_json(reference=True))
        for m in self.others:
            out.update({k: v for k, v in m.to_json(reference=False).items() if k not in out})
        return out

    @classmethod
    def from_json(cls, d: JsonObject) -> ComparisonSummary:
        """The numbers :meth:`to_json` wrote; KeyError naming a missing key (``cosserat_difference_max_mm``),
        ValueError when the reference is not the first model."""
        models = [str(m) for m in d["models"]]
        if not models or d["reference"] != models[0]:
            raise ValueError(f"the reference {d['reference']!r} must be the first of the models {models}")
        return cls(int(d["cases"]), int(d["all_converged"]),
                   tuple(ModelSummary.from_json(m, d, k == 0) for k, m in enumerate(models)))


#: a cell of a comparison's table
CsvValue = float | int | bool | str


@dataclass(frozen=True)
class CaseSolve:
    """One model's solve of one case.

    Attributes
    ----------
    model : str
    tip_m : tuple of 3 floats
        Its tip position [m] (NaN unless it converged).
    ms : float
        Its solve time [ms].
    converged : bool
    residual_Nm : float
        Its equilibrium residual [N m].
    path : str
        How it was solved (:class:`~pytdcr.statics.SolvePath`).
    """

    model: str
    tip_m: tuple[float, float, float]
    ms: float
    converged: bool
    residual_Nm: float
    path: str


@dataclass(frozen=True)
class CaseDifference:
    """One model's tip distance from the reference's on one case.

    Attributes
    ----------
    model : str
    mm : float
        The distance [mm] (NaN unless both converged).
    pct_length : float
        The same as a percentage of the backbone length.
    """

    model: str
    mm: float
    pct_length: float


@dataclass(frozen=True)
class ComparisonCase:
    """One case of a comparison: a row of ``compare.csv`` and of ``compare.md``'s table.

    Attributes
    ----------
    case : int
        Its number, from 1.
    tensions_N : tuple of float
        Its actuator tensions [N].
    solves : tuple of CaseSolve
        Each model's solve, the reference first.
    differences : tuple of CaseDifference
        Each other model's tip distance from the reference.
    """

    case: int
    tensions_N: tuple[float, ...]
    solves: tuple[CaseSolve, ...]
    differences: tuple[CaseDifference, ...]

    def to_row(self) -> dict[str, CsvValue]:
        """The columns of ``compare.csv`` in order: ``case``, ``T1_N``..., each model's tip (``pcc_x_m``...), each
        other model's difference (``cosserat_difference_mm``, ``cosserat_difference_pct_length``), then each
        model's time, convergence, residual and path (``pcc_ms``, ``pcc_converged``, ``pcc_residual_Nm``,
        ``pcc_path``)."""
        row: dict[str, CsvValue] = {"case": self.case}
        row.update({f"T{c + 1}_N": t for c, t in enumerate(self.tensions_N)})
        for s in self.solves:
            row.update({f"{s.model}_{a}_m": x for a, x in zip("xyz", s.tip_m, strict=True)})
        for d in self.differences:
            row.update({f"{d.model}_difference_mm": d.mm, f"{d.model}_difference_pct_length": d.pct_length})
        for s in self.solves:
            row.update({f"{s.model}_ms": s.ms, f"{s.model}_converged": s.converged,
                        f"{s.model}_residual_Nm": s.residual_Nm, f"{s.model}_path": s.path})
        return row


@dataclass(frozen=True, eq=False)
class ModelComparison:
    """Every model's equilibria for B tension vectors under the same external loads.

    Attributes
    ----------
    tensions : ndarray, shape (B, n_tendons)
        Actuator tensions of each case [N].
    models : tuple of str
        The models' names; the first is the reference.
    solutions : dict of str to list of StaticSolution
        Each model's solutions, case by case.
    length : float
        Backbone length [m], the scale of the relative differences.
    """

    tensions: np.ndarray
    models: tuple[str, ...]
    solutions: dict[str, list[StaticSolution]]
    length: float

    @property
    def reference(self) -> str:
        """The reference model's name (the first)."""
        return self.models[0]

    @property
    def others(self) -> tuple[str, ...]:
        """The models measured against the reference."""
        return self.models[1:]

    @property
    def all_converged(self) -> np.ndarray:
        """Cases where every model converged, shape (B,) of bool."""
        return np.array([all(self.solutions[m][k].converged for m in self.models) for k in range(len(self))])

    def __len__(self) -> int:
        return int(self.tensions.shape[0])

    def difference(self, model: str) -> np.ndarray:
        """Distance of ``model``'s tip from the reference's [m], shape (B,); NaN unless both converged."""
        out = np.full(len(self), np.nan)
        for k, (a, b) in enumerate(zip(self.solutions[self.reference], self.solutions[model], strict=True)):
            if a.converged and b.converged:
                out[k] = float(np.linalg.norm(a.tip_position - b.tip_position))
        return out

    def cases(self) -> list[ComparisonCase]:
        """One typed row per case: its tensions, each model's solve, each other model's tip difference."""
        diffs = {m: self.difference(m) for m in self.others}
        out = []
        for k in range(len(self)):
            solves = []
            for name in self.models:
                s = self.solutions[name][k]
                tip = s.tip_position if s.converged else np.full(3, np.nan)
                solves.append(CaseSolve(name, (float(tip[0]), float(tip[1]), float(tip[2])), float(s.seconds * 1e3),
                                        bool(s.converged), float(s.residual), s.path))
            out.append(ComparisonCase(k + 1, tuple(float(t) for t in self.tensions[k]), tuple(solves),
                                      tuple(CaseDifference(m, float(diffs[m][k] * 1e3),
                                                           float(diffs[m][k] / self.length * 100.0))
                                            for m in self.others)))
        return out

    def rows(self) -> list[dict[str, CsvValue]]:
        """One CSV-ready row per case (:meth:`ComparisonCase.to_row`): tips [m], differences [mm, % of length],
        times [ms], status."""
        return [c.to_row() for c in self.cases()]

    @property
    def n_all_converged(self) -> int:
        """Cases where every model converged."""
        return int(self.all_converged.sum())

    def summaries(self) -> dict[str, ModelSummary]:
        """Per model (in order, the reference first): failures, median solve time, tip difference from the
        reference."""
        diffs: dict[str, dict[str, float | None]] = {}
        for name in self.others:
            d = self.difference(name)
            ok = np.isfinite(d)
            diffs[name] = {"difference_median_mm": float(np.median(d[ok]) * 1e3) if ok.any() else None,
                           "difference_max_mm": float(np.max(d[ok]) * 1e3) if ok.any() else None,
                           "difference_median_pct_length": (float(np.median(d[ok]) / self.length * 100)
                                                            if ok.any() else None)}
        return {name: ModelSummary(name, sum(not s.converged for s in self.solutions[name]),
                                   float(np.median([s.seconds for s in self.solutions[name]]) * 1e3),
                                   **diffs.get(name, {}))
                for name in self.models}

    def summary(self) -> ComparisonSummary:
        """Its numbers as one typed result: the counts of cases and :meth:`summaries` (``compare.json``'s
        ``summary`` is its :meth:`ComparisonSummary.to_json`)."""
        return ComparisonSummary(len(self), self.n_all_converged, tuple(self.summaries().values()))


def compare_models(
    robot: Robot,
    loads: Loads,
    tensions: np.ndarray,
    *,
    models: Sequence[str | Model] = ("pcc", "cosserat"),
    options: Mapping[str, object] | None = None,
    progress: Callable[[], None] | None = None,
) -> ModelComparison:
    """Solve each row of ``tensions`` (B, n_tendons) [N] with every model under ``loads``' external wrenches.

    Parameters
    ----------
    models : sequence of str or Model
        Two or more distinct registered models; the first is the reference.
    options : mapping of model name to that model's options, optional
    progress : callable, optional
        Called with no argument after each case.

    Raises
    ------
    UnsupportedFeatureError
        Every model is checked against the robot and loads before any solve; this names the first that
        cannot take them.
    """
    resolved = check_models(models)
    names = tuple(m.name for m in resolved)
    opts = {m.name: resolve(m, robot, loads, (options or {}).get(m.name))[1] for m in resolved}
    T = check_tensions(tensions, robot.n_tendons)
    if T.ndim != 2:
        raise ValueError(f"tensions must have shape (B, {robot.n_tendons}), got {T.shape}")
    sols: dict[str, list[StaticSolution]] = {n: [] for n in names}
    for row in T:
        lds = loads.with_tensions(row)
        for m in resolved:
            sols[m.name].append(m.solve(robot, lds, None, opts[m.name]))
        if progress is not None:
            progress()
    return ModelComparison(tensions=T, models=names, solutions=sols, length=robot.length)

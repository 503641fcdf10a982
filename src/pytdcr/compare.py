"""Cross-checking models: the same cases solved by two or more registered models.

The first model is the reference; every other model's tip is measured from it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .loads import Loads, check_tensions
from .results import StaticSolution
from .robot import Robot
from .statics import Model, get_models, resolve
from .validate import SettingsError

__all__ = ["ModelComparison", "ModelSummary", "check_models", "compare_models"]


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

    def rows(self) -> list[dict[str, Any]]:
        """One JSON/CSV-ready row per case: tips [m], differences [mm, % of length], times [ms], status."""
        diffs = {m: self.difference(m) for m in self.others}
        rows = []
        for k in range(len(self)):
            row: dict[str, Any] = {"case": k + 1}
            row.update({f"T{c + 1}_N": float(t) for c, t in enumerate(self.tensions[k])})
            for name in self.models:
                s = self.solutions[name][k]
                tip = s.tip_position if s.converged else np.full(3, np.nan)
                row.update({f"{name}_x_m": tip[0], f"{name}_y_m": tip[1], f"{name}_z_m": tip[2]})
            for name in self.others:
                row[f"{name}_difference_mm"] = diffs[name][k] * 1e3
                row[f"{name}_difference_pct_length"] = diffs[name][k] / self.length * 100.0
            for name in self.models:
                s = self.solutions[name][k]
                row[f"{name}_ms"] = s.seconds * 1e3
                row[f"{name}_converged"] = bool(s.converged)
                row[f"{name}_residual_Nm"] = s.residual
                row[f"{name}_path"] = s.path
            rows.append(row)
        return rows

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

    def summary(self) -> dict[str, Any]:
        """:meth:`summaries` as one JSON-ready object with a key per model and quantity (``pcc_ms_median``,
        ``cosserat_difference_median_mm``, ...), with the counts of cases."""
        per = self.summaries()
        out: dict[str, Any] = {"cases": len(self), "reference": self.reference, "models": list(self.models),
                               "all_converged": self.n_all_converged}
        for name in self.models:
            out[f"{name}_not_converged"] = per[name].not_converged
            out[f"{name}_ms_median"] = per[name].ms_median
        for name in self.others:
            for key in ("difference_median_mm", "difference_max_mm", "difference_median_pct_length"):
                out[f"{name}_{key}"] = getattr(per[name], key)
        return out


def compare_models(
    robot: Robot,
    loads: Loads,
    tensions: np.ndarray,
    *,
    models: Sequence[str | Model] = ("pcc", "cosserat"),
    options: Mapping[str, Any] | None = None,
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

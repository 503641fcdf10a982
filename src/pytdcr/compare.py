"""Cross-checking the two static models: the same cases solved by PCC and by the Cosserat rod."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .design import Robot
from .loads import Loads
from .results import StaticSolution
from .statics import CosseratOptions, SolverOptions, solve

__all__ = ["ModelComparison", "compare_models"]


@dataclass(frozen=True, eq=False)
class ModelComparison:
    """Both models' equilibria for B tension vectors under the same external loads.

    Attributes
    ----------
    tensions : ndarray, shape (B, n_tendons)
        Actuator tensions of each case [N].
    pcc, cosserat : list of StaticSolution
        The solutions, case by case.
    length : float
        Backbone length [m], the scale of the relative differences.
    """

    tensions: np.ndarray
    pcc: list[StaticSolution]
    cosserat: list[StaticSolution]
    length: float

    @property
    def both_converged(self) -> np.ndarray:
        """Cases where both solves converged, shape (B,) of bool."""
        return np.array([a.converged and b.converged for a, b in zip(self.pcc, self.cosserat, strict=True)])

    @property
    def difference(self) -> np.ndarray:
        """Distance between the two tips [m], shape (B,); NaN unless both converged."""
        out = np.full(len(self.pcc), np.nan)
        for k, (a, b) in enumerate(zip(self.pcc, self.cosserat, strict=True)):
            if a.converged and b.converged:
                out[k] = float(np.linalg.norm(a.tip_position - b.tip_position))
        return out

    def rows(self) -> list[dict[str, Any]]:
        """One JSON/CSV-ready row per case: tips [m], difference [mm, % of length], times [ms], status."""
        rows = []
        diff = self.difference
        for k, (a, b) in enumerate(zip(self.pcc, self.cosserat, strict=True)):
            row: dict[str, Any] = {"case": k + 1}
            row.update({f"T{c + 1}_N": float(t) for c, t in enumerate(self.tensions[k])})
            for name, s in (("pcc", a), ("cosserat", b)):
                tip = s.tip_position if s.converged else np.full(3, np.nan)
                row.update({f"{name}_x_m": tip[0], f"{name}_y_m": tip[1], f"{name}_z_m": tip[2]})
            row["difference_mm"] = diff[k] * 1e3
            row["difference_pct_length"] = diff[k] / self.length * 100.0
            for name, s in (("pcc", a), ("cosserat", b)):
                row[f"{name}_ms"] = s.seconds * 1e3
                row[f"{name}_converged"] = bool(s.converged)
                row[f"{name}_residual_Nm"] = s.residual
                row[f"{name}_path"] = s.path
            rows.append(row)
        return rows

    def summary(self) -> dict[str, Any]:
        """Median and maximum tip difference and solve times over the cases."""
        d = self.difference
        ok = np.isfinite(d)
        return {
            "cases": len(self.pcc),
            "both_converged": int(ok.sum()),
            "pcc_not_converged": sum(not s.converged for s in self.pcc),
            "cosserat_not_converged": sum(not s.converged for s in self.cosserat),
            "difference_median_mm": float(np.median(d[ok]) * 1e3) if ok.any() else None,
            "difference_max_mm": float(np.max(d[ok]) * 1e3) if ok.any() else None,
            "difference_median_pct_length": float(np.median(d[ok]) / self.length * 100) if ok.any() else None,
            "pcc_ms_median": float(np.median([s.seconds for s in self.pcc]) * 1e3),
            "cosserat_ms_median": float(np.median([s.seconds for s in self.cosserat]) * 1e3),
        }


def compare_models(
    robot: Robot,
    loads: Loads,
    tensions: np.ndarray,
    *,
    pcc_options: SolverOptions | None = None,
    cosserat_options: CosseratOptions | None = None,
    progress: Any = None,
) -> ModelComparison:
    """Solve each row of ``tensions`` (B, n_tendons) [N] with both models under ``loads``' external wrenches.

    ``progress``, if given, is called with no argument after each case.
    The robot must have no friction (the Cosserat model has none).
    """
    T = np.asarray(tensions, dtype=float)
    if T.ndim != 2 or T.shape[1] != robot.n_tendons:
        raise ValueError(f"tensions must have shape (B, {robot.n_tendons}), got {T.shape}")
    pcc: list[StaticSolution] = []
    cr: list[StaticSolution] = []
    for row in T:
        lds = loads.with_tensions(row)
        cr.append(solve(robot, lds, model="cosserat", options=cosserat_options))  # refuses friction first
        pcc.append(solve(robot, lds, options=pcc_options))
        if progress is not None:
            progress()
    return ModelComparison(tensions=T, pcc=pcc, cosserat=cr, length=robot.length)

"""What a calibration returns: the fitted values with their standard errors, how well the data determine them, and
the tip errors before and after (and on held-out rows)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io import robot_to_dict
from ..records import JsonDict
from ..robot import Robot

__all__ = ["SCHEMA_VERSION", "CalibrationResult", "CrossValidation", "FittedParameter"]

#: the layout of :meth:`CalibrationResult.to_json`
SCHEMA_VERSION = 1


def _number(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


@dataclass(frozen=True)
class FittedParameter:
    """One parameter after the fit.

    Attributes
    ----------
    name, unit : str
    initial, value : float
        Before and after the fit, in ``unit``.
    standard_error : float
        One standard error of ``value`` (inf where the data do not determine it).
    lower, upper : float
        The bounds the fit kept it in.
    at_bound : bool
        ``value`` ended on a bound (its standard error then describes the free directions only).
    """

    name: str
    unit: str
    initial: float
    value: float
    standard_error: float
    lower: float
    upper: float
    at_bound: bool

    def to_json(self) -> JsonDict:
        """JSON-ready; a standard error that is not finite as null."""
        return {"name": self.name, "unit": self.unit, "initial": self.initial, "value": self.value,
                "standard_error": _number(self.standard_error), "lower": self.lower, "upper": self.upper,
                "at_bound": self.at_bound}


@dataclass(frozen=True, eq=False)
class CrossValidation:
    """Tip errors on rows the fit did not see: the rows split into ``folds`` parts, each predicted by a fit to the
    others (started from the same initial values).

    Attributes
    ----------
    folds : int
    errors_m : ndarray, shape (B,)
        Each row's held-out tip error [m] (NaN where its fold's fit failed).
    rms_m : float
        Their root mean square [m].
    rms_before_m : float
        The same rows' RMS tip error with the initial parameters [m].
    failed_folds : int
        Folds whose fit did not converge (their rows keep the errors of where it stopped) or found no equilibrium
        for a row (their rows NaN).
    """

    folds: int
    errors_m: np.ndarray
    rms_m: float
    rms_before_m: float
    failed_folds: int

    def to_json(self) -> JsonDict:
        """JSON-ready."""
        return {"folds": self.folds, "rms_m": _number(self.rms_m), "rms_before_m": self.rms_before_m,
                "failed_folds": self.failed_folds, "errors_m": [_number(e) for e in self.errors_m]}


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """A fitted model.

    Attributes
    ----------
    model : str
        The registered model that was fitted.
    parameters : tuple of FittedParameter
    correlation : ndarray, shape (n, n)
        The parameters' correlation matrix (NaN rows for undetermined ones).
    singular_values : ndarray, shape (n,)
        Of the whitened Jacobian with unit-norm columns, largest first: a near-zero one marks a combination of
        parameters the data do not determine (:attr:`warnings` names it).
    warnings : tuple of str
        One line per parameter (or combination) the data do not determine, and per other doubt.
    converged : bool
        The optimiser met its tolerance and every row has an equilibrium at the fitted values.
    message : str
        The optimiser's own account.
    evaluations : int
        Residual evaluations of the fit (each: one solve per row).
    solves : int
        Equilibria solved in all (cross-validation included).
    chi2 : float
        Sum of squared whitened residuals at the fit.
    dof : int
        Residuals minus parameters.
    predicted_before, predicted_after : ndarray, shape (B, 3)
        Each row's predicted tip in the measurement frame [m].
    errors_before_m, errors_after_m : ndarray, shape (B,)
        Each row's tip error [m].
    cross_validation : CrossValidation or None
    robot : Robot
        The robot with the fitted values.
    data_source, data_sha256 : str
        Which data were fitted.
    settings : dict
        The fit's settings (loss, scale, folds, seed, ...), JSON-ready.
    seconds : float
    """

    model: str
    parameters: tuple[FittedParameter, ...]
    correlation: np.ndarray
    singular_values: np.ndarray
    warnings: tuple[str, ...]
    converged: bool
    message: str
    evaluations: int
    solves: int
    chi2: float
    dof: int
    predicted_before: np.ndarray
    predicted_after: np.ndarray
    errors_before_m: np.ndarray
    errors_after_m: np.ndarray
    cross_validation: CrossValidation | None
    robot: Robot
    data_source: str
    data_sha256: str
    settings: JsonDict
    seconds: float

    @property
    def rms_before_m(self) -> float:
        """RMS tip error with the initial parameters [m]."""
        return float(np.sqrt(np.mean(self.errors_before_m**2)))

    @property
    def rms_after_m(self) -> float:
        """RMS tip error with the fitted parameters [m]."""
        return float(np.sqrt(np.mean(self.errors_after_m**2)))

    def value(self, name: str) -> float:
        """The fitted value of parameter ``name``."""
        for p in self.parameters:
            if p.name == name:
                return p.value
        raise KeyError(f"no fitted parameter {name!r}; fitted: {', '.join(p.name for p in self.parameters)}")

    def to_json(self) -> JsonDict:
        """The result as one JSON object (schema :data:`SCHEMA_VERSION`)."""
        corr = [[_number(c) for c in row] for row in self.correlation]
        return {
            "schema_version": SCHEMA_VERSION, "model": self.model, "converged": self.converged,
            "message": self.message, "parameters": [p.to_json() for p in self.parameters], "correlation": corr,
            "singular_values": self.singular_values.tolist(), "warnings": list(self.warnings),
            "evaluations": self.evaluations, "solves": self.solves, "chi2": self.chi2, "dof": self.dof,
            "rms_before_m": self.rms_before_m, "rms_after_m": self.rms_after_m,
            "rows": [{"predicted_before_m": b.tolist(), "predicted_after_m": a.tolist(), "error_before_m": eb,
                      "error_after_m": ea} for b, a, eb, ea in zip(self.predicted_before, self.predicted_after,
                                                                   self.errors_before_m.tolist(),
                                                                   self.errors_after_m.tolist(), strict=True)],
            "cross_validation": None if self.cross_validation is None else self.cross_validation.to_json(),
            "data": {"source": self.data_source, "sha256": self.data_sha256}, "settings": self.settings,
            "robot": robot_to_dict(self.robot), "seconds": self.seconds,
        }

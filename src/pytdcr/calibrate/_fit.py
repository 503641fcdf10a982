"""Fit a model's parameters to measurements: a bounded, robust trust-region least-squares fit (SciPy's
``least_squares``, trust-region reflective: a Levenberg–Marquardt-type method that keeps bounds) on exact
derivatives through the equilibrium (:mod:`._problem`), then standard errors, correlations, identifiability
and held-out errors.

Statistics at the fit (the Gauss–Newton approximation): with ``A`` the whitened residuals' Jacobian by the
parameters, the covariance is ``C = s^2 (A^T A)^-1`` with ``s^2 = chi^2 / (m - n)`` (the residuals' own scale; 1
with ``absolute_sigma``, when the given uncertainties are trusted as they are). A parameter combination is flagged
as undetermined when a singular value of ``A`` with unit-norm columns falls below ``identifiability`` times the
largest; the warning names the parameters that make up its singular vector.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
from scipy.optimize import least_squares

from ..records import JsonDict, JsonObject
from ..results import StaticSolution
from ..robot import Robot
from ..statics import Model, UnsupportedFeatureError
from ..statics.displacement import tendon_stiffness
from ..statics.options import ModelOptions
from ..statics.registry import resolve
from ..validate import SettingsError
from ._data import Measurements
from ._parameters import Parameter, parameters
from ._problem import Problem, RowFailure
from ._result import CalibrationResult, CrossValidation, FittedParameter

__all__ = ["Calibration", "CalibrationOptions", "FitStage", "FoldStage", "calibrate", "prepare"]

#: the losses the fit offers (SciPy's names): squares, or robust ones that weigh a residual beyond ``loss_scale``
#: standard uncertainties less (an outlier's pull grows like its square root or linearly, not its square)
LOSSES = ("linear", "soft_l1", "huber", "cauchy")


@dataclass(frozen=True)
class CalibrationOptions:
    """How a calibration fits.

    Attributes
    ----------
    loss : {'soft_l1', 'huber', 'cauchy', 'linear'}
        The robust loss (``'linear'``: plain least squares).
    loss_scale : float
        Where the robust loss starts to bend, in standard uncertainties of a residual.
    max_evaluations : int
        The most residual evaluations of one fit (each solves every row).
    tolerance : float
        The optimiser's relative tolerance on the cost, the step and the gradient.
    folds : int
        Held-out cross-validation folds (0: none; at most the number of rows).
    seed : int
        The folds' random split.
    absolute_sigma : bool
        Trust the data's uncertainties as they are (standard errors from them alone), rather than scaling them by
        the fit's residual scatter.
    identifiability : float
        A normalised singular value below this fraction of the largest marks an undetermined combination.
    """

    loss: Literal["linear", "soft_l1", "huber", "cauchy"] = "soft_l1"
    loss_scale: float = 3.0
    max_evaluations: int = 60
    tolerance: float = 1e-6
    folds: int = 5
    seed: int = 0
    absolute_sigma: bool = False
    identifiability: float = 1e-2

    def __post_init__(self) -> None:
        if self.loss not in LOSSES:
            raise SettingsError("loss", f" = {self.loss!r}: must be one of {', '.join(LOSSES)}")
        for name, lo, hi in (("loss_scale", 1e-3, 1e3), ("tolerance", 1e-15, 1e-2), ("identifiability", 1e-12, 0.5)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and lo <= v <= hi):
                raise SettingsError(name, f" = {v!r}: must be a number in [{lo:g}, {hi:g}]")
        for name, lo, hi in (("max_evaluations", 1, 10_000), ("folds", 0, 1000), ("seed", 0, 2**63 - 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise SettingsError(name, f" = {v!r}: must be a whole number in [{lo}, {hi}]")
        if self.folds == 1:
            raise SettingsError("folds", " = 1: must be 0 (no cross-validation) or at least 2")


#: a progress report: the fit's stage and a line about it
Progress = Callable[[str], None]


def _fit_model(robot: Robot, model: str | Model, model_options: ModelOptions | None) -> tuple[Model, ModelOptions]:
    m, opts = resolve(model, robot, None, model_options, gradient=True)
    if m.capabilities.gradient != "exact" or not hasattr(m, "equations"):
        raise UnsupportedFeatureError(m.name, "calibration (exact derivatives through the equilibrium)",
                                      "fit pcc, pcc2 or sscr")
    return m, opts


def _check_fit(problem: Problem) -> None:
    """Refuse (SettingsError naming the parameter) a parameter that acts on nothing in these data, such as a
    pretension of a tendon the data drive by displacement, and an initial value outside its bounds."""
    driven = problem.driven
    for p in problem.params:
        hit = re.search(r"_([0-9]+)$", p.name)
        k = int(hit.group(1)) - 1 if hit else None
        if p.name.startswith("pretension") and (driven.all() if k is None else driven[k]):
            which = "every tendon" if k is None else f"tendon {k + 1}"
            raise SettingsError("parameters", f": {p.name} offsets a tension, but the data drive {which} by its "
                                              "pull-in (DK_m columns): fit displacement_offset instead")
        if (p.name.startswith("displacement_offset") or p.name == "tendon_stiffness") and not (
                driven.any() if k is None else driven[k]):
            which = "no tendon" if k is None else f"not tendon {k + 1}"
            raise SettingsError("parameters", f": {p.name} acts on tendons driven by displacement, and the data "
                                              f"drive {which} so (give DK_m columns)")
    lo, hi = problem.bounds()
    for p, a, b in zip(problem.params, lo, hi, strict=True):
        if not a <= p.initial <= b:
            raise SettingsError("parameters", f": {p.name} starts at {p.initial:g} {p.unit}, outside the range the "
                                              f"fit allows, [{a:g}, {b:g}] {p.unit}")


def _least_squares(problem: Problem, options: CalibrationOptions, progress: Progress | None
                   ) -> tuple[np.ndarray, bool, str, int]:
    """Fit from the initial values: (values, converged, message, evaluations)."""
    x0, scale = problem.initial, problem.scales
    lo, hi = problem.bounds()
    cache: dict[bytes, list] = {}
    failed = [0]
    size = problem.n_residuals

    def values(x: np.ndarray) -> np.ndarray:  # x = 1 + (value - initial) / scale: the optimiser's first trust
        return np.clip(x0 + (x - 1.0) * scale, lo, hi)  # region is |x0| (SciPy), one scale step per parameter

    def fun(x: np.ndarray) -> np.ndarray:
        try:
            sols = problem.solutions(values(x))
        except (RowFailure, ValueError):  # ValueError: values the robot refuses (a bound met by round-off)
            failed[0] += 1
            return np.full(size, 1e6)  # a trial step into parameters without equilibria: rejected, shorter
        cache.clear()
        cache[x.tobytes()] = sols
        r = problem.residuals(values(x), sols)
        if progress is not None:
            progress(f"RMS whitened residual {np.sqrt(np.mean(r ** 2)):.4g}")
        return r

    def jac(x: np.ndarray) -> np.ndarray:
        sols = cache.get(x.tobytes()) or problem.solutions(values(x))
        return problem.jacobian(values(x), sols) * scale

    start = np.ones_like(x0)
    fit = least_squares(fun, start, jac=jac, bounds=(1.0 + (lo - x0) / scale, 1.0 + (hi - x0) / scale),
                        method="trf", loss=options.loss, f_scale=options.loss_scale, max_nfev=options.max_evaluations,
                        ftol=options.tolerance, xtol=options.tolerance, gtol=options.tolerance)
    message = str(fit.message)
    if failed[0]:
        message += f" ({failed[0]} trial steps left some row without an equilibrium)"
    return values(fit.x), bool(fit.status > 0), message, int(fit.nfev)


def _named(params: tuple[Parameter, ...], vector: np.ndarray) -> str:
    parts = [f"{p.name} ({c:+.2f})" for p, c in sorted(zip(params, vector, strict=True), key=lambda t: -abs(t[1]))
             if abs(c) >= 0.3]
    return " and ".join(parts) if parts else params[int(np.argmax(np.abs(vector)))].name


#: a normalised singular value at or below this is a direction the data do not move at all (numerically zero)
_NULL = 1e-12


def _statistics(problem: Problem, values: np.ndarray, jac: np.ndarray, r: np.ndarray, options: CalibrationOptions
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Standard errors (n,) in each parameter's unit, the correlation (n, n), the normalised singular values and
    the identifiability warnings (module docstring).

    A parameter the data do not depend on (a zero column) is set aside; the covariance of the others is the
    pseudo-inverse over the directions the data move, and only the parameters making up a direction they do not
    move at all get no error (inf) and no correlation (NaN)."""
    params, n = problem.params, values.size
    a = jac * problem.scales  # per unit step of each parameter's scale
    s2 = 1.0 if options.absolute_sigma else float(r @ r) / max(r.size - n, 1)
    norms = np.linalg.norm(a, axis=0)
    live = np.flatnonzero(norms > 0)
    warnings = [f"{params[i].name}: the data do not depend on it at all; fix it or add data that move it"
                for i in np.flatnonzero(norms == 0)]
    rel = np.zeros(n)
    cov = np.full((n, n), np.nan)
    if live.size:
        _, sv, vt = np.linalg.svd(a[:, live] / norms[live], full_matrices=False)
        rel[: sv.size] = sv / sv[0]
        kept = rel[: sv.size] > _NULL
        named = tuple(params[i] for i in live)
        for s, v in zip(rel[: sv.size], vt, strict=True):
            if s < options.identifiability:
                warnings.append(f"the data do not determine {_named(named, v)} apart (normalised singular value "
                                f"{s:.2g} < {options.identifiability:g}): fix one of them or add data that move them "
                                "differently")
        sub = (vt[kept].T / sv[kept] ** 2) @ vt[kept] / np.outer(norms[live], norms[live])  # per unit scale
        lost = np.any(np.abs(vt[~kept]) > 1e-6, axis=0)  # parameters in a direction the data do not move
        sub[lost, :] = sub[:, lost] = np.nan
        cov[np.ix_(live, live)] = sub
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    se = np.sqrt(np.abs(np.diag(cov)) * s2) * problem.scales
    se = np.where(np.isfinite(se), se, np.inf)
    for p, v, e in zip(params, values, se, strict=True):
        if p.initial > 0 and np.isfinite(e) and e > abs(v):
            warnings.append(f"{p.name}: its standard error {e:.3g} {p.unit} exceeds its value {v:.3g} {p.unit}; "
                            "the data barely determine it")
    return se, corr, rel, warnings


@dataclass(frozen=True)
class FitStage:
    """The fit's outcome: the values (in each parameter's unit), whether it converged, the optimiser's account, its
    evaluations and the solves it took. JSON-ready with :meth:`to_json` (a run's journal)."""

    values: np.ndarray
    converged: bool
    message: str
    evaluations: int
    solves: int

    def to_json(self) -> JsonDict:
        """JSON-ready."""
        return {"values": self.values.tolist(), "converged": self.converged, "message": self.message,
                "evaluations": self.evaluations, "solves": self.solves}

    @classmethod
    def from_json(cls, d: JsonObject) -> FitStage:
        """The stage :meth:`to_json` wrote."""
        return cls(np.array(d["values"], dtype=float), bool(d["converged"]), str(d["message"]),
                   int(d["evaluations"]), int(d["solves"]))


@dataclass(frozen=True)
class FoldStage:
    """One cross-validation fold: its held-out rows (0-based), their tip errors [m] predicted by a fit to the
    other rows (NaN where it failed), whether that fit converged, and the solves it took."""

    rows: np.ndarray
    errors_m: np.ndarray
    converged: bool
    solves: int

    def to_json(self) -> JsonDict:
        """JSON-ready (a NaN error as null)."""
        return {"rows": self.rows.tolist(), "errors_m": [None if not np.isfinite(e) else float(e)
                                                         for e in self.errors_m],
                "converged": self.converged, "solves": self.solves}

    @classmethod
    def from_json(cls, d: JsonObject) -> FoldStage:
        """The stage :meth:`to_json` wrote."""
        return cls(np.array(d["rows"], dtype=int), np.array([np.nan if e is None else e for e in d["errors_m"]],
                                                            dtype=float), bool(d["converged"]), int(d["solves"]))


@dataclass(eq=False)
class Calibration:
    """A calibration checked and ready (:func:`prepare`): its stages, each a function of the inputs alone, so that a
    run can keep each one's outcome and resume (:func:`pytdcr.runs.run_calibration`): :meth:`fit`, :meth:`fold`
    for each of ``options.folds``, then :meth:`result`.

    Attributes
    ----------
    problem : Problem
    options : CalibrationOptions
    before : list of StaticSolution
        Each row's equilibrium with the initial values.
    started : float
        ``time.perf_counter()`` when it was prepared.
    """

    problem: Problem
    options: CalibrationOptions
    before: list[StaticSolution]
    started: float

    def fit(self, progress: Progress | None = None) -> FitStage:
        """Fit every row; ``progress`` hears of each evaluation."""
        values, converged, message, evaluations = _least_squares(self.problem, self.options, progress)
        return FitStage(values, converged, message, evaluations, self.problem.solves)

    def fold(self, k: int) -> FoldStage:
        """Fold ``k`` (0-based) of the cross-validation: its rows predicted by a fit to the others."""
        p, o = self.problem, self.options
        b = p.data.n_rows
        test = np.sort(np.random.default_rng(o.seed).permutation(b)[k::o.folds])
        train = np.setdiff1d(np.arange(b), test)
        fit = Problem(p.robot, p.data.subset(train), p.params, p.model, p.options, p.stiffness)
        held = Problem(p.robot, p.data.subset(test), p.params, p.model, p.options, p.stiffness)
        try:
            values, ok, _, _ = _least_squares(fit, o, None)
            errors = held.tip_errors(values, held.solutions(values))[1]
        except (RowFailure, ValueError):  # a fold's fit or prediction without equilibria: its rows stay NaN
            ok, errors = False, np.full(test.size, np.nan)
        return FoldStage(test, errors, ok, fit.solves + held.solves)

    def result(self, fit: FitStage, folds: Sequence[FoldStage] = ()) -> CalibrationResult:
        """The :class:`CalibrationResult` of the fit's outcome and the folds' (their errors, statistics and the
        fitted robot, evaluated here)."""
        problem, options = self.problem, self.options
        values, converged, message = fit.values, fit.converged, fit.message
        solves0 = problem.solves
        try:
            after = problem.solutions(values)
        except RowFailure as e:
            after, converged, values = self.before, False, problem.initial
            message += f"; at the fitted values {e}"
        jac = problem.jacobian(values, after)
        r = problem.residuals(values, after)
        se, corr, rel, warnings = _statistics(problem, values, jac, r, options)
        if not converged:
            warnings.insert(0, f"the fit did not converge: {message}")
        tips_before, errors_before = problem.tip_errors(problem.initial, self.before)
        tips_after, errors_after = problem.tip_errors(values, after)
        lo, hi = problem.bounds()
        fitted = tuple(FittedParameter(p.name, p.unit, p.initial, float(v), float(e), float(a), float(b),
                                       bool(min(v - a, b - v) <= 1e-6 * min(p.scale, b - a)))
                       for p, v, e, a, b in zip(problem.params, values, se, lo, hi, strict=True))
        cv = _cross_validation(folds, problem.data.n_rows, errors_before) if folds else None
        k = problem.stiffness
        return CalibrationResult(
            model=problem.model.name, parameters=fitted, correlation=corr, singular_values=rel,
            warnings=tuple(warnings), converged=converged, message=message, evaluations=fit.evaluations,
            solves=fit.solves + problem.solves - solves0 + sum(f.solves for f in folds), chi2=float(r @ r),
            dof=int(r.size - values.size), predicted_before=tips_before, predicted_after=tips_after,
            errors_before_m=errors_before, errors_after_m=errors_after, cross_validation=cv,
            robot=problem.setting(values).robot(problem.robot), data_source=problem.data.source,
            data_sha256=problem.data.sha256,
            settings={**asdict(options), "parameters": [p.name for p in problem.params],
                      "stiffness_n_per_m": [float(v) if np.isfinite(v) else None for v in k]},
            seconds=time.perf_counter() - self.started)


def _cross_validation(folds: Sequence[FoldStage], n_rows: int, errors_before: np.ndarray) -> CrossValidation:
    """The folds' held-out errors as one :class:`CrossValidation`."""
    errors = np.full(n_rows, np.nan)
    for f in folds:
        errors[f.rows] = f.errors_m
    finite = np.isfinite(errors)
    rms = float(np.sqrt(np.mean(errors[finite] ** 2))) if finite.any() else float("nan")
    return CrossValidation(folds=len(folds), errors_m=errors, rms_m=rms,
                           rms_before_m=float(np.sqrt(np.mean(errors_before ** 2))),
                           failed_folds=sum(not f.converged for f in folds))


def prepare(robot: Robot, data: Measurements, fit: list[str] | tuple[str, ...], *, model: str | Model = "pcc",
            options: CalibrationOptions | None = None, model_options: ModelOptions | None = None,
            stiffness: float | Sequence[float | None] | None = None) -> Calibration:
    """The checks of :func:`calibrate` and each row's equilibrium with the initial values: a
    :class:`Calibration` whose stages a run takes one by one (same arguments and errors as :func:`calibrate`)."""
    started = time.perf_counter()
    options = options or CalibrationOptions()
    m, mopts = _fit_model(robot, model, model_options)
    try:
        k = tendon_stiffness(robot, stiffness)
    except ValueError as err:
        raise SettingsError.about("stiffness", err) from None
    params = parameters(robot, list(fit), k)
    if options.folds > data.n_rows:
        raise SettingsError("folds", f" = {options.folds}: must be at most the number of rows ({data.n_rows})")
    problem = Problem(robot, data, params, m, mopts, k)
    _check_fit(problem)
    try:
        before = problem.solutions(problem.initial)
    except RowFailure as e:
        raise SettingsError("data", f" ({data.source}): row {e.row + 1}: the '{m.name}' model finds no equilibrium "
                            f"for this row's inputs with the initial parameters (residual {e.residual:.3g} N m); drop "
                            "the row or check its tensions") from None
    return Calibration(problem, options, before, started)


def calibrate(robot: Robot, data: Measurements, fit: list[str] | tuple[str, ...], *, model: str | Model = "pcc",
              options: CalibrationOptions | None = None, model_options: ModelOptions | None = None,
              stiffness: float | Sequence[float | None] | None = None,
              progress: Progress | None = None) -> CalibrationResult:
    """Fit the parameters named in ``fit`` of ``robot`` and ``model`` to ``data``.

    Parameters
    ----------
    robot : Robot
        The robot as believed before the fit: the parameters' initial values and everything held fixed.
    data : Measurements
        Rows of inputs and measured poses (:func:`read_measurements`, :meth:`Measurements.from_arrays`).
    fit : list of str
        Parameter names (:data:`PARAMETER_HELP`), e.g. ``["youngs_modulus", "friction.mu0", "base_z"]``.
    model : str or Model
        A registered model with exact derivatives: ``"pcc"``, ``"pcc2"`` or ``"sscr"``.
    options : CalibrationOptions, optional
    model_options : the model's options, optional
    stiffness : float, sequence or None
        The tendons' axial stiffness [N/m] for rows driven by displacement (:func:`pytdcr.solve_displacements`;
        default: the robot's own, inextensible where a tendon has none); the initial value of
        ``tendon_stiffness`` when that is fitted.
    progress : callable, optional
        Called with a line after each evaluation of the fit and each cross-validation fold.

    Returns
    -------
    CalibrationResult
        Check ``converged`` and ``warnings``.

    Raises
    ------
    SettingsError
        A parameter the robot cannot take, or a row without an equilibrium at the initial values (named).
    UnsupportedFeatureError
        A model without exact derivatives.
    """
    cal = prepare(robot, data, fit, model=model, options=options, model_options=model_options, stiffness=stiffness)
    stage = cal.fit(progress)
    folds = []
    for k in range(cal.options.folds):
        folds.append(cal.fold(k))
        if progress is not None:
            progress(f"held-out fold {k + 1} of {cal.options.folds}")
    return cal.result(stage, folds)

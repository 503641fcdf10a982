"""The explorer's target point: answered by inverse statics where the model can (:func:`pytdcr.inverse_statics`,
a model with a tip gradient in the registry), else by the nearest converged, stable sample of a workspace run.

An answer found by inverse statics is then checked against the pose on the page: the tensions moved straight
from the last equilibrium shown to the answer's, continued (``pytdcr.solve(..., start=last)``), reach the same
equilibrium (``path`` ``"continued"``: the robot on the page gets there by moving its tendons) or not (the
answer's own path: ``"loading path"``, from rest, or ``"another branch"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import InversePath, InverseSearch, inverse_statics
from ..results import StaticSolution
from ..robot import Robot
from ..statics import Model, solve

__all__ = ["CONTINUED", "INVERSE", "SAME_TIP_M", "SAMPLE", "SEARCH", "NearestSample", "TargetAnswer",
           "answer_by_inverse", "answer_by_sample", "can_inverse", "nearest_sample", "show_distance"]

#: two tips closer than this are the same equilibrium [m]
SAME_TIP_M = 1e-6
#: how inverse statics searches from the page: the library's defaults (a tip within ``SEARCH.tol`` [m] reaches)
SEARCH = InverseSearch()
#: the methods of an answer
INVERSE, SAMPLE = "inverse statics", "nearest workspace sample"
#: the path of an inverse answer the page's robot reaches from its last pose by moving its tensions
CONTINUED = InversePath.CONTINUED


@dataclass(frozen=True, eq=False)
class NearestSample:
    """The workspace sample whose tip lies nearest a target: its tensions (n_tendons,) [N], its recorded tip
    (3,) [m], that tip's distance from the target [m], its index among the samples and how many there were."""

    tensions: np.ndarray
    tip: np.ndarray
    distance_m: float
    index: int
    count: int


@dataclass(frozen=True, eq=False)
class TargetAnswer:
    """How a target was answered.

    Attributes
    ----------
    target : ndarray, shape (3,)
        The point asked for [m], base frame.
    method : str
        :data:`INVERSE` or :data:`SAMPLE`.
    reached : bool
        The tip drawn lies within ``SEARCH.tol`` of the target (never claimed for a sample).
    distance_m : float
        The drawn tip's distance from the target [m] (NaN when nothing converged).
    path : str
        :data:`CONTINUED`, ``"loading path"`` or ``"another branch"`` (inverse statics); the solver's path of
        the sample's tensions solved from rest.
    evaluations : int
        Solves spent.
    note : str
        What else the page should say (the continuation from the last pose, the nearest sample's distance).
    sample : NearestSample or None
        The nearest workspace sample, when a run is loaded.
    departs : bool
        A pose was shown, and moving its tendons straight to the answer's tensions does not end on the answer's
        equilibrium (another one, or no converged one): the page's robot does not get there by continuation.
    """

    target: np.ndarray
    method: str
    reached: bool
    distance_m: float
    path: str
    evaluations: int
    note: str = ""
    sample: NearestSample | None = None
    departs: bool = False


def can_inverse(model: Model) -> bool:
    """Whether ``model`` can answer by inverse statics: its registered capabilities give a tip gradient."""
    return model.capabilities.gradient is not None


def nearest_sample(tensions: np.ndarray, tips: np.ndarray, target: np.ndarray) -> NearestSample:
    """The sample of ``tensions`` (K, n_tendons) [N] and ``tips`` (K, 3) [m] whose tip lies nearest ``target``
    (3,) [m]; ValueError when there is none."""
    tips = np.asarray(tips, dtype=float)
    if tips.ndim != 2 or tips.shape[0] == 0 or tips.shape[1] != 3 or len(tensions) != tips.shape[0]:
        raise ValueError("samples: give K >= 1 tensions and K tips (K, 3) [m]")
    d = np.linalg.norm(tips - np.asarray(target, dtype=float), axis=1)
    k = int(np.argmin(d))
    return NearestSample(np.array(tensions[k], dtype=float), tips[k].copy(), float(d[k]), k, int(d.size))


def show_distance(metres: float) -> str:
    """A distance [m] as text: in nm below 1 µm, in µm below 1 mm, else in mm to 0.1 mm (the page's rounding of
    positions)."""
    if not np.isfinite(metres):
        return "-"
    if metres < 1e-6:
        return f"{metres * 1e9:.3g} nm"
    return f"{metres * 1e6:.3g} µm" if metres < 1e-3 else f"{metres * 1e3:.1f} mm"


def _sample_note(sample: NearestSample | None) -> str:
    if sample is None:
        return ""
    return (f"nearest workspace sample (of {sample.count} converged, stable): recorded tip "
            f"{show_distance(sample.distance_m)} from the target")


def answer_by_inverse(robot: Robot, loads: Loads, model: Model, bounds: TensionBounds, target: np.ndarray,
                      last: StaticSolution | None,
                      sample: NearestSample | None = None) -> tuple[TargetAnswer, StaticSolution, np.ndarray]:
    """The target answered by :func:`pytdcr.inverse_statics` (``robot`` under ``loads``, their tensions ignored,
    inside ``bounds``, with ``model``): the answer, its equilibrium and its tensions [N].

    With ``last`` (the pose on the page, one ``model`` can continue) the answer's tensions are also reached by
    continuation from it; where that ends on the same equilibrium (tips within :data:`SAME_TIP_M`) the path is
    :data:`CONTINUED`. ValueError from inverse statics (a model that cannot, no start converged) passes on.
    """
    res = inverse_statics(robot, loads, target, bounds=bounds, model=model, search=SEARCH)
    if not res.converged:
        raise ValueError("inverse statics: no start converged")
    path, count, notes = res.path, res.evaluations, []
    if last is not None:
        try:
            moved = solve(robot, loads.with_tensions(res.tensions), model=model, start=last)
        except ValueError:  # the last state cannot be continued to these loads
            moved = None
        count += 1
        if moved is not None and moved.converged:
            gap = float(np.linalg.norm(moved.tip_position - res.tip_position))
            if gap <= SAME_TIP_M:
                path = CONTINUED
            else:
                notes.append(f"moving the tensions straight there from the last pose ends on another equilibrium "
                             f"(tip {show_distance(gap)} from this one)")
        else:
            notes.append("moving the tensions straight there from the last pose does not converge")
    sol = res.solution
    assert sol is not None  # a search's own answer holds its equilibrium (only a result read from JSON lacks it)
    notes.append(_sample_note(sample))
    answer = TargetAnswer(np.array(target, dtype=float), INVERSE, bool(res.reachable),
                          float(np.linalg.norm(sol.tip_position - target)), path, count,
                          "; ".join(n for n in notes if n), sample, departs=last is not None and path != CONTINUED)
    return answer, sol, res.tensions


def answer_by_sample(robot: Robot, loads: Loads, model: Model, bounds: TensionBounds, target: np.ndarray,
                     sample: NearestSample) -> tuple[TargetAnswer, StaticSolution, np.ndarray]:
    """The target answered by the nearest workspace ``sample``: its tensions (clipped into ``bounds``) solved from
    rest, as the run solved them, under the page's ``robot``, ``loads`` and ``model``; the answer, that
    equilibrium and the tensions [N]. Never marked reached: a sample is the nearest recorded, not a search."""
    t = bounds.clip(sample.tensions)
    sol = solve(robot, loads.with_tensions(t), model=model)
    gap = float(np.linalg.norm(sol.tip_position - target)) if sol.converged else float("nan")
    answer = TargetAnswer(np.array(target, dtype=float), SAMPLE, False, gap, sol.path, 1, _sample_note(sample),
                          sample)
    return answer, sol, t

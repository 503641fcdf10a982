"""The one result type of the reach search."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..runtime import to_jsonable

__all__ = ["Optimum", "ReachResult", "SearchFailed"]


class SearchFailed(RuntimeError):
    """A reach search that found no converged (and, if asked, stable) tension vector to report."""


@dataclass(frozen=True, eq=False)
class Optimum:
    """A tension vector and the equilibrium it reaches.

    Attributes
    ----------
    tensions : ndarray, shape (n_tendons,)
        Actuator tensions [N].
    tip_position : ndarray, shape (3,)
        [m]
    reach : float
        ||tip|| [m].
    cost : float
        The problem's minimised cost: 1/reach [1/m], or -d . tip [m] along a direction.
    stable : bool or None
        The equilibrium's static stability (None: the model has no such test).
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    reach: float
    cost: float
    stable: bool | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (:func:`pytdcr.runtime.to_jsonable`, the rule of every JSON file and answer: lists of
        floats, no -0.0, a non-finite number as None)."""
        return to_jsonable({"tensions": self.tensions, "tip_position": self.tip_position, "reach": self.reach,
                            "cost": self.cost, "stable": self.stable})


@dataclass(frozen=True, eq=False)
class ReachResult:
    """Outcome of :func:`~pytdcr.optimize.maximize_reach` and :func:`~pytdcr.optimize.polish_reach`.

    The top-level fields describe the final optimum (after the gradient
    polish, when there was one).

    Attributes
    ----------
    tensions : ndarray, shape (n_tendons,)
        The optimum's actuator tensions [N].
    tip_position : ndarray, shape (3,)
        [m]
    reach : float
        ||tip|| [m].
    cost : float
        The minimised cost (1/reach [1/m] for the paper's objective, -d . tip [m] along d).
    value : float
        What is maximised: the reach, or d . tip [m].
    stable : bool or None
        Whether the optimum is statically stable (None: the model has no such test). With
        ``ReachProblem(stable_only=True)`` unstable equilibria are infeasible.
    converged : bool
        The optimum's own solve converged *and* the stopping rule was met.
    stop_reason : str
        Why the search ended: ``"tolerance"`` (the best cost changed by less
        than the tolerance over the window), ``"generation cap"``, or the
        local optimiser's report for a polish alone.
    generations : int
        GA generations (0 for a polish alone).
    evaluations : int
        Model solves of the GA and its local searches (the final polish's are
        in ``polish_evaluations``).
    nonconverged : int
        GA evaluations whose solve did not converge (infeasible individuals).
    rejected_unstable : int
        GA evaluations that converged but were refused as unstable (with ``stable_only``; 0 without it): a
        count of rejected individuals, not a verdict on the optimum (that is ``stable``).
    seconds : float
        Wall time of the whole search [s].
    seed : int or None
    history : dict
        Per generation: ``best`` and ``mean`` feasible cost, cumulative
        ``evaluations``, ``nonconverged``, ``local_search_evaluations``.
    ga : Optimum or None
        The GA's best before the final polish (the start point for a polish alone).
    polish_gain : float
        Cost of ``ga`` minus the final cost (>= 0 when the polish improved it; 0 without a polish).
    polish_evaluations : int
    polish_message : str
    settings : dict
        The problem's and the algorithm's settings.
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    reach: float
    cost: float
    value: float
    stable: bool | None
    converged: bool
    stop_reason: str
    generations: int
    evaluations: int
    nonconverged: int
    seconds: float
    seed: int | None
    history: dict[str, list[float]]
    ga: Optimum | None
    polish_gain: float = 0.0
    polish_evaluations: int = 0
    polish_message: str = ""
    rejected_unstable: int = 0
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def polished(self) -> bool:
        """True when a gradient polish produced the final optimum."""
        return self.polish_evaluations > 0

    @property
    def optimum(self) -> Optimum:
        """The final optimum as an :class:`Optimum`."""
        return Optimum(self.tensions, self.tip_position, self.reach, self.cost, self.stable)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the keys of ``tdcr optimize --json``), by :func:`pytdcr.runtime.to_jsonable`'s rule:
        no -0.0 in it, a non-finite number as None."""
        return to_jsonable({
            **self.optimum.to_dict(),
            "value": self.value,
            "converged": self.converged,
            "stop_reason": self.stop_reason,
            "generations": self.generations,
            "evaluations": self.evaluations,
            "nonconverged": self.nonconverged,
            "rejected_unstable": self.rejected_unstable,
            "seconds": self.seconds,
            "seed": self.seed,
            "history": self.history,
            "ga": None if self.ga is None else self.ga.to_dict(),
            "polish": {"cost_change": self.polish_gain, "evaluations": self.polish_evaluations,
                       "message": self.polish_message},
            "settings": self.settings,
        })

"""The one result type of the reach search, :class:`ReachResult`, and its typed parts.

JSON happens at one boundary: :meth:`ReachResult.to_json` is what ``tdcr optimize --json`` prints and what
``optimize.json`` holds under ``result`` (the keys of every file written before, plus ``schema_version``), and
:meth:`ReachResult.from_json` reads it back. A missing key raises :class:`~pytdcr.records.RecordKeyError` naming
its path (``polish.evaluations``); absent times (``seconds``, as the golden baselines drop them) read as 0.

Two fields stay mappings because the searches that build them (:func:`~pytdcr.optimize.maximize_reach`,
:func:`~pytdcr.optimize.polish_reach`) write them so and callers index them: ``history`` (per generation; empty
for a polish alone) and ``settings`` (the problem's and the algorithm's settings, passed through to the file).
Their typed views are :attr:`ReachResult.per_generation` (:class:`SearchHistory`) and
:attr:`ReachResult.ga_settings` (:class:`GASettings`); the polish's numbers are :attr:`ReachResult.polish`
(:class:`PolishOutcome`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from ..records import JsonDict, JsonObject, check_schema, optional_part, part
from ..runtime import to_jsonable

__all__ = ["SCHEMA_VERSION", "GASettings", "Optimum", "PolishOutcome", "ReachResult", "SearchFailed",
           "SearchHistory"]

#: the layout of a reach result's JSON (``tdcr optimize --json``, ``result`` of ``optimize.json``)
SCHEMA_VERSION = 1

#: the record errors name
_FILE = "reach result"
_read = partial(part, _FILE)
_optional = partial(optional_part, _FILE)


def _number(x: float | None) -> float:
    """A float of a JSON file: null (a non-finite number, :func:`~pytdcr.runtime.to_jsonable`) as NaN."""
    return float("nan") if x is None else float(x)


def _floats(x: list[float | None]) -> np.ndarray:
    """A JSON list of numbers (nested or not) as a float array, null as NaN."""
    return np.array(x, dtype=float)


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

    def to_dict(self) -> JsonDict:
        """JSON-ready form (:func:`pytdcr.runtime.to_jsonable`, the rule of every JSON file and answer: lists of
        floats, no -0.0, a non-finite number as None)."""
        return to_jsonable({"tensions": self.tensions, "tip_position": self.tip_position, "reach": self.reach,
                            "cost": self.cost, "stable": self.stable})

    @classmethod
    def from_json(cls, d: JsonObject) -> Optimum:
        """The optimum :meth:`to_dict` wrote (a null number read as NaN); KeyError naming a missing key."""
        stable = d["stable"]
        return cls(_floats(d["tensions"]), _floats(d["tip_position"]), _number(d["reach"]), _number(d["cost"]),
                   None if stable is None else bool(stable))


@dataclass(frozen=True)
class PolishOutcome:
    """The final gradient polish of a reach search (``polish`` of its JSON).

    Attributes
    ----------
    cost_change : float
        The GA's best cost minus the final cost (>= 0 when the polish improved it; 0 without a polish) [1/m, or
        m along a direction].
    evaluations : int
        Its model solves (0 without a polish).
    message : str
        The local optimiser's report ("" without a polish).
    """

    cost_change: float
    evaluations: int
    message: str

    def to_json(self) -> JsonDict:
        """JSON-ready form (keys ``cost_change``, ``evaluations``, ``message``)."""
        return {"cost_change": self.cost_change, "evaluations": self.evaluations, "message": self.message}

    @classmethod
    def from_json(cls, d: JsonObject) -> PolishOutcome:
        """What :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(_number(d["cost_change"]), int(d["evaluations"]), str(d["message"]))


#: the per-generation counts of a result's ``history`` (its other entries are costs)
_COUNTS = ("evaluations", "nonconverged", "local_search_evaluations")


def _history_from_json(h: JsonObject) -> dict[str, list[float]]:
    """A result's ``history`` from its JSON: counts as integers, costs as floats (null as NaN)."""
    return {str(k): [int(x) if k in _COUNTS else _number(x) for x in v] for k, v in h.items()}


@dataclass(frozen=True, eq=False)
class SearchHistory:
    """The GA's progress, one entry per generation (all empty for a polish alone).

    Attributes
    ----------
    best, mean : ndarray, shape (generations,)
        The best and the mean feasible cost of the population [1/m, or m along a direction]; inf when none is
        feasible (NaN when read back from JSON, which holds either as null).
    evaluations : tuple of int
        Model solves so far (cumulative).
    nonconverged : tuple of int
        The generation's solves that did not converge.
    local_search_evaluations : tuple of int
        Solves of the local searches so far (cumulative).
    """

    best: np.ndarray
    mean: np.ndarray
    evaluations: tuple[int, ...]
    nonconverged: tuple[int, ...]
    local_search_evaluations: tuple[int, ...]

    @classmethod
    def of(cls, history: JsonObject) -> SearchHistory:
        """The typed view of a result's ``history`` mapping (empty parts where a key is absent)."""
        return cls(_floats(list(history.get("best", []))), _floats(list(history.get("mean", []))),
                   *(tuple(int(x) for x in history.get(k, [])) for k in _COUNTS))


@dataclass(frozen=True)
class GASettings:
    """The settings of the GA a result records in ``settings`` (beside the problem's: model, bounds, objective).

    Attributes
    ----------
    pop_size : int
    tol : float
        The stopping tolerance on the best cost over ``window`` generations.
    window, max_gen : int
        The stopping window and the generation cap.
    polish, local_search : bool
        Whether the final gradient polish and the memetic local searches ran.
    local_search_runs : int
        Local searches run.
    """

    pop_size: int
    tol: float
    window: int
    max_gen: int
    polish: bool
    local_search: bool
    local_search_runs: int

    @classmethod
    def from_json(cls, d: JsonObject) -> GASettings:
        """Read from a result's ``settings``; KeyError naming a missing key."""
        return cls(int(d["pop_size"]), float(d["tol"]), int(d["window"]), int(d["max_gen"]), bool(d["polish"]),
                   bool(d["local_search"]), int(d["local_search_runs"]))


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

    @property
    def polish(self) -> PolishOutcome:
        """The final polish's cost change, solves and message."""
        return PolishOutcome(self.polish_gain, self.polish_evaluations, self.polish_message)

    @property
    def per_generation(self) -> SearchHistory:
        """``history`` typed (empty for a polish alone)."""
        return SearchHistory.of(self.history)

    @property
    def ga_settings(self) -> GASettings | None:
        """The GA's settings from ``settings``; None for a polish alone (no GA ran)."""
        return GASettings.from_json(self.settings) if "pop_size" in self.settings else None

    def to_json(self) -> JsonDict:
        """JSON-ready summary (the keys of ``tdcr optimize --json`` and of ``optimize.json``'s ``result``, after
        ``schema_version``), by :func:`pytdcr.runtime.to_jsonable`'s rule: no -0.0 in it, a non-finite number as
        None."""
        return to_jsonable({
            "schema_version": SCHEMA_VERSION,
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
            "polish": self.polish.to_json(),
            "settings": self.settings,
        })

    def to_dict(self) -> JsonDict:
        """:meth:`to_json` (the name older code calls)."""
        return self.to_json()

    @classmethod
    def from_json(cls, d: JsonObject) -> ReachResult:
        """The result :meth:`to_json` wrote (or any ``optimize.json``'s ``result`` written before), a null number
        read as NaN and an absent ``seconds`` as 0. :class:`~pytdcr.records.RecordKeyError` naming the path of a
        missing key; ValueError for a part that is not a JSON object or another ``schema_version`` than
        :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> ReachResult:
            check_schema(d, _FILE, SCHEMA_VERSION)
            top = Optimum.from_json(d)
            polish = _read("polish", PolishOutcome.from_json, d["polish"])
            history = _read("history", _history_from_json, d["history"])
            seed = d["seed"]
            return cls(tensions=top.tensions, tip_position=top.tip_position, reach=top.reach, cost=top.cost,
                       value=_number(d["value"]), stable=top.stable, converged=bool(d["converged"]),
                       stop_reason=str(d["stop_reason"]), generations=int(d["generations"]),
                       evaluations=int(d["evaluations"]), nonconverged=int(d["nonconverged"]),
                       seconds=float(d.get("seconds", 0.0)), seed=None if seed is None else int(seed),
                       history=history, ga=_optional("ga", Optimum.from_json, d), polish_gain=polish.cost_change,
                       polish_evaluations=polish.evaluations, polish_message=polish.message,
                       rejected_unstable=int(d["rejected_unstable"]), settings=_read("settings", dict, d["settings"]))

        return _read("", read, d)

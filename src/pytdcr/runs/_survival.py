"""How much of the paper's result survives a better model: its optimum under ``pcc2`` and ``sscr``."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import MemeticGA, ReachProblem, ReachResult, Termination, maximize_reach, polish_reach
from ..records import JsonDict, JsonObject, optional_part
from ..robot import Robot
from ..runtime import end_stage, to_jsonable

if TYPE_CHECKING:
    from ._reproduce_records import OnGeneration, Progress, Step

__all__ = ["ModelVerdict", "model_verdicts", "verdict_text"]


@dataclass(frozen=True)
class ModelVerdict:
    """The paper's optimum (found with ``pcc``) seen by another model.

    Attributes
    ----------
    model : str
    converged : bool
        The other model's solve at the paper's optimal tensions converged.
    reach : float
        Its reach at those tensions [m] (NaN if not converged).
    tip_shift : float
        Distance between its tip and ``pcc``'s at those tensions [m].
    reoptimised : ReachResult or None
        Its own optimum: polished from the paper's (and, with a GA budget, searched afresh).
    method : str
        How the re-optimisation was done.
    """

    model: str
    converged: bool
    reach: float
    tip_shift: float
    reoptimised: ReachResult | None
    method: str

    def to_json(self) -> JsonDict:
        """A row of ``reproduce.json``'s ``better_models``: ``{"model", "converged", "reach", "tip_shift",
        "method", "reoptimised"}`` (a non-finite number as null, no re-optimisation as null)."""
        return to_jsonable({"model": self.model, "converged": self.converged, "reach": self.reach,
                            "tip_shift": self.tip_shift, "method": self.method,
                            "reoptimised": None if self.reoptimised is None else self.reoptimised.to_json()})

    def to_dict(self) -> JsonDict:
        """:meth:`to_json` (the name older code calls)."""
        return self.to_json()

    @classmethod
    def from_json(cls, d: JsonObject) -> ModelVerdict:
        """The row :meth:`to_json` wrote (a null reach or tip shift read as NaN); KeyError or
        :class:`~pytdcr.records.RecordKeyError` naming a missing key (``reoptimised.polish``)."""
        return cls(str(d["model"]), bool(d["converged"]), _number(d["reach"]), _number(d["tip_shift"]),
                   optional_part("reproduce.json", "reoptimised", ReachResult.from_json, d), str(d["method"]))


def _number(x: object) -> float:
    """A float of the file: null (a non-finite number as written) as NaN; ValueError for what is no number."""
    if x is None:
        return float("nan")
    if isinstance(x, (int, float)):
        return float(x)
    raise ValueError(f"reproduce.json: a number was expected, got {type(x).__name__}")


def model_verdicts(robot: Robot, loads: Loads, bounds: TensionBounds, best: ReachResult, *,
                   models: Sequence[str] = ("pcc2", "sscr"), budget: tuple[int, int] = (0, 8), seed: int = 0,
                   progress: Progress | None = None) -> list[ModelVerdict]:
    """Re-evaluate ``best`` (a ``pcc`` optimum) with each model, then re-optimise with it.

    ``budget`` is (``ga_pop``, ``polish_iter``). With ``ga_pop`` = 0 the re-optimisation is a gradient polish
    from ``best``'s tensions, at most ``polish_iter`` L-BFGS-B iterations (a modest budget); otherwise the
    memetic GA with that population, the polish starting from ``best`` too. ``progress(stage, total, unit)``, if
    given, is told each model's stage (the GA's generations, or the polish as one step).
    """
    ga_pop, polish_iter = budget
    out: list[ModelVerdict] = []
    for name in models:
        problem = ReachProblem.create(robot, loads, bounds, model=name)
        sol = problem.solve(best.tensions)
        reach = sol.reach if sol.converged else float("nan")
        shift = float(np.linalg.norm(sol.tip_position - best.tip_position)) if sol.converged else float("nan")
        stage: OnGeneration | Step | None = None  # the stage's callback, ended however the stage ends
        res: ReachResult | None
        try:
            if ga_pop:
                on_generation = progress(f"{name}: GA, population {ga_pop}", 30, "gen") if progress else None
                stage = on_generation
                res = maximize_reach(problem, MemeticGA(pop_size=ga_pop, extra_starts=(best.tensions,)),
                                     Termination(1e-6, 5, 30), seed=seed, on_generation=on_generation)
                method = f"memetic GA, population {ga_pop}, seed {seed}, polished also from the pcc optimum"
            else:
                step = progress(f"{name}: polish from the pcc optimum", 1, "run") if progress else None
                stage = step
                if step:
                    step(0)  # shown from its start
                res = polish_reach(problem, best.tensions, max_iter=polish_iter, restarts=0)
                if step:
                    step(1)
                method = f"gradient polish from the pcc optimum, at most {polish_iter} iterations"
        except RuntimeError:
            res, method = None, "re-optimisation failed: no converged solve"
        finally:
            end_stage(stage)
        out.append(ModelVerdict(name, bool(sol.converged), reach, shift, res, method))
    return out


def verdict_text(best: ReachResult, verdicts: Sequence[ModelVerdict]) -> list[str]:
    """The report's section."""
    lines = [
        "## The paper's optimum under better models",
        "",
        f"The optimum above is that of the paper's PCC model (`pcc`, each subsegment balanced about its base: "
        f"first order in the disk spacing): reach {best.reach:.6f} m. The same tensions solved by the second-order "
        "PCC (`pcc2`, balance at each subsegment's midpoint) and by the subsegment Cosserat rod (`sscr`, the "
        "reference: a rod between each pair of disks, tendons as chords), then re-optimised with each "
        "(`tdcr accuracy` tabulates the models' errors; docs/models.md derives them):",
        "",
        "| model | reach at the pcc optimum [m] | tip moves [mm] | own optimum: reach [m] | its tensions [N] | how |",
        "|---|---:|---:|---:|---|---|",
        f"| pcc | {best.reach:.6f} | 0 | {best.reach:.6f} | {np.round(best.tensions, 2).tolist()} | the study above |",
    ]
    for v in verdicts:
        r = v.reoptimised
        own = f"{r.reach:.6f}" if r is not None else "-"
        tens = str(np.round(r.tensions, 2).tolist()) if r is not None else "-"
        lines.append(f"| {v.model} | {v.reach:.6f} | {v.tip_shift * 1e3:.1f} | {own} | {tens} | {v.method} |")
    lines.append("")
    return lines

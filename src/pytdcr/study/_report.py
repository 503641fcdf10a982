"""The reproduction's ``report.md``, written from the data of the run."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..design import Robot
from ..optimize import ReachResult
from ..paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT, PAYLOAD_MASS
from ..runtime import default_threads

if TYPE_CHECKING:
    from ._reproduce import ReproduceRun, ReproduceSettings

__all__ = ["reproduce_report"]


def _bounds_comment(bound_study: list[tuple[float, ReachResult]]) -> str:
    reach = [r.reach for _, r in bound_study]
    active = [int(np.sum(np.isclose(r.tensions, hi))) for hi, r in bound_study]
    text = ("Tendons at the upper bound in the optimum: " + ", ".join(
        f"{a} of {len(bound_study[0][1].tensions)} at {hi:g} N" for (hi, _), a in zip(bound_study, active,
                                                                                     strict=True)) + ". ")
    if all(b >= a - 1e-9 for a, b in itertools.pairwise(reach)):
        text += ("The reach grows with the upper bound: more tension cancels more of the load's bending moment, "
                 "with diminishing returns once the tendons can hold the robot nearly straight against the load.")
    else:
        text += ("The reach does not grow monotonically with the upper bound although each set of bounds contains "
                 "the previous one: the optimiser missed the global optimum in at least one run (a wider box is "
                 "harder to search with the same budget).")
    return text


def _first_final(r: ReachResult, tol: float) -> int:
    """First generation whose best cost is within ``tol`` of the GA's final best."""
    final = r.ga.cost if r.ga is not None else r.cost
    return next((g + 1 for g, b in enumerate(r.history["best"]) if abs(b - final) < tol), r.generations)


def _beside_paper(ga: dict[int, ReachResult], tol: float) -> str:
    """The paper's Fig. 5 claim beside what these runs measured (written from the data)."""
    pop = next(iter(ga))
    r = ga[pop]
    met = r.stop_reason == "tolerance"
    text = (f"**Beside the paper.** The paper reports (its Fig. 5) that with population 50 the GA reached its "
            f"optimum by the fourth generation, to 1e-6. Here, with population {pop}, the best cost was final "
            f"(within {tol:g}) at generation {_first_final(r, tol)}; the stopping rule was "
            f"{'met' if met else 'not met (generation cap)'} at generation {r.generations}, after "
            f"{r.evaluations} model solves ({r.history['local_search_evaluations'][-1]} of them in the local "
            "searches).")
    if r.polished:
        moved = r.polish_gain
        text += (f" The final polish (several starts) then changed the cost by {moved:.1e} 1/m: "
                 + ("the GA had converged to that optimum." if abs(moved) < tol else
                    "it found a better optimum than the GA's."))
    finals = sorted({round(g_.reach, 6) for g_ in ga.values()})
    if len(finals) > 1:
        text += (f" The populations ended on {len(finals)} different optima (reach "
                 f"{', '.join(f'{x:.6f}' for x in finals)} m): the landscape has several local optima, separated "
                 "by kinks (friction regimes) and folds of the loading path, so which one a run settles in "
                 "depends on its initial population.")
    else:
        text += f" Every population ended on the same optimum (reach {finals[0]:.6f} m)."
    text += (" The GA is memetic: pymoo's GA explores, and each new leader is replaced by its local optimum from "
             "a gradient search (exact gradients by the implicit function theorem); `tdcr optimize --no-local-search` "
             "runs the plain GA. The paper's model has frame slips (its Eqs. 12-13) and gives no material values "
             "or bounds, so its optimum is not comparable number for number.")
    return text


def _ga_row(label: str, r: ReachResult) -> str:
    ga = r.ga if r.ga is not None else r.optimum
    first = _first_final(r, 1e-6)
    pr = f"{r.reach:.6f}" if r.polished else "-"
    pc = f"{r.polish_gain:.2e}" if r.polished else "-"
    return (f"| {label} | {ga.reach:.6f} | {ga.cost:.6f} | {pr} | {pc} | {first} | {r.generations} "
            f"{'(tol met)' if r.stop_reason == 'tolerance' else '(cap)'} | {r.evaluations} | {r.nonconverged} | "
            f"{r.seconds:.1f} |")


def _head(robot: Robot, run: ReproduceRun, bounds: TensionBounds, s: ReproduceSettings) -> list[str]:
    smp = run.sampling
    passive = run.passive
    return [
        "# Feasible static workspace of the paper robot: reproduction",
        "",
        f"Robot `{robot.name}`: {len(robot.segments)} segments, {robot.n_disks} disks, {robot.n_tendons} tendons, "
        f"length {robot.length} m; friction law `{robot.friction.law}`; gravity {list(robot.gravity)} m/s^2.",
        f"Tension bounds: [{bounds.lower[0]:g}, {bounds.upper[0]:g}] N per tendon (the paper gives none). "
        f"GA: pymoo GA (SBX crossover, polynomial mutation, tournament selection) with a gradient search on each "
        f"new leader (memetic; its solves are counted), seed {run.seed}; stop "
        f"when the best cost improves by less than {s.tol:g} 1/m over {s.window} generations, or at {s.max_gen} "
        f"({s.side_max_gen} for the payload and bounds studies). Each GA individual is one static solve along the "
        "loading path from the unloaded robot (the branch quasi-static loading reaches: a tension vector can "
        "have several equilibria under this load); a solve that does not converge makes it infeasible.",
        f"Whole run: {run.seconds:.1f} s on {default_threads()} cores.",
        "",
        "## Fig. 3(a), Fig. 4: random samples under the paper's load",
        "",
        f"{smp['n']} tension vectors uniform in the bounds, under tip force {PAPER_TIP_FORCE} N and tip moment "
        f"{PAPER_TIP_MOMENT} N m: {smp['converged']} converged; reach from {smp['reach_min']:.4f} to "
        f"{smp['reach_max']:.4f} m (`samples.csv`, `fig3a_samples.png`, `fig4_configurations.png`).",
        "",
        "## Fig. 3(b): the robot under the paper's load",
        "",
        (f"With every tension 0 the load alone puts the tip at {np.round(passive['tip'], 4).tolist()} m "
         f"(reach {passive['reach']:.4f} m): `fig3b_loaded.png`.") if passive["converged"]
        else "The passive solve did not converge (no figure).",
        "",
    ]


def _payload_text(robot: Robot, pay: ReachResult) -> str:
    ga = pay.ga if pay.ga is not None else pay.optimum
    return (f"Payload {PAYLOAD_MASS * 1e3:g} g at the tip (force (0, 0, {-PAYLOAD_MASS * 9.81:.4f}) N, along "
            f"gravity). GA (population {pay.settings['pop_size']}): reach {ga.reach:.6f} m after {pay.generations} "
            f"generations and {pay.evaluations} solves"
            + (f"; polished {pay.reach:.6f} m with tensions {np.round(pay.tensions, 3).tolist()} N"
               if pay.polished else "")
            + ". A robot pointing up carries a vertical payload axially: the straight robot reaches farthest, and "
            "any pair of equal antagonistic tensions keeps it straight, so the optimum is a whole set of tension "
            "vectors. The payload is kept below the straight robot's buckling load (about pi^2 EI / 4L^2 = "
            f"{np.pi**2 * robot.backbone.bending_stiffness / (4 * robot.length**2):.3f} N without gravity; the "
            "static model does not check the stability of an equilibrium).")


def reproduce_report(robot: Robot, run: ReproduceRun, bounds: TensionBounds, s: ReproduceSettings,
                     extra: Sequence[str] = ()) -> str:
    """The Markdown report of :func:`~pytdcr.study.run_reproduce`: its results ``run`` on ``robot`` within the
    paper's ``bounds``, at the budget ``s``; ``extra`` lines (the better models' and the workspace's sections)
    before the list of files."""
    ga, pay, bound_study = run.ga, run.payload, run.bounds_study
    head = ("| study | GA reach [m] | GA cost [1/m] | polished reach [m] | polish gain in cost | "
            "generation within 1e-6 of final | generations | model solves | not converged | time [s] |\n"
            "|---|---|---|---|---|---|---|---|---|---|")
    best = min(ga.values(), key=lambda r: r.cost)
    lines = [
        *_head(robot, run, bounds, s),
        "## Fig. 5: the GA under the paper's load",
        "",
        head,
        *[_ga_row(f"population {p}", r) for p, r in ga.items()],
        "",
        f"Best optimum found (after polishing): reach {best.reach:.6f} m with tensions "
        f"{np.round(best.tensions, 3).tolist()} N." if best.polished else "",
        f"Upper bound: the backbone length, {robot.length} m (cost {1 / robot.length:.2f} 1/m); no reach exceeds it.",
        "",
        _beside_paper(ga, s.tol),
        "",
        "## Fig. 6: the optimum under a vertical payload",
        "",
        _payload_text(robot, pay),
        "",
        "## How the optimum depends on the bounds",
        "",
        f"GA population {next(iter(ga))} for the other bounds, at most the side-study generation cap; at the "
        "default bounds the best of the main study's runs.",
        "",
        "| upper bound [N] | GA reach [m] | polished reach [m] | tensions at the polished optimum [N] |",
        "|---|---|---|---|",
        *[f"| {hi:g} | {(r.ga or r.optimum).reach:.6f} | {r.reach:.6f} | {np.round(r.tensions, 2).tolist()} |"
          if r.polished else f"| {hi:g} | {r.reach:.6f} | - | - |" for hi, r in bound_study],
        "",
        _bounds_comment(bound_study),
        "",
        *extra,
        "## Files",
        "",
        *[f"- `{f}`" for f in run.files],
        "- `reproduce.json`: every input, seed and result of this run",
        "",
    ]
    return "\n".join(lines)

"""The reproduction's ``report.md``, written from the typed result of the run (:class:`ReproduceRun`)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..optimize import ReachResult
from ..paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT, PAYLOAD_MASS, payload_gravity, payload_loads
from ..robot import Robot
from ..runtime import default_threads
from ..validate import direction_or_none, number_text

if TYPE_CHECKING:
    from ._reproduce import ReproduceSettings
    from ._reproduce_records import PassiveSolveRecord, ReproduceRun

__all__ = ["number_text", "reproduce_report"]


# number_text is the one rule for small non-zero numbers (pytdcr.validate); imported from here by pytdcr.runs

#: reaches closer than this [m] are the same in the report (its tables print 6 decimals)
SAME_REACH = 1e-6


def _bounds_trend(reach: Sequence[float], uppers: Sequence[float]) -> str:
    """How the reach moves as the upper bound widens, in words that claim no more than the numbers show: it
    "grows" only where every step raises it by more than :data:`SAME_REACH`."""
    steps = [b - a for a, b in itertools.pairwise(reach)]
    span = f"{reach[0]:.6f} m at {uppers[0]:g} N to {reach[-1]:.6f} m at {uppers[-1]:g} N"
    if all(abs(d) <= SAME_REACH for d in steps):
        return f"The reach stays the same at every upper bound ({reach[0]:.6f} m, within {SAME_REACH:g} m)."
    if any(d < -SAME_REACH for d in steps):
        return ("The reach does not grow monotonically with the upper bound although each set of bounds contains "
                "the previous one: the optimiser missed the global optimum in at least one run (a wider box is "
                "harder to search with the same budget).")
    if all(d > SAME_REACH for d in steps):
        widths = [h1 - h0 for h0, h1 in itertools.pairwise(uppers)]
        per_n = ([d / w for d, w in zip(steps, widths, strict=True)] if all(w > 0.0 for w in widths)
                 else [])  # an upper bound given twice: no rate per newton
        tail = (f", with diminishing returns ({', then '.join(f'{x * 1e3:.3g}' for x in per_n)} mm per N)"
                if len(per_n) > 1 and all(b < a for a, b in itertools.pairwise(per_n)) else "")
        return (f"The reach grows with the upper bound, from {span}{tail}: more tension can cancel more of the "
                "load's bending moment.")
    flat = [f"{h0:g} and {h1:g} N" for d, (h0, h1) in zip(steps, itertools.pairwise(uppers), strict=True)
            if abs(d) <= SAME_REACH]
    return (f"The reach does not decrease with the upper bound, from {span}, but stays the same (within "
            f"{SAME_REACH:g} m) between {'; between '.join(flat)}.")


def _bounds_comment(bound_study: list[tuple[float, ReachResult]]) -> str:
    """Which tendons sit at the upper bound in each optimum, and how the reach moves with that bound."""
    reach = [r.reach for _, r in bound_study]
    active = [int(np.sum(np.isclose(r.tensions, hi))) for hi, r in bound_study]
    text = ("Tendons at the upper bound in the optimum: " + ", ".join(
        f"{a} of {len(bound_study[0][1].tensions)} at {hi:g} N" for (hi, _), a in zip(bound_study, active,
                                                                                     strict=True)) + ". ")
    if len(bound_study) < 2:
        return text + "One upper bound only: nothing to compare across bounds."
    return text + _bounds_trend(reach, [hi for hi, _ in bound_study])


def _first_final(r: ReachResult, tol: float) -> int:
    """First generation whose best cost is within ``tol`` of the GA's final best."""
    final = r.ga.cost if r.ga is not None else r.cost
    return next((g + 1 for g, b in enumerate(r.per_generation.best) if abs(b - final) < tol), r.generations)


def _beside_paper(ga: dict[int, ReachResult], tol: float) -> str:
    """The paper's Fig. 5 claim beside what these runs measured (written from the data)."""
    pop = next(iter(ga))
    r = ga[pop]
    met = r.stop_reason == "tolerance"
    text = (f"**Beside the paper.** The paper reports (its Fig. 5) that with population 50 the GA reached its "
            f"optimum by the fourth generation, to 1e-6. Here, with population {pop}, the best cost was final "
            f"(within {tol:g}) at generation {_first_final(r, tol)}; the stopping rule was "
            f"{'met' if met else 'not met (generation cap)'} at generation {r.generations}, after "
            f"{r.evaluations} model solves ({r.per_generation.local_search_evaluations[-1]} of them in the local "
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
    return (f"| {label} | {ga.reach:.6f} | {ga.cost:.6f} | {pr} | {pc} | {_stable_cell(r.stable)} | {first} | "
            f"{r.generations} "
            f"{'(tol met)' if r.stop_reason == 'tolerance' else '(cap)'} | {r.evaluations} | {r.nonconverged} | "
            f"{r.seconds:.1f} |")


def _passive_text(passive: PassiveSolveRecord) -> str:
    """Fig. 3(b)'s sentence: where the load alone puts the tip, or that the solve did not converge."""
    if not passive.converged or passive.tip is None or passive.reach is None:
        return "The passive solve did not converge (no figure)."
    return (f"With every tension 0 the load alone puts the tip at {np.round(passive.tip, 4).tolist()} m "
            f"(reach {passive.reach:.4f} m): `fig3b_loaded.png`.")


def _head(robot: Robot, run: ReproduceRun, bounds: TensionBounds, s: ReproduceSettings) -> list[str]:
    smp = run.sampling
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
        f"{smp.n} tension vectors uniform in the bounds, under tip force {PAPER_TIP_FORCE} N and tip moment "
        f"{PAPER_TIP_MOMENT} N m: {smp.converged} converged; reach from {smp.reach_min:.4f} to "
        f"{smp.reach_max:.4f} m (`samples.csv`, `fig3a_samples.png`, `fig4_configurations.png`).",
        "",
        "## Fig. 3(b): the robot under the paper's load",
        "",
        _passive_text(run.passive),
        "",
    ]


def _stable_cell(stable: bool | None) -> str:
    """A table cell for an optimum's static stability."""
    return "untested" if stable is None else "yes" if stable else "**no**"


def _stability(stable: bool | None) -> str:
    """An optimum's static stability in words (the test of :attr:`ReachResult.stable`)."""
    if stable is None:
        return "the optimum's stability is untested (the model has no such test)"
    return "the optimum is statically stable" if stable else "the optimum is **flagged unstable**"


def _unstable_warning(run: ReproduceRun) -> list[str]:
    """A warning naming every optimum of the run flagged unstable (none: no line)."""
    named = [*((f"GA population {p}", r) for p, r in run.ga.items()), ("payload", run.payload),
             *((f"bounds [0, {hi:g}] N", r) for hi, r in run.bounds_study)]
    bad = [label for label, r in named if r.stable is False]
    if not bad:
        return []
    return [f"**Warning:** optimum flagged unstable: {', '.join(bad)}. The tangent stiffness there has a real "
            "eigenvalue <= 0 (the loading path crossed a fold or a bifurcation): a small disturbance can leave that "
            "equilibrium, so the robot may not hold it. `tdcr optimize --stable-only` makes unstable equilibria "
            "infeasible.", ""]


def _antagonistic_pairs(robot: Robot) -> list[tuple[int, int]]:
    """Pairs of tendons (1-based) routed opposite each other: the same segment and routing radius, routing
    angles pi apart. Equal tensions in such a pair put no bending moment on the straight robot."""
    t = robot.tendons
    return [(i + 1, j + 1) for i, j in itertools.combinations(range(len(t)), 2)
            if t[i].segment == t[j].segment and math.isclose(t[i].radius, t[j].radius, rel_tol=1e-12)
            and abs(math.remainder(t[i].angle - t[j].angle - math.pi, 2 * math.pi)) < 1e-9]


def _payload_is_axial(robot: Robot) -> bool:
    """True when the payload (:func:`~pytdcr.paper.payload_gravity`) acts along the unloaded robot's axis,
    against the direction it points (base z, the robot pointing up). Its direction is
    :func:`~pytdcr.validate.direction_or_none`'s (safe at any scale); a gravity whose components are all below
    :data:`~pytdcr.validate.MIN_DIRECTION` has no direction, so it is not axial."""
    g = direction_or_none(payload_gravity(robot), "gravity")
    return g is not None and bool(np.allclose(g, (0.0, 0.0, -1.0), rtol=0.0, atol=1e-12))


def _axial_text(robot: Robot) -> str:
    """What an axial payload means for the optimum: only where it holds (nothing otherwise)."""
    if not _payload_is_axial(robot):
        return ""
    pairs = _antagonistic_pairs(robot)
    weight = math.hypot(*payload_loads(robot).tip_force.tolist())
    buckling = np.pi**2 * robot.backbone.bending_stiffness / (4 * robot.length**2)
    text = (" The robot points up against the payload, which it carries axially: the straight robot reaches "
            f"farthest (its reach is the length, {robot.length} m)")
    if pairs:
        text += (", and equal tensions in a pair of opposite tendons (" + ", ".join(f"{a} and {b}" for a, b in pairs)
                 + ") keep it straight, so the optimum is a whole set of tension vectors")
    return text + (f". The payload's weight, {number_text(weight, 4)} N, is "
                   f"{'below' if weight < buckling else 'not below'} the straight robot's buckling load without "
                   f"gravity (about pi^2 EI / 4L^2 = {number_text(buckling)} N).")


def _payload_text(robot: Robot, pay: ReachResult) -> str:
    """The payload study's paragraph: the payload's force, the GA's and the polished optimum ``pay``, its
    stability and, where the payload is axial, what that means (:func:`_axial_text`)."""
    ga = pay.ga if pay.ga is not None else pay.optimum
    settings = pay.ga_settings
    force = ", ".join(f"{f:.4f}" for f in payload_loads(robot).tip_force)
    along = "the robot's gravity" if np.any(robot.gravity) else "standard gravity (the robot has none)"
    return (f"Payload {PAYLOAD_MASS * 1e3:g} g at the tip (force ({force}) N, along {along}). "
            + (f"GA (population {settings.pop_size})" if settings is not None else "A polish alone (no GA)")
            + f": reach {ga.reach:.6f} m after {pay.generations} generations and "
            f"{pay.evaluations} solves"
            + (f"; polished {pay.reach:.6f} m with tensions {np.round(pay.tensions, 3).tolist()} N"
               if pay.polished else "")
            + f"; {_stability(pay.stable)}." + _axial_text(robot))


def reproduce_report(robot: Robot, run: ReproduceRun, bounds: TensionBounds, s: ReproduceSettings,
                     extra: Sequence[str] = ()) -> str:
    """The Markdown report of :func:`~pytdcr.runs.run_reproduce`: its results ``run`` on ``robot`` within the
    paper's ``bounds``, at the budget ``s``; ``extra`` lines (the better models' and the workspace's sections)
    before the list of files."""
    ga, pay, bound_study = run.ga, run.payload, run.bounds_study
    head = ("| study | GA reach [m] | GA cost [1/m] | polished reach [m] | polish gain in cost | "
            "stable | generation within 1e-6 of final | generations | model solves | not converged | time [s] |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|")
    best = min(ga.values(), key=lambda r: r.cost)
    lines = [
        *_head(robot, run, bounds, s),
        *_unstable_warning(run),
        "## Fig. 5: the GA under the paper's load",
        "",
        head,
        *[_ga_row(f"population {p}", r) for p, r in ga.items()],
        "",
        f"Best optimum found (after polishing): reach {best.reach:.6f} m with tensions "
        f"{np.round(best.tensions, 3).tolist()} N; {_stability(best.stable)}." if best.polished else "",
        f"Upper bound: the backbone length, {robot.length} m (cost {1 / robot.length:.2f} 1/m); no reach exceeds it.",
        "",
        _beside_paper(ga, s.tol),
        "",
        "## Fig. 6: the optimum under a payload",
        "",
        _payload_text(robot, pay),
        "",
        "## How the optimum depends on the bounds",
        "",
        f"GA population {next(iter(ga))} for the other bounds, at most the side-study generation cap; at the "
        "default bounds the best of the main study's runs.",
        "",
        "| upper bound [N] | GA reach [m] | polished reach [m] | tensions at the polished optimum [N] | stable |",
        "|---|---|---|---|---|",
        *[f"| {hi:g} | {(r.ga or r.optimum).reach:.6f} | {r.reach:.6f} | {np.round(r.tensions, 2).tolist()} | "
          f"{_stable_cell(r.stable)} |" if r.polished else f"| {hi:g} | {r.reach:.6f} | - | - | "
          f"{_stable_cell(r.stable)} |" for hi, r in bound_study],
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

"""The paper's feasible-static-workspace study: runs that write data, figures and a report.

Every run writes the exact inputs (robot, loads, bounds, seeds, solver
options) beside its results, so it can be repeated exactly.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import os
import platform
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only; never opens a window
import matplotlib.pyplot as plt
import numpy as np

from . import __version__
from .compare import ModelComparison, compare_models
from .design import Robot
from .io import robot_to_dict, to_jsonable
from .loads import Loads
from .optimize import ReachResult, maximize_reach, polish_reach
from .plotting import plot_convergence, plot_model_overlay, plot_reach_samples, plot_robot, plot_robots
from .results import StaticSolution
from .statics import CosseratOptions, SolverOptions, options_for, solve
from .workspace import TensionBounds, WorkspaceSamples, sample_workspace

__all__ = [
    "DEFAULT_BOUNDS",
    "PAPER_TIP_FORCE",
    "PAPER_TIP_MOMENT",
    "PAYLOAD_MASS",
    "inputs_record",
    "run_optimize",
    "run_reproduce",
    "run_sample",
]

#: the paper's load of section 4 (base frame)
PAPER_TIP_FORCE = np.array([0.1, 0.1, -0.1])
PAPER_TIP_MOMENT = np.array([-0.1, 0.1, 0.1])
#: payload of the Fig. 6 study [kg]: 5 g, well below the straight robot's buckling load
PAYLOAD_MASS = 0.005
#: default tendon-force bounds [N] (the paper gives none): 0 to 20 N per tendon
DEFAULT_BOUNDS = (0.0, 20.0)

Progress = Callable[[str, int], Callable[[int, float, float], None]]


def inputs_record(robot: Robot, loads: Loads, **extra: Any) -> dict[str, Any]:
    """The exact inputs of a run (JSON-ready)."""
    return to_jsonable({
        "pytdcr": __version__,
        "python": platform.python_version(),
        "robot": robot_to_dict(robot),
        "loads": {"tip_force": loads.tip_force, "tip_moment": loads.tip_moment, "release": loads.release,
                  "point_loads": [{"disk": p.disk, "force": p.force, "moment": p.moment} for p in loads.point_loads]},
        **extra,
    })


def _save(fig: plt.Figure, out: Path, stem: str) -> list[str]:
    # the tight bounding box is measured once (it costs a full draw) and used for both formats
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    names = []
    for ext in ("png", "pdf"):
        path = out / f"{stem}.{ext}"
        fig.savefig(path, dpi=150, bbox_inches=bbox)
        names.append(path.name)
    plt.close(fig)
    return names


def _write_json(path: Path, data: Any) -> None:
    path.write_text(json.dumps(to_jsonable(data), indent=2, allow_nan=False))


def _load_arrows(sol: StaticSolution, loads: Loads, robot: Robot) -> list[tuple[np.ndarray, np.ndarray]]:
    arrows = []
    scale = 0.25 * robot.length
    if np.any(loads.tip_force):
        arrows.append((sol.tip_position, loads.tip_force / np.linalg.norm(loads.tip_force) * scale))
    if np.any(loads.tip_moment):  # the moment's axis, drawn from the tip in another colour
        arrows.append((sol.tip_position, loads.tip_moment / np.linalg.norm(loads.tip_moment) * scale * 0.6,
                       "tab:orange"))
    return arrows


@dataclass(frozen=True)
class SampleRun:
    """What :func:`run_sample` produced."""

    samples: WorkspaceSamples
    files: list[str]


def _solver_record(model: str, options: SolverOptions | CosseratOptions | None) -> dict[str, Any]:
    opts = options_for(model, options)
    return {"model": model, **opts.__dict__}


def run_sample(robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, out: Path | None,
               options: SolverOptions | CosseratOptions | None = None, n_shapes: int = 10,
               model: str = "pcc") -> SampleRun:
    """Random tension samples, the CSV of their equilibria, Fig. 3(a) and Fig. 4."""
    samples = sample_workspace(robot, loads, bounds, n, seed=seed, model=model, options=options)
    files: list[str] = []
    if out is None:
        return SampleRun(samples, files)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "samples.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sample", *[f"T{c + 1}_N" for c in range(robot.n_tendons)], "tip_x_m", "tip_y_m", "tip_z_m",
                    "reach_m", "converged", "residual_Nm"])
        for k in range(n):
            tip = samples.tip_position[k]
            w.writerow([k + 1, *[f"{x:.12g}" for x in samples.tensions[k]],
                        *[("" if not np.isfinite(x) else f"{x:.12g}") for x in tip],
                        "" if not samples.converged[k] else f"{samples.reach[k]:.12g}",
                        int(samples.converged[k]), f"{samples.residual[k]:.6g}"])
    files.append("samples.csv")
    ax = plot_reach_samples(samples.reach, samples.converged)
    ax.set_title(f"{robot.name}: reach of {n} random tension samples (seed {seed})")
    files += _save(ax.figure, out, "fig3a_samples")
    ok = np.flatnonzero(samples.converged)[:n_shapes]
    sols = [solve(robot, loads.with_tensions(samples.tensions[k]), model=model, q0=samples.q[k], options=options)
            for k in ok]
    ax = plot_robots(sols, robot)
    ax.set_title(f"{len(sols)} sampled configurations")
    files += _save(ax.figure, out, "fig4_configurations")
    _write_json(out / "sample_run.json", {
        "inputs": inputs_record(robot, loads, bounds=bounds.to_dict(), n=n, seed=seed,
                                solver=_solver_record(model, options)),
        "converged": int(samples.converged.sum()), "not_converged": int((~samples.converged).sum()),
        "reach_max_m": float(np.nanmax(samples.reach)) if samples.converged.any() else None,
        "seconds": samples.seconds, "files": files,
    })
    files.append("sample_run.json")
    return SampleRun(samples, files)


def run_optimize(robot: Robot, loads: Loads, bounds: TensionBounds, *, pop: int, tol: float, window: int,
                 max_gen: int, seed: int, polish: bool, out: Path | None, stem: str = "",
                 progress: Callable[[int, float, float], None] | None = None,
                 options: SolverOptions | CosseratOptions | None = None,
                 model: str = "pcc", local_search: bool = True) -> tuple[ReachResult, list[str]]:
    """The GA of Eq. 29, with Fig. 5 (convergence) and Fig. 6 (the optimal robot under its load)."""
    res = maximize_reach(robot, loads, bounds, pop_size=pop, tol=tol, window=window, max_gen=max_gen, seed=seed,
                         polish=polish, on_generation=progress, model=model, options=options,
                         local_search=local_search)
    if out is None:
        return res, []
    return res, write_optimize(res, robot, loads, bounds, out, stem=stem, model=model, options=options)


def write_optimize(res: ReachResult, robot: Robot, loads: Loads, bounds: TensionBounds, out: Path, *,
                   stem: str = "", model: str = "pcc",
                   options: SolverOptions | CosseratOptions | None = None) -> list[str]:
    """Fig. 5, Fig. 6, the history CSV and the JSON record of a GA run; returns the file names."""
    pop, tol, window, max_gen = (res.settings[k] for k in ("pop_size", "tol", "window", "max_gen"))
    files: list[str] = []
    out.mkdir(parents=True, exist_ok=True)
    sfx = f"_{stem}" if stem else ""
    ax = plot_convergence(res.history["best"], res.history["mean"])
    ax.set_title(f"GA, population {pop}: {res.generations} generations, {res.evaluations} solves")
    files += _save(ax.figure, out, f"fig5_convergence{sfx}")
    final_t = res.polish.tensions if res.polish is not None else res.tensions
    tight = replace(options_for(model, options), atol=1e-12)
    sol = solve(robot, loads.with_tensions(final_t), model=model, options=tight)
    ax = plot_robot(sol, robot, loads=_load_arrows(sol, loads, robot))
    ax.set_title(f"optimal robot: reach {sol.reach:.4f} m\n(purple: tip force, orange: tip moment axis)"
                 if np.any(loads.tip_moment) else f"optimal robot: reach {sol.reach:.4f} m (purple: tip force)")
    files += _save(ax.figure, out, f"fig6_optimum{sfx}")
    with open(out / f"history{sfx}.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["generation", "best_cost_per_m", "mean_cost_per_m", "evaluations", "nonconverged"])
        h = res.history
        for g in range(res.generations):
            w.writerow([g + 1, f"{h['best'][g]:.12g}", f"{h['mean'][g]:.12g}", h["evaluations"][g],
                        h["nonconverged"][g]])
    files.append(f"history{sfx}.csv")
    _write_json(out / f"optimize{sfx}.json", {
        "inputs": inputs_record(robot, loads, bounds=bounds.to_dict(), pop=pop, tol=tol, window=window,
                                max_gen=max_gen, seed=res.seed, polish=res.polish is not None,
                                local_search=res.settings["local_search"], solver=_solver_record(model, options)),
        "result": res.to_dict(), "files": files,
    })
    files.append(f"optimize{sfx}.json")
    return files


def _fmt(x: float, digits: int = 6) -> str:
    return f"{x:.{digits}f}"


def run_reproduce(robot: Robot, out: Path, *, seed: int = 0, progress: Progress | None = None,
                  pops: tuple[int, ...] = (50, 100, 200), n_samples: int = 100,
                  tol: float = 1e-6, window: int = 5, max_gen: int = 30,
                  bound_uppers: tuple[float, ...] = (10.0, 20.0, 40.0), side_max_gen: int = 30,
                  n_polish: int = 2) -> dict[str, Any]:
    """The paper's whole study (sections 3-4) on ``robot``; writes figures, data and ``report.md``."""
    t_start = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    nt = robot.n_tendons
    bounds = TensionBounds.uniform(nt, *DEFAULT_BOUNDS)
    paper_loads = Loads(np.zeros(nt), tip_force=PAPER_TIP_FORCE, tip_moment=PAPER_TIP_MOMENT)
    g = float(np.linalg.norm(robot.gravity)) or 9.81
    payload = Loads(np.zeros(nt), tip_force=np.array([0.0, 0.0, -PAYLOAD_MASS * g]))
    summary: dict[str, Any] = {"seed": seed, "files": []}

    def note(stage: str, total: int):
        return progress(stage, total) if progress is not None else None

    # The GA runs are independent: two at a time in worker threads (the compiled solver releases the GIL),
    # while this thread does the sampling and draws every figure (pyplot is not thread-safe). Each run is
    # deterministic by its seed, whatever the interleaving.
    def ga_job(lds: Loads, b: TensionBounds, pop: int, gens: int, label: str) -> ReachResult:
        return maximize_reach(robot, lds, b, pop_size=pop, tol=tol, window=window, max_gen=gens, seed=seed,
                              n_polish=n_polish, on_generation=note(label, gens))

    jobs: dict[str, tuple] = {f"pop{p}": (paper_loads, bounds, p, max_gen, f"GA population {p}") for p in pops}
    jobs["payload"] = (payload, bounds, pops[0], side_max_gen, "GA under a payload")
    for h in bound_uppers:
        if h != DEFAULT_BOUNDS[1] or DEFAULT_BOUNDS[0] != 0.0:
            jobs[f"bounds{h:g}"] = (paper_loads, TensionBounds.uniform(nt, 0.0, h), pops[0], side_max_gen,
                                    f"GA, bounds [0, {h:g}] N")
    order = sorted(jobs, key=lambda k: -jobs[k][2])  # largest populations first
    pool = ThreadPoolExecutor(max_workers=max(1, min(2, os.cpu_count() or 1)))
    futures = {k: pool.submit(ga_job, *jobs[k]) for k in order}

    # Fig. 3(a) and Fig. 4: random samples under the paper's load
    cb = note("sampling", 1)
    sample = run_sample(robot, paper_loads, bounds, n_samples, seed, out)
    if cb:
        cb(1, 0.0, 0.0)
    summary["files"] += sample.files
    s = sample.samples
    summary["sampling"] = {"n": n_samples, "converged": int(s.converged.sum()), "seconds": s.seconds,
                           "reach_max": float(np.nanmax(s.reach)), "reach_min": float(np.nanmin(s.reach))}

    # Fig. 3(b): the passive robot (all tensions 0) under the paper's load
    passive = solve(robot, paper_loads)
    if passive.converged:
        ax = plot_robot(passive, robot, loads=_load_arrows(passive, paper_loads, robot))
        ax.set_title("no tension; tip force (0.1, 0.1, -0.1) N (purple),\nmoment (-0.1, 0.1, 0.1) N m (orange: axis)")
        summary["files"] += _save(ax.figure, out, "fig3b_loaded")
    summary["passive"] = {"converged": passive.converged,
                          "tip": passive.tip_position.tolist() if passive.converged else None,
                          "reach": passive.reach if passive.converged else None}

    # Fig. 5 (each population, under the paper's load) and Fig. 6 (under a vertical payload), drawn as the
    # runs finish
    done: dict[str, ReachResult] = {}
    try:
        for k in order:
            done[k] = futures[k].result()
            if k.startswith("pop"):
                summary["files"] += write_optimize(done[k], robot, paper_loads, bounds, out, stem=k)
            elif k == "payload":
                summary["files"] += write_optimize(done[k], robot, payload, bounds, out, stem=k)
    finally:
        pool.shutdown(cancel_futures=True)
    ga = {pop: done[f"pop{pop}"] for pop in pops}
    pay = done["payload"]

    # how the optimum depends on the bounds
    # (each polish also starts from the optimum of the next tighter bounds, which lies inside these)
    bound_study: list[tuple[float, ReachResult]] = []
    for hi in sorted(bound_uppers):
        prev = [bound_study[-1][1].polish.tensions] if bound_study and bound_study[-1][1].polish else []
        b = TensionBounds.uniform(nt, 0.0, hi)
        # at the default bounds the main study's best run; else the side run. Then one more polish from the
        # optimum of the tighter bounds, which lies inside these, keeping the better
        r = done.get(f"bounds{hi:g}") or min(ga.values(), key=lambda g_: g_.polish.cost if g_.polish else g_.cost)
        for start in prev:
            p2 = polish_reach(robot, paper_loads, b, start)
            if r.polish is None or p2.cost < r.polish.cost:
                r = dataclasses.replace(r, polish=dataclasses.replace(p2, cost_change=r.cost - p2.cost))
        bound_study.append((hi, r))

    seconds = time.perf_counter() - t_start
    report = _report(robot, summary, ga, pay, bound_study, bounds, seconds, tol, window, max_gen, side_max_gen)
    (out / "report.md").write_text(report)
    summary["files"].append("report.md")
    _write_json(out / "reproduce.json", {
        "inputs": inputs_record(robot, paper_loads, bounds=bounds.to_dict(), seed=seed, pops=list(pops),
                                n_samples=n_samples, tol=tol, window=window, max_gen=max_gen,
                                side_max_gen=side_max_gen, payload_mass_kg=PAYLOAD_MASS,
                                bound_uppers=list(bound_uppers), n_polish=n_polish,
                                solver=SolverOptions().__dict__),
        "summary": summary,
        "ga": {str(p): r.to_dict() for p, r in ga.items()},
        "payload": pay.to_dict(),
        "bounds_study": [{"upper": hi, **r.to_dict()} for hi, r in bound_study],
        "seconds": seconds,
    })
    summary["seconds"] = seconds
    return summary


def pop_label(ga: dict[int, ReachResult]) -> int:
    """The population used by the side studies (the first of the main study's)."""
    return next(iter(ga))


def _bounds_comment(bound_study: list[tuple[float, ReachResult]]) -> str:
    reach = [r.polish.reach if r.polish else r.reach for _, r in bound_study]
    active = [int(np.sum(np.isclose(r.polish.tensions, hi))) if r.polish else 0 for hi, r in bound_study]
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
    """First generation whose best cost is within ``tol`` of the run's final best."""
    return next((g + 1 for g, b in enumerate(r.history["best"]) if abs(b - r.cost) < tol), r.generations)


def _beside_paper(ga: dict[int, ReachResult], tol: float) -> str:
    """The paper's Fig. 5 claim beside what these runs measured (written from the data)."""
    pop = next(iter(ga))
    r = ga[pop]
    text = (f"**Beside the paper.** The paper reports (its Fig. 5) that with population 50 the GA reached its "
            f"optimum by the fourth generation, to 1e-6. Here, with population {pop}, the best cost was final "
            f"(within {tol:g}) at generation {_first_final(r, tol)}; the stopping rule was "
            f"{'met' if r.converged else 'not met (generation cap)'} at generation {r.generations}, after "
            f"{r.evaluations} model solves ({r.history['local_search_evaluations'][-1]} of them in the local "
            "searches).")
    if r.polish is not None:
        moved = r.polish.cost_change
        text += (f" The final polish (several starts) then changed the cost by {moved:.1e} 1/m: "
                 + ("the GA had converged to that optimum." if abs(moved) < tol else
                    "it found a better optimum than the GA's."))
    finals = sorted({round(g_.polish.reach if g_.polish else g_.reach, 6) for g_ in ga.values()})
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
    pol = r.polish
    first = _first_final(r, 1e-6)
    pr = f"{pol.reach:.6f}" if pol else "-"
    pc = f"{pol.cost_change:.2e}" if pol else "-"
    return (f"| {label} | {r.reach:.6f} | {r.cost:.6f} | {pr} | {pc} | {first} | {r.generations} "
            f"{'(tol met)' if r.converged else '(cap)'} | {r.evaluations} | {r.nonconverged} | {r.seconds:.1f} |")


def _report(robot: Robot, summary: dict[str, Any], ga: dict[int, ReachResult], pay: ReachResult,
            bound_study: list[tuple[float, ReachResult]], bounds: TensionBounds, seconds: float,
            tol: float, window: int, max_gen: int, side_max_gen: int) -> str:
    s = summary["sampling"]
    head = ("| study | GA reach [m] | GA cost [1/m] | polished reach [m] | polish gain in cost | "
            "generation within 1e-6 of final | generations | model solves | not converged | GA time [s] |\n"
            "|---|---|---|---|---|---|---|---|---|---|")
    rows = [_ga_row(f"population {p}", r) for p, r in ga.items()]
    best_pop = min(ga.values(), key=lambda r: (r.polish.cost if r.polish else r.cost))
    bp = best_pop.polish
    lines = [
        "# Feasible static workspace of the paper robot: reproduction",
        "",
        f"Robot `{robot.name}`: {len(robot.segments)} segments, {robot.n_disks} disks, {robot.n_tendons} tendons, "
        f"length {robot.length} m; friction law `{robot.friction.law}`; gravity {list(robot.gravity)} m/s^2.",
        f"Tension bounds: [{bounds.lower[0]:g}, {bounds.upper[0]:g}] N per tendon (the paper gives none). "
        f"GA: pymoo GA (SBX crossover, polynomial mutation, tournament selection) with a gradient search on each "
        f"new leader (memetic; its solves are counted), seed {summary['seed']}; stop "
        f"when the best cost improves by less than {tol:g} 1/m over {window} generations, or at {max_gen} "
        f"({side_max_gen} for the payload and bounds studies). Each GA individual is one static solve along the "
        "loading path from the unloaded robot (the branch quasi-static loading reaches: a tension vector can "
        "have several equilibria under this load); a solve that does not converge makes it infeasible.",
        f"Whole run: {seconds:.1f} s on {os.cpu_count()} cores.",
        "",
        "## Fig. 3(a), Fig. 4: random samples under the paper's load",
        "",
        f"{s['n']} tension vectors uniform in the bounds, under tip force (0.1, 0.1, -0.1) N and tip moment "
        f"(-0.1, 0.1, 0.1) N m: {s['converged']} converged; reach from {s['reach_min']:.4f} to "
        f"{s['reach_max']:.4f} m (`samples.csv`, `fig3a_samples.png`, `fig4_configurations.png`).",
        "",
        "## Fig. 3(b): the robot under the paper's load",
        "",
        (f"With every tension 0 the load alone puts the tip at {np.round(summary['passive']['tip'], 4).tolist()} m "
         f"(reach {summary['passive']['reach']:.4f} m): `fig3b_loaded.png`.") if summary["passive"]["converged"]
        else "The passive solve did not converge (no figure).",
        "",
        "## Fig. 5: the GA under the paper's load",
        "",
        head,
        *rows,
        "",
        f"Best optimum found (after polishing): reach {bp.reach:.6f} m with tensions "
        f"{np.round(bp.tensions, 3).tolist()} N." if bp else "",
        f"Upper bound: the backbone length, {robot.length} m (cost {1 / robot.length:.2f} 1/m); no reach exceeds it.",
        "",
        _beside_paper(ga, tol),
        "",
        "## Fig. 6: the optimum under a vertical payload",
        "",
        f"Payload {PAYLOAD_MASS * 1e3:g} g at the tip (force (0, 0, {-PAYLOAD_MASS * 9.81:.4f}) N, along gravity). "
        f"GA (population {pay.settings['pop_size']}): reach {pay.reach:.6f} m after {pay.generations} generations "
        f"and {pay.evaluations} solves" + (f"; polished {pay.polish.reach:.6f} m with tensions "
                                            f"{np.round(pay.polish.tensions, 3).tolist()} N" if pay.polish else "")
        + ". A robot pointing up carries a vertical payload axially: the straight robot reaches farthest, and "
        "any pair of equal antagonistic tensions keeps it straight, so the optimum is a whole set of tension "
        "vectors. The payload is kept below the straight robot's buckling load (about pi^2 EI / 4L^2 = "
        f"{np.pi**2 * robot.backbone.bending_stiffness / (4 * robot.length**2):.3f} N without gravity; the "
        "static model does not check the stability of an equilibrium).",
        "",
        "## How the optimum depends on the bounds",
        "",
        f"GA population {pop_label(ga)} for the other bounds, at most the side-study generation cap; at the "
        "default bounds the best of the main study's runs.",
        "",
        "| upper bound [N] | GA reach [m] | polished reach [m] | tensions at the polished optimum [N] |",
        "|---|---|---|---|",
        *[f"| {hi:g} | {r.reach:.6f} | {r.polish.reach:.6f} | {np.round(r.polish.tensions, 2).tolist()} |"
          if r.polish else f"| {hi:g} | {r.reach:.6f} | - | - |" for hi, r in bound_study],
        "",
        _bounds_comment(bound_study),
        "",
        "## Files",
        "",
        *[f"- `{f}`" for f in summary["files"]],
        "- `reproduce.json`: every input, seed and result of this run",
        "",
    ]
    return "\n".join(lines)


def _markdown_table(rows: list[dict[str, Any]], columns: list[tuple[str, str, str]]) -> str:
    head = "| " + " | ".join(c[1] for c in columns) + " |"
    sep = "|" + "|".join("---:" for _ in columns) + "|"
    body = []
    for r in rows:
        cells = []
        for key, _, fmt in columns:
            v = r[key]
            cells.append("n/c" if isinstance(v, float) and not np.isfinite(v) else format(v, fmt))
        body.append("| " + " | ".join(cells) + " |")
    return "\n".join([head, sep, *body])


def run_compare(robot: Robot, loads: Loads, tensions: np.ndarray, out: Path, *, source: dict[str, Any],
                n_overlay: int = 4, progress: Callable[[], None] | None = None,
                cosserat_options: CosseratOptions | None = None) -> tuple[ModelComparison, list[str]]:
    """Both models on every case: ``compare.csv``, ``compare.md``, ``compare.json`` and the overlay figure."""
    cmp = compare_models(robot, loads, tensions, cosserat_options=cosserat_options, progress=progress)
    out.mkdir(parents=True, exist_ok=True)
    rows = cmp.rows()
    files = ["compare.csv", "compare.md"]
    with open(out / "compare.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    summ = cmp.summary()
    cols = [("case", "case", "d"), ("pcc_x_m", "PCC x [m]", ".5f"), ("pcc_y_m", "PCC y [m]", ".5f"),
            ("pcc_z_m", "PCC z [m]", ".5f"), ("cosserat_x_m", "CR x [m]", ".5f"), ("cosserat_y_m", "CR y [m]", ".5f"),
            ("cosserat_z_m", "CR z [m]", ".5f"), ("difference_mm", "diff [mm]", ".3f"),
            ("difference_pct_length", "diff [% L]", ".3f"), ("pcc_ms", "PCC [ms]", ".2f"),
            ("cosserat_ms", "CR [ms]", ".2f")]

    def fmt(v: float | None, f: str) -> str:
        return "n/a" if v is None else format(v, f)

    text = [
        f"# PCC against Cosserat rod: robot '{robot.name}'", "",
        f"{summ['cases']} cases ({source.get('cases', 'random')}), tip force {loads.tip_force.tolist()} N, "
        f"tip moment {loads.tip_moment.tolist()} N m, gravity {list(robot.gravity)} m/s^2, no friction. "
        f"Both models follow the loading path from the unloaded robot.", "",
        f"- both converged: {summ['both_converged']} of {summ['cases']} (PCC failed {summ['pcc_not_converged']}, "
        f"Cosserat failed {summ['cosserat_not_converged']})",
        f"- tip difference: median {fmt(summ['difference_median_mm'], '.3f')} mm "
        f"({fmt(summ['difference_median_pct_length'], '.3f')} % of the {robot.length:g} m length), "
        f"max {fmt(summ['difference_max_mm'], '.3f')} mm",
        f"- median solve time: PCC {summ['pcc_ms_median']:.2f} ms, Cosserat {summ['cosserat_ms_median']:.2f} ms", "",
        "n/c: that model did not converge on the case (its residual is in compare.csv).", "",
        _markdown_table(rows, cols), "",
    ]
    (out / "compare.md").write_text("\n".join(text))
    shown = [k for k in range(len(cmp.pcc)) if cmp.pcc[k].converged and cmp.cosserat[k].converged][:n_overlay]
    pairs = [(cmp.pcc[k], cmp.cosserat[k]) for k in shown]
    ax = plot_model_overlay(pairs, robot, case_ids=[k + 1 for k in shown])
    ax.set_title(f"{robot.name}: PCC (solid) and Cosserat rod (dashed), {len(pairs)} cases")
    files += _save(ax.figure, out, "fig_compare")
    _write_json(out / "compare.json", {
        "inputs": inputs_record(robot, loads, tensions=np.asarray(tensions), **source,
                                pcc_solver=SolverOptions().__dict__,
                                cosserat_solver=(cosserat_options or CosseratOptions()).__dict__),
        "summary": summ, "files": files,
    })
    files.append("compare.json")
    return cmp, files

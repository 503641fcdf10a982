"""Runs that write data, figures and their inputs: sampling, the reach search, the model comparison."""

from __future__ import annotations

import csv
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..compare import ModelComparison, compare_models
from ..design import Robot
from ..loads import Loads
from ..optimize import MemeticGA, ReachProblem, ReachResult, Termination, maximize_reach
from ..plotting import plot_convergence, plot_model_overlay, plot_reach_samples, plot_robot, plot_robots
from ..statics import TIGHT_ATOL, Model, options_record, resolve, solve
from ..workspace import WorkspaceSamples, sample_workspace
from ._output import inputs_record, load_arrows, markdown_table, save_figure, write_json

__all__ = ["SampleRun", "run_compare", "run_optimize", "run_sample", "write_optimize"]


@dataclass(frozen=True)
class SampleRun:
    """What :func:`run_sample` produced."""

    samples: WorkspaceSamples
    files: list[str]


def _write_samples_csv(path: Path, robot: Robot, samples: WorkspaceSamples) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sample", *[f"T{c + 1}_N" for c in range(robot.n_tendons)], "tip_x_m", "tip_y_m", "tip_z_m",
                    "reach_m", "converged", "residual_Nm", "stable"])
        stable = samples.stable
        for k in range(samples.tensions.shape[0]):
            tip = samples.tip_position[k]
            w.writerow([k + 1, *[f"{x:.12g}" for x in samples.tensions[k]],
                        *[("" if not np.isfinite(x) else f"{x:.12g}") for x in tip],
                        "" if not samples.converged[k] else f"{samples.reach[k]:.12g}",
                        int(samples.converged[k]), f"{samples.residual[k]:.6g}",
                        "" if not np.isfinite(stable[k]) else int(stable[k])])


def run_sample(robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, out: Path | None, *,
               model: str | Model = "pcc", options: Any = None, n_shapes: int = 10) -> SampleRun:
    """Random tension samples, the CSV of their equilibria, Fig. 3(a) and Fig. 4."""
    m, opts = resolve(model, robot, loads, options)
    samples = sample_workspace(robot, loads, bounds, n, seed=seed, model=m, options=opts)
    files: list[str] = []
    if out is None:
        return SampleRun(samples, files)
    out.mkdir(parents=True, exist_ok=True)
    _write_samples_csv(out / "samples.csv", robot, samples)
    files.append("samples.csv")
    ax = plot_reach_samples(samples.reach, samples.converged)
    ax.set_title(f"{robot.name}: reach of {n} random tension samples (seed {seed})")
    files += save_figure(ax.figure, out, "fig3a_samples")
    ok = np.flatnonzero(samples.converged)[:n_shapes]
    sols = [solve(robot, loads.with_tensions(samples.tensions[k]), model=m, q0=samples.q[k], options=opts)
            for k in ok]
    ax = plot_robots(sols, robot)
    ax.set_title(f"{len(sols)} sampled configurations")
    files += save_figure(ax.figure, out, "fig4_configurations")
    write_json(out / "sample_run.json", {
        "inputs": inputs_record(robot, loads, bounds=bounds.to_dict(), n=n, seed=seed,
                                solver=options_record(m, opts)),
        "converged": int(samples.converged.sum()), "not_converged": int((~samples.converged).sum()),
        "unstable": int(np.sum(samples.stable == 0.0)),
        "reach_max_m": float(np.nanmax(samples.reach)) if samples.converged.any() else None,
        "seconds": samples.seconds, "files": files,
    })
    files.append("sample_run.json")
    return SampleRun(samples, files)


def run_optimize(problem: ReachProblem, algorithm: MemeticGA, termination: Termination, *, seed: int,
                 out: Path | None, stem: str = "",
                 progress: Callable[[int, float, float], None] | None = None) -> tuple[ReachResult, list[str]]:
    """The GA of Eq. 29, with Fig. 5 (convergence) and Fig. 6 (the optimal robot under its load)."""
    res = maximize_reach(problem, algorithm, termination, seed=seed, on_generation=progress)
    if out is None:
        return res, []
    return res, write_optimize(res, problem, out, stem=stem)


def write_optimize(res: ReachResult, problem: ReachProblem, out: Path, *, stem: str = "") -> list[str]:
    """Fig. 5, Fig. 6, the history CSV and the JSON record of a GA run; returns the file names."""
    robot, loads = problem.robot, problem.loads
    files: list[str] = []
    out.mkdir(parents=True, exist_ok=True)
    sfx = f"_{stem}" if stem else ""
    ax = plot_convergence(res.history["best"], res.history["mean"])
    ax.set_title(f"GA, population {res.settings['pop_size']}: {res.generations} generations, "
                 f"{res.evaluations} solves")
    files += save_figure(ax.figure, out, f"fig5_convergence{sfx}")
    sol = problem.solve(res.tensions, atol=TIGHT_ATOL)
    ax = plot_robot(sol, robot, loads=load_arrows(sol, loads, robot))
    ax.set_title(f"optimal robot: reach {sol.reach:.4f} m\n(purple: tip force, orange: tip moment axis)"
                 if np.any(loads.tip_moment) else f"optimal robot: reach {sol.reach:.4f} m (purple: tip force)")
    files += save_figure(ax.figure, out, f"fig6_optimum{sfx}")
    with open(out / f"history{sfx}.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["generation", "best_cost_per_m", "mean_cost_per_m", "evaluations", "nonconverged"])
        h = res.history
        for g in range(res.generations):
            w.writerow([g + 1, f"{h['best'][g]:.12g}", f"{h['mean'][g]:.12g}", h["evaluations"][g],
                        h["nonconverged"][g]])
    files.append(f"history{sfx}.csv")
    s = res.settings
    write_json(out / f"optimize{sfx}.json", {
        "inputs": inputs_record(robot, loads, bounds=problem.bounds.to_dict(), pop=s["pop_size"], tol=s["tol"],
                                window=s["window"], max_gen=s["max_gen"], seed=res.seed, polish=s["polish"],
                                local_search=s["local_search"], solver=options_record(problem.model,
                                                                                      problem.options)),
        "result": res.to_dict(), "files": files,
    })
    files.append(f"optimize{sfx}.json")
    return files


def _compare_markdown(cmp: ModelComparison, robot: Robot, loads: Loads, source: Mapping[str, Any]) -> str:
    summ = cmp.summary()
    ref = cmp.reference

    def fmt(v: float | None, f: str) -> str:
        return "n/a" if v is None else format(v, f)

    cols = [("case", "case", "d")]
    for name in cmp.models:
        cols += [(f"{name}_{a}_m", f"{name} {a} [m]", ".5f") for a in "xyz"]
    for name in cmp.others:
        cols += [(f"{name}_difference_mm", f"{name} diff [mm]", ".3f"),
                 (f"{name}_difference_pct_length", f"{name} diff [% L]", ".3f")]
    cols += [(f"{name}_ms", f"{name} [ms]", ".2f") for name in cmp.models]
    text = [
        f"# Models compared: robot '{robot.name}'", "",
        f"{summ['cases']} cases ({source.get('cases', 'random')}), tip force {loads.tip_force.tolist()} N, "
        f"tip moment {loads.tip_moment.tolist()} N m, gravity {list(robot.gravity)} m/s^2, friction law "
        f"`{robot.friction.law}`. Every model follows the loading path from the unloaded robot; differences are "
        f"tip distances from `{ref}`.", "",
        f"- every model converged: {summ['all_converged']} of {summ['cases']} ("
        + ", ".join(f"{n} failed {summ[f'{n}_not_converged']}" for n in cmp.models) + ")",
    ]
    for name in cmp.others:
        text.append(f"- `{name}` from `{ref}`: median {fmt(summ[f'{name}_difference_median_mm'], '.3f')} mm "
                    f"({fmt(summ[f'{name}_difference_median_pct_length'], '.3f')} % of the {robot.length:g} m "
                    f"length), max {fmt(summ[f'{name}_difference_max_mm'], '.3f')} mm")
    text.append("- median solve time: " + ", ".join(f"{n} {summ[f'{n}_ms_median']:.2f} ms" for n in cmp.models))
    text += ["", "n/c: that model did not converge on the case (its residual is in compare.csv).", "",
             markdown_table(cmp.rows(), cols), ""]
    return "\n".join(text)


def run_compare(robot: Robot, loads: Loads, tensions: np.ndarray, out: Path, *, source: dict[str, Any],
                models: tuple[str | Model, ...] = ("pcc", "cosserat"), options: Mapping[str, Any] | None = None,
                n_overlay: int = 4, progress: Callable[[], None] | None = None) -> tuple[ModelComparison, list[str]]:
    """Every model on every case: ``compare.csv``, ``compare.md``, ``compare.json`` and the overlay figure."""
    cmp = compare_models(robot, loads, tensions, models=models, options=options, progress=progress)
    out.mkdir(parents=True, exist_ok=True)
    rows = cmp.rows()
    files = ["compare.csv", "compare.md"]
    with open(out / "compare.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    (out / "compare.md").write_text(_compare_markdown(cmp, robot, loads, source))
    shown = np.flatnonzero(cmp.all_converged)[:n_overlay]
    groups = [[cmp.solutions[name][k] for name in cmp.models] for k in shown]
    ax = plot_model_overlay(groups, robot, labels=cmp.models, case_ids=[int(k) + 1 for k in shown])
    ax.set_title(f"{robot.name}: " + ", ".join(f"{n} ({s})" for n, s in zip(cmp.models, ("solid", "dashed", "dotted",
                                                                                          "dash-dot"), strict=False))
                 + f"; {len(groups)} cases")
    files += save_figure(ax.figure, out, "fig_compare")
    solvers = {name: options_record(name, (options or {}).get(name)) for name in cmp.models}
    write_json(out / "compare.json", {
        "inputs": inputs_record(robot, loads, tensions=np.asarray(tensions), **source, solvers=solvers),
        "summary": cmp.summary(), "files": files,
    })
    files.append("compare.json")
    return cmp, files

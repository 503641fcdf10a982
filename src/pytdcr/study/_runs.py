"""Runs that write data, figures and their inputs: sampling, the reach search, the model comparison."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..compare import ModelComparison, compare_models
from ..design import Robot
from ..loads import Loads
from ..optimize import MemeticGA, ReachProblem, ReachResult, Termination, maximize_reach
from ..plotting import plot_convergence, plot_model_overlay, plot_reach_samples, plot_robot, plot_robots, save_figure
from ..runtime import atomic_write_text, output_folder, write_csv, write_json
from ..statics import TIGHT_ATOL, Model, options_record, resolve, saving, solve
from ..workspace import SamplingInterrupted, WorkspaceSamples, sample_workspace
from ._output import inputs_record, load_arrows, markdown_table

__all__ = ["SampleRun", "run_compare", "run_optimize", "run_sample", "sample_into", "write_optimize"]


@dataclass(frozen=True)
class SampleRun:
    """What :func:`run_sample` produced."""

    samples: WorkspaceSamples
    files: list[str]


def _samples_rows(samples: WorkspaceSamples) -> Iterator[list[Any]]:
    stable = samples.stable
    for k in range(samples.tensions.shape[0]):
        tip = samples.tip_position[k]
        yield [k + 1, *[f"{x:.12g}" for x in samples.tensions[k]],
               *[("" if not np.isfinite(x) else f"{x:.12g}") for x in tip],
               "" if not samples.converged[k] else f"{samples.reach[k]:.12g}",
               int(samples.converged[k]), f"{samples.residual[k]:.6g}",
               "" if not np.isfinite(stable[k]) else int(stable[k])]


def _samples_json(out: Path, robot: Robot, loads: Loads, bounds: TensionBounds, samples: WorkspaceSamples, n: int,
                  solver: dict[str, Any], files: list[str]) -> None:
    done = samples.converged.size
    write_json(out / "sample_run.json", {
        "inputs": inputs_record(robot, loads, bounds=bounds.to_dict(), n=n, seed=samples.seed, solver=solver),
        "solved": done, "complete": done == n,
        "converged": int(samples.converged.sum()), "not_converged": int((~samples.converged).sum()),
        "unstable": int(np.sum(samples.stable == 0.0)),
        "reach_max_m": float(np.nanmax(samples.reach)) if samples.converged.any() else None,
        "seconds": samples.seconds, "files": [*files, "sample_run.json"],
    })


def _write_samples(out: Path, robot: Robot, loads: Loads, bounds: TensionBounds, samples: WorkspaceSamples, n: int,
                   solver: dict[str, Any]) -> list[str]:
    """samples.csv and sample_run.json in ``out`` (the data first, then the figures)."""
    write_csv(out / "samples.csv", ["sample", *[f"T{c + 1}_N" for c in range(robot.n_tendons)], "tip_x_m",
                                    "tip_y_m", "tip_z_m", "reach_m", "converged", "residual_Nm", "stable"],
              _samples_rows(samples))
    _samples_json(out, robot, loads, bounds, samples, n, solver, ["samples.csv"])
    return ["samples.csv", "sample_run.json"]


def sample_into(out: Path, robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, *,
                model: str | Model = "pcc", options: Any = None, n_shapes: int = 10,
                progress: Callable[[int], None] | None = None) -> SampleRun:
    """Sample and write the files of :func:`run_sample` into ``out``, a folder the caller manages.

    The data (CSV and JSON) are written as soon as the samples are solved, the figures after. On Ctrl-C during
    the sampling the samples solved so far are written (``complete: false``) and
    :class:`~pytdcr.workspace.SamplingInterrupted` is raised again.
    """
    m, opts = resolve(model, robot, loads, options)
    solver = options_record(m, opts)
    try:
        samples = sample_workspace(robot, loads, bounds, n, seed=seed, model=m, options=opts, progress=progress,
                                   stability=True)
    except SamplingInterrupted as stop:
        with saving():
            _write_samples(out, robot, loads, bounds, stop.samples, n, solver)
        raise
    with saving():  # the samples are solved: Ctrl-C from here waits for the files
        files = _write_samples(out, robot, loads, bounds, samples, n, solver)[:1]
        ax = plot_reach_samples(samples.reach, samples.converged)
        ax.set_title(f"{robot.name}: reach of {n} random tension samples (seed {samples.seed})")
        files += save_figure(ax.figure, out, "fig3a_samples")
        ok = np.flatnonzero(samples.converged)[:n_shapes]
        shapes = [solve(robot, loads.with_tensions(samples.tensions[k]), model=m, q0=samples.q[k], options=opts)
                  for k in ok]
        ax = plot_robots(shapes, robot)
        ax.set_title(f"{len(shapes)} sampled configurations")
        files += save_figure(ax.figure, out, "fig4_configurations")
        _samples_json(out, robot, loads, bounds, samples, n, solver, files)
    return SampleRun(samples, [*files, "sample_run.json"])


def run_sample(robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, out: str | Path | None, *,
               model: str | Model = "pcc", options: Any = None, n_shapes: int = 10,
               progress: Callable[[int], None] | None = None) -> SampleRun:
    """Random tension samples, the CSV of their equilibria, Fig. 3(a) and Fig. 4, in the folder ``out``.

    ``out`` follows the output-folder rule (:func:`output_folder`); ``None`` writes nothing. Ctrl-C saves the
    samples solved so far (status ``interrupted``) and raises :class:`RunInterrupted` saying so.
    """
    if out is None:
        m, opts = resolve(model, robot, loads, options)
        return SampleRun(sample_workspace(robot, loads, bounds, n, seed=seed, model=m, options=opts,
                                          progress=progress), [])
    with output_folder(out, "sample", {"n": n, "seed": seed, "bounds": bounds.to_dict()}) as run:
        try:
            return sample_into(run.staging, robot, loads, bounds, n, seed, model=model, options=options,
                               n_shapes=n_shapes, progress=progress)
        except SamplingInterrupted as stop:
            run.interrupted_note = f"saved {stop.samples.converged.size} of {n} samples"
            raise
        except KeyboardInterrupt:
            if (run.staging / "samples.csv").exists():
                run.interrupted_note = f"saved all {n} samples, not every figure"
            raise


def run_optimize(problem: ReachProblem, algorithm: MemeticGA, termination: Termination, *, seed: int,
                 out: str | Path | None, stem: str = "",
                 progress: Callable[[int, float, float], None] | None = None) -> tuple[ReachResult, list[str]]:
    """The GA of Eq. 29, with Fig. 5 (convergence) and Fig. 6 (the optimal robot under its load) in ``out``.

    ``out`` follows the output-folder rule; ``None`` writes nothing. An interrupted search saves nothing.
    """
    if out is None:
        return maximize_reach(problem, algorithm, termination, seed=seed, on_generation=progress), []
    with output_folder(out, "optimize", {"seed": seed, "bounds": problem.bounds.to_dict(),
                                         "pop": algorithm.pop_size}) as run:
        res = maximize_reach(problem, algorithm, termination, seed=seed, on_generation=progress)
        with saving():
            return res, write_optimize(res, problem, run.staging, stem=stem)


def write_optimize(res: ReachResult, problem: ReachProblem, out: Path, *, stem: str = "") -> list[str]:
    """Fig. 5, Fig. 6, the history CSV and the JSON record of a GA run into ``out``, a folder the caller
    manages; returns the file names."""
    robot, loads = problem.robot, problem.loads
    files: list[str] = []
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
    h = res.history
    write_csv(out / f"history{sfx}.csv",
              ["generation", "best_cost_per_m", "mean_cost_per_m", "evaluations", "nonconverged"],
              ([g + 1, f"{h['best'][g]:.12g}", f"{h['mean'][g]:.12g}", h["evaluations"][g], h["nonconverged"][g]]
               for g in range(res.generations)))
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


def run_compare(robot: Robot, loads: Loads, tensions: np.ndarray, out: str | Path, *, source: dict[str, Any],
                models: tuple[str | Model, ...] = ("pcc", "cosserat"), options: Mapping[str, Any] | None = None,
                n_overlay: int = 4, progress: Callable[[], None] | None = None) -> tuple[ModelComparison, list[str]]:
    """Every model on every case: ``compare.csv``, ``compare.md``, ``compare.json`` and the overlay figure in
    ``out`` (the output-folder rule; an interrupted comparison saves nothing)."""
    with output_folder(out, "compare", {"models": [getattr(m, "name", m) for m in models], **source}) as run:
        cmp = compare_models(robot, loads, tensions, models=models, options=options, progress=progress)
        with saving():
            return cmp, _write_compare(run.staging, cmp, robot, loads, tensions, source, options, n_overlay)


def _write_compare(out: Path, cmp: ModelComparison, robot: Robot, loads: Loads, tensions: np.ndarray,
                   source: dict[str, Any], options: Mapping[str, Any] | None, n_overlay: int) -> list[str]:
    rows = cmp.rows()
    files = ["compare.csv", "compare.md"]
    write_csv(out / "compare.csv", list(rows[0]),
              ([(f"{v:.12g}" if isinstance(v, float) else v) for v in r.values()] for r in rows))
    atomic_write_text(out / "compare.md", _compare_markdown(cmp, robot, loads, source))
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
    return [*files, "compare.json"]

"""Runs that write data, figures and their inputs: the random samples and the reach search."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import ReachProblem, ReachResult, maximize_reach
from ..plotting import plot_convergence, plot_reach_samples, plot_robot, plot_robots, save_figure
from ..robot import Robot
from ..runtime import output_folder, write_csv, write_json
from ..statics import TIGHT_ATOL, options_record, saving, solve, stability_counts, stability_test
from ..workspace import SamplingConfig, SamplingInterrupted, WorkspaceSamples, sample_workspace
from ._output import inputs_record, load_arrows
from ._settings import OptimizeSettings, SampleSettings
from ._specs import RunInputs

__all__ = ["OptimizeRun", "SampleRun", "run_optimize", "run_sample", "sample_into", "write_optimize"]


def _sample_counts(samples: WorkspaceSamples, model: str) -> dict[str, Any]:
    """Converged, not converged, unstable among the converged (None: ``model`` has no stability test;
    :func:`stability_counts`), whether the test ran, untested, and the largest reach [m]."""
    test = stability_test(model)
    states = stability_counts(samples.converged, samples.stable, test)
    return {"converged": int(samples.converged.sum()), "not_converged": int((~samples.converged).sum()),
            "unstable": states["unstable"],
            "stability_test": test, "stability_untested": states["untested"],
            "reach_max_m": float(np.nanmax(samples.reach)) if samples.converged.any() else None}


@dataclass(frozen=True)
class SampleRun:
    """What :func:`run_sample` produced.

    Attributes
    ----------
    robot : Robot
        The robot sampled.
    samples : WorkspaceSamples
    files : list of str
        The files written (none without a folder).
    model : str
        The model that solved them (whether their stability was tested: ``stability_test`` in the summary).
    """

    robot: Robot
    samples: WorkspaceSamples
    files: list[str]
    model: str = "pcc"

    @property
    def converged(self) -> int:
        """Samples that converged."""
        return int(self.samples.converged.sum())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: counts, the largest reach [m], time [s] and files."""
        return {"robot": self.robot.name, "solved": int(self.samples.converged.size), "seed": self.samples.seed,
                **_sample_counts(self.samples, self.model), "seconds": self.samples.seconds, "files": list(self.files)}


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
        "solved": done, "complete": done == n, **_sample_counts(samples, solver["model"]),
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


def sample_into(out: Path, settings: SampleSettings, *, robot: Robot | None = None, loads: Loads | None = None,
                bounds: TensionBounds | None = None, progress: Callable[[int], None] | None = None) -> SampleRun:
    """Sample and write the files of :func:`run_sample` into ``out``, a folder the caller manages.

    ``robot``, ``loads`` and ``bounds`` are built from ``settings`` unless given. The data (CSV and JSON) are
    written as soon as the samples are solved, the figures after. On Ctrl-C during the sampling the samples
    solved so far are written (``complete: false``) and :class:`~pytdcr.workspace.SamplingInterrupted` is
    raised again.
    """
    return _sample_into(out, settings, settings.build(robot, loads, bounds), progress)


def _sample_into(out: Path, settings: SampleSettings, inputs: RunInputs,
                 progress: Callable[[int], None] | None) -> SampleRun:
    robot, loads, bounds, m, opts = inputs.robot, inputs.loads, inputs.bounds, inputs.model, inputs.options
    n = settings.n
    solver = options_record(m, opts)
    try:
        samples = sample_workspace(robot, loads, bounds, n, seed=settings.seed, model=m, options=opts,
                                   config=SamplingConfig(progress=progress, stability=True))
    except SamplingInterrupted as stop:
        with saving():
            _write_samples(out, robot, loads, bounds, stop.samples, n, solver)
        raise
    with saving():  # the samples are solved: Ctrl-C from here waits for the files
        files = _write_samples(out, robot, loads, bounds, samples, n, solver)[:1]
        ax = plot_reach_samples(samples.reach, samples.converged)
        ax.set_title(f"{robot.name}: reach of {n} random tension samples (seed {samples.seed})")
        files += save_figure(ax.figure, out, "fig3a_samples")
        ok = np.flatnonzero(samples.converged)[:settings.n_shapes]
        shapes = [solve(robot, loads.with_tensions(samples.tensions[k]), model=m, q0=samples.q[k], options=opts)
                  for k in ok]
        ax = plot_robots(robot, shapes)
        ax.set_title(f"{len(shapes)} sampled configurations")
        files += save_figure(ax.figure, out, "fig4_configurations")
        _samples_json(out, robot, loads, bounds, samples, n, solver, files)
    return SampleRun(robot, samples, [*files, "sample_run.json"], m.name)


def run_sample(settings: SampleSettings, out: str | Path | None, *, robot: Robot | None = None,
               loads: Loads | None = None, bounds: TensionBounds | None = None,
               progress: Callable[[int], None] | None = None) -> SampleRun:
    """Random tension samples, the CSV of their equilibria, Fig. 3(a) and Fig. 4, in the folder ``out``.

    ``robot``, ``loads`` and ``bounds`` are built from ``settings`` unless given, before any work. ``out``
    follows the output-folder rule (:func:`output_folder`); ``None`` writes nothing. ``progress`` is called with
    the size of each block solved. Ctrl-C saves the samples solved so far (status ``interrupted``) and raises
    :class:`RunInterrupted` saying so.
    """
    inputs = settings.build(robot, loads, bounds)
    if out is None:
        return SampleRun(inputs.robot, sample_workspace(inputs.robot, inputs.loads, inputs.bounds, settings.n,
                                                        seed=settings.seed, model=inputs.model,
                                                        options=inputs.options,
                                                        config=SamplingConfig(progress=progress)), [],
                         inputs.model.name)
    n = settings.n
    with output_folder(out, "sample", {"n": n, "seed": settings.seed, "bounds": inputs.bounds.to_dict()}) as run:
        try:
            return _sample_into(run.staging, settings, inputs, progress)
        except SamplingInterrupted as stop:
            run.interrupted_note = f"saved {stop.samples.converged.size} of {n} samples"
            raise
        except KeyboardInterrupt:
            if (run.staging / "samples.csv").exists():
                run.interrupted_note = f"saved all {n} samples, not every figure"
            raise


@dataclass(frozen=True)
class OptimizeRun:
    """What :func:`run_optimize` produced.

    Attributes
    ----------
    problem : ReachProblem
        The problem searched (robot, loads, bounds, model).
    result : ReachResult
    files : list of str
        The files written (none without a folder).
    """

    problem: ReachProblem
    result: ReachResult
    files: list[str]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the result (:meth:`ReachResult.to_dict`) and the files."""
        return {"result": self.result.to_dict(), "files": list(self.files)}


def run_optimize(settings: OptimizeSettings, out: str | Path | None, *, robot: Robot | None = None,
                 loads: Loads | None = None, bounds: TensionBounds | None = None,
                 progress: Callable[[int, float, float], None] | None = None) -> OptimizeRun:
    """The GA of Eq. 29, with Fig. 5 (convergence) and Fig. 6 (the optimal robot under its load) in ``out``.

    ``robot``, ``loads`` and ``bounds`` are built from ``settings`` unless given, before any work; ``progress``
    is called after each generation (generation, best cost, mean cost). ``out`` follows the output-folder rule;
    ``None`` writes nothing. An interrupted search saves nothing; :class:`~pytdcr.optimize.SearchFailed` when no
    tension vector converged.
    """
    inputs = settings.build(robot, loads, bounds)
    problem = ReachProblem.create(inputs.robot, inputs.loads, inputs.bounds, model=inputs.model,
                                  options=inputs.options, stable_only=settings.stable_only)
    algorithm, termination = settings.algorithm(), settings.termination()
    if out is None:
        return OptimizeRun(problem, maximize_reach(problem, algorithm, termination, seed=settings.seed,
                                                   on_generation=progress), [])
    with output_folder(out, "optimize", {"seed": settings.seed, "bounds": problem.bounds.to_dict(),
                                         "pop": algorithm.pop_size}) as run:
        res = maximize_reach(problem, algorithm, termination, seed=settings.seed, on_generation=progress)
        with saving():
            return OptimizeRun(problem, res, write_optimize(res, problem, run.staging))


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
    ax = plot_robot(robot, sol, loads=load_arrows(sol, loads, robot))
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

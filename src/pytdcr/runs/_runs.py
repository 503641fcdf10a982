"""Runs that write data, figures and their inputs: the random samples and the reach search.

Each run returns a result holding its live objects (:class:`SampleRun`, :class:`OptimizeRun`) and reports typed
records, JSON at one boundary (``to_json``/``from_json``, a ``schema_version`` per file, and the keys and meanings
of the files written before it existed):

- :class:`SampleRecord`: ``sample_run.json`` (:data:`SAMPLE_SCHEMA_VERSION`), with the counts of
  :class:`SampleRunCounts`; :class:`SampleSummary` is :meth:`SampleRun.to_json`'s summary;
- :class:`OptimizeRecord`: ``optimize.json`` (:data:`OPTIMIZE_SCHEMA_VERSION`), the search's
  :class:`~pytdcr.optimize.ReachResult` under ``result``.

A reader refuses a missing key with :class:`~pytdcr.records.RecordKeyError` naming its path, and reads an absent
time (``seconds``: the golden baselines drop them) as 0. A record's ``inputs`` are what the run was given
(:func:`~pytdcr.runs._output.inputs_record`: robot, loads, bounds, solver, ...), passed through unread.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bounds import TensionBounds
from ..loads import Loads
from ..optimize import ReachProblem, ReachResult, maximize_reach
from ..plotting import plot_convergence, plot_reach_samples, plot_robot, plot_robots, save_figure
from ..records import JsonDict, JsonObject, check_schema, part
from ..robot import Robot
from ..runtime import output_folder, write_csv, write_json
from ..statics import TIGHT_ATOL, options_record, saving, solve, stability_counts, stability_test
from ..workspace.sampling import SamplingConfig, SamplingInterrupted, WorkspaceSamples, sample_workspace
from ._output import inputs_record, load_arrows
from ._settings import OptimizeSettings, SampleSettings
from ._specs import RunInputs

__all__ = ["OPTIMIZE_SCHEMA_VERSION", "SAMPLE_SCHEMA_VERSION", "OptimizeRecord", "OptimizeRun", "SampleRecord",
           "SampleRun", "SampleRunCounts", "SampleSummary", "run_optimize", "run_sample", "sample_into",
           "write_optimize"]

#: the layout of ``sample_run.json`` (and of :meth:`SampleRun.to_json`) this module writes and reads
SAMPLE_SCHEMA_VERSION = 1
#: the layout of ``optimize.json`` (and of :meth:`OptimizeRun.to_json`) this module writes and reads
OPTIMIZE_SCHEMA_VERSION = 1

_SAMPLE_FILE = "sample_run.json"
_OPTIMIZE_FILE = "optimize.json"


def _files(d: JsonObject) -> tuple[str, ...]:
    """A record's ``files``: the names of the files written."""
    return tuple(str(f) for f in d["files"])


@dataclass(frozen=True)
class SampleRunCounts:
    """What the random samples of one run held.

    Attributes
    ----------
    converged, not_converged : int
        Samples whose solve converged, and the others.
    unstable : int or None
        Converged samples that failed the stability test; None (unknown) when the model has no test.
    stability_test : str
        ``"run"`` or ``"untested"`` (:func:`pytdcr.statics.stability_test`).
    stability_untested : int
        Converged samples whose stability was not tested.
    reach_max_m : float or None
        The largest reach of a converged sample [m]; None when none converged.
    """

    converged: int
    not_converged: int
    unstable: int | None
    stability_test: str
    stability_untested: int
    reach_max_m: float | None

    @classmethod
    def of(cls, samples: WorkspaceSamples, model: str) -> SampleRunCounts:
        """The counts of ``samples`` solved by ``model`` (whose stability test decides ``unstable``:
        :func:`stability_counts`)."""
        test = stability_test(model)
        states = stability_counts(samples.converged, samples.stable, test)
        return cls(int(samples.converged.sum()), int((~samples.converged).sum()), states["unstable"], test,
                   int(states["untested"] or 0),
                   float(np.nanmax(samples.reach)) if samples.converged.any() else None)

    def to_json(self) -> JsonDict:
        """JSON-ready form (keys in the files' order)."""
        return {"converged": self.converged, "not_converged": self.not_converged, "unstable": self.unstable,
                "stability_test": self.stability_test, "stability_untested": self.stability_untested,
                "reach_max_m": self.reach_max_m}

    @classmethod
    def from_json(cls, d: JsonObject) -> SampleRunCounts:
        """The counts of a record holding :meth:`to_json`'s keys; KeyError naming a missing key."""
        unstable, reach = d["unstable"], d["reach_max_m"]
        return cls(int(d["converged"]), int(d["not_converged"]), None if unstable is None else int(unstable),
                   str(d["stability_test"]), int(d["stability_untested"]), None if reach is None else float(reach))


@dataclass(frozen=True)
class SampleRecord:
    """``sample_run.json``: what a sample run was given, how far it got and what its samples held.

    Attributes
    ----------
    inputs : dict
        The run's inputs (robot, loads, bounds, n, seed, solver), passed through unread.
    solved : int
        Samples solved (``n`` unless interrupted).
    complete : bool
        Whether all ``n`` were solved.
    counts : SampleRunCounts
        At the top level of the JSON.
    seconds : float
        Wall time of the samples [s] (0 where a record dropped it).
    files : tuple of str
        The files of the run, this one included.
    """

    inputs: JsonDict
    solved: int
    complete: bool
    counts: SampleRunCounts
    seconds: float
    files: tuple[str, ...]

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``schema_version``, the inputs, solved, complete, the counts, the time and the
        files."""
        return {"schema_version": SAMPLE_SCHEMA_VERSION, "inputs": self.inputs, "solved": self.solved,
                "complete": self.complete, **self.counts.to_json(), "seconds": self.seconds,
                "files": list(self.files)}

    @classmethod
    def from_json(cls, d: JsonObject) -> SampleRecord:
        """A ``sample_run.json`` (or :meth:`to_json`). :class:`~pytdcr.records.RecordKeyError` naming a missing
        key; ValueError for a part that is not a JSON object or another ``schema_version`` than
        :data:`SAMPLE_SCHEMA_VERSION`."""
        def read(d: JsonObject) -> SampleRecord:
            check_schema(d, _SAMPLE_FILE, SAMPLE_SCHEMA_VERSION)
            return cls(part(_SAMPLE_FILE, "inputs", dict, d["inputs"]), int(d["solved"]), bool(d["complete"]),
                       SampleRunCounts.from_json(d), float(d.get("seconds", 0.0)), _files(d))

        return part(_SAMPLE_FILE, "", read, d)


@dataclass(frozen=True)
class SampleSummary:
    """A sample run's summary (:meth:`SampleRun.to_json`).

    Attributes
    ----------
    robot : str
        The robot's name.
    solved : int
    seed : int or None
        The sampling's seed.
    counts : SampleRunCounts
        At the top level of the JSON.
    seconds : float
        Wall time [s] (0 where a record dropped it).
    files : tuple of str
        The files written (none without a folder).
    """

    robot: str
    solved: int
    seed: int | None
    counts: SampleRunCounts
    seconds: float
    files: tuple[str, ...]

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``schema_version``, robot, solved, seed, the counts, the time and the files."""
        return {"schema_version": SAMPLE_SCHEMA_VERSION, "robot": self.robot, "solved": self.solved,
                "seed": self.seed, **self.counts.to_json(), "seconds": self.seconds, "files": list(self.files)}

    @classmethod
    def from_json(cls, d: JsonObject) -> SampleSummary:
        """What :meth:`to_json` wrote; :class:`~pytdcr.records.RecordKeyError` naming a missing key."""
        def read(d: JsonObject) -> SampleSummary:
            check_schema(d, "sample summary", SAMPLE_SCHEMA_VERSION)
            seed = d["seed"]
            return cls(str(d["robot"]), int(d["solved"]), None if seed is None else int(seed),
                       SampleRunCounts.from_json(d), float(d.get("seconds", 0.0)), _files(d))

        return part("sample summary", "", read, d)


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

    @property
    def counts(self) -> SampleRunCounts:
        """What the samples held."""
        return SampleRunCounts.of(self.samples, self.model)

    @property
    def summary(self) -> SampleSummary:
        """The run's numbers, typed: counts, the largest reach [m], time [s] and files."""
        return SampleSummary(self.robot.name, int(self.samples.converged.size), self.samples.seed, self.counts,
                             self.samples.seconds, tuple(self.files))

    def to_json(self) -> JsonDict:
        """JSON-ready summary (:meth:`SampleSummary.to_json`)."""
        return self.summary.to_json()

    def to_dict(self) -> JsonDict:
        """:meth:`to_json` (the name older code calls)."""
        return self.to_json()


def _samples_rows(samples: WorkspaceSamples) -> Iterator[list[int | str]]:
    """samples.csv's rows: the sample (from 1), its tensions [N], tip [m] and reach [m] (empty when not
    converged), whether it converged, its residual [N m] and stability (1, 0, empty: untested)."""
    stable = samples.stable
    for k in range(samples.tensions.shape[0]):
        tip = samples.tip_position[k]
        yield [k + 1, *[f"{x:.12g}" for x in samples.tensions[k]],
               *[("" if not np.isfinite(x) else f"{x:.12g}") for x in tip],
               "" if not samples.converged[k] else f"{samples.reach[k]:.12g}",
               int(samples.converged[k]), f"{samples.residual[k]:.6g}",
               "" if not np.isfinite(stable[k]) else int(stable[k])]


@dataclass(frozen=True)
class _SampleFiles:
    """Writes the data of a run of ``n`` samples into ``out``: what the run was given (``inputs``: the inputs
    record) and the model that solves the samples."""

    out: Path
    n: int
    n_tendons: int
    inputs: JsonDict
    model: str

    def record(self, samples: WorkspaceSamples, files: list[str]) -> SampleRecord:
        """``sample_run.json``'s record of ``samples`` (of ``n`` asked), the run's ``files`` before it."""
        done = int(samples.converged.size)
        return SampleRecord(self.inputs, done, done == self.n, SampleRunCounts.of(samples, self.model), samples.seconds,
                            (*files, "sample_run.json"))

    def write_record(self, samples: WorkspaceSamples, files: list[str]) -> None:
        """``sample_run.json``."""
        write_json(self.out / "sample_run.json", self.record(samples, files).to_json())

    def write(self, samples: WorkspaceSamples) -> list[str]:
        """samples.csv and sample_run.json (the data first, then the figures)."""
        write_csv(self.out / "samples.csv", ["sample", *[f"T{c + 1}_N" for c in range(self.n_tendons)], "tip_x_m",
                                             "tip_y_m", "tip_z_m", "reach_m", "converged", "residual_Nm", "stable"],
                  _samples_rows(samples))
        self.write_record(samples, ["samples.csv"])
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
    try:
        samples = sample_workspace(robot, loads, bounds, n, seed=settings.seed, model=m, options=opts,
                                   config=SamplingConfig(progress=progress, stability=True))
    except SamplingInterrupted as stop:
        with saving():
            _sample_files(out, inputs, n, stop.samples.seed).write(stop.samples)
        raise
    with saving():  # the samples are solved: Ctrl-C from here waits for the files
        writer = _sample_files(out, inputs, n, samples.seed)
        files = writer.write(samples)[:1]
        ax = plot_reach_samples(samples.reach, samples.converged)
        ax.set_title(f"{robot.name}: reach of {n} random tension samples (seed {samples.seed})")
        files += save_figure(ax.figure, out, "fig3a_samples")
        ok = np.flatnonzero(samples.converged)[:settings.n_shapes]
        shapes = [solve(robot, loads.with_tensions(samples.tensions[k]), model=m, q0=samples.q[k], options=opts)
                  for k in ok]
        ax = plot_robots(robot, shapes)
        ax.set_title(f"robot '{robot.name}' ({m.name}): {len(shapes)} sampled configurations, coloured by reach")
        files += save_figure(ax.figure, out, "fig4_configurations")
        writer.write_record(samples, files)
    return SampleRun(robot, samples, [*files, "sample_run.json"], m.name)


def _sample_files(out: Path, inputs: RunInputs, n: int, seed: int | None) -> _SampleFiles:
    """The writer of a sample run's data in ``out``: ``n`` samples of ``inputs`` drawn with ``seed``."""
    robot, m = inputs.robot, inputs.model
    record = inputs_record(robot, inputs.loads, bounds=inputs.bounds.to_dict(), n=n, seed=seed,
                           solver=options_record(m, inputs.options))
    return _SampleFiles(out, n, robot.n_tendons, record, m.name)


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

    @property
    def record(self) -> OptimizeRecord:
        """The result and the files, typed (no inputs: those are ``optimize.json``'s alone)."""
        return OptimizeRecord(None, self.result, tuple(self.files))

    def to_json(self) -> JsonDict:
        """JSON-ready: ``schema_version``, the result (:meth:`ReachResult.to_json`) and the files."""
        return self.record.to_json()

    def to_dict(self) -> JsonDict:
        """:meth:`to_json` (the name older code calls)."""
        return self.to_json()


@dataclass(frozen=True, eq=False)
class OptimizeRecord:
    """``optimize.json``: what a reach search was given, its result and the files written.

    Attributes
    ----------
    inputs : dict or None
        The run's inputs (robot, loads, bounds, the GA's settings, seed, solver), passed through unread; None
        for :meth:`OptimizeRun.to_json`, which has none (the key is then absent).
    result : ReachResult
    files : tuple of str
        The files written before it (figures and the history CSV).
    """

    inputs: JsonDict | None
    result: ReachResult
    files: tuple[str, ...]

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``schema_version``, the inputs (when known), the result and the files."""
        head: JsonDict = {"schema_version": OPTIMIZE_SCHEMA_VERSION}
        if self.inputs is not None:
            head["inputs"] = self.inputs
        return {**head, "result": self.result.to_json(), "files": list(self.files)}

    @classmethod
    def from_json(cls, d: JsonObject) -> OptimizeRecord:
        """An ``optimize.json`` (or :meth:`to_json`): :class:`~pytdcr.records.RecordKeyError` naming the path of
        a missing key (``result.polish.message``); ValueError for a part that is not a JSON object or another
        ``schema_version``."""
        def read(d: JsonObject) -> OptimizeRecord:
            check_schema(d, _OPTIMIZE_FILE, OPTIMIZE_SCHEMA_VERSION)
            inputs = d.get("inputs")
            return cls(None if inputs is None else part(_OPTIMIZE_FILE, "inputs", dict, inputs),
                       part(_OPTIMIZE_FILE, "result", ReachResult.from_json, d["result"]), _files(d))

        return part(_OPTIMIZE_FILE, "", read, d)


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


def write_optimize(res: ReachResult, problem: ReachProblem, out: Path, *, stem: str = "",
                   load_words: str = "") -> list[str]:
    """Fig. 5, Fig. 6, the history CSV and the JSON record (:class:`OptimizeRecord`) of a GA run into ``out``, a
    folder the caller manages; returns the file names. ``load_words`` names the load case in the figures' titles
    (e.g. "the paper's tip wrench", "a payload"; default "the given loads"). ValueError for the result of a
    polish alone (no GA)."""
    s = res.ga_settings
    if s is None:
        raise ValueError("write_optimize: the result of a polish alone has no GA to report")
    robot, loads = problem.robot, problem.loads
    files: list[str] = []
    sfx = f"_{stem}" if stem else ""
    h = res.per_generation
    ax = plot_convergence(h.best.tolist(), h.mean.tolist())
    where = f"robot '{robot.name}' ({problem.model.name}), {load_words or 'the given loads'}"
    ax.set_title(f"{where}\nGA, population {s.pop_size}: {res.generations} generations, {res.evaluations} solves")
    files += save_figure(ax.figure, out, f"fig5_convergence{sfx}")
    sol = problem.solve(res.tensions, atol=TIGHT_ATOL)
    ax = plot_robot(robot, sol, loads=load_arrows(sol, loads, robot))
    ax.set_title(f"{where}\nthe optimum: reach {sol.reach:.4f} m")
    files += save_figure(ax.figure, out, f"fig6_optimum{sfx}")
    write_csv(out / f"history{sfx}.csv",
              ["generation", "best_cost_per_m", "mean_cost_per_m", "evaluations", "nonconverged"],
              ([g + 1, f"{h.best[g]:.12g}", f"{h.mean[g]:.12g}", h.evaluations[g], h.nonconverged[g]]
               for g in range(res.generations)))
    files.append(f"history{sfx}.csv")
    inputs = inputs_record(robot, loads, bounds=problem.bounds.to_dict(), pop=s.pop_size, tol=s.tol,
                           window=s.window, max_gen=s.max_gen, seed=res.seed, polish=s.polish,
                           local_search=s.local_search, solver=options_record(problem.model, problem.options))
    write_json(out / f"optimize{sfx}.json", OptimizeRecord(inputs, res, tuple(files)).to_json())
    files.append(f"optimize{sfx}.json")
    return files

"""The paper's whole study (sections 3-4) in one run: samples, the GA at three populations, a payload, bounds."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bounds import TensionBounds
from ..loads import MAX_TENSION, Loads
from ..optimize import MemeticGA, ReachProblem, ReachResult, Termination, maximize_reach, polish_reach
from ..paper import DEFAULT_BOUNDS, PAYLOAD_MASS, paper_bounds, paper_loads, payload_loads
from ..plotting import plot_robot, save_figure
from ..robot import Robot
from ..runtime import (
    atomic_write_text,
    default_threads,
    end_stage,
    output_folder,
    saving,
    single_threaded_blas,
    worker_pool,
    write_json,
)
from ..statics import options_record, resolve, solve
from ..validate import SettingsError, check_real, show
from ..workspace.parts import Estimate
from ._output import inputs_record, load_arrows
from ._reproduce_records import OnGeneration, PassiveSolveRecord, Progress, ReproduceRun, SamplingRecord, Step
from ._reproduce_report import reproduce_report
from ._runs import sample_into, write_optimize
from ._settings import SampleSettings
from ._survival import ModelVerdict, model_verdicts, verdict_text
from ._workspace import section_check, section_estimate, workspace_section, workspace_text
from ._workspace_records import WorkspaceSection

__all__ = ["Progress", "ReproduceRun", "ReproduceSettings", "check_reproduce", "reproduce_estimate",
           "run_reproduce"]


@dataclass(frozen=True)
class ReproduceSettings:
    """The budget of :func:`run_reproduce`. The defaults are the demo's (``make demo``: the paper's study at a
    modest budget, about a minute on 2 cores); :meth:`full` is the paper's whole study.

    Attributes
    ----------
    pops : tuple of int
        GA populations under the paper's load (the paper: 50, 100, 200; the demo: 50 and 100).
    n_samples : int
        Random tension vectors of Fig. 3(a).
    tol, window, max_gen : float, int, int
        The GA's termination (:class:`~pytdcr.optimize.Termination`).
    bound_uppers : tuple of float
        Upper tension bounds of the bounds study [N] (the demo: 20 and 40; :meth:`full` adds 10, whose GA is the
        study's slowest: its optimum lies where loading paths fold, and up to a third of the solves of its local
        searches snap through, at about 40 ms each against 5 ms).
    side_max_gen : int
        Generation cap of the payload and bounds studies.
    n_polish : int
        Starts of each final polish.
    verdict_models : tuple of str
        Models that re-evaluate and re-optimise the paper's optimum.
    workspace_n, workspace_budget, workspace_voxels, workspace_directions : int
        The workspace section (the FSW under the paper's load next to no load): base samples, the boundary
        search's budget of solves, voxels per robot length, support directions (0: no h(d) and no reach search,
        the largest reach is the farthest sample's). Modest by default (the demo: about 11 s, a wide error).
    verdict_ga_pop : int
        Their GA population; 0 (the modest default): a gradient polish from the paper's optimum only, at most
        ``verdict_polish_iter`` iterations (an ``sscr`` solve near that optimum crosses folds: about 0.4 s).
    workspace_models : tuple of str
        Models whose FSWs under the paper's load the workspace section compares (volumes, the Hausdorff distance
        between boundaries, the share of each inside the others): how much of the paper's workspace is its
        model's error. None by default (the demo); :meth:`full`: pcc, pcc2 and sscr.
    models_n, models_voxels : int
        That comparison's base samples and voxels per robot length (its boundary search has 25 n solves and stops
        at folds, ``folds="stop"``: snapping through them, ``sscr``'s search takes hours; with it the three
        regions take about 7 minutes at the full settings on 2 cores).
    """

    pops: tuple[int, ...] = (50, 100)
    n_samples: int = 100
    tol: float = 1e-6
    window: int = 5
    max_gen: int = 30
    bound_uppers: tuple[float, ...] = (20.0, 40.0)
    side_max_gen: int = 30
    n_polish: int = 2
    verdict_models: tuple[str, ...] = ("pcc2", "sscr")
    verdict_ga_pop: int = 0
    verdict_polish_iter: int = 4
    workspace_n: int = 128
    workspace_budget: int = 300
    workspace_voxels: int = 10
    workspace_directions: int = 0
    workspace_models: tuple[str, ...] = ()
    models_n: int = 1000
    models_voxels: int = 16

    def __post_init__(self) -> None:
        """The bounds study's upper bounds: one or more distinct finite tensions in (0, MAX_TENSION] N (two equal
        bounds gave a rate of change per newton of 0/0)."""
        if isinstance(self.bound_uppers, (str, bytes)) or not hasattr(self.bound_uppers, "__len__") or \
                not 1 <= len(self.bound_uppers) <= 16:
            raise SettingsError("bound_uppers", f" = {show(self.bound_uppers)}: give 1 to 16 upper tension bounds [N]")
        ups = tuple(check_real(v, "bound_uppers", 0.0, MAX_TENSION, "N", lo_open=True) for v in self.bound_uppers)
        if len(set(ups)) != len(ups):
            raise SettingsError("bound_uppers", f" = {show(self.bound_uppers)}: the bounds must differ")
        object.__setattr__(self, "bound_uppers", ups)

    @classmethod
    def full(cls) -> ReproduceSettings:
        """The paper's whole study (``tdcr reproduce --full``): populations 50, 100 and 200, bounds 10, 20 and
        40 N, the better models re-optimising with the memetic GA too, the workspace section at ``tdcr
        workspace``'s defaults (n 4000, 12.5 mm voxels, 200 directions), and the FSWs of pcc, pcc2 and sscr
        under the paper's load compared (n 1000, 25 mm voxels)."""
        return cls(pops=(50, 100, 200), bound_uppers=(10.0, 20.0, 40.0), verdict_ga_pop=50, verdict_polish_iter=8,
                   workspace_n=4000, workspace_budget=25 * 4000, workspace_voxels=32, workspace_directions=200,
                   workspace_models=("pcc", "pcc2", "sscr"))


@dataclass(frozen=True)
class _Stages:
    """The study's ``progress`` (or None: nothing shown), asked for each stage's callback."""

    progress: Progress | None

    def generations(self, stage: str, total: int) -> OnGeneration | None:
        """A GA stage of at most ``total`` generations: its ``on_generation`` (None without progress)."""
        return None if self.progress is None else self.progress(stage, total, "gen")

    def steps(self, stage: str, total: int | None, unit: str) -> Step | None:
        """A stage of ``total`` steps of ``unit`` (None: not known): its ``step(k)`` (None without progress)."""
        return None if self.progress is None else self.progress(stage, total, unit)


@dataclass(frozen=True)
class _Job:
    problem: ReachProblem
    pop: int
    max_gen: int
    label: str


def _jobs(robot: Robot, s: ReproduceSettings) -> dict[str, _Job]:
    """Every GA run of the study, by key: ``pop50``..., ``payload``, ``bounds10``..."""
    nt = robot.n_tendons
    bounds = paper_bounds(nt)
    loaded = ReachProblem.create(robot, paper_loads(np.zeros(nt)), bounds)
    jobs = {f"pop{p}": _Job(loaded, p, s.max_gen, f"GA population {p}") for p in s.pops}
    jobs["payload"] = _Job(ReachProblem.create(robot, payload_loads(robot), bounds), s.pops[0], s.side_max_gen,
                           "GA under a payload")
    for h in s.bound_uppers:
        if h != DEFAULT_BOUNDS[1] or DEFAULT_BOUNDS[0] != 0.0:
            b = TensionBounds.uniform(nt, 0.0, h)
            jobs[f"bounds{h:g}"] = _Job(ReachProblem.create(robot, loaded.loads, b), s.pops[0], s.side_max_gen,
                                        f"GA, bounds [0, {h:g}] N")
    return jobs


def _sample_and_passive(robot: Robot, loads: Loads, bounds: TensionBounds, s: ReproduceSettings, seed: int,
                        out: Path, files: list[str], stages: _Stages) -> tuple[SamplingRecord, PassiveSolveRecord]:
    """Fig. 3(a) and Fig. 4 (random samples under the paper's load), Fig. 3(b) (no tension, the load alone):
    writes their figures and data in ``out``, appends the files' names to ``files``."""
    step = stages.steps("sampling", s.n_samples, "solve")
    sample = sample_into(out, SampleSettings(n=s.n_samples, seed=seed), robot=robot, loads=loads, bounds=bounds,
                         progress=step)
    end_stage(step)
    files += sample.files
    smp = sample.samples
    sampling = SamplingRecord.of(s.n_samples, smp.converged, smp.reach, smp.seconds)
    passive = solve(robot, loads)
    if passive.converged:
        ax = plot_robot(robot, passive, loads=load_arrows(passive, loads, robot))
        ax.set_title(f"robot '{robot.name}', no tension: tip force {tuple(loads.tip_force.tolist())} N,\n"
                     f"tip moment {tuple(loads.tip_moment.tolist())} N m (arrows: the legend)", fontsize=10)
        files += save_figure(ax.figure, out, "fig3b_loaded")
    return sampling, PassiveSolveRecord.of(bool(passive.converged), passive.tip_position, passive.reach)


def _adopt(r: ReachResult, other: ReachResult) -> ReachResult:
    """``r`` with ``other``'s optimum as its final one (the GA stage of ``r`` kept)."""
    start_cost = r.ga.cost if r.ga is not None else r.cost
    return dataclasses.replace(r, tensions=other.tensions, tip_position=other.tip_position, reach=other.reach,
                               cost=other.cost, value=other.value, stable=other.stable,
                               polish_gain=start_cost - other.cost)


def _bounds_study(robot: Robot, jobs: dict[str, _Job], done: dict[str, ReachResult], ga: dict[int, ReachResult],
                  s: ReproduceSettings) -> list[tuple[float, ReachResult]]:
    """How the optimum depends on the upper bound.

    At the default bounds the main study's best run, else the side run; then one more polish from the
    optimum of the next tighter bounds (which lies inside these), keeping the better.
    """
    loads = jobs[f"pop{s.pops[0]}"].problem.loads
    study: list[tuple[float, ReachResult]] = []
    for hi in sorted(s.bound_uppers):
        b = TensionBounds.uniform(robot.n_tendons, 0.0, hi)
        r = done.get(f"bounds{hi:g}") or min(ga.values(), key=lambda g_: g_.cost)
        if study:
            p2 = polish_reach(ReachProblem.create(robot, loads, b), study[-1][1].tensions)
            if p2.cost < r.cost:
                r = _adopt(r, p2)
        study.append((hi, r))
    return study


def _run_jobs(jobs: dict[str, _Job], s: ReproduceSettings, seed: int, stages: _Stages,
              between: Callable[[], None], finished: Callable[[str, ReachResult], None]) -> dict[str, ReachResult]:
    """Run the GA jobs two at a time in worker threads (the compiled solvers release the GIL).

    This thread runs ``between`` meanwhile and then ``finished`` for each job in order (pyplot, which
    draws the figures, is not thread-safe). Each run is deterministic by its seed, whatever the interleaving.
    """
    def run(j: _Job) -> ReachResult:
        step = stages.generations(j.label, j.max_gen)
        try:
            return maximize_reach(j.problem, MemeticGA(pop_size=j.pop, n_polish=s.n_polish),
                                  Termination(s.tol, s.window, j.max_gen), seed=seed, on_generation=step)
        finally:
            end_stage(step)

    order = sorted(jobs, key=lambda k: -jobs[k].pop)  # largest populations first
    done: dict[str, ReachResult] = {}
    # BLAS on one thread throughout: a job's gradients call LAPACK outside the solvers' own limit, and whether the
    # other job's solve held that limit at the time changed their last bits from run to run
    with single_threaded_blas(), worker_pool(min(2, default_threads())) as submit:  # Ctrl-C stops the jobs too
        futures = {k: submit(run, jobs[k]) for k in order}
        between()
        for k in order:
            done[k] = futures[k].result()
            finished(k, done[k])
    return done


def reproduce_estimate(robot: Robot, settings: ReproduceSettings | None = None, *, seed: int = 0) -> Estimate:
    """The expected length of :func:`run_reproduce`'s workspace sections (:func:`~pytdcr.workspace.workspace_estimate`),
    which take longest when they are large (``--full``); the GAs and the better models run beside them."""
    return section_estimate(robot, paper_bounds(robot.n_tendons), settings or ReproduceSettings(), seed=seed)


def check_reproduce(robot: Robot, settings: ReproduceSettings, *, seed: int = 0) -> None:
    """Every model the study will ask of ``robot``, checked against its capabilities before any solve: the
    better models' re-optimisation (a tip gradient, the robot's friction law, the paper's wrench) and each case
    of the workspace sections (:func:`section_check`).

    Raises
    ------
    SettingsError
        Naming the field (``verdict_models``, ``workspace_models``, or ``robot``), the model and what it lacks.
    """
    loads = paper_loads(np.zeros(robot.n_tendons))
    try:  # the study's own model (the GAs'), as the study makes its problems
        ReachProblem.create(robot, loads, paper_bounds(robot.n_tendons))
    except ValueError as err:
        raise SettingsError("robot", f": {err}") from None
    for name in settings.verdict_models:
        try:
            resolve(name, robot, loads, gradient=True)
        except ValueError as err:  # UnsupportedFeatureError, or an unknown model
            raise SettingsError("verdict_models", f": model '{name}': {err}") from None
    section_check(robot, settings, seed=seed)


def run_reproduce(robot: Robot, out: str | Path, *, seed: int = 0, progress: Progress | None = None,
                  settings: ReproduceSettings | None = None) -> ReproduceRun:
    """The paper's whole study (sections 3-4) on ``robot``; writes figures, data and ``report.md`` in ``out``.

    ``out`` follows the output-folder rule (:func:`output_folder`): Ctrl-C keeps the figures and data
    finished so far, with the manifest's status ``interrupted``. ``progress(stage, total, unit)``
    (:class:`~pytdcr.runs._reproduce_records.Progress`) returns each stage's callback: a GA's ``on_generation``
    for ``unit`` "gen", a ``step(k)`` otherwise; its ``close()``, where it has one, is called when the stage ends
    (a GA that converges stops before ``total``). The result is typed; ``reproduce.json`` is its
    :meth:`ReproduceRun.to_json`, read back with :meth:`ReproduceRun.from_json`.
    """
    s = settings or ReproduceSettings()
    check_reproduce(robot, s, seed=seed)
    with output_folder(out, "reproduce", {"seed": seed, **dataclasses.asdict(s)}) as run:
        return _reproduce(robot, run.staging, seed, progress, s)


def _reproduce(robot: Robot, out: Path, seed: int, progress: Progress | None, s: ReproduceSettings) -> ReproduceRun:
    t_start = time.perf_counter()
    bounds = paper_bounds(robot.n_tendons)
    jobs = _jobs(robot, s)
    loaded = jobs[f"pop{s.pops[0]}"].problem
    stages = _Stages(progress)
    files: list[str] = []  # every file written, in order
    sampling: SamplingRecord | None = None
    passive: PassiveSolveRecord | None = None
    workspace: WorkspaceSection | None = None

    pops: dict[int, ReachResult] = {}
    later: list[Future[list[ModelVerdict]]] = []

    def finished(key: str, r: ReachResult) -> None:
        # Fig. 5 (each population, under the paper's load) and Fig. 6 (under a payload along gravity), drawn as
        # the runs finish
        if key.startswith("pop") or key == "payload":
            words = f"a {PAYLOAD_MASS * 1e3:g} g payload" if key == "payload" else "the paper's tip wrench"
            files.extend(write_optimize(r, jobs[key].problem, out, stem=key, load_words=words))
        if key.startswith("pop"):
            pops[jobs[key].pop] = r
            if len(pops) == len(set(s.pops)):  # the optimum is known: each better model takes it up beside the GA
                best = min(pops.values(), key=lambda g_: g_.cost)
                later.extend(submit(model_verdicts, robot, loaded.loads, bounds, best, models=(m,),
                                    budget=(s.verdict_ga_pop, s.verdict_polish_iter), seed=seed,
                                    progress=progress)
                             for m in s.verdict_models)

    def side() -> None:
        nonlocal sampling, passive, workspace
        sampling, passive = _sample_and_passive(robot, loaded.loads, bounds, s, seed, out, files, stages)
        workspace = workspace_section(robot, bounds, s, out, files, seed=seed, progress=progress)

    # the better models' runs are independent of each other and of the GA's other jobs (BLAS on one thread)
    with single_threaded_blas(), worker_pool(max(1, len(s.verdict_models))) as submit:
        done = _run_jobs(jobs, s, seed, stages, side, finished)
        ga = {pop: done[f"pop{pop}"] for pop in s.pops}
        pay = done["payload"]
        best = min(ga.values(), key=lambda r: r.cost)
        bound_study = _bounds_study(robot, jobs, done, ga, s)
        verdicts = [v for f in later for v in f.result()]
    if sampling is None or passive is None or workspace is None:  # side() ran before any job finished
        raise RuntimeError("the study's samples and workspace section were not computed")
    with saving():  # everything is computed: Ctrl-C from here waits for the report
        inputs = inputs_record(robot, loaded.loads, bounds=bounds.to_dict(), seed=seed, payload_mass_kg=PAYLOAD_MASS,
                               **dataclasses.asdict(s), solver=options_record(loaded.model, loaded.options))
        run = ReproduceRun(seed, files, sampling, passive, workspace, time.perf_counter() - t_start, ga, pay,
                           bound_study, verdicts, inputs)
        report = reproduce_report(robot, run, bounds, s, [*verdict_text(best, verdicts),
                                                          *workspace_text(run.workspace, s)])
        atomic_write_text(out / "report.md", report)
        run = dataclasses.replace(run, files=[*files, "report.md"])
        write_json(out / "reproduce.json", run.to_json())
    return run

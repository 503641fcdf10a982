"""One design of a study, evaluated on its own: the same numbers wherever it runs.

:func:`evaluate_design` takes plain data (the study as a dict, the design's index and parameter values) and
returns a :class:`~pytdcr.designs._records.DesignRecord` (a frozen dataclass of plain values), so that a local
process or a Dask worker can run it and pickle its result back. Its randomness comes from the study's
seed and the design's index alone; its solves run on one thread (the executor runs designs side by side).
"""

from __future__ import annotations

import os
import socket
import time
import traceback
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..statics import Cancelled
from ..workspace import WorkspaceSettings, check_workspace, workspace_estimate, workspace_study
from ..workspace.parts import Estimate
from ._records import CaseRow, DesignRecord, Timing
from ._space import apply_parameters
from ._spec import MEASURES, DesignStudy

if TYPE_CHECKING:
    from ..loads import Loads
    from ..robot import Robot

__all__ = ["MEASURES", "check_capabilities", "design_seed", "designs_estimate", "evaluate_design"]


def design_seed(study_seed: int, index: int) -> int:
    """The seed of design ``index``: from the study's seed and the index alone (the reference, index -1, has its
    own)."""
    entropy = [int(study_seed), int(index)] if index >= 0 else [int(study_seed), 0, -int(index)]
    return int(np.random.SeedSequence(entropy).generate_state(1, dtype=np.uint32)[0])


def _workspace_settings(study: DesignStudy, base: Robot, seed: int) -> WorkspaceSettings:
    """The workspace study of every design and load case of ``study``: its budget, seeded by the design's
    ``seed``, h(d) along the study's named directions, on one thread (designs run side by side), on one grid
    for every design (the voxel of the base robot ``base``). The largest reach is the farthest of the feasible
    samples and the tips attaining h(d), and of the reach search with ``budget.reach_search``. No multistability
    check: it would cost 200 solves a design and rank nothing. The search meets folds as ``budget.folds`` says."""
    directions = tuple(tuple(v) for v in study.measures.directions.values())
    return WorkspaceSettings(n=study.budget.samples, seed=seed, voxel=study.budget.voxel,
                             search=study.budget.search > 0, budget=study.budget.search, directions=directions or 0,
                             reach="farthest" if study.budget.reach_search else "support",
                             threads=1, multistability=0, folds=study.budget.folds).with_voxel_for(base)


def check_capabilities(study: DesignStudy, robot: Robot, source: str = "study") -> None:
    """Every load case of ``study`` on its base ``robot`` against the study's model's capabilities, before any
    design is solved (:func:`pytdcr.workspace.check_workspace`, with each design's settings): the parameters vary
    geometry and stiffness only, so what the base robot can ask of the model, every design asks.

    Raises
    ------
    StudyError
        Naming ``model``, the load case and the capability the model lacks.
    """
    from ._spec import StudyError

    settings = _workspace_settings(study, robot, study.seed)
    for name, (case_robot, loads) in study.load_cases(robot).items():
        try:
            check_workspace(case_robot, loads, settings, model=study.model)
        except ValueError as err:  # UnsupportedFeatureError among them
            raise StudyError(f"{source}: model = {study.model!r}: load case '{name}': {err}") from None


def designs_estimate(study: DesignStudy, robot: Robot, designs: int, workers: int) -> Estimate:
    """The expected length of ``designs`` designs (and the base robot) of ``study`` on ``workers`` processes: the
    base robot's workspace study of each load case (:func:`~pytdcr.workspace.workspace_estimate`, on one thread)
    for each design. Designs that move the tendons or the backbone cost more or less than the base robot."""
    settings = _workspace_settings(study, robot, study.seed)
    bounds = TensionBounds.uniform(robot.n_tendons, *study.bounds)
    one = workspace_estimate([(r, loads, settings, study.model, None)
                              for r, loads in study.load_cases(robot).values()], bounds)
    runs = (designs + 1) / max(1, workers)
    return Estimate(one.seconds * runs, round(one.solves * (designs + 1)), one.solve_seconds, workers)


def _case_row(study: DesignStudy, settings: WorkspaceSettings, name: str, robot: Robot, loads: Loads) -> CaseRow:
    """Load case ``name``'s row of a design (``robot`` under ``loads``): its workspace study's numbers
    (:attr:`~pytdcr.workspace.WorkspaceStudy.summary`, the same ``tdcr workspace`` writes: volumes [m^3] with
    errors, dimension, shares of the samples, largest reach [m]), the peak bending stress [Pa] over the converged
    samples, the arc length [m], h [m] along the study's named directions, and the tensions that reach farthest
    [N]."""
    bounds = TensionBounds.uniform(robot.n_tendons, *study.bounds)
    ws = workspace_study(robot, loads, bounds, settings, model=study.model)
    s, numbers = ws.samples, ws.summary
    fsw, counts = numbers.fsw, numbers.counts
    names = list(study.measures.directions)
    h: dict[str, float] = {}
    if names:
        if ws.support is not None:
            along = ws.support.h
        else:  # no gradient search (or nothing feasible): the samples' own
            tips, D = s.tip_position[s.feasible], settings.direction_vectors()
            along = (tips @ D.T).max(axis=0) if tips.size else np.full(len(names), np.nan)
        h = {k: float(v) for k, v in zip(names, along, strict=True)}
    far = ws.largest_reach  # the tensions that reach farthest, to draw the design (not a column of the table)
    return CaseRow(
        load_case=name, volume_m3=fsw.volume_m3, volume_err_m3=fsw.volume_err_m3,
        realisable_volume_m3=numbers.realisable.volume_m3, realisable_volume_err_m3=numbers.realisable.volume_err_m3,
        fsw_dimension=fsw.dimension,
        fraction_converged=counts.converged / counts.solved if counts.solved else float("nan"),
        fraction_realisable=counts.fraction_realisable,
        peak_stress_pa=(float(robot.backbone.youngs_modulus * np.nanmax(s.curvature) * robot.backbone.outer_radius)
                        if counts.converged else np.nan),
        arc_length_m=float(robot.length), h_m=h,
        largest_reach_m=fsw.largest_reach_m if fsw.largest_reach_m is not None else np.nan,
        reach_tensions_n=None if far.tensions is None else tuple(float(t) for t in far.tensions))


def evaluate_design(study_data: Mapping[str, object], robot_data: Mapping[str, object], index: int,
                    params: dict[str, float]) -> DesignRecord:
    """Evaluate design ``index`` (``params`` applied to the base robot ``robot_data``) under every load case.

    ``study_data`` and ``robot_data`` are a :class:`~pytdcr.designs.DesignStudy`'s and a
    :class:`~pytdcr.robot.Robot`'s dumps (``model_dump()``: plain data a process pickles), validated again here.

    Returns its record: status ``"ok"`` with a row per load case (:class:`~pytdcr.designs._records.CaseRow`),
    or ``"failed"`` with its reason, and where and how long it ran. A design whose robot is invalid, or whose
    study raises, fails with its reason (and the traceback's end) instead of raising; an interrupt is not caught.
    The run sets its generation when it writes it.
    """
    from ..robot import Robot

    t0 = time.perf_counter()
    study = DesignStudy.model_validate(study_data)
    base = Robot.model_validate(robot_data)
    status, reason, trace = "ok", "", None
    rows: tuple[CaseRow, ...] = ()
    try:
        robot = apply_parameters(base, params)
        settings = _workspace_settings(study, base, design_seed(study.seed, index))
        rows = tuple(_case_row(study, settings, name, case_robot, loads)
                     for name, (case_robot, loads) in study.load_cases(robot).items())
        if all(r.fraction_converged == 0.0 for r in rows):
            status, reason = "failed", "no sample converged under any load case"
    except (Cancelled, KeyboardInterrupt):
        raise
    except Exception as err:  # a failed design is recorded and the study goes on
        status, reason, rows = "failed", f"{type(err).__name__}: {err}"[:500], ()
        trace = traceback.format_exc(limit=4)[-2000:]
    timing = Timing(time.perf_counter() - t0, socket.gethostname(), os.getpid())
    return DesignRecord(int(index), dict(params), status, reason, rows, timing, traceback=trace)

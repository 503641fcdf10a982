"""One design of a study, evaluated on its own: the same numbers wherever it runs.

:func:`evaluate_design` takes plain data (the study as a dict, the design's index and parameter values) and
returns plain data, so that a local process or a Dask worker can run it. Its randomness comes from the study's
seed and the design's index alone; its solves run on one thread (the executor runs designs side by side).
"""

from __future__ import annotations

import os
import socket
import time
import traceback
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..optimize import ReachProblem
from ..region import largest_reach, support_function, workspace_region
from ..statics import Cancelled, resolve
from ._space import apply_parameters
from ._spec import DesignStudy

__all__ = ["MEASURES", "design_seed", "evaluate_design"]

#: the measures of every row, with their units (h along the study's named directions come after, ``h_<name>_m``)
MEASURES = {
    "volume_m3": "FSW volume (converged, stable equilibria) [m^3]",
    "volume_err_m3": "its error [m^3]",
    "realisable_volume_m3": "volume of the realisable region (no disk below the base, no disks touching) [m^3]",
    "realisable_volume_err_m3": "its error [m^3]",
    "largest_reach_m": "largest ||tip|| over the feasible samples and the tips attaining h (searched when "
                       "budget.reach_search) [m]",
    "fraction_converged": "converged samples / samples solved",
    "fraction_realisable": "realisable samples / converged samples",
    "peak_stress_pa": "largest backbone bending stress E kappa r over the converged samples [Pa]",
    "arc_length_m": "the robot's length [m]",
}


def design_seed(study_seed: int, index: int) -> int:
    """The seed of design ``index``: from the study's seed and the index alone."""
    return int(np.random.SeedSequence([int(study_seed), int(index)]).generate_state(1, dtype=np.uint32)[0])


def _case_row(study: DesignStudy, robot: Any, loads: Any, seed: int) -> dict[str, Any]:
    bounds = TensionBounds.uniform(robot.n_tendons, *study.bounds)
    m, opts = resolve(study.model, robot, loads, None)
    wr = workspace_region(robot, loads, bounds, study.budget.samples, seed, model=m, options=opts,
                          search=study.budget.search > 0, budget=study.budget.search, threads=1)
    s = wr.samples
    ok, feas = s.converged, s.feasible
    tips = s.tip[feas]
    row: dict[str, Any] = {
        "volume_m3": wr.fsw.volume_m3, "volume_err_m3": wr.fsw.error_m3,
        "realisable_volume_m3": wr.realisable.volume_m3, "realisable_volume_err_m3": wr.realisable.error_m3,
        "largest_reach_m": float(np.linalg.norm(tips, axis=1).max()) if tips.size else np.nan,
        "fraction_converged": float(ok.mean()),
        "fraction_realisable": float(s.realisable.sum() / max(int(ok.sum()), 1)),
        "peak_stress_pa": (float(robot.backbone.youngs_modulus * np.nanmax(s.curvature)
                                 * robot.backbone.outer_radius) if ok.any() else np.nan),
        "arc_length_m": float(robot.length)}
    names = list(study.measures.directions)
    gradient = m.capabilities.gradient is not None
    problem = ReachProblem.create(robot, loads, bounds, model=m, options=opts) if gradient and tips.size else None
    if names:
        D = np.array([study.measures.directions[k] for k in names], dtype=float)
        D /= np.linalg.norm(D, axis=1, keepdims=True)
        if problem is not None:
            sf = support_function(problem, s.tensions[feas], tips, D, threads=1)
            h = sf.h  # the tips that attain h are feasible too: the largest reach is at least theirs
            row["largest_reach_m"] = max(row["largest_reach_m"], float(np.linalg.norm(sf.tips, axis=1).max()))
        else:
            h = (tips @ D.T).max(axis=0) if tips.size else np.full(len(names), np.nan)
        row.update({f"h_{k}_m": float(v) for k, v in zip(names, h, strict=True)})
    if study.budget.reach_search and problem is not None:
        row["largest_reach_m"] = float(largest_reach(problem, s.tensions[feas], tips, threads=1).reach)
    return row


def evaluate_design(study_data: dict[str, Any], robot_data: dict[str, Any], index: int,
                    params: dict[str, float]) -> dict[str, Any]:
    """Evaluate design ``index`` (``params`` applied to the base robot ``robot_data``) under every load case.

    Returns ``{"design", "params", "status": "ok" | "failed", "reason", "rows": [one per load case],
    "timing": {"seconds", "host", "pid"}}``. A design whose robot is invalid, or whose study raises, fails with
    its reason instead of raising; an interrupt is not caught.
    """
    from ..design import Robot

    t0 = time.perf_counter()
    study = DesignStudy.model_validate(study_data)
    base = Robot.model_validate(robot_data)
    out: dict[str, Any] = {"design": int(index), "params": dict(params), "status": "ok", "reason": "", "rows": []}
    try:
        robot = apply_parameters(base, params)
        seed = design_seed(study.seed, index)
        for name, (case_robot, loads) in study.load_cases(robot).items():
            row = _case_row(study, case_robot, loads, seed)
            out["rows"].append({"load_case": name, **row})
        if all(r["fraction_converged"] == 0.0 for r in out["rows"]):
            out["status"], out["reason"] = "failed", "no sample converged under any load case"
    except (Cancelled, KeyboardInterrupt):
        raise
    except Exception as err:  # a failed design is recorded and the study goes on
        out["status"] = "failed"
        out["reason"] = f"{type(err).__name__}: {err}"[:500]
        out["rows"] = []
        out["traceback"] = traceback.format_exc(limit=4)[-2000:]
    out["timing"] = {"seconds": time.perf_counter() - t0, "host": socket.gethostname(), "pid": os.getpid()}
    return out

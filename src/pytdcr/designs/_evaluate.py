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
from ..region import VOXELS_PER_LENGTH, largest_reach, support_function, workspace_region
from ..statics import Cancelled, resolve
from ._space import apply_parameters
from ._spec import MEASURES, DesignStudy

__all__ = ["MEASURES", "design_seed", "evaluate_design"]

def design_seed(study_seed: int, index: int) -> int:
    """The seed of design ``index``: from the study's seed and the index alone (the reference, index -1, has its
    own)."""
    entropy = [int(study_seed), int(index)] if index >= 0 else [int(study_seed), 0, -int(index)]
    return int(np.random.SeedSequence(entropy).generate_state(1, dtype=np.uint32)[0])


def _case_row(study: DesignStudy, robot: Any, loads: Any, seed: int, voxel: float) -> dict[str, Any]:
    bounds = TensionBounds.uniform(robot.n_tendons, *study.bounds)
    m, opts = resolve(study.model, robot, loads, None)
    wr = workspace_region(robot, loads, bounds, study.budget.samples, seed, model=m, options=opts, voxel=voxel,
                          search=study.budget.search > 0, budget=study.budget.search, threads=1)
    s = wr.samples
    ok, feas = s.converged, s.feasible
    tips = s.tip[feas]
    reach = np.linalg.norm(tips, axis=1)
    far = (float(reach.max()), s.tensions[feas][int(reach.argmax())]) if tips.size else (np.nan, None)
    row: dict[str, Any] = {
        "volume_m3": wr.fsw.volume_m3, "volume_err_m3": wr.fsw.error_m3,
        "realisable_volume_m3": wr.realisable.volume_m3, "realisable_volume_err_m3": wr.realisable.error_m3,
        "fraction_converged": float(ok.mean()),
        "fraction_realisable": float(s.realisable.sum() / max(int(ok.sum()), 1)),
        "peak_stress_pa": (float(robot.backbone.youngs_modulus * np.nanmax(s.curvature)
                                 * robot.backbone.outer_radius) if ok.any() else np.nan),
        "arc_length_m": float(robot.length)}
    names = list(study.measures.directions)
    sf = None
    gradient = m.capabilities.gradient is not None
    problem = ReachProblem.create(robot, loads, bounds, model=m, options=opts) if gradient and tips.size else None
    if names:
        D = np.array([study.measures.directions[k] for k in names], dtype=float)
        D /= np.linalg.norm(D, axis=1, keepdims=True)
        if problem is not None:
            sf = support_function(problem, s.tensions[feas], tips, D, threads=1)
            h = sf.h  # the tips that attain h are feasible too: the largest reach is at least theirs
            r = np.linalg.norm(sf.tips, axis=1)
            if r.max() > far[0]:
                far = (float(r.max()), sf.tensions[int(r.argmax())])
        else:
            h = (tips @ D.T).max(axis=0) if tips.size else np.full(len(names), np.nan)
        row.update({f"h_{k}_m": float(v) for k, v in zip(names, h, strict=True)})
    if study.budget.reach_search and problem is not None:
        lr = largest_reach(problem, s.tensions[feas], tips, support=sf, threads=1)
        if lr.reach >= far[0]:  # keep the farther of the search and the support function's tips
            far = (float(lr.reach), lr.tensions)
    row["largest_reach_m"] = far[0]
    # not a column: the tensions that reach farthest, to draw the design (the table ignores this key)
    row["reach_tensions_n"] = None if far[1] is None else [float(t) for t in far[1]]
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
        voxel = study.budget.voxel or base.length / VOXELS_PER_LENGTH  # one voxel for every design
        for name, (case_robot, loads) in study.load_cases(robot).items():
            row = _case_row(study, case_robot, loads, seed, voxel)
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

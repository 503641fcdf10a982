"""A calibration run (``tdcr calibrate``): the fit of :func:`pytdcr.calibrate.calibrate` and its files.

The folder holds ``calibration.json`` (the :class:`~pytdcr.calibrate.CalibrationResult`, with the robot before the
fit and the run's inputs), ``robot_fitted.toml`` (the robot with the fitted values, ready for every other
command's ``--robot``), ``rows.csv`` (each row's inputs, measured tip, predicted tips and errors) and the figure
``fig_calibration`` (.png, .pdf).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..calibrate import CalibrationOptions, CalibrationResult, Measurements, calibrate
from ..io import write_robot
from ..loads import Loads
from ..plotting import plot_calibration, save_figure
from ..robot import Robot
from ..runtime import output_folder, write_csv, write_json
from ..statics import saving
from ._output import inputs_record

__all__ = ["CalibrationRun", "run_calibration"]


@dataclass(frozen=True)
class CalibrationRun:
    """A finished calibration run: the fit and the names of the files written."""

    result: CalibrationResult
    files: tuple[str, ...]


def _rows(data: Measurements, r: CalibrationResult) -> tuple[list[str], list[list[object]]]:
    """``rows.csv``'s header and rows: inputs, measurement, predictions [m] and errors [mm]."""
    n = data.tensions.shape[1]
    xyz = ("x", "y", "z")
    driven = [] if data.displacements is None else list(np.flatnonzero(~np.isnan(data.displacements[0])))
    header = (["row"] + [f"T{k + 1}_N" for k in range(n)] + [f"D{k + 1}_m" for k in driven]
              + [f"tip_{a}_m" for a in xyz] + ["sigma_m"]
              + [f"before_{a}_m" for a in xyz] + [f"fitted_{a}_m" for a in xyz]
              + ["error_before_mm", "error_fitted_mm", "error_held_out_mm"])
    held = r.cross_validation.errors_m if r.cross_validation is not None else np.full(data.n_rows, np.nan)
    pulls = np.zeros((data.n_rows, 0)) if data.displacements is None else data.displacements[:, driven]
    rows = [[b + 1, *data.tensions[b], *pulls[b], *data.tip_position[b], data.sigma[b], *r.predicted_before[b],
             *r.predicted_after[b], r.errors_before_m[b] * 1e3, r.errors_after_m[b] * 1e3,
             "" if not np.isfinite(held[b]) else held[b] * 1e3] for b in range(data.n_rows)]
    return header, rows


def run_calibration(robot: Robot, data: Measurements, fit: Sequence[str], out: str | Path, *, model: str = "pcc",
                    options: CalibrationOptions | None = None, stiffness: Sequence[float | None] | None = None,
                    progress: Callable[[str], None] | None = None) -> CalibrationRun:
    """Fit ``fit`` of ``robot`` and ``model`` to ``data`` (:func:`pytdcr.calibrate.calibrate`) and write the
    module's files in ``out`` (the output-folder rule: whole, or the previous run kept); ``stiffness``: the
    tendons' axial stiffness [N/m] for displacement-driven rows (one value, or one per tendon, None for an
    inextensible one; default the robot's own)."""
    options = options or CalibrationOptions()
    inputs = {"data": {"source": data.source, "sha256": data.sha256, "rows": data.n_rows}, "model": model,
              "parameters": list(fit)}
    with output_folder(out, "calibrate", inputs) as run:
        k = None if stiffness is None else (stiffness[0] if len(stiffness) == 1 else list(stiffness))
        k = np.inf if stiffness is not None and k is None else k  # one "-": every tendon inextensible
        result = calibrate(robot, data, list(fit), model=model, options=options, stiffness=k, progress=progress)
        with saving():
            doc = result.to_json()
            doc["inputs"] = inputs_record(robot, Loads(np.zeros(robot.n_tendons)), **inputs)
            write_json(run.staging / "calibration.json", doc)
            write_robot(result.robot, run.staging / "robot_fitted.toml")
            header, rows = _rows(data, result)
            write_csv(run.staging / "rows.csv", header, rows)
            files = ["calibration.json", "robot_fitted.toml", "rows.csv",
                     *save_figure(plot_calibration(result, data.tip_position), run.staging, "fig_calibration")]
    return CalibrationRun(result, tuple(files))

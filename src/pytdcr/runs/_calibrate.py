"""A calibration run (``tdcr calibrate``): the fit of :func:`pytdcr.calibrate.calibrate` and its files.

The folder holds ``calibration.json`` (the :class:`~pytdcr.calibrate.CalibrationResult`, with the robot before the
fit and the run's inputs), ``robot_fitted.toml`` (the robot with the fitted values, ready for every other
command's ``--robot``), ``rows.csv`` (each row's inputs, measured tip, predicted tips and errors), the figure
``fig_calibration`` (.png, .pdf) and the journal of its stages (``stage_fit.json``, ``stage_fold_K.json``), from
which a stopped run resumes.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .._version import __version__
from ..calibrate import CalibrationOptions, CalibrationResult, FitStage, FoldStage, Measurements, prepare
from ..io import robot_to_dict, write_robot
from ..loads import Loads
from ..plotting import plot_calibration, save_figure
from ..records import JsonObject
from ..robot import Robot
from ..runtime import resumable_folder, write_csv, write_json
from ..statics import saving
from ._output import inputs_record

__all__ = ["CalibrationRun", "CalibrationSettings", "run_calibration"]


@dataclass(frozen=True)
class CalibrationSettings:
    """What a calibration run fits (``tdcr calibrate``'s options): the parameters' names (:data:`pytdcr.calibrate
    .PARAMETER_HELP`), the model's registered name, the fit's options, and the tendons' axial stiffness [N/m] for
    displacement-driven rows (one value, or one per tendon, None for an inextensible one; None: the robot's own)."""

    fit: tuple[str, ...]
    model: str = "pcc"
    options: CalibrationOptions = field(default_factory=CalibrationOptions)
    stiffness: tuple[float | None, ...] | None = None

    def stiffness_arg(self) -> float | list[float | None] | None:
        """The stiffness as :func:`pytdcr.calibrate.calibrate` takes it (one ``-``: every tendon inextensible)."""
        s = self.stiffness
        if s is None:
            return None
        if len(s) == 1:
            return np.inf if s[0] is None else float(s[0])
        return list(s)


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


def _layout(folds: int) -> tuple[str, ...]:
    """The names a calibration run with ``folds`` folds may write: its stages' journal, then its results."""
    return ("stage_fit.json", *(f"stage_fold_{k + 1}.json" for k in range(folds)), "calibration.json",
            "robot_fitted.toml", "rows.csv", "fig_calibration.png", "fig_calibration.pdf")


def _digest(robot: Robot, data: Measurements, s: CalibrationSettings, stiffness: np.ndarray) -> str:
    """What a calibration folder's stages rest on: the robot, the data's hash, the parameters, the model, the
    options, the tendons' stiffness and pytdcr's version. A folder is resumed only when this is unchanged."""
    text = json.dumps([robot_to_dict(robot), data.sha256, list(s.fit), s.model, asdict(s.options),
                       [None if not np.isfinite(k) else float(k) for k in stiffness], __version__], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _stage(path: Path) -> JsonObject | None:
    """A stage's record in the folder (a regular file, not a link), or None."""
    if path.is_symlink() or not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):  # a stage cut short is done again
        return None


def run_calibration(robot: Robot, data: Measurements, settings: CalibrationSettings, out: str | Path, *,
                    restart: bool = False, progress: Callable[[str], None] | None = None) -> CalibrationRun:
    """Fit ``settings.fit`` of ``robot`` and ``settings.model`` to ``data`` (:func:`pytdcr.calibrate.calibrate`)
    and write the module's files in ``out``.

    The fit and each cross-validation fold are journalled as they finish (``stage_*.json``), in a resumable
    folder (:func:`pytdcr.runtime.resumable_folder`): a run stopped by Ctrl-C or killed is resumed by the same
    command, its finished stages kept (the fit's values, each fold's errors); ``restart`` starts again. Inputs are
    checked, and the rows solved with the initial values, before the folder is touched."""
    s, options = settings, settings.options
    cal = prepare(robot, data, list(s.fit), model=s.model, options=options, stiffness=s.stiffness_arg())
    inputs = {"data": {"source": data.source, "sha256": data.sha256, "rows": data.n_rows}, "model": s.model,
              "parameters": list(s.fit)}
    digest = _digest(robot, data, s, cal.problem.stiffness)
    with resumable_folder(out, "calibrate", inputs, digest, restart, _layout(options.folds)) as run:
        folder = run.path
        done = _stage(folder / "stage_fit.json")
        stage = FitStage.from_json(done) if done is not None else cal.fit(progress)
        if done is None:
            write_json(folder / "stage_fit.json", stage.to_json())
        folds = []
        for j in range(options.folds):
            name = folder / f"stage_fold_{j + 1}.json"
            kept = _stage(name)
            folds.append(FoldStage.from_json(kept) if kept is not None else cal.fold(j))
            if kept is None:
                write_json(name, folds[-1].to_json())
            if progress is not None:
                progress(f"held-out fold {j + 1} of {options.folds}" + (" (kept)" if kept is not None else ""))
        result = cal.result(stage, folds)
        with saving():
            doc = result.to_json()
            doc["inputs"] = inputs_record(robot, Loads(np.zeros(robot.n_tendons)), **inputs)
            write_json(folder / "calibration.json", doc)
            write_robot(result.robot, folder / "robot_fitted.toml")
            header, rows = _rows(data, result)
            write_csv(folder / "rows.csv", header, rows)
            files = ["calibration.json", "robot_fitted.toml", "rows.csv",
                     *save_figure(plot_calibration(result, data.tip_position), folder, "fig_calibration")]
    return CalibrationRun(result, tuple(files))

"""Calibration: fit a model's parameters (moduli, friction, routing, pretensions, a payload, the measurement
frame) to measured poses, with standard errors, correlations, identifiability warnings and held-out errors.

>>> from pytdcr import paper_robot
>>> from pytdcr.calibrate import calibrate, read_measurements
>>> robot = paper_robot()
>>> data = read_measurements("measured.csv", robot)  # doctest: +SKIP
>>> result = calibrate(robot, data, ["youngs_modulus", "friction.mu0"])  # doctest: +SKIP
"""

from ._data import DEFAULT_SIGMA_AXIS, DEFAULT_SIGMA_M, Measurements, read_measurements
from ._fit import LOSSES, Calibration, CalibrationOptions, FitStage, FoldStage, calibrate, prepare
from ._parameters import PARAMETER_HELP, Parameter, parameters
from ._result import SCHEMA_VERSION, CalibrationResult, CrossValidation, FittedParameter

__all__ = [
    "DEFAULT_SIGMA_AXIS",
    "DEFAULT_SIGMA_M",
    "LOSSES",
    "PARAMETER_HELP",
    "SCHEMA_VERSION",
    "Calibration",
    "CalibrationOptions",
    "CalibrationResult",
    "CrossValidation",
    "FitStage",
    "FittedParameter",
    "FoldStage",
    "Measurements",
    "Parameter",
    "calibrate",
    "parameters",
    "prepare",
    "read_measurements",
]

"""Statics: the registered models (PCC, Cosserat rod) and the functions that solve them.

``solve``, ``solve_batch`` and ``tip_gradient`` take a model's name or object
and ask the registry (:data:`MODELS`), which checks the request against what
the model supports.
"""

from ._batch import Cancelled, CancelScope, cancellable, check_cancelled, mark_saving, saving
from ._constants import DEFAULT_ATOL, PATH_NAMES, TIGHT_ATOL
from .base import Capabilities, Model, UnsupportedFeatureError
from .cosserat import CosseratModel, CosseratOptions, CosseratShooting
from .pcc import PCCEquations, PCCModel, SolverOptions
from .pcc2 import PCC2Model
from .registry import MODELS, check_resources, configure, get_model, options_record, resolve
from .solve import solve, solve_batch, tip_gradient, warmup
from .sscr import SSCREquations, SSCRModel, SSCROptions

__all__ = ["DEFAULT_ATOL", "MODELS", "PATH_NAMES", "TIGHT_ATOL", "CancelScope", "Cancelled", "Capabilities",
           "CosseratModel", "CosseratOptions", "CosseratShooting", "Model", "PCC2Model", "PCCEquations", "PCCModel",
           "SSCREquations", "SSCRModel", "SSCROptions", "SolverOptions", "UnsupportedFeatureError", "cancellable",
           "check_cancelled", "check_resources", "configure", "get_model", "mark_saving", "options_record", "resolve",
           "saving", "solve", "solve_batch", "tip_gradient", "warmup"]

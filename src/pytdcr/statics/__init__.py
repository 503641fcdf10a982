"""Statics: the registered models (PCC, Cosserat rod) and the functions that solve them.

``solve``, ``solve_batch`` and ``tip_gradient`` take a model's name or object
and ask the registry (:data:`MODELS`), which checks the request against what
the model supports.
"""

from ..runtime import Cancelled, CancelScope, cancellable, check_cancelled, mark_saving, saving
from .base import Capabilities, Model, UnsupportedFeatureError
from .cosserat import CosseratModel, CosseratShooting
from .displacement import (
    DisplacementOptions,
    DisplacementSolution,
    pulled_in,
    solve_displacements,
    tendon_stiffness,
)
from .equilibrium import solve, solve_batch, tip_gradient, warmup
from .options import DEFAULT_ATOL, TIGHT_ATOL, CosseratOptions, ModelOptions, SolvePath, SolverOptions, SSCROptions
from .pcc import PCCEquations, PCCModel
from .pcc2 import PCC2Model
from .registry import MODELS, check_resources, configure, get_model, get_models, options_record, resolve
from .sensitivity import Jacobians, TipCompliance, equilibrium_jacobians, tip_compliance
from .sscr import SSCREquations, SSCRModel
from .stability import STABILITY_TESTS, feasible_words, stability_counts, stability_test, stability_words

__all__ = ["DEFAULT_ATOL", "MODELS", "STABILITY_TESTS", "TIGHT_ATOL", "CancelScope", "Cancelled", "Capabilities",
           "CosseratModel", "CosseratOptions", "CosseratShooting", "DisplacementOptions", "DisplacementSolution",
           "Jacobians", "Model", "ModelOptions", "PCC2Model", "PCCEquations", "PCCModel", "SSCREquations",
           "SSCRModel", "SSCROptions", "SolvePath", "SolverOptions", "TipCompliance", "UnsupportedFeatureError",
           "cancellable", "check_cancelled", "check_resources", "configure", "equilibrium_jacobians",
           "feasible_words", "get_model", "get_models", "mark_saving", "options_record", "pulled_in", "resolve",
           "saving", "solve", "solve_batch", "solve_displacements", "stability_counts", "stability_test",
           "stability_words", "tendon_stiffness", "tip_compliance", "tip_gradient", "warmup"]

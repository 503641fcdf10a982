"""Statics: the PCC equilibrium model, the Cosserat-rod model and their solvers."""

from .cosserat import CosseratModel, CosseratOptions, solve_cosserat
from .model import StaticModel
from .solve import MODELS, BatchSolution, SolverOptions, _prime, options_for, solve, solve_batch, solve_model, warmup

_prime()

__all__ = ["MODELS", "BatchSolution", "CosseratModel", "CosseratOptions", "SolverOptions", "StaticModel",
           "options_for", "solve", "solve_batch", "solve_cosserat", "solve_model", "warmup"]

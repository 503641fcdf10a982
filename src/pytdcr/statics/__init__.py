"""Statics: the PCC equilibrium model and its solver."""

from .model import StaticModel
from .solve import BatchSolution, SolverOptions, solve, solve_batch, solve_model, warmup

__all__ = ["BatchSolution", "SolverOptions", "StaticModel", "solve", "solve_batch", "solve_model", "warmup"]

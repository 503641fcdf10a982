"""pytdcr: statics and workspace of tendon-driven continuum robots."""

from .design import (
    Backbone,
    ConstantFriction,
    ExponentialFriction,
    NoFriction,
    Robot,
    Segment,
    Tendon,
    paper_robot,
    rao_robot,
)
from .loads import Loads, PointLoad
from .results import NotConvergedError, StaticSolution
from .statics import BatchSolution, CosseratOptions, SolverOptions, StaticModel, solve, solve_batch

__version__ = "0.1.0"

__all__ = [
    "Backbone",
    "BatchSolution",
    "ConstantFriction",
    "CosseratOptions",
    "ExponentialFriction",
    "Loads",
    "NoFriction",
    "NotConvergedError",
    "PointLoad",
    "Robot",
    "Segment",
    "SolverOptions",
    "StaticModel",
    "StaticSolution",
    "Tendon",
    "__version__",
    "paper_robot",
    "rao_robot",
    "solve",
    "solve_batch",
]

"""pytdcr: statics and workspace of tendon-driven continuum robots.

Importing the package runs nothing and imports no plotting library.
"""

from ._version import __version__
from .bounds import TensionBounds
from .design import (
    Backbone,
    ConstantFriction,
    ExponentialFriction,
    NoFriction,
    Robot,
    Segment,
    Tendon,
)
from .loads import Loads, PointLoad
from .paper import paper_loads, paper_robot, rao_robot
from .results import BatchSolution, NotConvergedError, StaticSolution
from .statics import (
    MODELS,
    CosseratOptions,
    Jacobians,
    Model,
    PCCEquations,
    SolverOptions,
    TipCompliance,
    UnsupportedFeatureError,
    equilibrium_jacobians,
    get_model,
    solve,
    solve_batch,
    tip_compliance,
    tip_gradient,
)

__all__ = [
    "MODELS",
    "Backbone",
    "BatchSolution",
    "ConstantFriction",
    "CosseratOptions",
    "ExponentialFriction",
    "Jacobians",
    "Loads",
    "Model",
    "NoFriction",
    "NotConvergedError",
    "PCCEquations",
    "PointLoad",
    "Robot",
    "Segment",
    "SolverOptions",
    "StaticSolution",
    "Tendon",
    "TensionBounds",
    "TipCompliance",
    "UnsupportedFeatureError",
    "__version__",
    "equilibrium_jacobians",
    "get_model",
    "paper_loads",
    "paper_robot",
    "rao_robot",
    "solve",
    "solve_batch",
    "tip_compliance",
    "tip_gradient",
]

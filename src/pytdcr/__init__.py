"""pytdcr: statics and workspace of tendon-driven continuum robots.

Importing the package runs nothing and imports no plotting library. Inverse statics (:func:`inverse_statics`,
:func:`inverse_path` and their types, from :mod:`pytdcr.optimize`) load with the optimisers on first use.
"""

from typing import TYPE_CHECKING, Any

from ._version import __version__
from .bounds import TensionBounds
from .loads import Loads, PointLoad
from .paper import paper_loads, paper_robot, rao_robot
from .results import BatchSolution, NotConvergedError, StaticSolution
from .robot import (
    Backbone,
    ConstantFriction,
    ExponentialFriction,
    NoFriction,
    Robot,
    Segment,
    Tendon,
)
from .statics import (
    MODELS,
    CosseratOptions,
    DisplacementOptions,
    DisplacementSolution,
    Jacobians,
    Model,
    PCCEquations,
    SolvePath,
    SolverOptions,
    TipCompliance,
    UnsupportedFeatureError,
    equilibrium_jacobians,
    get_model,
    pulled_in,
    solve,
    solve_batch,
    solve_displacements,
    tip_compliance,
    tip_gradient,
)

if TYPE_CHECKING:
    from .optimize import InverseResult, InverseSearch, TipTarget, inverse_path, inverse_statics

#: names of :mod:`pytdcr.optimize` offered here, imported when first used (the optimisers load pymoo)
_LAZY = ("InverseResult", "InverseSearch", "TipTarget", "inverse_path", "inverse_statics")


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from . import optimize

        return getattr(optimize, name)
    raise AttributeError(f"module 'pytdcr' has no attribute {name!r}")


__all__ = [
    "MODELS",
    "Backbone",
    "BatchSolution",
    "ConstantFriction",
    "CosseratOptions",
    "DisplacementOptions",
    "DisplacementSolution",
    "ExponentialFriction",
    "InverseResult",
    "InverseSearch",
    "Jacobians",
    "Loads",
    "Model",
    "NoFriction",
    "NotConvergedError",
    "PCCEquations",
    "PointLoad",
    "Robot",
    "Segment",
    "SolvePath",
    "SolverOptions",
    "StaticSolution",
    "Tendon",
    "TensionBounds",
    "TipCompliance",
    "TipTarget",
    "UnsupportedFeatureError",
    "__version__",
    "equilibrium_jacobians",
    "get_model",
    "inverse_path",
    "inverse_statics",
    "paper_loads",
    "paper_robot",
    "pulled_in",
    "rao_robot",
    "solve",
    "solve_batch",
    "solve_displacements",
    "tip_compliance",
    "tip_gradient",
]

"""The reach search of the paper's Eq. 29, in pymoo's shape, and inverse statics.

What is solved (:class:`ReachProblem`: robot, loads, bounds and model give a
cost, the reach or the reach along a direction, and its gradient), how
(:class:`MemeticGA`), when to stop (:class:`Termination`), joined by one
:func:`maximize_reach` call that returns one :class:`ReachResult`. Inverse statics
(:func:`inverse_statics`, :func:`inverse_path`): the tensions that put the tip at a target, the best by an
objective.
"""

from ._inverse import OBJECTIVES, InversePath, InverseResult, InverseSearch, TipTarget, inverse_path, inverse_statics
from ._problem import INFEASIBLE_COST, Evaluated, ReachProblem
from ._result import Optimum, ReachResult, SearchFailed
from ._search import MemeticGA, Termination, maximize_reach, polish_reach

__all__ = ["INFEASIBLE_COST", "OBJECTIVES", "Evaluated", "InversePath", "InverseResult", "InverseSearch",
           "MemeticGA", "Optimum", "ReachProblem", "ReachResult", "SearchFailed", "Termination", "TipTarget",
           "inverse_path", "inverse_statics", "maximize_reach", "polish_reach"]

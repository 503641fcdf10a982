"""Design studies: which robot to build. A study file names a base robot, the parameters to vary and their
ranges, how designs are chosen (a grid, Sobol points, or NSGA-II over the parameters), the load cases, the
objectives and a per-design budget; every design gets a workspace study (:mod:`pytdcr.workspace`), on local
processes or a Dask cluster, written one file per design so that a stopped study resumes. ``tdcr designs``
runs it from the command line."""

from ._evaluate import check_capabilities, design_seed, designs_estimate, evaluate_design
from ._optimize import DesignSearch, measures_nothing, objective_matrix, pareto_front
from ._report import format_measure
from ._run import DesignsRun, DesignsRunOptions, WorkersLost, run_designs
from ._space import PARAMETERS, apply_parameters, choose_designs, from_unit, parameter_info, read_parameter
from ._spec import (
    LOAD_CASE_NAMES,
    MEASURES,
    DesignStudy,
    Objective,
    Parameter,
    StudyError,
    load_study,
    measures_for,
    study_from_dict,
)

__all__ = [
    "LOAD_CASE_NAMES",
    "MEASURES",
    "PARAMETERS",
    "DesignSearch",
    "DesignStudy",
    "DesignsRun",
    "DesignsRunOptions",
    "Objective",
    "Parameter",
    "StudyError",
    "WorkersLost",
    "apply_parameters",
    "check_capabilities",
    "choose_designs",
    "design_seed",
    "designs_estimate",
    "evaluate_design",
    "format_measure",
    "from_unit",
    "load_study",
    "measures_for",
    "measures_nothing",
    "objective_matrix",
    "parameter_info",
    "pareto_front",
    "read_parameter",
    "run_designs",
    "study_from_dict",
]

"""Design studies: which robot to build. A study file names a base robot, the parameters to vary and their
ranges, the load cases and a per-design budget; every design gets a workspace study (:mod:`pytdcr.region`), on
local processes or a Dask cluster, written one file per design so that a stopped study resumes. ``tdcr designs``
runs it from the command line."""

from ._evaluate import MEASURES, design_seed, evaluate_design
from ._run import DesignsRun, run_designs
from ._space import PARAMETERS, apply_parameters, choose_designs, parameter_info
from ._spec import LOAD_CASE_NAMES, DesignStudy, Parameter, StudyError, load_study, study_from_dict

__all__ = ["LOAD_CASE_NAMES", "MEASURES", "PARAMETERS", "DesignStudy", "DesignsRun", "Parameter", "StudyError",
           "apply_parameters", "choose_designs", "design_seed", "evaluate_design", "load_study", "parameter_info",
           "run_designs", "study_from_dict"]

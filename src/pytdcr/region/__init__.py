"""The feasible static workspace as a region: sampling that covers it, the boundary search that makes its volume
converge, its boundary surface and volume with an error, the support function h(d) and the largest reach, and
what is physically realisable. :func:`workspace_study` does it all, from one :class:`WorkspaceSettings`
(:func:`workspace_region` is its first stage); ``tdcr workspace`` writes it out."""

from ._compute import WorkspaceRegion, check_workspace, planned_work, workspace_region
from ._estimate import Estimate, solve_seconds, workspace_estimate
from ._frontier import FOLD_RULES, BoundarySearch, GrowthSettings, SearchRound, SearchState, grow_region, tension_step
from ._grid import MIN_MESH_POINTS, Region, inside, region_from_points
from ._history import Multistability, measure_multistability
from ._overlap import RegionOverlap, region_overlap
from ._plan import SOURCES, TensionPlan, plan_tensions
from ._settings import (
    REACH_RULES,
    VOXELS_PER_LENGTH,
    WorkspaceHooks,
    WorkspaceSettings,
    search_budget,
)
from ._solve import (
    AGREEMENT_REQUIRED,
    EQUILIBRIA,
    FIRST_WAVE,
    ROOT,
    RegionSamples,
    WarmStartCheck,
    WarmStarts,
    continue_plan,
    equilibria_for,
    same_tip,
    solve_plan,
    solves_needed,
)
from ._stability import STABILITY_TESTS, feasible_words, stability_counts, stability_test, stability_words
from ._study import Reach, WorkspaceStudy, workspace_study
from ._support import (
    LargestReach,
    SampleStates,
    SupportFunction,
    SupportSettings,
    fibonacci_directions,
    largest_reach,
    support_function,
)
from ._volume import MEASURES, RegionDimension, VolumeEstimate, estimate_volume, nested_stages, region_dimension

__all__ = [
    "AGREEMENT_REQUIRED",
    "EQUILIBRIA",
    "FIRST_WAVE",
    "FOLD_RULES",
    "MEASURES",
    "MIN_MESH_POINTS",
    "REACH_RULES",
    "ROOT",
    "SOURCES",
    "STABILITY_TESTS",
    "VOXELS_PER_LENGTH",
    "BoundarySearch",
    "Estimate",
    "GrowthSettings",
    "LargestReach",
    "Multistability",
    "Reach",
    "Region",
    "RegionDimension",
    "RegionOverlap",
    "RegionSamples",
    "SampleStates",
    "SearchRound",
    "SearchState",
    "SupportFunction",
    "SupportSettings",
    "TensionPlan",
    "VolumeEstimate",
    "WarmStartCheck",
    "WarmStarts",
    "WorkspaceHooks",
    "WorkspaceRegion",
    "WorkspaceSettings",
    "WorkspaceStudy",
    "check_workspace",
    "continue_plan",
    "equilibria_for",
    "estimate_volume",
    "feasible_words",
    "fibonacci_directions",
    "grow_region",
    "inside",
    "largest_reach",
    "measure_multistability",
    "nested_stages",
    "plan_tensions",
    "planned_work",
    "region_dimension",
    "region_from_points",
    "region_overlap",
    "same_tip",
    "search_budget",
    "solve_plan",
    "solve_seconds",
    "solves_needed",
    "stability_counts",
    "stability_test",
    "stability_words",
    "support_function",
    "tension_step",
    "workspace_estimate",
    "workspace_region",
    "workspace_study",
]

"""The feasible static workspace as a region: sampling that covers it, the boundary search that makes its volume
converge, its boundary surface and volume with an error, the support function h(d) and the largest reach, and
what is physically realisable. :func:`workspace_region` does it all; ``tdcr workspace`` writes it out."""

from ._compute import VOXELS_PER_LENGTH, WorkspaceRegion, search_budget, workspace_region
from ._frontier import BoundarySearch, SearchRound, grow_region, tension_step
from ._grid import MIN_MESH_POINTS, Region, inside, region_from_points
from ._plan import SOURCES, TensionPlan, plan_tensions
from ._solve import AGREEMENT_REQUIRED, RegionSamples, WarmStartCheck, solve_plan, solves_needed
from ._support import LargestReach, SupportFunction, fibonacci_directions, largest_reach, support_function
from ._volume import VolumeEstimate, estimate_volume, nested_stages

__all__ = ["AGREEMENT_REQUIRED", "MIN_MESH_POINTS", "SOURCES", "VOXELS_PER_LENGTH", "BoundarySearch", "LargestReach",
           "Region", "RegionSamples", "SearchRound", "SupportFunction", "TensionPlan", "VolumeEstimate",
           "WarmStartCheck", "WorkspaceRegion", "estimate_volume", "fibonacci_directions", "grow_region", "inside",
           "largest_reach", "nested_stages", "plan_tensions", "region_from_points", "search_budget", "solve_plan",
           "solves_needed", "support_function", "tension_step", "workspace_region"]

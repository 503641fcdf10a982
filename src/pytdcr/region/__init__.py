"""The feasible static workspace as a region: sampling that covers it, its boundary surface and volume with an
error, and what is physically realisable (issue 12, in progress: the boundary search, the support function and
the load comparison come next)."""

from ._grid import Region, inside, region_from_points
from ._plan import SOURCES, TensionPlan, plan_tensions
from ._solve import AGREEMENT_REQUIRED, RegionSamples, WarmStartCheck, solve_plan, solves_needed
from ._volume import VolumeEstimate, estimate_volume

__all__ = ["AGREEMENT_REQUIRED", "SOURCES", "Region", "RegionSamples", "TensionPlan", "VolumeEstimate",
           "WarmStartCheck", "estimate_volume", "inside", "plan_tensions", "region_from_points", "solve_plan",
           "solves_needed"]

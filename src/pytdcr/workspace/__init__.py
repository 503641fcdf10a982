"""The feasible static workspace (FSW): what a robot reaches under its loads, with stable equilibria only.

One call does it all: :func:`workspace_study` samples the tension box, grows the region by a boundary search
until its volume converges, and measures the support function h(d), the largest reach and multistability, from
one :class:`WorkspaceSettings`; it returns a :class:`WorkspaceStudy` whose parts are the region
(:class:`WorkspaceRegion`: its samples, its :class:`Region` with a :class:`VolumeEstimate`, the
:class:`BoundarySearch` that grew it), :class:`SupportFunction`, :class:`LargestReach` and
:class:`Multistability`. :func:`workspace_estimate` says beforehand what a study will cost, and
:func:`region_overlap` compares two regions. Its numbers, read by attribute wherever they are reported, are one
:class:`WorkspaceSummary` (:attr:`WorkspaceStudy.summary`; ``workspace.json`` through its ``to_json`` and
``from_json``), whose parts are :class:`RegionNumbers`, :class:`SampleCounts` and
:class:`MultistabilityCounts` beside the study's own. :func:`sample_workspace` is the paper's plain random sampling.
``tdcr workspace`` runs the study and writes it out (:mod:`pytdcr.runs`).
"""

from ._compute import WorkspaceRegion, check_workspace
from ._estimate import Estimate, workspace_estimate
from ._frontier import FOLD_RULES, BoundarySearch, SearchRound
from ._grid import Region
from ._history import Multistability, MultistabilityCounts
from ._overlap import RegionOverlap, region_overlap
from ._sampling import SamplingConfig, SamplingInterrupted, WorkspaceSamples, sample_workspace
from ._settings import WorkspaceHooks, WorkspaceSettings
from ._solve import EQUILIBRIA, RegionSamples, equilibria_for
from ._study import Reach, WorkspaceStudy, workspace_study
from ._summary import RegionNumbers, SampleCounts, WorkspaceSummary
from ._support import LargestReach, SupportFunction
from ._volume import VolumeEstimate

__all__ = [
    "EQUILIBRIA",
    "FOLD_RULES",
    "BoundarySearch",
    "Estimate",
    "LargestReach",
    "Multistability",
    "MultistabilityCounts",
    "Reach",
    "Region",
    "RegionNumbers",
    "RegionOverlap",
    "RegionSamples",
    "SampleCounts",
    "SamplingConfig",
    "SamplingInterrupted",
    "SearchRound",
    "SupportFunction",
    "VolumeEstimate",
    "WorkspaceHooks",
    "WorkspaceRegion",
    "WorkspaceSamples",
    "WorkspaceSettings",
    "WorkspaceStudy",
    "WorkspaceSummary",
    "check_workspace",
    "equilibria_for",
    "region_overlap",
    "sample_workspace",
    "workspace_estimate",
    "workspace_study",
]

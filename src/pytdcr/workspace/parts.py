"""The types of a workspace study's parts, for annotations and ``isinstance``: what the study's result holds
below its first level, and what :func:`~pytdcr.workspace.workspace_estimate` and
:func:`~pytdcr.workspace.region_overlap` return.

A study is read from its result (:class:`~pytdcr.workspace.WorkspaceStudy`): ``study.region.fsw`` is a
:class:`VolumeEstimate` (by sample size, :class:`VolumeScale`), ``study.region.search`` a
:class:`BoundarySearch` of :class:`SearchRound` s, ``study.region.samples`` the :class:`RegionSamples`,
``study.largest_reach`` a :class:`Reach`; its numbers
(:class:`~pytdcr.workspace.WorkspaceSummary`) are :class:`RegionNumbers`, :class:`SampleCounts` and
:class:`MultistabilityCounts`.
"""

from ._estimate import Estimate
from ._frontier import BoundarySearch, SearchRound
from ._history import MultistabilityCounts
from ._overlap import RegionOverlap
from ._solve import RegionSamples
from ._study import Reach
from ._summary import RegionNumbers, SampleCounts
from ._volume import VolumeEstimate, VolumeScale

__all__ = ["BoundarySearch", "Estimate", "MultistabilityCounts", "Reach", "RegionNumbers", "RegionOverlap",
           "RegionSamples", "SampleCounts", "SearchRound", "VolumeEstimate",
           "VolumeScale"]

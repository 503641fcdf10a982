"""The feasible static workspace (FSW): what a robot reaches under its loads, with stable equilibria only.

One call does it all: :func:`workspace_study` samples the tension box, grows the region by a boundary search
until its volume converges, and measures the support function h(d), the largest reach and multistability, from
one :class:`WorkspaceSettings`; it returns a :class:`WorkspaceStudy` whose parts are the region
(:class:`WorkspaceRegion`: its samples, its :class:`Region` with its volume and error, the boundary search that
grew it), :class:`SupportFunction`, :class:`LargestReach` and :class:`Multistability`. Its numbers, read by
attribute wherever they are reported, are one :class:`WorkspaceSummary` (:attr:`WorkspaceStudy.summary`;
``workspace.json`` through its ``to_json`` and ``from_json``). :func:`check_workspace` checks a study's inputs
before any solve, :func:`workspace_estimate` says beforehand what it will cost, and :func:`region_overlap`
compares two regions. Hooks (:class:`WorkspaceHooks`) watch a study run.

Two public submodules hold the rest: :mod:`pytdcr.workspace.parts`, the types of the result's deeper parts
(``VolumeEstimate``, ``BoundarySearch``, ``RegionNumbers``, ...), and :mod:`pytdcr.workspace.sampling`, the
paper's plain random sampling (``sample_workspace``). ``tdcr workspace`` runs the study and writes it out
(:mod:`pytdcr.runs`).
"""

from ._compute import WorkspaceRegion, check_workspace
from ._estimate import workspace_estimate
from ._grid import Region
from ._history import Multistability
from ._overlap import region_overlap
from ._settings import WorkspaceHooks, WorkspaceSettings
from ._study import WorkspaceStudy, workspace_study
from ._summary import WorkspaceSummary
from ._support import LargestReach, SupportFunction

__all__ = [
    "LargestReach",
    "Multistability",
    "Region",
    "SupportFunction",
    "WorkspaceHooks",
    "WorkspaceRegion",
    "WorkspaceSettings",
    "WorkspaceStudy",
    "WorkspaceSummary",
    "check_workspace",
    "region_overlap",
    "workspace_estimate",
    "workspace_study",
]

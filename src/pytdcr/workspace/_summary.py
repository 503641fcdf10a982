"""The numbers of one workspace study as one typed result (:class:`WorkspaceSummary`), assembled once from the
study (:meth:`pytdcr.workspace.WorkspaceStudy.summary`) and read by attribute wherever they are reported; JSON
at one boundary: :meth:`WorkspaceSummary.to_json` is ``workspace.json``'s numbers, key for key and in order,
and :meth:`WorkspaceSummary.from_json` reads them back from any file a run wrote.

Each part reads its own JSON back into its own type (:meth:`BoundarySearch.from_dict`,
:meth:`SupportFunction.from_dict`, :meth:`LargestReach.from_dict`, :meth:`WarmStartCheck.from_dict`,
:meth:`VolumeEstimate.from_dict`). :class:`Multistability` keeps arrays a file does not hold: what the file holds
of it is :class:`MultistabilityCounts`. Two parts stay dictionaries on purpose: the shares of the boundary voxels
and the samples by source (``boundary_sources``, ``SampleCounts.by_source``) are mappings from the source names
(:data:`RegionSamples.SOURCES`) to numbers, data keyed by name rather than records; and h(d)'s ``settings`` is the
search problem's own settings record, passed through to the file unread.

A file missing a required key raises :class:`~pytdcr.records.RecordKeyError`, naming the key with its path
(``counts.converged``). The keys that may be absent: ``root`` (None), ``boundary_search``, ``support``,
``largest_reach`` and ``multistability`` (None: not computed), a region's ``mesh`` (None: not a run's file) and
every time in seconds (0: a record with its times dropped, as the golden baselines keep them).

:meth:`WorkspaceSummary.to_json` writes ``schema_version`` (:data:`SCHEMA_VERSION`) first; a file holding
another is refused, and a file without one (written before the key existed) is read as version 1.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from scipy import ndimage

from ..records import JsonDict, JsonObject, check_schema, optional_part, part
from ..statics import stability_counts, stability_words
from ..validate import measured, unmeasured_text
from ._compute import WorkspaceRegion
from ._frontier import BoundarySearch
from ._grid import MIN_MESH_POINTS, Region
from ._history import MultistabilityCounts
from ._plan import SOURCES
from ._solve import RegionSamples, WarmStartCheck
from ._support import LargestReach, SupportFunction
from ._volume import VolumeEstimate

__all__ = ["SCHEMA_VERSION", "RegionNumbers", "SampleCounts", "WorkspaceSummary", "reach_rule", "summarise"]

#: the layout of ``workspace.json``'s numbers this module writes and reads
SCHEMA_VERSION = 1

#: the file these numbers are read from, as errors name it
_FILE = "workspace.json"
_read = partial(part, _FILE)
_optional = partial(optional_part, _FILE)


@dataclass(frozen=True)
class RegionNumbers:
    """A region's numbers (the FSW, or its realisable part).

    Attributes
    ----------
    volume_m3, volume_err_m3 : float
        Its volume and error [m^3] (0 below three dimensions).
    dimension : int
        0..3 (:class:`~pytdcr.workspace.RegionDimension`; 3 when the estimate has no dimension).
    measure : str
        What measures it: ``"volume"``, ``"area"``, ``"length"`` or ``"none"``.
    area_m2, area_err_m2 : float or None
        Its area and error [m^2] when 2-D (None otherwise).
    length_m, length_err_m : float or None
        Its length and resolution [m] when 1-D (None otherwise).
    largest_reach_m : float or None
        Its largest reach [m] (None without a sample).
    reach_rule : str
        What that reach is, in words (:func:`reach_rule`).
    points : int
        Its samples.
    volume : VolumeEstimate
        The whole estimate.
    mesh : str or None
        The name of its boundary mesh in a run's folder: set by the run (:meth:`WorkspaceSummary.with_meshes`);
        None where none was written, and outside a run.
    """

    volume_m3: float
    volume_err_m3: float
    dimension: int
    measure: str
    area_m2: float | None
    area_err_m2: float | None
    length_m: float | None
    length_err_m: float | None
    largest_reach_m: float | None
    reach_rule: str
    points: int
    volume: VolumeEstimate
    mesh: str | None = None

    @classmethod
    def of(cls, est: VolumeEstimate, points: int, reach: float | None, rule: str) -> RegionNumbers:
        """The numbers of a region of ``points`` samples whose volume estimate is ``est``, largest reach
        ``reach`` [m] by ``rule``."""
        dim = est.dimension
        two, one = dim is not None and dim.dimension == 2, dim is not None and dim.dimension == 1
        return cls(est.volume_m3, est.error_m3, 3 if dim is None else dim.dimension,
                   "volume" if dim is None else dim.measure, dim.area_m2 if two else None,
                   dim.area_err_m2 if two else None, dim.length_m if one else None, dim.length_err_m if one else None,
                   reach, rule, int(points), est)

    @property
    def meshable(self) -> bool:
        """Whether it has a boundary to mesh: enough points (:attr:`Region.MIN_MESH_POINTS`) and a volume to
        enclose (dimension 3)."""
        return self.points >= MIN_MESH_POINTS and self.dimension == 3

    def measure_words(self) -> str:
        """Its measure in words: its volume with error in cm³ (where the error is below the volume:
        :func:`~pytdcr.validate.measured`), or, below three dimensions, what it is and its area or length."""
        if self.dimension == 3:
            if not measured(self.volume_m3, self.volume_err_m3):
                return "volume " + unmeasured_text(f"{self.volume_err_m3 * 1e6:.0f} cm³")
            return f"volume {self.volume_m3 * 1e6:.0f} ± {self.volume_err_m3 * 1e6:.0f} cm³"
        if self.dimension == 2:
            area, err = self.area_m2 or 0.0, self.area_err_m2 or 0.0
            return f"planar (dimension 2, volume 0): area {area * 1e4:.1f} ± {err * 1e4:.1f} cm²"
        if self.dimension == 1:
            length, err = self.length_m or 0.0, self.length_err_m or 0.0
            return f"a segment (dimension 1, volume 0): length {length:.4f} ± {err:.4f} m"
        return "a point or nothing (dimension 0, volume 0)"

    def to_json(self, mesh: bool = False) -> JsonDict:
        """JSON-ready form: volume, error, dimension, measure (area or length with error when 2- or 1-D),
        largest reach, with ``mesh`` its mesh's name, the reach's rule, points and the whole estimate."""
        out: JsonDict = {"volume_m3": self.volume_m3, "volume_err_m3": self.volume_err_m3,
                         "dimension": self.dimension, "measure": self.measure}
        if self.dimension == 2:
            out.update(area_m2=self.area_m2, area_err_m2=self.area_err_m2)
        if self.dimension == 1:
            out.update(length_m=self.length_m, length_err_m=self.length_err_m)
        out["largest_reach_m"] = self.largest_reach_m
        if mesh:
            out["mesh"] = self.mesh
        return {**out, "reach_rule": self.reach_rule, "points": self.points, "volume": self.volume.to_dict()}

    @classmethod
    def from_json(cls, d: JsonObject) -> RegionNumbers:
        """The numbers :meth:`to_json` wrote; KeyError naming a missing key."""
        dim = int(d["dimension"])
        two, one = dim == 2, dim == 1
        return cls(d["volume_m3"], d["volume_err_m3"], dim, d["measure"], d["area_m2"] if two else None,
                   d["area_err_m2"] if two else None, d["length_m"] if one else None,
                   d["length_err_m"] if one else None, d["largest_reach_m"], d["reach_rule"], int(d["points"]),
                   _read("volume", VolumeEstimate.from_dict, d["volume"]), d.get("mesh"))


@dataclass(frozen=True)
class SampleCounts:
    """How many samples were solved, and what they held.

    Attributes
    ----------
    solved, converged, not_converged : int
    unstable, stable : int or None
        Of the converged; None (unknown) when the model has no stability test.
    stability_untested : int
        Converged samples whose stability was not tested.
    below_base, disks_touch : int
        Samples with a disk below the base plane; with two disks touching.
    fraction_below_base, fraction_disks_touch, fraction_realisable : float
        Their shares of the converged samples (of one when none converged), and the realisable ones'.
    by_source : dict of str to int
        Samples by source (:data:`RegionSamples.SOURCES`).
    """

    solved: int
    converged: int
    not_converged: int
    unstable: int | None
    stability_untested: int
    stable: int | None
    below_base: int
    disks_touch: int
    fraction_below_base: float
    fraction_disks_touch: float
    fraction_realisable: float
    by_source: dict[str, int]

    @classmethod
    def of(cls, samples: RegionSamples, test: str) -> SampleCounts:
        """The counts of ``samples``, whose model's stability ``test`` is ``"run"`` or ``"untested"``."""
        ok = samples.converged
        n_ok = max(int(ok.sum()), 1)
        states = stability_counts(ok, samples.stable, test)
        return cls(int(ok.size), int(ok.sum()), int((~ok).sum()), states["unstable"], int(states["untested"] or 0),
                   states["stable"], int(samples.below_base.sum()), int(samples.disks_touch.sum()),
                   float(samples.below_base.sum() / n_ok), float(samples.disks_touch.sum() / n_ok),
                   float(samples.realisable.sum() / n_ok),
                   {name: int(np.sum(samples.source == k)) for k, name in enumerate(SOURCES)})

    def stability_words(self, test: str) -> str:
        """The converged samples' stability in words (:func:`pytdcr.statics.stability_words`)."""
        return stability_words(self.to_json(), test)

    def to_json(self) -> JsonDict:
        """JSON-ready form."""
        return {"solved": self.solved, "converged": self.converged, "not_converged": self.not_converged,
                "unstable": self.unstable, "stability_untested": self.stability_untested, "stable": self.stable,
                "below_base": self.below_base, "disks_touch": self.disks_touch,
                "fraction_below_base": self.fraction_below_base, "fraction_disks_touch": self.fraction_disks_touch,
                "fraction_realisable": self.fraction_realisable, "by_source": dict(self.by_source)}

    @classmethod
    def from_json(cls, d: JsonObject) -> SampleCounts:
        """The counts :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["solved"], d["converged"], d["not_converged"], d["unstable"], d["stability_untested"],
                   d["stable"], d["below_base"], d["disks_touch"], d["fraction_below_base"],
                   d["fraction_disks_touch"], d["fraction_realisable"], dict(d["by_source"]))


def reach_rule(source: str, searched: bool, region: str = "feasible") -> str:
    """What a region's largest reach is, in words (``workspace.json``'s ``reach_rule``): from where it comes
    (``source``: :attr:`~pytdcr.workspace.Reach.source`), whether the reach search ran (``searched``) and the
    samples it is taken from (``region``: ``"feasible"`` or ``"realisable"``). Only ``"search"`` is a searched
    optimum."""
    if source == "none":
        return f"none: no {region} sample"
    if source == "search":
        return "the reach search's optimum"
    what = "the farthest tip attaining h(d)" if source == "support" else f"the farthest {region} sample"
    return what + (", farther than the reach search's optimum" if searched else " (not searched)")


def _boundary_sources(region: Region, samples: RegionSamples, mask: np.ndarray) -> dict[str, float]:
    """Of the region's boundary voxels (occupied, with an empty face neighbour), the share holding a sample
    from each source (a voxel can hold several)."""
    occ = region.occupied
    boundary = occ & ~ndimage.binary_erosion(occ, structure=ndimage.generate_binary_structure(3, 1))
    total = int(boundary.sum())
    idx = np.floor((samples.tip_position[mask] - region.origin) / region.voxel).astype(np.int64)
    src = samples.source[mask]
    shares = {}
    for k, name in enumerate(SOURCES):
        hit = np.zeros_like(occ)
        i = idx[src == k]
        hit[i[:, 0], i[:, 1], i[:, 2]] = True
        shares[name] = float((hit & boundary).sum() / total) if total else 0.0
    return shares


@dataclass(frozen=True, eq=False)
class WorkspaceSummary:
    """The numbers of one workspace study (``workspace.json`` less what a run adds: its inputs, warnings and
    files).

    Attributes
    ----------
    fsw : RegionNumbers
        The feasible static workspace's (at the top level of the JSON).
    realisable : RegionNumbers
        Its realisable part's (``realisable``): its largest reach is the farthest realisable sample, never
        searched.
    voxel_m : float
        The voxel's edge [m].
    counts : SampleCounts
    warm_start : WarmStartCheck
        How the samples were solved.
    boundary_sources : dict of str to float
        Of the FSW's boundary voxels, the share holding a sample of each source (empty without a feasible one).
    boundary_search : BoundarySearch or None
        None when it did not run.
    support : SupportFunction or None
        h(d), None when not computed.
    largest_reach : LargestReach or None
        The reach search, None when it did not run.
    seconds_sampling : float
        Wall time of the samples [s].
    equilibria : str
        Which equilibria the region holds (:data:`~pytdcr.workspace.EQUILIBRIA`).
    root : str or None
        The root's state, for continued samples (:attr:`RegionSamples.root`).
    stability_test : str
        ``"run"`` or ``"untested"`` (:func:`pytdcr.statics.stability_test`).
    multistability : MultistabilityCounts or None
        None when not checked.
    """

    fsw: RegionNumbers
    realisable: RegionNumbers
    voxel_m: float
    counts: SampleCounts
    warm_start: WarmStartCheck
    boundary_sources: dict[str, float]
    boundary_search: BoundarySearch | None
    support: SupportFunction | None
    largest_reach: LargestReach | None
    seconds_sampling: float
    equilibria: str
    root: str | None
    stability_test: str
    multistability: MultistabilityCounts | None

    def stability_words(self) -> str:
        """The converged samples' stability in words (:meth:`SampleCounts.stability_words`)."""
        return self.counts.stability_words(self.stability_test)

    def with_meshes(self, fsw: str, realisable: str) -> WorkspaceSummary:
        """These numbers with the regions' boundary meshes named ``fsw`` and ``realisable``, where a region has
        one (:attr:`RegionNumbers.meshable`; None elsewhere)."""
        return replace(self, fsw=replace(self.fsw, mesh=fsw if self.fsw.meshable else None),
                       realisable=replace(self.realisable, mesh=realisable if self.realisable.meshable else None))

    def to_json(self, meshes: bool = False) -> JsonDict:
        """JSON-ready form: the FSW's numbers at the top level, the realisable region's under ``realisable``,
        then the voxel, the counts, the warm starts, the boundary voxels' sources, the boundary search, h(d),
        the reach search, the sampling time, the equilibria, the root, the stability test and the
        multistability check. With ``meshes``, each region's ``mesh`` (as a run's ``workspace.json``)."""
        return {"schema_version": SCHEMA_VERSION, **self.fsw.to_json(meshes),
                "realisable": self.realisable.to_json(meshes), "voxel_m": self.voxel_m,
                "counts": self.counts.to_json(), "warm_start": self.warm_start.to_dict(),
                "boundary_sources": dict(self.boundary_sources),
                "boundary_search": self.boundary_search.to_dict() if self.boundary_search is not None else None,
                "support": self.support.to_dict() if self.support is not None else None,
                "largest_reach": self.largest_reach.to_dict() if self.largest_reach is not None else None,
                "seconds_sampling": self.seconds_sampling, "equilibria": self.equilibria, "root": self.root,
                "stability_test": self.stability_test,
                "multistability": self.multistability.to_json() if self.multistability is not None else None}

    @classmethod
    def from_json(cls, d: JsonObject) -> WorkspaceSummary:
        """The numbers of a ``workspace.json`` (or of :meth:`to_json`), ignoring what a run adds (``inputs``,
        ``warnings``, ``files``). :class:`~pytdcr.records.RecordKeyError` naming the path of a missing key;
        ValueError for a part that is not a JSON object or another ``schema_version`` than
        :data:`SCHEMA_VERSION`."""
        def read(d: JsonObject) -> WorkspaceSummary:
            check_schema(d, _FILE, SCHEMA_VERSION)
            return cls(RegionNumbers.from_json(d), _read("realisable", RegionNumbers.from_json, d["realisable"]),
                       d["voxel_m"], _read("counts", SampleCounts.from_json, d["counts"]),
                       _read("warm_start", WarmStartCheck.from_dict, d["warm_start"]), dict(d["boundary_sources"]),
                       _optional("boundary_search", BoundarySearch.from_dict, d),
                       _optional("support", SupportFunction.from_dict, d),
                       _optional("largest_reach", LargestReach.from_dict, d), d.get("seconds_sampling", 0.0),
                       d["equilibria"], d.get("root"), d["stability_test"],
                       _optional("multistability", MultistabilityCounts.from_json, d))

        return _read("", read, d)


def summarise(region: WorkspaceRegion, support: SupportFunction | None, search: LargestReach | None,
              reach: tuple[float | None, str], realisable_reach: float | None, test: str) -> WorkspaceSummary:
    """The numbers of a study: its ``region``, h(d) (``support``), the reach ``search``, the FSW's largest
    ``reach`` [m] with its source (:attr:`~pytdcr.workspace.Reach.source`), the farthest realisable sample's
    reach [m] and the model's stability ``test``."""
    s = region.samples
    real = "none" if realisable_reach is None else "samples"
    return WorkspaceSummary(
        RegionNumbers.of(region.fsw, int(s.feasible.sum()), reach[0], reach_rule(reach[1], search is not None)),
        RegionNumbers.of(region.realisable, int(s.realisable.sum()), realisable_reach,
                         reach_rule(real, False, "realisable")),
        region.voxel, SampleCounts.of(s, test), s.warm,
        _boundary_sources(region.fsw_region, s, s.feasible) if np.any(s.feasible) else {},
        region.search, support, search, s.seconds, region.equilibria, s.root, test,
        region.multistability.counts() if region.multistability is not None else None)

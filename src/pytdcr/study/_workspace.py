"""``tdcr workspace``: the feasible static workspace as a region, with its volume, boundary and realisability."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bounds import TensionBounds
from ..design import Robot
from ..loads import Loads
from ..plotting import plot_region_slices
from ..region import (
    SOURCES,
    Region,
    RegionSamples,
    VolumeEstimate,
    estimate_volume,
    plan_tensions,
    solve_plan,
    solves_needed,
)
from ..statics import Model, options_record, resolve, saving
from ._folder import atomic_write_text, output_folder
from ._output import inputs_record, save_figure, write_json

__all__ = ["WorkspaceRun", "run_workspace", "workspace_solves"]

#: voxels per robot length by default (12 mm for the paper robot's 370 mm)
VOXELS_PER_LENGTH = 32


@dataclass(frozen=True, eq=False)
class WorkspaceRun:
    """What :func:`run_workspace` produced."""

    samples: RegionSamples
    fsw: VolumeEstimate
    realisable: VolumeEstimate
    summary: dict[str, Any]
    files: list[str]


def workspace_solves(bounds: TensionBounds, n: int, seed: int, warm: bool = True) -> int:
    """The solves :func:`run_workspace` makes, for a progress bar."""
    return solves_needed(plan_tensions(bounds, n, seed), warm)


def _boundary_sources(region: Region, samples: RegionSamples, mask: np.ndarray) -> dict[str, float]:
    """Of the region's boundary voxels (occupied, with an empty face neighbour), the share holding a sample
    from each source."""
    from scipy import ndimage

    occ = region.occupied
    boundary = occ & ~ndimage.binary_erosion(occ, structure=ndimage.generate_binary_structure(3, 1))
    total = int(boundary.sum())
    idx = np.floor((samples.tip[mask] - region.origin) / region.voxel).astype(np.int64)
    src = samples.source[mask]
    shares = {}
    for k, name in enumerate(SOURCES):
        hit = np.zeros_like(occ)
        i = idx[src == k]
        hit[i[:, 0], i[:, 1], i[:, 2]] = True
        shares[name] = float((hit & boundary).sum() / total) if total else 0.0
    return shares


def _region_of(samples: RegionSamples, mask: np.ndarray, voxel: float) -> tuple[VolumeEstimate, Region]:
    pts = np.where(mask[:, None], samples.tip, np.nan)
    base_index = np.where(samples.source == 0, np.arange(samples.source.size), -1)
    return estimate_volume(pts, base_index, samples.n_base, voxel)


def _numbers(est: VolumeEstimate, samples: RegionSamples, mask: np.ndarray, mesh: str) -> dict[str, Any]:
    reach = np.linalg.norm(samples.tip[mask], axis=1)
    return {"volume_m3": est.volume_m3, "volume_err_m3": est.error_m3,
            "largest_reach_m": float(reach.max()) if reach.size else None, "mesh": mesh, "points": int(mask.sum()),
            "volume": est.to_dict()}


def _counts(samples: RegionSamples) -> dict[str, Any]:
    ok = samples.converged
    n_ok = max(int(ok.sum()), 1)
    return {"solved": int(ok.size), "converged": int(ok.sum()), "not_converged": int((~ok).sum()),
            "unstable": int(np.sum(samples.stable == 0.0)),
            "stability_untested": int(np.sum(ok & np.isnan(samples.stable))),
            "below_base": int(samples.below_base.sum()), "disks_touch": int(samples.disks_touch.sum()),
            "fraction_below_base": float(samples.below_base.sum() / n_ok),
            "fraction_disks_touch": float(samples.disks_touch.sum() / n_ok),
            "fraction_realisable": float(samples.realisable.sum() / n_ok),
            "by_source": {name: int(np.sum(samples.source == k)) for k, name in enumerate(SOURCES)}}


def _report(summary: dict[str, Any], command: str) -> str:
    f, r, c = summary, summary["realisable"], summary["counts"]
    w = summary["warm_start"]
    lines = [f"# Feasible static workspace of robot '{summary['inputs']['robot']['name']}'", "",
             f"Made by `{command}`.", "",
             "| region | volume [cm³] | error [cm³] | largest reach [m] | points |", "|---|---|---|---|---|",
             f"| FSW (converged, stable) | {f['volume_m3'] * 1e6:.0f} | {f['volume_err_m3'] * 1e6:.0f} | "
             f"{f['largest_reach_m']:.4f} | {f['points']} |",
             f"| realisable (no disk below the base, no disks touching) | {r['volume_m3'] * 1e6:.0f} | "
             f"{r['volume_err_m3'] * 1e6:.0f} | {r['largest_reach_m'] or 0:.4f} | {r['points']} |", "",
             "Volume at n/4, n/2 and n base samples (FSW): "
             + ", ".join(f"{s['n_base']}: {s['estimate_m3'] * 1e6:.0f} cm³" for s in f["volume"]["scales"]) + ".", "",
             f"Samples: {c['solved']} solved ({c['by_source']}), {c['converged']} converged, {c['unstable']} unstable; "
             f"of the converged, {c['fraction_below_base']:.1%} have a disk below the base plane, "
             f"{c['fraction_disks_touch']:.1%} two disks touching; {c['fraction_realisable']:.1%} are realisable.", "",
             f"Warm starts: {w['mode']} ({w['agreed']} of {w['checked']} checked warm starts agreed with the loading "
             f"path; {w['required']:.1%} required).", "",
             "Boundary voxels holding a sample, by source: "
             + ", ".join(f"{k} {v:.0%}" for k, v in summary["boundary_sources"].items()) + ".", ""]
    return "\n".join(lines)


def run_workspace(robot: Robot, loads: Loads, bounds: TensionBounds, n: int, seed: int, out: str | Path, *,
                  model: str | Model = "pcc", options: Any = None, voxel: float | None = None, warm: bool = True,
                  command: str = "tdcr workspace", progress: Callable[[int], None] | None = None) -> WorkspaceRun:
    """Sample the workspace (Sobol points, the tension box's corners and edges), build the FSW and the
    realisable region, and write ``workspace.json``, ``fsw.ply``, ``fsw_realisable.ply``, ``samples.npz``,
    ``report.md`` and the slice figure in ``out`` (the output-folder rule)."""
    m, opts = resolve(model, robot, loads, options)
    voxel = float(voxel) if voxel is not None else robot.length / VOXELS_PER_LENGTH
    with output_folder(out, "workspace", {"n": n, "seed": seed, "bounds": bounds.to_dict()}) as run:
        samples = solve_plan(robot, loads, bounds, plan_tensions(bounds, n, seed), model=m, options=opts,
                             warm=warm, seed=seed, progress=progress)
        with saving():
            fsw, region = _region_of(samples, samples.feasible, voxel)
            real, region_r = _region_of(samples, samples.realisable, voxel)
            files = _write(run.staging, samples, region, region_r, robot)
            summary = {**_numbers(fsw, samples, samples.feasible, "fsw.ply"),
                       "realisable": _numbers(real, samples, samples.realisable, "fsw_realisable.ply"),
                       "voxel_m": voxel, "counts": _counts(samples), "warm_start": samples.warm.to_dict(),
                       "boundary_sources": _boundary_sources(region, samples, samples.feasible),
                       "seconds_solving": samples.seconds, "not_yet": "the boundary search and the support "
                       "function h(d) (issue 12, in progress): the volume does not converge by sampling alone",
                       "inputs": inputs_record(robot, loads, bounds=bounds.to_dict(), n=n, seed=seed,
                                               solver=options_record(m, opts), warm_starts=warm)}
            atomic_write_text(run.staging / "report.md", _report(summary, command))
            write_json(run.staging / "workspace.json", {**summary, "files": [*files, "report.md", "workspace.json"]})
    return WorkspaceRun(samples, fsw, real, summary, [*files, "report.md", "workspace.json"])


def _write(out: Path, samples: RegionSamples, region: Region, region_r: Region, robot: Robot) -> list[str]:
    for name, reg in (("fsw.ply", region), ("fsw_realisable.ply", region_r)):
        tmp = out / f".{name}.tmp"
        reg.mesh().export(tmp, file_type="ply")
        tmp.replace(out / name)
    np.savez_compressed(out / "samples.npz", tensions=samples.tensions, source=samples.source, tip=samples.tip,
                        converged=samples.converged, stable=samples.stable, below_base=samples.below_base,
                        disks_touch=samples.disks_touch, sources=np.array(SOURCES))
    fig = plot_region_slices({"FSW": region, "realisable": region_r}, robot.length,
                             f"robot '{robot.name}': workspace slices")
    return ["fsw.ply", "fsw_realisable.ply", "samples.npz", *save_figure(fig, out, "slices")]

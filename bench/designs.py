"""Design studies at scale: designs per minute where the compute is, and what the Dask path costs.

Sobol studies of the paper robot (its budget: ``--samples`` samples, ``--search`` search solves, under the
paper's wrench) of ``--designs`` and of twice as many designs are each run into a fresh folder, ``--repeat``
times, on:
- 1 local process, 2 local processes (``DesignsRunOptions(workers=...)``, spawned: their start-up is in the wall time);
- a ``distributed.LocalCluster`` of 2 single-threaded worker processes (``DesignsRunOptions(scheduler=...)``), started
  once before the runs (a cluster is long-lived: its start-up is not in the wall time).
Each executor's median wall times at the two sizes give a line: wall = start-up + designs x slope. Printed and
written to ``bench/results/designs.json``: designs per minute at the larger size, the median seconds one design
takes inside its worker, the start-up and the slope, and the overhead per design of each path: slope x workers
- seconds inside (what a worker spends per design beyond the design itself: sending, receiving, writing its
file); for Dask also the round trip of an empty task. Then the estimate for a 1,000-design study at this budget
and at ``--design-seconds`` (the per-design time of a real study, e.g. the median of ``timings.csv`` of
examples/design_study_routing.toml) on 2 local processes and on N Dask workers:
start-up + 1000 x (seconds + overhead) / workers.

Usage: python bench/designs.py [--designs 8] [--samples 64] [--search 0] [--repeat 3] [--design-seconds 15]
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import pandas as pd
from _common import add_out_argument, write_result

from pytdcr.designs import DesignsRunOptions, run_designs, study_from_dict


def _study(designs: int, samples: int, search: int) -> dict:
    return {"name": "bench", "robot": "paper", "seed": 11, "designs": {"method": "sobol", "count": designs},
            "parameters": {"routing_radius_2": {"range": [0.006, 0.012]}, "segment_length_1": {"range": [0.16, 0.24]}},
            "budget": {"samples": samples, "search": search}, "loads": {"cases": ["paper wrench"]},
            "reference": False}


def _run(data: dict, **where: object) -> tuple[float, float]:
    """One study into a fresh folder: (wall seconds, median seconds per design inside its worker)."""
    study, robot = study_from_dict(data)
    out = Path(tempfile.mkdtemp(prefix="bench-designs-"))
    try:
        t0 = time.perf_counter()
        run_designs(study, robot, out / "run", options=DesignsRunOptions(figures=False, **where))
        wall = time.perf_counter() - t0
        inside = float(pd.read_csv(out / "run" / "timings.csv")["seconds"].median())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return wall, inside


def _noop() -> None:
    return None


def _dask(studies: list[dict], repeat: int) -> tuple[list[list[tuple[float, float]]], float]:
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.submit(_noop, pure=False).result()
        trips = []
        for _ in range(50):
            t0 = time.perf_counter()
            client.submit(_noop, pure=False).result()
            trips.append(time.perf_counter() - t0)
        runs = [[_run(data, scheduler=cluster.scheduler_address) for _ in range(repeat)] for data in studies]
    return runs, statistics.median(trips)


def _line(sizes: tuple[int, int], runs: list[list[tuple[float, float]]], workers: int) -> dict:
    """Start-up and slope of wall = start-up + designs x slope, from the median walls at two sizes."""
    walls = [statistics.median(r[0] for r in rs) for rs in runs]
    inside = statistics.median(r[1] for rs in runs for r in rs)
    slope = (walls[1] - walls[0]) / (sizes[1] - sizes[0])
    return {"wall_s": dict(zip(map(str, sizes), walls, strict=True)), "designs_per_min": 60 * sizes[1] / walls[1],
            "design_s_inside": inside, "startup_s": walls[0] - sizes[0] * slope, "slope_s": slope,
            "overhead_per_design_s": slope * workers - inside}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", type=int, default=8)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--search", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--design-seconds", type=float, default=15.0,
                    help="per-design seconds of a real study, for the 1,000-design estimate [15]")
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "designs")
    args = ap.parse_args()
    sizes = (args.designs, 2 * args.designs)
    studies = [_study(n, args.samples, args.search) for n in sizes]
    result: dict = {"designs": list(sizes), "samples": args.samples, "search": args.search, "repeat": args.repeat}
    for name, workers in (("local_1", 1), ("local_2", 2)):
        result[name] = _line(sizes, [[_run(d, workers=workers) for _ in range(args.repeat)] for d in studies],
                             workers)
    dask_runs, trip = _dask(studies, args.repeat)
    result["dask_2"] = _line(sizes, dask_runs, 2)
    result["dask_roundtrip_s"] = trip
    for name, r in ((k, result[k]) for k in ("local_1", "local_2", "dask_2")):
        print(f"{name:8s}: {r['wall_s'][str(sizes[1])]:6.1f} s for {sizes[1]} designs = {r['designs_per_min']:5.1f} "
              f"designs/min; start-up {r['startup_s']:.1f} s, then {r['slope_s']:.2f} s per design (a design takes "
              f"{r['design_s_inside']:.2f} s inside its worker; overhead {r['overhead_per_design_s']:+.2f} s)")
    print(f"Dask path: an empty task's round trip {trip * 1e3:.1f} ms")
    est = {}
    for sec, label in ((result["local_2"]["design_s_inside"], "this budget"), (args.design_seconds, "real")):
        local, dask = result["local_2"], result["dask_2"]
        e = {"design_s": sec, "2_processes_h": (local["startup_s"] + 1000 * (sec + max(
            local["overhead_per_design_s"], 0.0)) / 2) / 3600}
        for n in (2, 8, 32, 128):
            e[f"{n}_dask_workers_h"] = (dask["startup_s"] + 1000 * (sec + max(dask["overhead_per_design_s"], 0.0))
                                        / n) / 3600
        est[label] = e
        print(f"1,000 designs at {sec:.1f} s each ({label}): {e['2_processes_h']:.2f} h on 2 local processes; "
              + ", ".join(f"{e[f'{n}_dask_workers_h'] * 60:.1f} min on {n} Dask workers" for n in (2, 8, 32, 128)))
    result["estimate_1000_designs"] = est
    write_result("designs", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

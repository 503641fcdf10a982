"""The region traced from its boundary: its volume's error on shapes of known volume, and its cost.

Two measurements (``pytdcr.workspace._surface.trace_surface``, one core):
- known shapes (a ball, a box turned off the grid's axes, a torus: images of a box under known maps): each
  level's volume against the truth, the reported error (the change from the level before) and whether it
  covers the true error, the map's evaluations per level and the ratio of the last two (a surface method: about
  4 per halving; a volume method: 8);
- the paper robot (``--robot``): its continued region under the paper's load and without one (tensions in
  [0, 20] N, ``--model``), traced from a coarse ``--spacing`` [m] with ``--levels`` refinements: each level's
  volume [cm^3], the evaluations, the refused ones, the wall time, and the solves as cold-solve equivalents
  (the time spent solving, testing stability and differentiating, over the median cold solve measured here);
- with ``--membership N``, how much the region's membership depends on the path taken: of N points drawn
  uniformly inside the robot's traced surface, the share a straight follow reaches from the nearest reached node
  and from one of the four nearest; of N points outside it but within one finest spacing of its vertices, the
  share one of the four nearest reaches (region the trace missed).

Prints the tables and writes ``bench/results/surface.json``.

Usage: python bench/surface.py [--levels 2] [--robot] [--spacing 0.05] [--robot-levels 1] [--model pcc]
       [--membership 0] [--json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import add_out_argument, write_result
from scipy.spatial import cKDTree

from pytdcr import Loads
from pytdcr.paper import paper_bounds, paper_loads, paper_robot
from pytdcr.statics import MODELS
from pytdcr.workspace._follow import ParameterMap
from pytdcr.workspace._known import KNOWN_SHAPES
from pytdcr.workspace._robot_map import trace_robot_region
from pytdcr.workspace._surface import SurfaceSettings, TracedSurface, reached_by_follow, trace_surface, winding_numbers


def known(levels: int) -> list[dict]:
    rows = []
    for name, shape in KNOWN_SHAPES.items():
        box = np.full(3, shape.extent + shape.spacing)
        t0 = time.perf_counter()
        out = trace_surface(shape.fmap, shape.seeds(), -box, box, SurfaceSettings(spacing=shape.spacing,
                                                                                  levels=levels))
        seconds = time.perf_counter() - t0
        err = [abs(v - shape.volume) / shape.volume for v in out.volumes]
        reported = [float("inf")] + [abs(b - a) / shape.volume for a, b in zip(out.volumes, out.volumes[1:],
                                                                              strict=False)]
        rows.append({"shape": name, "true_volume": shape.volume, "spacings": list(out.spacings),
                     "volumes": list(out.volumes), "true_error": err, "reported_error": reported,
                     "covered": [e <= r for e, r in zip(err, reported, strict=True)],
                     "evaluations": list(out.evaluations),
                     "ratio_last": out.evaluations[-1] / max(out.evaluations[-2], 1) if levels else None,
                     "seconds": seconds})
    return rows


def cold_solve_seconds(model: str, loads: Loads, n: int = 30) -> float:
    """The median cold solve of the paper robot at uniform random tensions in [0, 20] N [s]."""
    robot, m = paper_robot(), MODELS[model]
    rng = np.random.default_rng(1)
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        m.solve(robot, loads.with_tensions(rng.uniform(0.0, 20.0, robot.n_tendons)), None, m.default_options())
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _draw(surface: TracedSurface, n: int, inside: bool, rng: np.random.Generator) -> np.ndarray:
    """``n`` points drawn uniformly inside ``surface`` (``inside``), or outside it within one finest spacing of a
    vertex, by rejection from the vertices' bounding box widened by that spacing."""
    h = surface.spacings[-1]
    lo, hi = surface.vertices.min(axis=0) - h, surface.vertices.max(axis=0) + h
    tree = cKDTree(surface.vertices)
    found: list[np.ndarray] = []
    while sum(len(f) for f in found) < n:
        y = rng.uniform(lo, hi, (4 * n, 3))
        if not inside:
            y = y[tree.query(y)[0] <= h]
        y = y[(winding_numbers(surface.vertices, surface.faces, y) > 0.5) == inside]
        found.append(y)
    return np.concatenate(found)[:n]


def membership(fmap: ParameterMap, surface: TracedSurface, settings: SurfaceSettings, n: int) -> dict:
    """The shares of points inside and just outside ``surface`` that straight follows reach, with their binomial
    standard errors (see the module's docstring)."""
    rng = np.random.default_rng(5)
    inner, outer = _draw(surface, n, True, rng), _draw(surface, n, False, rng)
    shares = {"inside_nearest": reached_by_follow(fmap, surface, inner, 1, settings),
              "inside_four_nearest": reached_by_follow(fmap, surface, inner, 4, settings),
              "outside_four_nearest": reached_by_follow(fmap, surface, outer, 4, settings)}
    return {k: {"share": float(v.mean()), "stderr": float(np.sqrt(v.mean() * (1 - v.mean()) / n)), "n": n}
            for k, v in shares.items()}


def robot(spacing: float, levels: int, model: str, n_membership: int = 0) -> list[dict]:
    rows = []
    for case, loads in (("paper load", paper_loads()), ("no load", Loads(np.zeros(8)))):
        cold = cold_solve_seconds(model, loads)
        t0 = time.perf_counter()
        settings = SurfaceSettings(spacing=spacing, levels=levels)
        out, fmap = trace_robot_region(paper_robot(), loads, paper_bounds(), MODELS[model], settings)
        seconds = time.perf_counter() - t0
        row = {"case": case, "model": model, "spacings_m": list(out.spacings),
               "volumes_cm3": [v * 1e6 for v in out.volumes], "reported_error_cm3": out.volume_err * 1e6,
               "evaluations": list(out.evaluations), "refused": fmap.refused, "seconds": seconds,
               "solve_seconds": fmap.solve_seconds, "cold_solve_ms": cold * 1e3,
               "cold_solve_equivalents": fmap.solve_seconds / cold, "unresolved": out.unresolved}
        if n_membership:
            row["membership"] = membership(fmap, out, settings, n_membership)
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, default=2)
    ap.add_argument("--robot", action="store_true", help="also trace the paper robot's region")
    ap.add_argument("--spacing", type=float, default=0.05, help="the robot's coarse spacing [m]")
    ap.add_argument("--robot-levels", type=int, default=1)
    ap.add_argument("--model", default="pcc", choices=sorted(MODELS))
    ap.add_argument("--membership", type=int, default=0, help="points drawn inside and outside the robot's surface")
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "surface")
    a = ap.parse_args()
    result: dict = {"known": known(a.levels)}
    print(f"{'shape':11s} {'spacing':>8s} {'volume':>9s} {'true err':>9s} {'reported':>9s} {'evaluations':>11s}")
    for row in result["known"]:
        for k, h in enumerate(row["spacings"]):
            print(f"{row['shape']:11s} {h:8.4f} {row['volumes'][k]:9.5f} {100 * row['true_error'][k]:8.3f}% "
                  f"{100 * row['reported_error'][k]:8.3f}% {row['evaluations'][k]:11,d}")
    if a.robot:
        result["robot"] = robot(a.spacing, a.robot_levels, a.model, a.membership)
        for row in result["robot"]:
            print(f"{row['case']}: volumes {[round(v) for v in row['volumes_cm3']]} cm3 at "
                  f"{row['spacings_m']} m, evaluations {row['evaluations']} ({row['refused']} refused), "
                  f"{row['seconds']:.1f} s, {row['cold_solve_equivalents']:,.0f} cold-solve equivalents")
            for name, m in row.get("membership", {}).items():
                print(f"  {name}: {100 * m['share']:.1f} +- {100 * m['stderr']:.1f} % of {m['n']} reached")
    write_result("surface", result, a.json, a.out)


if __name__ == "__main__":
    main()

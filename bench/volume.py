"""How true the workspace's volume estimate and its error are, on shapes of known volume (not part of the tests).

Each shape (a ball, an axis-aligned box, a torus: convex, flat-faced, concave) is filled with ``--points``
uniform random points (rejection from its bounding box), all counted at every nested size, so that the
sampling error is nil and what remains is the voxel resolution's. At voxel edges of L/32, L/24 and L/16
(L = 0.4 m, the paper robot's length) :func:`pytdcr.workspace.estimate_volume` gives the outer (occupied voxels)
and inner (surface moved in half a voxel) estimates, their mean (the reported volume) and the discretisation
error it claims; beside them the true relative error of each. A claimed error below the true one is an error
bar that misses. The last columns weigh an alternative: the inner estimate at twice the voxel edge, and the
change between the two as the inner estimate's error.

Prints a table and writes ``bench/results/volume.json``.

Usage: python bench/volume.py [--points 400000] [--seed 0] [--json]
"""

from __future__ import annotations

import argparse

import numpy as np
from _common import add_out_argument, write_result

from pytdcr.workspace._volume import estimate_volume

LENGTH = 0.4
DIVISIONS = (32, 24, 16)
#: the box's turn: 0.3 rad about (1, 2, 3)
_AXIS = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
_K = np.array([[0.0, -_AXIS[2], _AXIS[1]], [_AXIS[2], 0.0, -_AXIS[0]], [-_AXIS[1], _AXIS[0], 0.0]])
_TURN = np.eye(3) + np.sin(0.3) * _K + (1.0 - np.cos(0.3)) * _K @ _K


def _inside(kind: str, p: np.ndarray) -> np.ndarray:
    if kind == "ball":
        return np.linalg.norm(p, axis=1) <= 0.2
    if kind == "box":  # turned off the grid's axes: a box aligned with the voxels would favour the outer estimate
        return np.all(np.abs((p - [0.0, 0.0, 0.06]) @ _TURN) <= [0.15, 0.1, 0.06], axis=1)
    rho = np.hypot(p[:, 0], p[:, 1])  # torus: major radius 0.18 m, minor 0.07 m
    return np.hypot(rho - 0.18, p[:, 2]) <= 0.07


VOLUMES = {"ball": 4.0 / 3.0 * np.pi * 0.2**3, "box": 0.3 * 0.2 * 0.12, "torus": 2.0 * np.pi**2 * 0.18 * 0.07**2}


def _fill(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` uniform points inside the shape."""
    got: list[np.ndarray] = []
    count = 0
    while count < n:
        p = rng.uniform(-0.26, 0.26, (2 * n, 3))
        p = p[_inside(kind, p)]
        got.append(p)
        count += p.shape[0]
    return np.concatenate(got)[:n]


def main() -> None:
    """Run every shape at every voxel edge; print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=400_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "volume")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    for kind, true in VOLUMES.items():
        p = _fill(kind, args.points, rng)
        stage = np.zeros(p.shape[0], dtype=np.int8)
        for div in DIVISIONS:
            est, _ = estimate_volume(p, stage, args.points, LENGTH / div)
            sc = est.scales[-1]
            row = {"shape": kind, "voxel": f"L/{div}", "true_cm3": true * 1e6,
                   "outer_pct": 100 * (sc.voxel_m3 - true) / true,
                   "inner_pct": 100 * (sc.centre_m3 - true) / true,
                   "mean_pct": 100 * (est.volume_m3 - true) / true, "claimed_pct": 100 * est.discretisation_m3 / true}
            row["misses"] = abs(row["mean_pct"]) > row["claimed_pct"]
            # an alternative to weigh: the inner estimate, its error the change from twice the voxel edge
            coarse, _ = estimate_volume(p, stage, args.points, 2 * LENGTH / div)
            row["inner_2h_pct"] = 100 * (coarse.scales[-1].centre_m3 - true) / true
            row["two_scale_pct"] = abs(row["inner_pct"] - row["inner_2h_pct"])
            rows.append(row)
            print(f"{kind:5s} {row['voxel']:5s} true {row['true_cm3']:7.0f} cm3: outer {row['outer_pct']:+6.1f} %, "
                  f"inner {row['inner_pct']:+6.1f} %, mean {row['mean_pct']:+6.1f} %, "
                  f"claimed ±{row['claimed_pct']:.1f} %{' MISSES' if row['misses'] else ''}; inner at 2h "
                  f"{row['inner_2h_pct']:+6.1f} % (two-scale ±{row['two_scale_pct']:.1f} %)", flush=True)
    write_result("volume", {"points": args.points, "seed": args.seed, "length_m": LENGTH, "rows": rows},
                 args.json, out=args.out)


if __name__ == "__main__":
    main()

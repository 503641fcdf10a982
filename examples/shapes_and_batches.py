"""Shapes and batches out: many tension vectors with one model, a point load on a disk, every disk's pose as CSV.

The same as ``tdcr solve --cases cases.csv --csv table.csv``, ``tdcr solve --disk-force 10:0,0,-0.05`` and
``tdcr solve --csv shape.csv``, from Python; the files go to a folder given as the first argument (kept), or to a
temporary one (removed at the end).
"""

from __future__ import annotations

import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from pytdcr import PointLoad, paper_loads, paper_robot, solve, solve_batch
from pytdcr.runs import case_rows, write_shape_csv
from pytdcr.runtime import write_csv

robot = paper_robot()
scratch = tempfile.TemporaryDirectory(prefix="pytdcr-example-")
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(scratch.name)

# a batch: one row per case, one model (the table tdcr solve --cases writes)
cases = np.array([[3.0, 0, 0, 0, 2.0, 0, 0, 0], [0, 4.0, 0, 0, 0, 0, 3.0, 0], [18, 2, 0, 9, 0, 14, 1, 6]])
batch = solve_batch(robot, cases, paper_loads())
header, rows = case_rows(batch)
write_csv(out / "table.csv", header, rows)
print(f"{int(batch.converged.sum())} of {len(rows)} cases converged; tips [mm]:")
print(np.round(batch.tip_position * 1e3, 1))

# a 50 g payload hung at disk 10 (the middle), as --disk-force 10:0,0,-0.49 does
loads = paper_loads(cases[0])
hung = replace(loads, point_loads=(PointLoad(10, force=np.array([0.0, 0.0, -0.05 * 9.81])),))
free, loaded = solve(robot, loads), solve(robot, hung)
print(f"the payload moves the tip by {np.linalg.norm(loaded.tip_position - free.tip_position) * 1e3:.1f} mm")

# every disk's centre and frame, one row per disk from the base (the file tdcr solve --csv writes)
path = write_shape_csv(out / "shape.csv", loaded)
lines = path.read_text().splitlines()
print(f"{path.name}: {len(lines) - 1} disks; columns {lines[0]}")
print(f"wrote table.csv and shape.csv in {out}")
scratch.cleanup()

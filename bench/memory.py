"""Peak memory and time of one solve of large robots, against the estimate the memory budget uses.

Each solve runs in its own process (the paper robot with more disks, tensions 3, 0, 0, 0, 2, 0, 0, 0 N,
gravity, no tip load); its peak resident memory is read from ``getrusage`` and the baseline of a process that
only imports pytdcr and compiles the kernels is subtracted. Prints per size: measured peak, estimate, their
ratio, the solve's time and the time estimate; writes ``bench/results/memory.json``.

Usage: python bench/memory.py [--disks 500,1000,2000] [--json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from _common import add_out_argument, write_result

CHILD = """
import json, resource, sys, time
import numpy as np
from pytdcr import Loads, solve
from pytdcr.paper import paper_robot
from pytdcr.statics import get_model
per_segment = int(sys.argv[1])
small = paper_robot().with_disks(2)
solve(small, Loads(np.zeros(8)))  # compile / load the kernels first
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
robot = paper_robot().with_disks(per_segment) if per_segment else small
res = get_model("pcc").resources(robot, get_model("pcc").default_options())
t0 = time.perf_counter()
sol = solve(robot, Loads(np.array([3.0, 0, 0, 0, 2.0, 0, 0, 0])))
seconds = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"disks": robot.n_disks, "converged": bool(sol.converged), "seconds": seconds,
                  "peak_bytes": peak - base, "estimate_bytes": res.bytes, "estimate_seconds": res.seconds}))
"""


def main() -> None:
    """Measure each size in a fresh process."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--disks", default="250,500,1000", help="disks per segment, comma-separated")
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "memory")
    args = ap.parse_args()
    rows = []
    for per_segment in (int(x) for x in args.disks.split(",")):
        out = subprocess.run([sys.executable, "-c", CHILD, str(per_segment)], capture_output=True, text=True,
                             check=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(f"{row['disks']:6d} disks: peak {row['peak_bytes'] / 1e9:6.2f} GB (estimate "
              f"{row['estimate_bytes'] / 1e9:6.2f} GB, {row['estimate_bytes'] / max(row['peak_bytes'], 1):.2f}x), "
              f"solve {row['seconds']:6.1f} s (estimate {row['estimate_seconds']:6.1f} s), "
              f"converged {row['converged']}", flush=True)
    write_result("memory", {"model": "pcc", "robot": "paper", "rows": rows}, args.json, out=args.out)


if __name__ == "__main__":
    main()

"""First use as a new user meets it: the install, then each first answer from an empty kernel cache.

1. ``install``: a new virtual environment in a temporary folder and ``pip install`` of this checkout into it
   (a regular install, not editable; the packages come from pip's local cache, as on a developer's machine).
   Skipped with ``--python PY``, which times the calls below with that environment's interpreter instead.
2. ``calls``: each in a fresh process with an empty cache folder of its own (``PYTDCR_CACHE_DIR``), so that each
   pays everything its first use compiles: the README's first solve with each model (the paper robot under the
   paper's load; without friction for ``cosserat``, which has none), the first ``tdcr inverse`` answer, the
   first ``tdcr workspace`` answer (a small run) and the explorer's first solve (its app built, one drive
   solved). Then the first solve again on its filled cache.

Each entry: seconds of wall time (the process's whole life, start-up included), the lines on stderr that say
something compiles, and whether the call succeeded.

Run: python bench/first_use.py [--python .venv/bin/python] [--json] [--out FILE]
     (writes bench/results/first_use.json)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import add_out_argument, write_result

ROOT = Path(__file__).resolve().parents[1]

_SOLVE = """
import numpy as np
from pytdcr import paper_loads, paper_robot, solve
from pytdcr.robot import NoFriction
robot = paper_robot() if {model!r} != "cosserat" else paper_robot().with_friction(NoFriction())  # it has none
sol = solve(robot, paper_loads(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0])), model={model!r})
assert sol.converged, sol
print(*sol.tip_position)
"""

_EXPLORE = """
import numpy as np
from pytdcr.explore import create_app
from pytdcr.explore._session import Controls, Explorer
create_app()
ex = Explorer()
out = ex.step("s", Controls(np.array([4.0, 0, 0, 0, 2.0, 0, 0, 0]), np.zeros(3), np.zeros(3), 0.0, True, "own",
                            "pcc"))
assert out.solution is not None and out.solution.converged, out.error
print(*out.solution.tip_position)
"""

_MODELS = ("pcc", "pcc2", "sscr", "cosserat")


def _install(tmp: Path) -> tuple[Path, float]:
    """A new venv in ``tmp`` with this checkout installed: its interpreter and the seconds it took."""
    env_dir = tmp / "venv"
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True)
    py = env_dir / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--upgrade", "pip"], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", str(ROOT)], check=True)
    return py, time.perf_counter() - t0


def _run(argv: list[str], cache: Path, cwd: Path) -> dict:
    """Run ``argv`` with the cache folder ``cache``: seconds, success and the compile notices on stderr."""
    env = {**os.environ, "PYTDCR_CACHE_DIR": str(cache), "MPLBACKEND": "Agg"}
    for name in ("NUMBA_CACHE_DIR", "PYTDCR_KERNEL_CACHE_DIR"):
        env.pop(name, None)
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    notices = [line for line in done.stderr.splitlines() if "compiling" in line]
    entry = {"seconds": round(seconds, 2), "ok": done.returncode == 0, "compile_notices": notices}
    if done.returncode != 0:
        entry["stderr_tail"] = done.stderr.strip().splitlines()[-3:]
    return entry


def _say(name: str, entry: dict) -> None:
    """One progress line on stderr: the call, its time, and how it failed if it did."""
    failed = "" if entry["ok"] else f"  FAILED: {' / '.join(entry.get('stderr_tail', []))}"
    print(f"{name}: {entry['seconds']:.1f} s{failed}", file=sys.stderr)


def _calls(py: Path, tmp: Path, models: list[str]) -> dict:
    """Each first use in its own empty cache, then the first solve again on its filled cache."""
    tdcr = py.parent / "tdcr"
    calls: dict[str, dict] = {}
    for model in models:
        calls[f"first solve ({model})"] = _run([str(py), "-c", _SOLVE.format(model=model)], tmp / f"c-{model}", tmp)
        _say(f"first solve ({model})", calls[f"first solve ({model})"])
    calls["first solve (pcc), cache filled"] = _run([str(py), "-c", _SOLVE.format(model="pcc")], tmp / "c-pcc", tmp)
    calls["tdcr inverse"] = _run([str(tdcr), "inverse", "--target", "0.1,0.05,0.3", "--seed", "1"],
                                 tmp / "c-inverse", tmp)
    calls["tdcr workspace"] = _run([str(tdcr), "workspace", "--n", "200", "--seed", "1", "--out",
                                    str(tmp / "ws")], tmp / "c-workspace", tmp)
    calls["explore (first solve)"] = _run([str(py), "-c", _EXPLORE], tmp / "c-explore", tmp)
    for name in ("first solve (pcc), cache filled", "tdcr inverse", "tdcr workspace", "explore (first solve)"):
        _say(name, calls[name])
    return calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--python", default=None, help="time the calls with this interpreter (no install timed)")
    ap.add_argument("--models", default=",".join(_MODELS), help="models whose first solve is timed")
    ap.add_argument("--json", action="store_true", help="print the result as one JSON line")
    add_out_argument(ap, "first_use")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="pytdcr-first-use-") as name:
        tmp = Path(name)
        result: dict = {}
        if args.python is None:
            py, seconds = _install(tmp)
            result["install_s"] = round(seconds, 1)
            print(f"install: {seconds:.1f} s", file=sys.stderr)
        else:
            py = Path(args.python).absolute()
        result["calls"] = _calls(py, tmp, [m for m in args.models.split(",") if m])
    write_result("first_use", result, args.json, args.out)


if __name__ == "__main__":
    main()

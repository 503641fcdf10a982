"""Where the first use's time goes: numba compile time per model, per call and per compiled function.

Each model runs in a fresh process with an empty kernel cache (``PYTDCR_CACHE_DIR`` a new temporary folder), so
every model pays its whole compile as a user's first call would; then all models in one process (what
``make demo``'s warm-up compiles), and that process again on its now filled cache (what every later run pays).
For each compiled function numba's compile events give the time inclusive of the functions it compiles in
turn, the time of its own (exclusive: what remains once the nested compiles are taken out) and the number of
type signatures compiled.

Run: python bench/compile_profile.py [--models pcc,sscr] [--json]  (writes bench/results/compile_profile.json)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from _common import add_out_argument, write_result


def _calls(name: str) -> list[tuple[str, object]]:
    """The first use of each capability of model ``name``, as :func:`pytdcr.statics.warmup` makes them, as
    (label, thunk) pairs run in order."""
    import numpy as np

    from pytdcr.loads import Loads
    from pytdcr.paper import rao_robot
    from pytdcr.statics import MODELS, solve, solve_batch, tip_gradient

    robot, model = rao_robot(), MODELS[name]
    loads = Loads(np.full(robot.n_tendons, 1.0), tip_force=np.array([0.0, 0.01, 0.0]))
    ones, state = np.ones((2, robot.n_tendons)), {}

    def first() -> None:
        state["sol"] = solve(robot, loads, model=name)

    calls = [("first solve", first),
             ("warm start (q0)", lambda: solve(robot, loads, model=name, q0=state["sol"].q))]
    if model.capabilities.continuation:
        calls += [("continuation", lambda: solve(robot, loads.with_tensions(np.full(robot.n_tendons, 1.5)),
                                                 model=name, start=state["sol"])),
                  ("batch", lambda: solve_batch(robot, ones, loads, model=name, threads=1))]
    calls += [("stability", lambda: solve_batch(robot, ones, loads, model=name, threads=1).stability),
              ("tip gradient", lambda: tip_gradient(robot, loads, state["sol"], model=name)),
              ("tip gradients (batch)", lambda: model.tip_gradients(robot, np.ones((1, robot.n_tendons)), loads,
                                                                    state["sol"].q[None], model.options_type()))]
    if "shear_extension" in model.options_type.__dataclass_fields__:
        calls.append(("shear and extension", lambda: solve(robot, loads, model=name,
                                                           options=model.options_type(shear_extension=True))))
    return calls


def _functions(buffer: list) -> list[dict]:
    """Per compiled function, from numba's compile events: inclusive and exclusive seconds, signatures."""
    stack: list[list] = []
    inclusive: dict[str, float] = defaultdict(float)
    exclusive: dict[str, float] = defaultdict(float)
    signatures: dict[str, int] = defaultdict(int)
    for stamp, event in buffer:
        disp = event.data["dispatcher"]
        key = f"{disp.py_func.__module__}.{disp.py_func.__qualname__}"
        if event.is_start:
            stack.append([key, stamp, 0.0])
            continue
        name, start, nested = stack.pop()
        took = stamp - start
        if not any(k == name for k, _, _ in stack):  # a recursive compile counts once, at its outermost
            inclusive[name] += took
        exclusive[name] += took - nested
        signatures[name] += 1
        if stack:
            stack[-1][2] += took
    return sorted(({"function": k, "inclusive_s": round(inclusive[k], 3), "exclusive_s": round(exclusive[k], 3),
                    "signatures": signatures[k]} for k in exclusive), key=lambda r: -r["exclusive_s"])


def child(models: list[str]) -> dict:
    """In this process (its kernel cache under ``PYTDCR_CACHE_DIR``): import, then each model's first calls, timed,
    with numba's compile events recorded."""
    t0 = time.perf_counter()
    from numba.core import event

    import pytdcr  # noqa: F401

    imported = time.perf_counter() - t0
    out: dict = {"import_s": round(imported, 3), "models": {}}
    with event.install_recorder("numba:compile") as rec:
        for name in models:
            calls = {}
            for label, thunk in _calls(name):
                t = time.perf_counter()
                thunk()
                calls[label] = round(time.perf_counter() - t, 3)
            out["models"][name] = {"calls_s": calls, "total_s": round(sum(calls.values()), 3)}
    out["functions"] = _functions(rec.buffer)
    out["compile_s"] = round(sum(f["exclusive_s"] for f in out["functions"]), 3)
    return out


def _run(models: list[str], cache: str) -> dict:
    """:func:`child` in a new process whose kernel cache is ``cache``."""
    env = {**os.environ, "PYTDCR_CACHE_DIR": cache, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    done = subprocess.run([sys.executable, __file__, "--child", ",".join(models)], env=env, capture_output=True,
                          text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default=None, help="comma-separated registered models (default: all)")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "compile_profile")
    args = ap.parse_args()
    if args.child is not None:
        print(json.dumps(child(args.child.split(","))))
        return
    from pytdcr.runtime import versions_record
    from pytdcr.statics import MODELS

    models = args.models.split(",") if args.models else list(MODELS)
    result: dict = {"cores": os.cpu_count(), "versions": versions_record(), "cold_by_model": {}}
    for name in models:
        with tempfile.TemporaryDirectory() as cache:
            result["cold_by_model"][name] = r = _run([name], cache)
        print(f"{name}: first use {r['models'][name]['total_s']:.1f} s cold "
              f"(first solve {r['models'][name]['calls_s']['first solve']:.1f} s), compiling {r['compile_s']:.1f} s "
              f"in {len(r['functions'])} functions", flush=True)
    with tempfile.TemporaryDirectory() as cache:
        result["cold_all"] = _run(models, cache)
        result["cached_all"] = _run(models, cache)
    print(f"all models in one process: {sum(m['total_s'] for m in result['cold_all']['models'].values()):.1f} s "
          f"cold, {sum(m['total_s'] for m in result['cached_all']['models'].values()):.1f} s from the cache")
    print("largest own compile times (all models, one process):")
    for f in result["cold_all"]["functions"][:15]:
        print(f"  {f['exclusive_s']:7.1f} s own, {f['inclusive_s']:7.1f} s with callees, {f['signatures']:3d} "
              f"signatures  {f['function']}")
    write_result("compile_profile", result, args.json, out=args.out)


if __name__ == "__main__":
    main()

"""Time from Ctrl-C (SIGINT) to exit for every ``tdcr`` command (not part of the tests).

Each command is started as a real process and interrupted in the middle of its work (once its progress shows,
then after a further random delay of up to a second, seed 0), ``--repeats`` times. Prints the median and the
largest time from the signal to the process's exit, the exit status and the last line it printed; writes
``bench/results/interrupt.json`` (with ``--json`` also prints it as the last line). ``solve`` is interrupted
inside one compiled call (a 1,000-disk robot, seconds per solve).

Usage: python bench/interrupt.py [--repeats 3] [--json]
"""

from __future__ import annotations

import argparse
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from _common import add_out_argument, write_result

from pytdcr.io import write_robot
from pytdcr.paper import paper_robot

TDCR = [sys.executable, "-m", "pytdcr.cli"]


def commands(tmp: Path) -> dict[str, tuple[list[str], str]]:
    """Each command's arguments and the pattern of stderr that says its work is under way."""
    big = tmp / "robot_1000_disks.toml"
    write_robot(paper_robot().with_disks(500), big)
    return {
        "solve": (["solve", "--robot", str(big), "--tensions", "1,0,0,0,0,0,0,0"], ""),
        "sample": (["sample", "--n", "400000"], r"\d{4,}/400000"),
        "optimize": (["optimize", "--pop", "200", "--max-gen", "500", "--tol", "1e-15", "--window", "400"],
                     r"GA: .*?[1-9]\d*/500"),
        "reproduce": (["reproduce"], r"GA population 100: .*?[1-9]\d*/"),
        "compare": (["compare", "--n", "2000", "--models", "pcc,sscr"], r"[1-9]\d*/2000"),
        "accuracy": (["accuracy", "--n", "50"], r"accuracy"),
    }


def interrupt_once(args: list[str], ready: str, delay: float, out: Path) -> dict:
    argv = [*TDCR, *args] + ([] if args[0] == "solve" else ["--out", str(out)])
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    err: list[str] = []
    reader = threading.Thread(target=lambda: [err.append(c) for c in iter(lambda: p.stderr.read(64), "")],
                              daemon=True)
    reader.start()
    t0 = time.monotonic()
    while ready and not re.search(ready, "".join(err)) and p.poll() is None and time.monotonic() - t0 < 300:
        time.sleep(0.05)
    time.sleep(delay + (3.0 if not ready else 0.0))
    start = time.perf_counter()
    p.send_signal(signal.SIGINT)
    code = p.wait(timeout=120)
    seconds = time.perf_counter() - start
    reader.join(5)
    lines = [ln[ln.index("tdcr:"):] for ln in re.split(r"[\r\n]", "".join(err)) if "tdcr:" in ln]
    return {"seconds": seconds, "exit": code, "line": lines[-1] if lines else "",
            "traceback": "Traceback" in "".join(err)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    add_out_argument(ap, "interrupt")
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    result: dict = {"repeats": a.repeats, "commands": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (args, ready) in commands(Path(tmp)).items():
            runs = [interrupt_once(args, ready, float(rng.uniform(0, 1)), Path(tmp) / f"{name}{k}")
                    for k in range(a.repeats)]
            secs = [r["seconds"] for r in runs]
            result["commands"][name] = {"median_s": float(np.median(secs)), "max_s": max(secs),
                                        "exits": [r["exit"] for r in runs], "tracebacks": sum(r["traceback"]
                                                                                             for r in runs),
                                        "last_line": runs[-1]["line"]}
            print(f"{name:10s} Ctrl-C to exit: median {np.median(secs):.2f} s, max {max(secs):.2f} s; exit "
                  f"{[r['exit'] for r in runs]}; {runs[-1]['line']}", flush=True)
    write_result("interrupt", result, a.json, out=a.out)


if __name__ == "__main__":
    main()

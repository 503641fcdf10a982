"""Shared by the benchmark scripts: where results go and the machine they were measured on."""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
"""Default folder of the results (``bench/results/``); ``--out`` writes elsewhere, e.g. ``docs/validation/``."""

_LOAD_AT_START = os.getloadavg() if hasattr(os, "getloadavg") else None


def add_out_argument(ap: argparse.ArgumentParser, name: str) -> None:
    """Add ``--out FILE`` to a script's parser (default ``bench/results/<name>.json``)."""
    ap.add_argument("--out", default=None, metavar="FILE",
                    help=f"JSON file to write (default bench/results/{name}.json; the validation page's tables "
                         f"read docs/validation/{name}.json)")


def cpu_model() -> str:
    """The CPU's model name (from ``/proc/cpuinfo`` on Linux, else :func:`platform.processor`)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict:
    """Cores, CPU model, platform, load average (1, 5, 15 min) when the script started and ended, and the time."""
    end = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {
        "cores": os.cpu_count(),
        "cpu": cpu_model(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "load_average_start": [round(x, 2) for x in _LOAD_AT_START] if _LOAD_AT_START else None,
        "load_average_end": [round(x, 2) for x in end] if end else None,
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    }


def write_result(name: str, result: dict, print_json: bool, out: str | os.PathLike | None = None) -> None:
    """Write the result as JSON to ``out`` (default ``bench/results/<name>.json``).

    The result gains two keys: ``command`` (the command line that made it, as run from the repository's
    root) and ``machine`` (see :func:`machine`). With ``print_json`` it is also printed as one line (the last).
    """
    path = Path(out) if out is not None else RESULTS / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    script = Path(sys.argv[0])
    try:
        script = script.resolve().relative_to(Path.cwd())
    except ValueError:
        pass
    result = {**result, "command": " ".join(["python", script.as_posix(), *sys.argv[1:]]), "machine": machine()}
    path.write_text(json.dumps(result, indent=2) + "\n")
    if print_json:
        print(json.dumps(result))

"""Shared by the benchmark scripts: where results go."""

from __future__ import annotations

import json
from pathlib import Path


def write_result(name: str, result: dict, print_json: bool) -> None:
    """Write ``bench/results/<name>.json``; with ``print_json`` also print it as one line (the last)."""
    out = Path(__file__).resolve().parent / "results"
    out.mkdir(exist_ok=True)
    (out / f"{name}.json").write_text(json.dumps(result, indent=2))
    if print_json:
        print(json.dumps(result))

"""The accuracy study's summary for the validation page (not part of the tests).

Runs ``tdcr accuracy`` with the given options into a temporary folder and writes its ``accuracy.json``'s
``summary`` (each model's tip error against the reference ``sscr`` by load group, and the order studies'
errors and orders in the disk spacing) together with the options and the machine.

Usage: python bench/accuracy.py [--n 20] [--order-cases 3] [--out FILE] [--json] [-- more tdcr accuracy options]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import add_out_argument, write_result


def main() -> None:
    """Run the study, write the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="random tension vectors (tdcr accuracy --n)")
    ap.add_argument("--order-cases", type=int, default=3, help="tension vectors of the order study (0: none)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="also print the result as one JSON line")
    add_out_argument(ap, "accuracy")
    args, extra = ap.parse_known_args()
    extra = [a for a in extra if a != "--"]
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(Path(sys.executable).with_name("tdcr")), "accuracy", "--n", str(args.n), "--order-cases",
               str(args.order_cases), "--seed", str(args.seed), "--out", tmp, "-q", *extra]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True)
        seconds = time.perf_counter() - t0
        summary = json.loads((Path(tmp) / "accuracy.json").read_text())["summary"]
    for row in summary["rows"]:
        print(f"{row['group']:>24s} {row['model']:9s} median {row['median_error_mm']} mm, "
              f"p95 {row['p95_error_mm']} mm, converged {row['converged']}/{row['reference_converged']}")
    write_result("accuracy", {"n": args.n, "order_cases": args.order_cases, "seed": args.seed,
                              "options": extra, "seconds": round(seconds, 1), "summary": summary},
                 args.json, out=args.out)


if __name__ == "__main__":
    main()

"""``tdcr sample``: random tension samples, their CSV, Fig. 3(a) and Fig. 4."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ..validate import escape_controls
from ._args import (
    add_bounds,
    add_model,
    add_n,
    add_out,
    add_robot_and_loads,
    add_seed,
    bounds_spec,
    check_out,
    load_spec,
    model_spec,
    robot_spec,
)
from ._progress import Bar
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``sample`` command and its options."""
    sm = sub.add_parser("sample", help="random tension samples: CSV, Fig. 3(a) and Fig. 4")
    add_robot_and_loads(sm)
    add_model(sm)
    add_bounds(sm)
    add_n(sm, 100, "number of samples")
    add_seed(sm)
    add_out(sm, "out/sample")
    sm.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Sample; print the counts and the reach, and what was written."""
    from ..runs import BoundsSpec, SampleSettings, run_sample

    out = check_out(args.out)
    settings = SampleSettings(robot=robot_spec(args), loads=load_spec(args), model=model_spec(args),
                              bounds=bounds_spec(args) or BoundsSpec(), n=args.n, seed=args.seed)
    with Bar("sample", args.n, "solve") as bar:
        res = run_sample(settings, out, progress=bar.step)
    summary = res.summary
    counts = summary.counts
    ok = counts.converged
    reach = (f"reach {np.nanmin(res.samples.reach):.4f} to {counts.reach_max_m:.4f} m" if ok else "no reach")
    print(f"{args.n} samples of robot '{summary.robot}' (seed {args.seed}): {ok} converged, "
          f"{counts.not_converged} not; {reach}; {summary.seconds:.2f} s")
    print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    if ok == 0:
        print(f"tdcr: none of the {args.n} samples converged", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK

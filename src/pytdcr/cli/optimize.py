"""``tdcr optimize``: the GA maximising the tip's distance from the base (the paper's Eq. 29)."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ..optimize import ReachResult, SearchFailed
from ..runtime import dump_json
from ..validate import escape_controls
from ._args import (
    add_bounds,
    add_model,
    add_out,
    add_robot_and_loads,
    add_seed,
    bounds_spec,
    check_out,
    count_type,
    load_spec,
    model_spec,
    real_type,
    robot_spec,
)
from ._progress import Bar
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, one_line

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``optimize`` command and its options."""
    op = sub.add_parser("optimize", help="GA maximising the tip's distance from the base (paper Eq. 29)")
    add_robot_and_loads(op)
    add_model(op)
    add_bounds(op)
    op.add_argument("--pop", type=count_type, default=50, help="population size [50]")
    op.add_argument("--tol", type=real_type, default=1e-6, help="stop when the best cost improves by less [1e-6]")
    op.add_argument("--window", type=count_type, default=5, help="... over this many generations [5]")
    op.add_argument("--max-gen", type=count_type, default=100, help="generation cap [100]")
    add_seed(op)
    op.add_argument("--no-polish", action="store_true", help="skip the gradient polish of the GA's best")
    op.add_argument("--no-local-search", action="store_true",
                    help="plain GA: no gradient search on each new leader (the default GA is memetic)")
    op.add_argument("--stable-only", action="store_true",
                    help="an equilibrium that fails the static stability test is infeasible (models with the test)")
    op.add_argument("--json", action="store_true", help="print one JSON object")
    add_out(op, None, "write figures and data to this folder")
    op.set_defaults(func=run)


def _rounded(values: np.ndarray, decimals: int) -> list[float]:
    """``values`` rounded to ``decimals`` for a message, a zero always 0.0 (never -0.0)."""
    return (np.round(values, decimals) + 0.0).tolist()


def print_reach(res: ReachResult, args: argparse.Namespace) -> None:
    """The GA's outcome and the polished optimum, in a few lines."""
    ga = res.ga
    print(f"GA (population {args.pop}, seed {args.seed}): {res.generations} generations"
          f"{'' if res.stop_reason == 'tolerance' else ' (generation cap)'}, {res.evaluations} solves, "
          f"{res.nonconverged} not converged, {res.seconds:.1f} s")
    print(f"  GA best: tensions {_rounded(ga.tensions, 4)} N, reach {ga.reach:.6f} m, cost {ga.cost:.6f} 1/m")
    if res.polished:
        print(f"  polished: reach {res.reach:.6f} m (cost {res.cost:.6f}, gain {res.polish_gain:.2e}), "
              f"tensions {_rounded(res.tensions, 4)} N")
    print(f"  optimum tip {_rounded(res.tip_position, 6)} m; "
          f"{'stable' if res.stable else 'UNSTABLE' if res.stable is False else 'stability untested'}"
          f"{f' ({res.rejected_unstable} unstable individuals refused)' if res.rejected_unstable else ''}")


def run(args: argparse.Namespace) -> int:
    """Search; print the optimum (or one JSON object) and what was written."""
    from ..runs import BoundsSpec, OptimizeSettings, run_optimize

    out = check_out(args.out) if args.out else None
    settings = OptimizeSettings(robot=robot_spec(args), loads=load_spec(args), model=model_spec(args),
                                bounds=bounds_spec(args) or BoundsSpec(), pop=args.pop, tol=args.tol,
                                window=args.window, max_gen=args.max_gen, seed=args.seed, polish=not args.no_polish,
                                local_search=not args.no_local_search, stable_only=args.stable_only)
    try:
        with Bar("GA", args.max_gen, "gen") as bar:
            res = run_optimize(settings, out, progress=None if args.json else bar.generation)
    except SearchFailed as err:
        print(f"tdcr: {one_line(err)}; nothing written", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if args.json:
        print(dump_json(res.result.to_json()))
    else:
        print_reach(res.result, args)
        if res.files:
            print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    return EXIT_OK

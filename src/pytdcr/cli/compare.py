"""``tdcr compare`` (two or more models on the same cases) and ``tdcr accuracy`` (which model to trust: every
model against ``sscr``, by load group, and the order study)."""

from __future__ import annotations

import argparse
import math
import sys

from ..compare import check_models
from ..statics import MODELS
from ..validate import escape_controls, show
from ._args import (
    add_bounds,
    add_n,
    add_out,
    add_robot_and_loads,
    add_seed,
    bounds_spec,
    check_out,
    count_type,
    has_tip_wrench,
    load_spec,
    parse_floats,
    real_type,
    robot_spec,
)
from ._progress import Bar
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, CliError

__all__ = ["add_accuracy_parser", "add_parser", "error_mm", "run", "run_accuracy_command"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``compare`` command and its options."""
    c = sub.add_parser("compare", help="two or more models on the same cases: table and overlay figure")
    add_robot_and_loads(c)
    add_bounds(c)
    c.add_argument("--cases", metavar="FILE", help="CSV of tension vectors, one case per row [N]")
    add_n(c, 20, "number of random cases when no --cases")
    add_seed(c)
    c.add_argument("--models", default="pcc,cosserat", metavar="A,B[,...]",
                   help=f"models to compare, the first the reference ({', '.join(MODELS)}) [pcc,cosserat]")
    c.add_argument("--shear-extension", action="store_true",
                   help="backbones shear and stretch (models with that option)")
    add_out(c, "out/compare")
    c.set_defaults(func=run)


def _names(text: str) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip())


def run(args: argparse.Namespace) -> int:
    """Compare; print the tip differences and solve times, and what was written."""
    from ..runs import CompareSettings, run_compare

    models = _names(args.models)
    check_models(models)  # before any other option
    out = check_out(args.out)
    settings = CompareSettings(robot=robot_spec(args), loads=load_spec(args), models=models,
                               shear_extension=args.shear_extension, cases=args.cases, n=args.n,
                               bounds=bounds_spec(args), seed=args.seed)
    with Bar("compare", 0, "case") as bar:

        def step(_done: int, total: int) -> None:
            bar.total = total  # the cases' number, known once they are read
            bar.step()

        res = run_compare(settings, out, progress=step)
    cmp, robot = res.comparison, res.robot
    per = cmp.summaries()
    note = (f" (friction of robot '{robot.name}' turned off for every model: {', '.join(res.friction_off)} "
            "has none)") if res.friction_off else ""

    def mm(v: float | None) -> str:
        return "n/a" if v is None else error_mm(v)

    diffs = "; ".join(f"{n} from {cmp.reference}: median {mm(per[n].difference_median_mm)} mm, max "
                      f"{mm(per[n].difference_max_mm)} mm" for n in cmp.others)
    times = ", ".join(f"{n} {s.ms_median:.2f} ms" for n, s in per.items())
    print(f"{len(cmp)} cases on robot '{robot.name}'{note}: every model converged on {cmp.n_all_converged}; "
          f"tip difference {diffs}; median solve {times}")
    print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    if cmp.n_all_converged == 0:
        failed = ", ".join(f"{n} {s.not_converged}" for n, s in per.items())
        print(f"tdcr: no case converged for every model (not converged of {len(cmp)}: {failed})", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def error_mm(value: float, width: int = 0) -> str:
    """A distance or error [mm] for a message, right-aligned in ``width`` characters: three decimals, or three
    significant digits where three decimals would show a non-zero value as 0 (below half a micrometre):
    :func:`pytdcr.runs.number_text`, the one rule."""
    from ..runs import number_text

    return number_text(value, 3, width)


# ---------------------------------------------------------------- accuracy
def add_accuracy_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``accuracy`` command and its options."""
    a = sub.add_parser("accuracy", help="which model to trust: every model against sscr, by load group, and the "
                       "order study")
    add_robot_and_loads(a)
    add_bounds(a)
    add_n(a, 20, "random tension vectors")
    add_seed(a)
    a.add_argument("--models", metavar="A,B,...", help=f"models to compare (default all: {', '.join(MODELS)})")
    a.add_argument("--disks", default="5,10,20,40", metavar="N1,N2,...",
                   help="disks per segment of the order study [5,10,20,40]")
    a.add_argument("--order-cases", type=count_type, default=3,
                   help="tension vectors of the order study (0: none) [3]")
    a.add_argument("--reference-steps", type=count_type, default=160,
                   help="Runge-Kutta steps per segment of the reference sscr, at least 4 per subsegment [160]")
    a.add_argument("--payload-g", type=real_type, default=10.0, help="payload of the last load group [10 g]")
    add_out(a, "out/accuracy")
    a.set_defaults(func=run_accuracy_command)


def _int_list(text: str, name: str) -> tuple[int, ...]:
    vals = parse_floats(text, name)
    if any(v != round(v) or v < 1 for v in vals):
        raise CliError(f"{name}: expected comma-separated integers >= 1, got {show(text)}")
    return tuple(int(v) for v in vals)


def run_accuracy_command(args: argparse.Namespace) -> int:
    """The accuracy study; print its table and orders, and what was written."""
    from ..runs import AccuracySettings, BoundsSpec, run_accuracy

    out = check_out(args.out)
    robot = robot_spec(args)
    if has_tip_wrench(args):
        raise CliError("accuracy: the study sets its own load groups; drop --tip-force/--tip-moment/--disk-force/"
                       "--disk-moment")
    settings = AccuracySettings(robot=robot, bounds=bounds_spec(args) or BoundsSpec(), n=args.n, seed=args.seed,
                                models=[m.strip() for m in args.models.split(",")] if args.models else None,
                                disks=_int_list(args.disks, "--disks"), order_cases=args.order_cases,
                                reference_steps=args.reference_steps, payload_g=args.payload_g)
    with Bar("accuracy", settings.steps, "step") as bar:
        res = run_accuracy(settings, out, progress=lambda label: bar.step(1, label))
    study = res.study
    why = study.nothing_compared()
    print(f"{args.n} tension vectors on robot '{study.robot.name}', {len(study.groups)} load groups, "
          f"{len(study.models)} models against sscr ({study.seconds:.1f} s)" + ("." if why else ":"))
    for r in [] if why else study.rows():
        if r.unsupported:
            print(f"  {r.group:>18s}  {r.model:9s} unsupported")
        elif not r.converged:
            print(f"  {r.group:>18s}  {r.model:9s} nothing compared: converged 0/{r.reference_converged}")
        else:
            print(f"  {r.group:>18s}  {r.model:9s} median {error_mm(r.median_error_mm, 9)} mm, 95th pct "
                  f"{error_mm(r.p95_error_mm, 9)} mm, converged {r.converged}/{r.reference_converged}, "
                  f"{r.median_ms:.2f} ms")
    for st in [] if why else res.orders:
        print(f"  order ({st.group}): " + ", ".join(f"{m} {o:.2f}" if math.isfinite(o) else f"{m} -"
                                                     for m, o in st.order.items()))
    print(f"wrote {', '.join(res.files)} in {escape_controls(str(out))}")
    if why:
        print(f"tdcr: accuracy: nothing could be compared: {why}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK

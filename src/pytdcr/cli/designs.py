"""``tdcr designs``: a design study (a workspace study per design) on local processes or a Dask cluster;
resumable."""

from __future__ import annotations

import argparse

from ..validate import escape_controls
from ._args import add_out, count_type
from ._progress import Bar, quiet, say
from ._runtime import EXIT_NOT_CONVERGED, EXIT_OK, CliError

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The ``designs`` command and its options."""
    d = sub.add_parser("designs", help="a design study: a workspace study per design, on local processes or a "
                       "Dask cluster; resumable")
    d.add_argument("study", help="the study file (TOML; see examples/design_study_small.toml)")
    add_out(d, "out/designs", "output folder; a stopped study there resumes [out/designs]")
    d.add_argument("--scheduler", help="a Dask scheduler's address (tcp://host:8786) to run on; default: local "
                   "processes")
    d.add_argument("--workers", type=count_type, help="local processes [all cores]")
    d.add_argument("--restart", action="store_true", help="discard what the folder holds and start again")
    d.add_argument("--no-figures", action="store_true", help="write no figures (the table and report only)")
    d.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """The design study; print the best design per load case, and what was written."""
    from ..designs import DesignsRunOptions, format_measure, load_study, run_designs

    study, robot, text = load_study(args.study)
    if args.scheduler is None and not quiet():  # on a cluster the workers are not known before the run
        from ..designs import choose_designs, designs_estimate
        from ..runtime import default_threads

        count = (study.designs.total if study.designs.method == "optimize" else
                 len(choose_designs(study.parameters, study.designs.method, study.designs.count, seed=study.seed)))
        est = designs_estimate(study, robot, count, args.workers or default_threads())
        if est.seconds > 60:
            say(f"{est.text()} for {count} designs, each as the base robot")
    bar = Bar("designs", None, "design")

    def progress(done: int, failed: int, total: int) -> None:
        bar.set_total(total)  # the optimiser's total is an upper bound until it ends
        bar.step(done - bar.done, f"{failed} failed" if failed else None)

    try:
        options = DesignsRunOptions(scheduler=args.scheduler, workers=args.workers, restart=args.restart,
                                    progress=progress, figures=not args.no_figures)
    except ValueError as err:  # the options check their ranges; the message names the option
        raise CliError(f"--{err}") from None
    try:
        res = run_designs(study, robot, args.out, study_text=text, options=options)
    finally:
        bar.__exit__()
    s = res.summary
    print(f"design study '{study.name}': {s.designs} designs, {s.designs_computed} computed, "
          f"{s.designs_reused} reused, {s.designs_failed} failed, on {s.executor} in {s.seconds:.1f} s")
    t = res.table
    for b in s.best:
        m = b.measure
        ref = t[(t["load_case"] == b.load_case) & (t["design"] == -1) & (t["status"] == "ok")]
        err = f" ± {format_measure(b.error, m)}" if b.error is not None else ""
        versus = f" (base robot {format_measure(ref[m].iloc[0], m)})" if not ref.empty else ""
        print(f"  {escape_controls(b.load_case)}: best by {b.goal} {m}: design {b.design}, "
              f"{format_measure(b.value, m)}{err}{versus}")
    for u in s.unranked:
        print(f"  {escape_controls(u.load_case)}: no best by {u.goal} {u.measure}: {u.reason}")
    if s.warnings:
        print("  warning: at this budget the volumes are a screening index, not a measurement: their errors exceed "
              "the margins between the leading designs (see report.md)")
    figures = ", figures" if s.figures else ""
    best = ", best/" if s.best else ""  # no design measured: no best robot file
    print(f"wrote designs.parquet, designs.csv, timings.csv, summary.json, report.md{best}{figures} in "
          f"{escape_controls(str(res.path))}")
    return EXIT_OK if s.designs_failed < s.designs else EXIT_NOT_CONVERGED

"""The ``tdcr`` command. Nothing in the package imports it.

One module per command (or pair of commands): ``solve``, ``inverse``, ``sample``, ``workspace``, ``optimize``,
``reproduce``, ``compare`` (with ``accuracy``), ``designs``, ``calibrate``, ``robot``, ``explore``; each declares
its options (``add_parser``) and runs (``run``): it turns the options into the study's settings (:mod:`pytdcr.runs`),
calls the library and prints.
The options the commands share are declared once (:mod:`._args`); how a command runs, Ctrl-C and the exit
status are in :mod:`._runtime`: 0 success, 1 not converged, 2 bad input, 70 internal error (a bug), 75 the
compute went away under a resumable run, 130 interrupted, 141 the output's reader closed the pipe. The study
and the heavy libraries are imported when a command runs, not for ``--help``.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Sequence

from . import calibrate, compare, designs, explore, inverse, optimize, reproduce, robot, sample, solve, workspace
from ._args import FLAGS, Parser, glue_negative_values
from ._progress import set_quiet
from ._runtime import (
    EXIT_INTERRUPTED,
    EXIT_NOT_CONVERGED,
    EXIT_OK,
    EXIT_PIPE_CLOSED,
    StderrGuard,
    pipe_closed,
    run,
    speak_the_terminals_encoding,
    terminate,
)

__all__ = ["build_parser", "entry", "main"]


def version_text() -> str:
    """``tdcr --version``: pytdcr's version and those of the libraries its results depend on (read from the
    installed packages' metadata, without importing them; the same every run's manifest records)."""
    from .._version import __version__
    from ..runtime import library_versions

    libs = ", ".join(f"{n} {v}" for n, v in library_versions().items())
    return f"tdcr (pytdcr) {__version__}; Python {sys.version.split()[0]}; {libs}"


class _Version(argparse.Action):
    """``--version``: print :func:`version_text` on one line (argparse's own action wraps it) and exit 0."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(version_text())
        parser.exit(0)


def build_parser() -> Parser:
    """The argument parser of ``tdcr``."""
    p = Parser(prog="tdcr", description="Statics and workspace of tendon-driven continuum robots.")
    p.add_argument("--version", action=_Version, nargs=0,
                   help="print the version of pytdcr and of the libraries its results depend on, and exit")
    sub = p.add_subparsers(dest="command", required=True)
    for add in (solve.add_parser, inverse.add_parser, sample.add_parser, workspace.add_parser, optimize.add_parser,
                reproduce.add_parser, compare.add_parser, compare.add_accuracy_parser, designs.add_parser,
                calibrate.add_parser, robot.add_parser, explore.add_parser):
        add(sub)
    for command in sub.choices.values():
        command.add_argument("-q", "--quiet", action="store_true",
                             help="no progress or first-use compiling notice on stderr (results, warnings and "
                                  "errors still print)")
    return p


def _parse(argv: Sequence[str]) -> argparse.Namespace:
    """The arguments, parsed; ``--quiet`` silences the progress display."""
    args = build_parser().parse_args(glue_negative_values(argv))
    set_quiet(getattr(args, "quiet", False))
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``tdcr``; returns the exit status (0 success, 1 not converged, 2 bad input, 130 Ctrl-C,
    75 the compute went away under a resumable run, 70 a bug).

    Arguments are checked before any work starts; errors are one line on stderr. The command line writes
    figures to files and never opens a window: it alone picks matplotlib's Agg backend (unless
    ``MPLBACKEND`` says otherwise). Set ``PYTDCR_DEBUG=1`` to see the traceback behind an error message.
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    speak_the_terminals_encoding()
    args = sys.argv[1:] if argv is None else argv
    guard = StderrGuard.install()
    try:
        code = run(lambda: _parse(args), FLAGS)
        sys.stderr.flush()
    finally:
        guard.uninstall()
        set_quiet(False)  # --quiet was this run's: a later main() or library call in the process shows progress
    # the reader of the messages went away: a run that finished says so as one whose output's reader did
    return EXIT_PIPE_CLOSED if guard.lost and code in (EXIT_OK, EXIT_NOT_CONVERGED) else code


def entry() -> None:
    """The console script: :func:`main`, with SIGTERM treated as Ctrl-C; after an interrupt the process leaves
    without waiting for worker threads still finishing a chunk (everything saved has been written)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, terminate)
    code = main()
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        code = pipe_closed()
    sys.stderr.flush()
    if code == EXIT_INTERRUPTED:
        os._exit(code)
    sys.exit(code)

"""How a ``tdcr`` command runs: in a worker thread, Ctrl-C turned into a cancellation, errors on one line, and
the exit status.

Exit status:

- 0 success;
- 1 solved but not converged (a single solve, a batch where nothing converged, a search that found no
  converged tension vector, a design study where every design failed);
- 2 bad input (one line on stderr naming what is wrong);
- 70 internal error: a bug in pytdcr (sysexits' EX_SOFTWARE; one line, ``PYTDCR_DEBUG=1`` shows the traceback);
- 75 the compute went away under a run that resumes (a design study's worker processes died; sysexits'
  EX_TEMPFAIL: run the same command again);
- 130 interrupted (Ctrl-C or SIGTERM: one line saying what was saved);
- 141 the reader of the output went away (``tdcr solve ... | head -1``: the pipe closed; no message, as a
  program ended by SIGPIPE; everything the run writes to files was written).

The command runs in a worker thread; the main thread waits for it and turns Ctrl-C into a cancellation the
solvers check between small chunks of work (:func:`pytdcr.runtime.cancellable`), so every command stops within
about a second and saves what it has (:func:`pytdcr.runtime.output_folder`).
"""

from __future__ import annotations

import argparse
import codecs
import contextvars
import os
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import TextIO

from ..runtime import cancellable
from ..validate import SettingsError, show

__all__ = ["EXIT_BAD_INPUT", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "EXIT_NOT_CONVERGED", "EXIT_OK", "EXIT_TRY_AGAIN",
           "SAVE_GRACE_S", "CliError", "one_line", "run", "terminate"]

#: success
EXIT_OK = 0
#: solved, but not converged (or nothing converged)
EXIT_NOT_CONVERGED = 1
#: bad input
EXIT_BAD_INPUT = 2
#: a bug in pytdcr (sysexits' EX_SOFTWARE)
EXIT_INTERNAL = 70
#: the compute went away under a run that resumes (sysexits' EX_TEMPFAIL: try again)
EXIT_TRY_AGAIN = 75
#: interrupted (Ctrl-C, SIGTERM)
EXIT_INTERRUPTED = 130
#: the reader of standard output closed the pipe (128 + SIGPIPE, the status of a program that signal ends)
EXIT_PIPE_CLOSED = 141

#: how long the main thread lets an interrupted command save what it has before it stops waiting [s]
SAVE_GRACE_S = 0.6


class CliError(Exception):
    """Bad command-line input: reported on one line, exit status 2."""


class _Interrupted(Exception):
    """The command was interrupted; ``str()`` says what was saved."""


def one_line(message: object, limit: int = 600) -> str:
    """A message on one line: newlines folded, control characters escaped, at most ``limit`` characters."""
    text = " ".join(str(message).split())
    return show(text, limit)[1:-1]


def _run_command(args: argparse.Namespace) -> int:
    """Run the chosen command in a worker thread within a cancellation scope; Ctrl-C here cancels it.

    The main thread waits on an event, not on ``Thread.join`` (an interrupted join can leave the thread
    reported as finished while it still runs).
    """
    code: list[int] = []  # the command's exit status, once it returned
    error: list[BaseException] = []  # what it raised instead
    done = threading.Event()

    def target() -> None:
        try:
            code.append(int(args.func(args)))
        except BaseException as err:  # handed to the main thread as it is
            error.append(err)
        finally:
            done.set()

    with cancellable() as scope:
        threading.Thread(target=contextvars.copy_context().run, args=(target,), name="tdcr-command",
                         daemon=True).start()
        try:
            while not done.wait(0.1):
                pass
        except KeyboardInterrupt:
            scope.cancel()
            if getattr(args, "serves", False):  # a page served until Ctrl-C: its normal end, with nothing to save
                raise _Interrupted("the page is closed (it saves nothing)") from None
            try:
                if not done.wait(SAVE_GRACE_S):
                    if not scope.saving.is_set():  # still inside one compiled call, with nothing to save
                        raise _Interrupted("nothing saved")
                    print("tdcr: interrupted; saving what was finished (Ctrl-C again to leave at once)",
                          file=sys.stderr, flush=True)
                    while not done.wait(0.1):
                        pass
            except KeyboardInterrupt:
                raise _Interrupted("left at once; nothing more saved") from None
            err = error[0] if error else None
            if err is None:
                raise _Interrupted("the run had finished; everything it wrote was saved") from None
            raise _Interrupted(getattr(err, "message", None) or "nothing saved") from None
    err = error[0] if error else None
    if err is None:
        return code[0]
    if isinstance(err, KeyboardInterrupt):
        raise _Interrupted(getattr(err, "message", None) or "nothing saved") from None
    raise err


def run(parse: Callable[[], argparse.Namespace], flags: dict[str, str]) -> int:
    """Parse the arguments with ``parse`` and run the command they name; returns the exit status.

    Every error is one line on stderr; a :class:`~pytdcr.validate.SettingsError` calls each setting by its
    option (``flags``: field name to option). Set ``PYTDCR_DEBUG=1`` to see the traceback behind an error.
    """
    try:
        return _run_command(parse())
    except _Interrupted as stop:
        print(f"tdcr: interrupted; {one_line(stop)}", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:
        print("tdcr: interrupted; nothing saved", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return pipe_closed()
    except (CliError, ValueError, TypeError, OSError, MemoryError) as err:
        if os.environ.get("PYTDCR_DEBUG"):
            raise
        text = err.worded(flags) if isinstance(err, SettingsError) else err
        print(f"tdcr: error: {one_line(text)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as err:  # a search with nothing converged, or a bug: one line, no traceback unless asked
        from ..designs import WorkersLost
        from ..optimize import SearchFailed

        if isinstance(err, SearchFailed):
            print(f"tdcr: {one_line(err)}", file=sys.stderr)
            return EXIT_NOT_CONVERGED
        if isinstance(err, WorkersLost):
            print(f"tdcr: {one_line(err)}", file=sys.stderr)
            return EXIT_TRY_AGAIN
        if os.environ.get("PYTDCR_DEBUG"):
            raise
        print(f"tdcr: internal error: {type(err).__name__}: {one_line(err, 300)} (a bug in pytdcr: please report "
              "it; PYTDCR_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


#: ASCII for the characters the command line prints (plus-minus, superscripts, dashes, quotes, the progress
#: bar's block; by code point), on a terminal or file whose encoding lacks them; every other one becomes "?"
_ASCII = {"\u00b1": '+/-', "\u00b3": '^3', "\u00b2": '^2', "\u00b0": ' deg', "\u00b5": 'u', "\u2014": '--',
          "\u2013": '-', "\u00b7": '*', "\u00d7": 'x', "\u2264": '<=', "\u2265": '>=', "\u2192": '->',
          "\u2026": '...', "\u2019": "'", "\u2018": "'", "\u201c": '"', "\u201d": '"', "\u2588": '#'}


def _to_ascii(err: UnicodeError) -> tuple[str, int]:
    """The codec error handler ``tdcr-ascii``: a character the output's encoding cannot hold becomes its ASCII
    spelling (``±`` as ``+/-``), or ``?``."""
    if not isinstance(err, UnicodeEncodeError):
        raise err
    text = err.object[err.start:err.end]
    return "".join(_ASCII.get(c, "?") for c in text), err.end


codecs.register_error("tdcr-ascii", _to_ascii)


def speak_the_terminals_encoding() -> None:
    """Standard output and error write what their encoding cannot hold in ASCII (``±`` as ``+/-``) instead of
    failing: a terminal or file that is not UTF-8 gets the same run and the same words."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors="tdcr-ascii")
            except (ValueError, OSError):  # pragma: no cover - a stream that cannot be reconfigured
                pass


class StderrGuard:
    """Standard error that outlives its reader: a write or flush that finds the pipe closed (``tdcr ... 2>&1 |
    head -1``) points the descriptor at ``os.devnull`` and goes on, so the run finishes and writes its files
    instead of failing inside a progress bar; :attr:`lost` says it happened (the exit status is then
    :data:`EXIT_PIPE_CLOSED` for a run that would have returned 0 or 1)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.lost = False

    @classmethod
    def install(cls) -> StderrGuard:
        """Put a guard in place of ``sys.stderr`` (:meth:`uninstall` puts it back)."""
        guard = cls(sys.stderr)
        sys.stderr = guard  # type: ignore[assignment]
        return guard

    def uninstall(self) -> None:
        """Restore the stream this guard replaced."""
        if sys.stderr is self:
            sys.stderr = self.stream

    def _closed(self) -> None:
        self.lost = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self.stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):  # not a file descriptor (a test's capture)
            pass

    def write(self, text: str) -> int:
        """Write ``text``; nothing when the reader is gone."""
        if self.lost:
            return len(text)
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            self._closed()
            return len(text)

    def flush(self) -> None:
        """Flush; nothing when the reader is gone."""
        if self.lost:
            return
        try:
            self.stream.flush()
        except BrokenPipeError:
            self._closed()

    def __getattr__(self, name: str) -> object:
        """Anything else of the stream it guards (``fileno``, ``isatty``, ``encoding``, ...)."""
        return getattr(self.stream, name)


def pipe_closed() -> int:
    """Standard output's reader went away: say nothing more there (what is buffered goes nowhere, so the
    interpreter's last flush cannot fail too) and return :data:`EXIT_PIPE_CLOSED`."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a file descriptor (a notebook, a test's capture)
        pass
    return EXIT_PIPE_CLOSED


def terminate(_signum: int, _frame: FrameType | None) -> None:
    """SIGTERM's handler: the same as Ctrl-C."""
    raise KeyboardInterrupt

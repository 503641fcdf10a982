"""Cancellation: work that a caller (a command line's Ctrl-C, a notebook) can stop between small chunks.

Inside :func:`cancellable`, cancelling the scope makes every chunk of work not yet started, in this thread or in
threads started through :func:`pytdcr.runtime.submit_in_context`, raise :class:`Cancelled` (a
KeyboardInterrupt). :func:`saving` marks work that has results and is writing them: it is waited for, not
abandoned.
"""

from __future__ import annotations

import contextvars
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["CancelScope", "Cancelled", "cancellable", "check_cancelled", "current_scope", "mark_saving", "saving"]


class CancelScope:
    """Work that can be cancelled: ``cancel()`` stops it at its next chunk of solves.

    Scopes nest: work in an inner scope stops when any enclosing one is cancelled. ``saving`` says that the
    scope's work has results and is writing them (and should be waited for, not abandoned); it is set on the
    scope and every enclosing one.
    """

    def __init__(self, parent: CancelScope | None = None, shield: bool = False) -> None:
        self.parent = parent
        self.shield = shield
        self.cancelled = threading.Event()
        self.saving = threading.Event()

    def cancel(self) -> None:
        """Stop the scope's work at its next chunk (from any thread)."""
        self.cancelled.set()

    def is_cancelled(self) -> bool:
        """True once this scope or an enclosing one is cancelled."""
        scope: CancelScope | None = self
        while scope is not None:
            if scope.cancelled.is_set():
                return True
            scope = None if scope.shield else scope.parent
        return False


_scope: contextvars.ContextVar[CancelScope | None] = contextvars.ContextVar("pytdcr_cancel", default=None)


class Cancelled(KeyboardInterrupt):
    """Work stopped because the run it belongs to was interrupted (see :func:`cancellable`)."""


@contextmanager
def cancellable() -> Iterator[CancelScope]:
    """A scope whose work stops, at the next chunk of solves, once it (or an enclosing scope) is cancelled."""
    scope = CancelScope(_scope.get())
    token = _scope.set(scope)
    try:
        yield scope
    finally:
        _scope.reset(token)


def check_cancelled() -> None:
    """Raise :class:`Cancelled` if the enclosing :func:`cancellable` scope has been cancelled."""
    scope = _scope.get()
    if scope is not None and scope.is_cancelled():
        raise Cancelled("cancelled: the run was interrupted")


@contextmanager
def saving() -> Iterator[None]:
    """Writing results: the work inside is not cancelled by the enclosing scopes (a Ctrl-C then waits for it,
    a second one leaves at once), and they are told so (:func:`mark_saving`)."""
    mark_saving()
    scope = CancelScope(_scope.get(), shield=True)
    token = _scope.set(scope)
    try:
        yield
    finally:
        _scope.reset(token)


def mark_saving() -> None:
    """Say that the work has results and is writing them (no-op outside a scope)."""
    scope = _scope.get()
    while scope is not None:
        scope.saving.set()
        scope = scope.parent


def current_scope() -> CancelScope | None:
    """The innermost cancellation scope of this thread's context (None outside one)."""
    return _scope.get()

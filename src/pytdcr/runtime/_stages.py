"""The progress protocol's end of a stage, and durations as people read them."""

from __future__ import annotations

__all__ = ["duration", "end_stage"]


def end_stage(step: object) -> None:
    """End a stage whose progress callback is ``step`` (what ``progress(stage, total, ...)`` returned): calls
    ``step.close()`` where the callback has one (a display then shows the stage whole, at the work done, which
    may be less than its cap), and nothing otherwise or for ``None``."""
    close = getattr(step, "close", None)
    if callable(close):
        close()


def duration(t: float) -> str:
    """A duration [s] for people: ``42 s``, ``3 min 05 s``, ``1 h 02 min``."""
    t = max(0.0, float(t))
    if t < 60:
        return f"{t:.0f} s"
    if t < 3600:
        return f"{int(t // 60)} min {int(t % 60):02d} s"
    return f"{int(t // 3600)} h {int(t % 3600 // 60):02d} min"

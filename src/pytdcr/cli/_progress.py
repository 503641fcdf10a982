"""Progress bars on stderr (tqdm), drawn from their first step: input refused before any work prints alone."""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["Bar", "Bars"]


class Bar:
    """A tqdm progress bar on stderr, drawn from its first step."""

    def __init__(self, desc: str, total: int, unit: str) -> None:
        self.desc, self.total, self.unit = desc, total, unit
        self.bar: Any = None

    def step(self, k: int = 1, label: str | None = None) -> None:
        """Advance by ``k``; ``label`` shows beside the bar."""
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, desc=self.desc, unit=self.unit, leave=False, file=sys.stderr)
        if label is not None:
            self.bar.set_postfix_str(label, refresh=False)
        self.bar.update(k)

    def generation(self, _gen: int, best: float, _mean: float) -> None:
        """The GA's progress callback."""
        self.step(1, f"best={best:.6f}")

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.close()


class Bars:
    """One progress bar per stage of a long run (``progress(stage, total)``), closed when the next opens."""

    def __init__(self) -> None:
        self.bar: Bar | None = None

    def __call__(self, stage: str, total: int | None) -> Any:
        self.close()
        self.bar = Bar(stage, total, "solve" if "h(d)" not in stage else "dir")  # type: ignore[arg-type]
        return self.bar.step

    def close(self) -> None:
        """Close the open bar, if any."""
        if self.bar is not None:
            self.bar.__exit__()
            self.bar = None

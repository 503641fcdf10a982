"""Actuator tension bounds: the box every sampling and search stays in."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .loads import check_tensions
from .robot import MAX_TENDONS, Robot
from .validate import as_real_array, check_count

__all__ = ["TensionBounds"]


@dataclass(frozen=True)
class TensionBounds:
    """Per-tendon actuator tension bounds [N].

    Parameters
    ----------
    lower, upper : array-like, shape (n_tendons,)
        Finite, 0 <= lower <= upper.
    """

    lower: np.ndarray
    upper: np.ndarray

    def __post_init__(self) -> None:
        lo = as_real_array(self.lower, "bounds: lower").reshape(-1)  # strings, bools, complex numbers refused
        hi = as_real_array(self.upper, "bounds: upper").reshape(-1)
        if lo.shape != hi.shape:
            raise ValueError(f"bounds: lower has {lo.size} entries, upper {hi.size}")
        lo = check_tensions(lo, name="bounds: lower")
        hi = check_tensions(hi, name="bounds: upper")
        bad = lo > hi
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(f"bounds: tendon {k + 1} has lower {lo[k]} > upper {hi[k]} N")
        lo.flags.writeable = False
        hi.flags.writeable = False
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def uniform(cls, n_tendons: int, lower: float, upper: float) -> TensionBounds:
        """The same bounds [lower, upper] N for every tendon."""
        n = check_count(n_tendons, "n_tendons", lo=1, hi=MAX_TENDONS)  # no robot has more: nothing huge allocated
        lo = as_real_array(lower, "bounds: lower")
        hi = as_real_array(upper, "bounds: upper")
        return cls(np.full(n, lo, dtype=float), np.full(n, hi, dtype=float))

    @property
    def n(self) -> int:
        """Number of tendons."""
        return int(self.lower.size)

    @property
    def free(self) -> np.ndarray:
        """Tendons whose tension may vary (upper > lower), shape (n_tendons,) of bool."""
        return self.upper > self.lower

    @property
    def span(self) -> np.ndarray:
        """upper - lower, floored at 1e-12 N (a scale for distances in tension space), shape (n_tendons,)."""
        return np.maximum(self.upper - self.lower, 1e-12)

    def check_robot(self, robot: Robot) -> None:
        """Raise ValueError unless there is one bound pair per tendon of ``robot``."""
        if self.n != robot.n_tendons:
            raise ValueError(f"bounds: robot '{robot.name}' has {robot.n_tendons} tendons, got bounds for {self.n}")

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` uniform random tension vectors, shape (n, n_tendons) [N]."""
        return self.lower + (self.upper - self.lower) * rng.random((n, self.n))

    def clip(self, tensions: np.ndarray) -> np.ndarray:
        """``tensions`` (..., n_tendons) clipped into the box [N]."""
        return np.clip(np.asarray(tensions, dtype=float), self.lower, self.upper)

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-ready form."""
        return {"lower": self.lower.tolist(), "upper": self.upper.tolist()}

"""Multistability: how often the equilibrium a tension vector holds the robot in depends on how it got there.

A region of continued samples (:data:`~pytdcr.workspace.EQUILIBRIA` ``"continuation"``) holds, for each tension
vector, the equilibrium the robot reaches by its own history of quasi-static tension changes from rest; a
loading-path region holds the one reached from rest with every load ramped together. Where the robot has two
stable equilibria for one tension vector the two histories can end in different ones. A random subset of the
region's samples is solved the other way as well (from rest along the loading path, or continued straight from
the root) and the equilibria are compared tip by tip.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..records import JsonDict, JsonObject
from ._solve import EQUILIBRIA, RegionSamples, _Solver, same_tip

__all__ = ["FROM_REST", "FROM_ROOT", "Multistability", "MultistabilityCounts", "measure_multistability"]

#: the second history of a continued region's samples
FROM_REST = "loading path from rest"
#: the second history of a loading-path region's samples
FROM_ROOT = "continuation from the root"


@dataclass(frozen=True, eq=False)
class Multistability:
    """Samples of a region solved along a second history and compared.

    Attributes
    ----------
    equilibria : str
        The region's equilibria (:data:`~pytdcr.workspace.EQUILIBRIA`).
    other : str
        How the checked samples were solved the second time: ``"loading path from rest"`` (every load ramped
        together) for a continued region, ``"continuation from the root"`` for a loading-path one.
    rows : ndarray of int, shape (K,)
        The checked samples (rows of the region's samples; stable equilibria of the region).
    other_tip : ndarray, shape (K, 3)
        The tip the second history reaches [m]; NaN where it did not converge.
    other_converged, other_stable : ndarray of bool, shape (K,)
        Whether the second history converged, and on an equilibrium that is not unstable (for a model without
        the stability test, every converged one: ``tested`` is then False).
    distinct : ndarray of bool, shape (K,)
        The second history converged on another equilibrium (tips farther apart than
        ``same_tip``).
    seconds : float
        Wall time of the second solves [s].
    tested : bool
        The model tested the equilibria's stability; without the test ``distinct_unstable`` is None (unknown),
        never 0.
    """

    equilibria: str
    other: str
    rows: np.ndarray
    other_tip: np.ndarray
    other_converged: np.ndarray
    other_stable: np.ndarray
    distinct: np.ndarray
    seconds: float
    tested: bool = True

    @property
    def checked(self) -> int:
        """Samples checked."""
        return int(self.rows.size)

    @property
    def fraction(self) -> float | None:
        """distinct / checked (None when nothing was checked)."""
        return float(self.distinct.sum()) / self.checked if self.checked else None

    def counts(self) -> MultistabilityCounts:
        """Its numbers (what ``workspace.json`` keeps of it)."""
        return MultistabilityCounts(self.equilibria, self.other, self.checked, int(self.distinct.sum()),
                                    self.fraction, int(np.sum(~self.other_converged)),
                                    int(np.sum(self.distinct & ~self.other_stable)) if self.tested else None,
                                    self.seconds)

    def to_dict(self) -> JsonDict:
        """JSON-ready summary (:meth:`MultistabilityCounts.to_json`)."""
        return self.counts().to_json()


@dataclass(frozen=True)
class MultistabilityCounts:
    """The numbers of a :class:`Multistability` check, as ``workspace.json`` keeps them (its arrays are not kept:
    a file read back gives these).

    Attributes
    ----------
    equilibria, other : str
        The region's equilibria and the second history (:class:`Multistability`).
    checked : int
        Samples checked.
    distinct : int
        Of those, how many reached another equilibrium by the second history.
    fraction : float or None
        ``distinct / checked`` (None when nothing was checked).
    other_not_converged : int
        Checked samples whose second history did not converge.
    distinct_unstable : int or None
        Distinct ones whose other equilibrium is unstable; None (unknown) where the model has no stability test.
    seconds : float
        Wall time of the second solves [s] (0 read from a record with its times dropped).
    """

    equilibria: str
    other: str
    checked: int
    distinct: int
    fraction: float | None
    other_not_converged: int
    distinct_unstable: int | None
    seconds: float = 0.0

    def to_json(self) -> JsonDict:
        """JSON-ready form: ``checked``, ``distinct``, ``fraction``, and what the second history did."""
        return {"equilibria": self.equilibria, "other": self.other, "checked": self.checked,
                "distinct": self.distinct, "fraction": self.fraction,
                "other_not_converged": self.other_not_converged, "distinct_unstable": self.distinct_unstable,
                "seconds": self.seconds}

    @classmethod
    def from_json(cls, d: JsonObject) -> MultistabilityCounts:
        """The numbers :meth:`to_json` wrote; KeyError naming a missing key."""
        return cls(d["equilibria"], d["other"], d["checked"], d["distinct"], d["fraction"],
                   d["other_not_converged"], d["distinct_unstable"], d.get("seconds", 0.0))


def measure_multistability(solver: _Solver, samples: RegionSamples, count: int, *, seed: int = 0) -> Multistability:
    """Solve ``count`` random stable samples of ``samples`` (``seed``; all of them when there are fewer) along the
    other history (see the module) with ``solver`` and compare the equilibria."""
    continued = samples.parent is not None
    pool = np.flatnonzero(samples.feasible)
    rng = np.random.default_rng([seed, 3])
    rows = np.sort(rng.choice(pool, min(count, pool.size), replace=False)) if pool.size else pool
    t0 = time.perf_counter()
    T = samples.tensions[rows]
    if continued:
        got = solver.solve(T)
    else:
        root = solver.batch(np.zeros((1, T.shape[1])))
        got = solver.solve(T, start=root.rows(np.zeros(rows.size, dtype=np.int64))) if root.converged[0] else None
    seconds = time.perf_counter() - t0
    if got is None:  # the root itself did not converge: nothing to continue from
        nan = np.full((rows.size, 3), np.nan)
        no = np.zeros(rows.size, dtype=bool)
        return Multistability(EQUILIBRIA[1], FROM_ROOT, rows, nan, no, no, no, seconds, solver.stability)
    ok = np.asarray(got.converged, dtype=bool)
    gap = np.linalg.norm(np.nan_to_num(got.tip_position - samples.tip_position[rows], nan=np.inf), axis=1)
    return Multistability(EQUILIBRIA[0] if continued else EQUILIBRIA[1], FROM_REST if continued else FROM_ROOT,
                          rows, got.tip_position,
                          ok, ok & (got.stable != 0.0), ok & (gap > same_tip(solver.robot)), seconds,
                          solver.stability)

"""Result types."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, partial
from typing import TypeVar

import numpy as np

from .kinematics import backbone_curve
from .loads import Loads
from .records import JsonDict
from .robot import Robot

__all__ = ["BatchSolution", "NotConvergedError", "Stability", "StaticSolution"]

_T = TypeVar("_T")
#: a solution's class: what a pickled solution is rebuilt as
_Solution = TypeVar("_Solution", "StaticSolution", "BatchSolution")
#: what ``__reduce__`` returns for a solution (pickle's protocol): the function that rebuilds it and its arguments
_Reduced = tuple[Callable[[type[_Solution], dict[str, object]], _Solution], tuple[type[_Solution], dict[str, object]]]


class NotConvergedError(RuntimeError):
    """Raised when a shape is asked of a solve that did not converge."""


def _known(value: _T) -> _T:
    """A stability test already computed (what a pickled solution carries instead of the test itself)."""
    return value


def _rebuild(cls: type[_Solution], fields: dict[str, object]) -> _Solution:
    return cls(**fields)


def _reduce(obj: _Solution, stability: Stability | tuple[Stability | None, ...] | None) -> _Reduced[_Solution]:
    """Pickle a solution: its fields, with the stability test (a closure over the model) replaced by its result,
    computed now; so solutions come back whole from a process pool or a file."""
    fields = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}
    if fields["_stability_fn"] is not None:
        fields["_stability_fn"] = partial(_known, stability)
    return (_rebuild, (type(obj), fields))


@dataclass(frozen=True)
class Stability:
    """The eigenvalue test of one equilibrium.

    Attributes
    ----------
    stable : bool
        No real eigenvalue of K is <= 0.
    min_real_eigenvalue : float
        The smallest real eigenvalue of K (NaN if K has none) [N m per unit of q].
    n_real_nonpositive : int
        How many real eigenvalues are <= 0.
    flutter_pairs : int
        Complex-conjugate pairs with a negative real part (possible flutter; not called unstable).
    least_damped : complex or None
        Of those, the eigenvalue with the most negative real part.
    """

    stable: bool
    min_real_eigenvalue: float
    n_real_nonpositive: int
    flutter_pairs: int
    least_damped: complex | None

    def to_dict(self) -> JsonDict:
        """JSON-ready form (the complex eigenvalue as [real, imag])."""
        z = self.least_damped
        return {"stable": self.stable, "min_real_eigenvalue": self.min_real_eigenvalue,
                "n_real_nonpositive": self.n_real_nonpositive, "flutter_pairs": self.flutter_pairs,
                "least_damped_pair": None if z is None else [z.real, abs(z.imag)]}


@dataclass(frozen=True, eq=False)
class StaticSolution:
    """The outcome of one static solve.

    Attributes
    ----------
    converged : bool
        True when max |residual| <= atol and every value is finite.
    residual : float
        max |residual| [N m] at the returned unknowns.
    iterations : int
        Newton iterations in all (load steps included).
    load_steps : int
        Continuation steps taken (0 when the direct solve converged).
    path : SolvePath
        How the equilibrium was reached, a :class:`pytdcr.statics.SolvePath` member (a ``str`` equal to its
        value): ``"loading"`` (followed the loading path from the unloaded robot), ``"snap"`` (that path,
        relaxed through a fold), ``"direct"`` (Newton at full load from the start point), ``"fallback"`` (the
        loading path failed; another equilibrium), ``"continued"`` (from a solved state), ``"fold"`` (stopped
        at a fold, not converged) or ``"self-contact"`` (refused, see ``failure``). Annotated ``str`` here:
        this module lies below :mod:`pytdcr.statics`, which defines the enumeration.
    q : ndarray
        The model's unknowns, a warm start for a nearby solve of the same
        model (its ``unknowns`` attribute says what they are). PCC: shape
        (N, 3), (beta [1/m], gamma [1/m], eps [rad]) per subsegment (MODEL.md);
        Cosserat: shape (3,), the total moment at the base [N m], base frame.
        Not converged: the solver's last iterate, no equilibrium (:meth:`to_dict` gives null).
    tensions : ndarray, shape (n_tendons, N)
        Tension in each tendon piece i (between disk i-1 and i) [N]; 0 past the anchor. Not converged: those
        of the last iterate, no equilibrium's (:meth:`to_dict` gives null).
    seconds : float
        Wall time of the solve [s].
    atol : float
        Convergence tolerance used [N m].
    model : str
        The registered name of the model that solved it (:data:`pytdcr.statics.MODELS`).
    stability : Stability or None
        The static stability test of the equilibrium (computed on first use);
        None when not converged or when the model has no such test.
    stable : bool or None
        ``stability.stable``.
    failure : str
        Why a solve whose residual is small is still not converged (empty otherwise): the rod models
        refuse an equilibrium whose backbone passes through itself (``path = "self-contact"``).
    loads : Loads or None
        The loads it was solved under (what ``solve(..., start=solution)`` continues from).
    """

    converged: bool
    residual: float
    iterations: int
    load_steps: int
    path: str
    q: np.ndarray
    tensions: np.ndarray
    seconds: float
    atol: float
    _positions: np.ndarray
    _rotations: np.ndarray
    model: str = "pcc"
    _curve: np.ndarray | None = None
    _stability_fn: Callable[[], Stability | None] | None = None
    failure: str = ""
    loads: Loads | None = None

    def _require(self) -> None:
        if self.failure:
            raise NotConvergedError(f"the solve gave no valid shape: {self.failure}")
        if not self.converged:
            raise NotConvergedError(
                f"the solve did not converge (max |residual| = {self.residual:.3e} N m > atol = "
                f"{self.atol:.1e}); it has no shape"
            )

    @property
    def disk_positions(self) -> np.ndarray:
        """Disk centres in the base frame, shape (N+1, 3) [m]; row 0 is the base."""
        self._require()
        return self._positions

    @property
    def disk_rotations(self) -> np.ndarray:
        """Disk frame orientations in the base frame, shape (N+1, 3, 3)."""
        self._require()
        return self._rotations

    @property
    def tip_position(self) -> np.ndarray:
        """Tip position ^0P_n, shape (3,) [m]."""
        return self.disk_positions[-1]

    @property
    def tip_rotation(self) -> np.ndarray:
        """Tip orientation ^0R_n, shape (3, 3)."""
        return self.disk_rotations[-1]

    def backbone_points(self, robot: Robot) -> np.ndarray:
        """Points along the backbone in the base frame, shape (K, 3) [m], base to tip."""
        self._require()
        if self._curve is not None:
            return self._curve
        return backbone_curve(self.q, robot.subsegment_lengths)

    @property
    def reach(self) -> float:
        """||^0P_n||_2 [m]."""
        return float(np.linalg.norm(self.tip_position))

    @cached_property
    def stability(self) -> Stability | None:
        """The eigenvalue test of the equilibrium's tangent stiffness (None: not converged, or no such test)."""
        if not self.converged or self._stability_fn is None:
            return None
        return self._stability_fn()

    @property
    def stable(self) -> bool | None:
        """True when the equilibrium is statically stable, False when not, None when untested."""
        s = self.stability
        return None if s is None else s.stable

    def __reduce__(self) -> _Reduced[StaticSolution]:
        return _reduce(self, self.stability)

    def to_dict(self) -> JsonDict:
        """JSON-ready dictionary (what ``tdcr solve --json`` prints).

        Not converged: what was not obtained is None (``tip_position``, ``tip_rotation``, ``disk_positions``,
        ``q``, ``tensions``, ``stable``, ``stability``), never the numbers of the last iterate; ``converged``,
        ``failure``, ``residual``, ``iterations``, ``load_steps``, ``path`` and ``seconds`` say what happened.
        """
        ok = self.converged
        return {
            "converged": bool(ok),
            "failure": self.failure or None,
            "stable": self.stable,
            "stability": None if self.stability is None else self.stability.to_dict(),
            "residual": float(self.residual),
            "iterations": int(self.iterations),
            "load_steps": int(self.load_steps),
            "model": self.model,
            "path": self.path,
            "seconds": float(self.seconds),
            "tip_position": self.tip_position.tolist() if ok else None,
            "tip_rotation": self.tip_rotation.tolist() if ok else None,
            "disk_positions": self.disk_positions.tolist() if ok else None,
            "q": self.q.tolist() if ok else None,
            "tensions": self.tensions.tolist() if ok else None,
        }


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """Solutions of many tension vectors under the same external loads.

    Attributes
    ----------
    tensions : ndarray, shape (B, n_tendons)
        The actuator tensions solved [N], one row per case (not the per-piece tensions of
        :attr:`StaticSolution.tensions`, shape (n_tendons, N)).
    converged : ndarray of bool, shape (B,)
    residual : ndarray, shape (B,)
        max |residual| [N m].
    iterations : ndarray of int, shape (B,)
    q : ndarray
        The model's unknowns per case: PCC (B, N, 3), Cosserat (B, 3); NaN where not converged (the last
        iterate is no equilibrium: warm-start a new batch from the converged rows).
    tip_position : ndarray, shape (B, 3)
        [m]; NaN where not converged.
    seconds : float
        Wall time of the whole batch [s].
    path : ndarray of object, shape (B,)
        How each equilibrium was reached, :class:`pytdcr.statics.SolvePath` members (see
        :class:`StaticSolution`; ``"no start"``: a row not continued, its start not converged).
    model : str
        The registered name of the model.
    disk_positions : ndarray, shape (B, N+1, 3), or None
        Disk centres in the base frame [m], row 0 the base; NaN where not converged.
    disk_rotations : ndarray, shape (B, N+1, 3, 3), or None
        Disk orientations in the base frame; NaN where not converged.
    atol : ndarray, shape (B,), or None
        The tolerance each case was judged by [N m] (:mod:`pytdcr.statics.tolerance`).
    loads : Loads or None
        The external loads every case was solved under (their tensions are the rows of ``tensions``): what
        ``solve_batch(..., start=batch)`` continues from.
    """

    tensions: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    q: np.ndarray
    tip_position: np.ndarray
    seconds: float
    path: np.ndarray
    model: str
    _stability_fn: Callable[[], Sequence[Stability | None]] | None = None
    disk_positions: np.ndarray | None = None
    disk_rotations: np.ndarray | None = None
    atol: np.ndarray | None = None
    loads: Loads | None = None

    def __post_init__(self) -> None:
        ok = np.asarray(self.converged, dtype=bool)
        if not np.all(ok):  # a case not converged carries no unknowns that could be read as its equilibrium
            q = np.array(self.q, dtype=float)
            q[~ok] = np.nan
            object.__setattr__(self, "q", q)

    @cached_property
    def stability(self) -> tuple[Stability | None, ...]:
        """Each case's stability test (computed on first use, in parallel); None where not converged or
        untested."""
        if self._stability_fn is None:
            return (None,) * len(self.converged)
        return tuple(self._stability_fn())

    def __reduce__(self) -> _Reduced[BatchSolution]:
        return _reduce(self, self.stability)

    def rows(self, index: slice | np.ndarray) -> BatchSolution:
        """The cases ``index`` selects (a slice, indices or a boolean mask), as a batch of their own."""
        stab = self.stability if self._stability_fn is not None else None
        pick = np.arange(len(self.converged))[index]
        return BatchSolution(
            tensions=self.tensions[pick], converged=self.converged[pick], residual=self.residual[pick],
            iterations=self.iterations[pick], q=self.q[pick], tip_position=self.tip_position[pick],
            seconds=self.seconds, path=self.path[pick], model=self.model,
            _stability_fn=None if stab is None else partial(_known, tuple(stab[k] for k in pick)),
            disk_positions=None if self.disk_positions is None else self.disk_positions[pick],
            disk_rotations=None if self.disk_rotations is None else self.disk_rotations[pick],
            atol=None if self.atol is None else self.atol[pick], loads=self.loads)

    @property
    def stable(self) -> np.ndarray:
        """Per case: 1.0 stable, 0.0 unstable, NaN not converged or untested, shape (B,)."""
        return np.array([np.nan if s is None else float(s.stable) for s in self.stability])

    @classmethod
    def from_solutions(cls, tensions: np.ndarray, solutions: Sequence[StaticSolution], seconds: float,
                       model: str) -> BatchSolution:
        """Gather single solutions, case by case."""
        ok = np.array([s.converged for s in solutions], dtype=bool)
        tips = np.full((len(solutions), 3), np.nan)
        n1 = solutions[0]._positions.shape[0] if solutions else 1
        pos = np.full((len(solutions), n1, 3), np.nan)
        rot = np.full((len(solutions), n1, 3, 3), np.nan)
        for b in np.flatnonzero(ok):
            tips[b] = solutions[b].tip_position
            pos[b], rot[b] = solutions[b].disk_positions, solutions[b].disk_rotations
        return cls(tensions=tensions, converged=ok, residual=np.array([s.residual for s in solutions]),
                   iterations=np.array([s.iterations for s in solutions], dtype=np.int64),
                   q=np.array([s.q for s in solutions]), tip_position=tips, seconds=seconds,
                   path=np.array([s.path for s in solutions], dtype=object), model=model, disk_positions=pos,
                   disk_rotations=rot, atol=np.array([s.atol for s in solutions], dtype=float))

    @property
    def reach(self) -> np.ndarray:
        """||tip|| [m], shape (B,); NaN where not converged."""
        return np.linalg.norm(self.tip_position, axis=1)

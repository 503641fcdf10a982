"""Solving a tension plan: in blocks on all cores, with warm starts only where they are checked to agree
with the loading path, and the realisability of every equilibrium."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from scipy.spatial import cKDTree

from ..bounds import TensionBounds
from ..contact import bending_curvature, disks_below_base, disks_touch
from ..limits import check_memory
from ..loads import Loads
from ..records import JsonDict, JsonObject
from ..results import BatchSolution
from ..robot import Robot
from ..statics import Model, SolvePath, check_resources, resolve, solve_batch
from ..validate import SettingsError, check_count
from ._plan import SOURCES, TensionPlan

if TYPE_CHECKING:
    from ..statics.options import ModelOptions

__all__ = [
    "AGREEMENT_REQUIRED",
    "EQUILIBRIA",
    "FIRST_WAVE",
    "ROOT",
    "SAME_TIP",
    "SAME_TIP_LENGTH",
    "RegionSamples",
    "SolvedRows",
    "WarmStartCheck",
    "WarmStarts",
    "equilibria_for",
    "plan_stages",
    "same_tip",
    "solve_plan",
    "solves_needed",
]

#: the share of checked warm starts that must land on the loading path's equilibrium for warm starts to be used
AGREEMENT_REQUIRED = 0.999
#: two equilibria of a robot of length :data:`SAME_TIP_LENGTH` are the same when their tips are this close [m];
#: on another robot the distance scales with its length (:func:`same_tip`)
SAME_TIP = 1e-6
#: the robot length at which :data:`SAME_TIP` holds as it is [m] (that of the paper's robot, two 0.2 m
#: segments: its results are those of the absolute 1e-6 m this replaced, bit for bit)
SAME_TIP_LENGTH = 0.4
#: rows solved per call (progress and Ctrl-C between blocks)
BLOCK = 512
#: warm-started samples also solved along the loading path, by default
CHECK = 1000
#: which equilibria a region holds: ``"continuation"`` those the robot reaches from rest by quasi-static tension
#: paths (each sample continued from a solved parent), ``"loading-path"`` each tension vector's equilibrium
#: reached from rest with every load ramped together (the paper's)
EQUILIBRIA = ("continuation", "loading-path")
#: the parent of a sample continued from the root: zero tension under the load, solved from rest
ROOT = -1
#: the size of the first wave of continued samples (each wave doubles the samples solved before it)
FIRST_WAVE = 32


@dataclass(frozen=True)
class WarmStarts:
    """How :func:`solve_plan` uses warm starts from solved neighbours.

    Attributes
    ----------
    check : int
        Warm-started samples also solved along the loading path before warm starts are used, >= 0 (0: none
        checked, so none used).
    seed : int
        Seed of the checked random subset, >= 0.
    """

    check: int = CHECK
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "check", check_count(self.check, "check", lo=0))
        object.__setattr__(self, "seed", check_count(self.seed, "seed", lo=0))


@dataclass(frozen=True)
class WarmStartCheck:
    """How the samples were solved: warm starts from solved neighbours, checked on a random subset.

    Attributes
    ----------
    mode : str
        ``"warm"`` (the check passed), ``"loading path"`` (it failed, or warm starts were off: every sample
        followed the loading path from the unloaded robot).
    anchors : int
        Samples solved along the loading path to serve as neighbours.
    checked : int
        Warm-started samples also solved along the loading path.
    agreed : int
        Of those, how many reached the same equilibrium (tips within :func:`same_tip`, 1e-6 m per 0.4 m of the
        robot's length, or neither converged).
    seconds_warm, seconds_cold : float
        Wall time of the checked subset warm and cold [s].
    """

    mode: str
    anchors: int = 0
    checked: int = 0
    agreed: int = 0
    seconds_warm: float = 0.0
    seconds_cold: float = 0.0

    @property
    def agreement(self) -> float | None:
        """agreed / checked (None when nothing was checked)."""
        return self.agreed / self.checked if self.checked else None

    @property
    def required(self) -> float:
        """The agreement the check requires (:data:`AGREEMENT_REQUIRED`)."""
        return AGREEMENT_REQUIRED

    def to_dict(self) -> JsonDict:
        """JSON-ready form, with the required agreement."""
        return {"mode": self.mode, "anchors": self.anchors, "checked": self.checked, "agreed": self.agreed,
                "agreement": self.agreement, "required": self.required,
                "seconds_warm": self.seconds_warm, "seconds_cold": self.seconds_cold}

    @classmethod
    def from_dict(cls, d: JsonObject) -> WarmStartCheck:
        """The check :meth:`to_dict` wrote (``agreement`` and ``required`` are derived; times absent from a record
        with its times dropped read 0); KeyError naming a missing key."""
        return cls(d["mode"], d["anchors"], d["checked"], d["agreed"], d.get("seconds_warm", 0.0),
                   d.get("seconds_cold", 0.0))


@dataclass(frozen=True, eq=False)
class SolvedRows:
    """What a region keeps of M solved tension vectors (not their shapes), row by row.

    Attributes
    ----------
    tip_position : ndarray, shape (M, 3)
        Tip position [m] (NaN where not converged).
    converged : ndarray of bool, shape (M,)
    stable : ndarray, shape (M,)
        1.0 stable, 0.0 unstable, NaN not converged or untested.
    q : ndarray, shape (M, ...)
        The model's unknowns (NaN where not converged).
    curvature : ndarray, shape (M,)
        The largest bending curvature of any subsegment [1/m] (NaN where not converged).
    plain : ndarray of bool, shape (M,)
        Reached along the loading path without a fold (a warm start may come from it).
    residual, atol : ndarray, shape (M,)
        Each solve's max |residual| and the tolerance it was judged by [N m].
    at_fold : ndarray of bool, shape (M,)
        The solve stopped at a fold (a continuation told to stop there).
    below_base, disks_touch : ndarray of bool, shape (M,)
        A disk below the base plane; two disks that are not neighbours intersecting (converged rows only).
    """

    tip_position: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    q: np.ndarray
    curvature: np.ndarray
    plain: np.ndarray
    residual: np.ndarray
    at_fold: np.ndarray
    atol: np.ndarray
    below_base: np.ndarray
    disks_touch: np.ndarray

    @classmethod
    def concatenated(cls, parts: Sequence[SolvedRows]) -> SolvedRows:
        """The rows of ``parts``, one after the other."""
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)))

    def take(self, rows: np.ndarray | slice) -> SolvedRows:
        """The rows ``rows`` (indices, a mask or a slice)."""
        return SolvedRows(*(getattr(self, f.name)[rows] for f in fields(self)))

    def blank_rows(self, count: int) -> SolvedRows:
        """``count`` unsolved rows shaped like these: NaN, False or 0 (:func:`_blank`)."""
        return SolvedRows(*(np.full((count, *a.shape[1:]), _blank(a.dtype), dtype=a.dtype)
                            for a in (getattr(self, f.name) for f in fields(self))))

    def put(self, rows: np.ndarray | slice, other: SolvedRows) -> None:
        """Write ``other``'s rows into these at ``rows`` (in place: the arrays are this object's own)."""
        for f in fields(self):
            getattr(self, f.name)[rows] = getattr(other, f.name)


#: the fields of :class:`RegionSamples` that hold one entry per row
_ROW_FIELDS = ("tensions", "source", "tip_position", "converged", "stable", "below_base", "disks_touch", "q",
               "stage", "curvature", "residual", "atol")


@dataclass(frozen=True, eq=False)
class RegionSamples:
    """Solved tension vectors of a workspace study and what each equilibrium is.

    Attributes
    ----------
    tensions : ndarray, shape (M, n_tendons)
        The actuator tensions solved [N], one row per sample (not the per-piece tensions of
        :attr:`pytdcr.StaticSolution.tensions`, shape (n_tendons, N)).
    source : ndarray of int8, shape (M,)
        Where each comes from (:attr:`SOURCES`).
    tip_position : ndarray, shape (M, 3)
        Tip position [m]; NaN where not converged.
    converged : ndarray of bool, shape (M,)
    stable : ndarray, shape (M,)
        1.0 stable, 0.0 unstable, NaN not converged or untested (a model without the test).
    below_base : ndarray of bool, shape (M,)
        A disk reaches below the base plane z = 0.
    disks_touch : ndarray of bool, shape (M,)
        Two disks that are not neighbours intersect (:func:`pytdcr.contact.disks_touch`).
    n_base : int
        The first ``n_base`` rows are the Sobol points.
    warm : WarmStartCheck
    seconds : float
    q : ndarray, shape (M, ...), or None
        The model's unknowns at each equilibrium (NaN where not converged), for warm starts and gradients.
    stage : ndarray of int8, shape (M,), or None
        The nested sample size from which each row counts: 0 at n/4 base samples (the first quarter of the
        Sobol points, the box's corners and edges, the boundary search from them), 1 at n/2, 2 at n.
    curvature : ndarray, shape (M,), or None
        The largest bending curvature of any subsegment [1/m] (:func:`pytdcr.contact.bending_curvature`); NaN
        where not converged. The backbone's peak bending stress is ``E * curvature * outer radius``.
    parent : ndarray of int64, shape (M,), or None
        Continued samples (:data:`EQUILIBRIA` ``"continuation"``): the row each was continued from along the
        straight segment in tension space, :data:`ROOT` (-1) for the root (zero tension, solved from rest);
        None for samples each solved from rest.
    residual, atol : ndarray, shape (M,), or None
        Each solve's max |residual| and the tolerance it was judged by [N m] (what a continuation from the
        sample checks).
    root : str or None
        Continued samples: the root (zero tension under the load, solved from rest): ``"stable"``,
        ``"unstable"`` (an axial load past buckling), ``"stability untested"`` (converged, by a model without
        the stability test: continued from as if stable) or ``"not converged"``; when it is unstable or not
        converged no sample has a parent and none is solved. None for samples each solved from rest.
    SOURCES : tuple of str
        (class attribute) The names of the ``source`` codes, by code.
    """

    SOURCES: ClassVar[tuple[str, ...]] = SOURCES
    tensions: np.ndarray
    source: np.ndarray
    tip_position: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    below_base: np.ndarray
    disks_touch: np.ndarray
    n_base: int
    warm: WarmStartCheck = field(default_factory=lambda: WarmStartCheck("loading path"))
    seconds: float = 0.0
    q: np.ndarray | None = None
    stage: np.ndarray | None = None
    curvature: np.ndarray | None = None
    parent: np.ndarray | None = None
    residual: np.ndarray | None = None
    atol: np.ndarray | None = None
    root: str | None = None

    @property
    def feasible(self) -> np.ndarray:
        """The paper's FSW: converged and not unstable, shape (M,) of bool. For a model without the stability
        test every converged sample (untested: :func:`pytdcr.statics.feasible_words` says so wherever it is
        reported)."""
        return self.converged & (self.stable != 0.0)

    @property
    def realisable(self) -> np.ndarray:
        """Feasible, no disk below the base plane, no disks touching, shape (M,) of bool."""
        return self.feasible & ~self.below_base & ~self.disks_touch

    def take(self, rows: np.ndarray) -> RegionSamples:
        """The samples at ``rows`` (indices or a mask); ``n_base`` counts the Sobol rows kept. Parents are
        renumbered to the rows kept; a parent left out becomes -2 (the path cannot be replayed from the subset)."""
        idx = np.arange(self.source.size)[rows]
        parent = None
        if self.parent is not None:
            where = np.full(self.source.size, -2, dtype=np.int64)
            where[idx] = np.arange(idx.size)
            p = self.parent[idx]
            parent = np.where(p >= 0, where[np.maximum(p, 0)], p)

        def pick(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[idx]

        kept = {name: pick(getattr(self, name)) for name in _ROW_FIELDS}
        return replace(self, **kept, n_base=int(np.sum(self.source[idx] == 0)), parent=parent)

    def joined(self, other: RegionSamples) -> RegionSamples:
        """These samples followed by ``other``'s (unknowns, stages, parents and residuals kept when both have
        them; ``other``'s parents number the rows of the joined samples)."""

        def cat(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
            return np.concatenate([a, b]) if a is not None and b is not None else None

        both = {name: cat(getattr(self, name), getattr(other, name)) for name in (*_ROW_FIELDS, "parent")}
        return replace(self, **both, n_base=self.n_base + other.n_base, seconds=self.seconds + other.seconds)

    @classmethod
    def of(cls, tensions: np.ndarray, source: np.ndarray, got: SolvedRows, n_base: int, stage: np.ndarray, *,
           warm: WarmStartCheck, seconds: float) -> RegionSamples:
        """The samples of ``tensions`` (M, n_tendons) [N] with their ``source`` codes (M,), solved as ``got``
        holds, the first ``n_base`` rows the Sobol points, each counting from the nested size ``stage`` (M,);
        ``warm`` the warm-start check, ``seconds`` the wall time [s]. Parents and the root are set apart
        (``dataclasses.replace``) where the samples are continued."""
        return cls(tensions, source, got.tip_position, got.converged, got.stable, got.below_base, got.disks_touch,
                   n_base, warm, seconds, got.q, stage, got.curvature, None, got.residual, got.atol)

    def start_batch(self, rows: np.ndarray, loads: Loads, model: str) -> BatchSolution:
        """The samples at ``rows`` (indices) as a batch a continuation starts from (``solve_batch(...,
        start=...)``), solved by ``model`` under ``loads`` (their tensions are the rows')."""
        if self.q is None or self.residual is None or self.atol is None:
            raise ValueError("these samples keep no unknowns and residuals: they cannot be continued from")
        idx = np.asarray(rows, dtype=np.int64)
        return _batch_of(self, self.tensions, idx, loads, model)


@dataclass
class _Solver:
    """Solves blocks of tension vectors and keeps what the region needs of each (not the shapes)."""

    robot: Robot
    loads: Loads
    model: Model
    options: ModelOptions
    threads: int | None
    progress: Callable[[int], None] | None
    stability: bool

    def batch(self, tensions: np.ndarray, q0: np.ndarray | None = None, options: ModelOptions | None = None,
              start: BatchSolution | None = None) -> BatchSolution:
        """One solve_batch call on ``tensions`` (B, n_tendons), from rest, warm from ``q0`` or continued from
        ``start``'s rows."""
        return solve_batch(self.robot, tensions, self.loads, model=self.model, options=options or self.options,
                           q0=q0, threads=self.threads, start=start)

    def keep(self, b: BatchSolution) -> SolvedRows:
        """The tips, flags and unknowns of a solved block."""
        r = self.robot.disk_radius
        pos, rot = b.disk_positions, b.disk_rotations
        ok = b.converged
        stable = b.stable if self.stability else np.full(ok.shape, np.nan)
        q = np.array(b.q, dtype=float)
        q[~ok] = np.nan
        kappa = bending_curvature(rot, self.robot.subsegment_lengths).max(axis=1)
        kappa[~ok] = np.nan
        atol = np.full(ok.shape, np.nan) if b.atol is None else np.asarray(b.atol, dtype=float)
        return SolvedRows(b.tip_position, ok, stable, q, kappa, np.asarray(b.path == SolvePath.LOADING, dtype=bool),
                          np.asarray(b.residual, float), np.asarray(b.path == SolvePath.FOLD, dtype=bool), atol,
                          disks_below_base(pos, rot, r) & ok, disks_touch(pos, rot, r) & ok)

    def solve(self, tensions: np.ndarray, q0: np.ndarray | None = None,
              start: BatchSolution | None = None) -> SolvedRows:
        """Every row in blocks, warm from ``q0`` (per row) or continued from ``start`` (its row b to row b of
        ``tensions``) when given."""
        parts = []
        for first in range(0, tensions.shape[0], BLOCK):
            stop = min(first + BLOCK, tensions.shape[0])
            parts.append(self.keep(self.batch(tensions[first:stop], None if q0 is None else q0[first:stop],
                                              start=None if start is None else start.rows(slice(first, stop)))))
            if self.progress is not None:
                self.progress(stop - first)
        if not parts:  # no rows: the same arrays, empty (a search round whose steps all left the box)
            return self.keep(self.batch(tensions, q0))
        return SolvedRows.concatenated(parts)


def same_tip(robot: Robot) -> float:
    """How close two tips of ``robot`` are when they belong to the same equilibrium [m]: :data:`SAME_TIP` per
    :data:`SAME_TIP_LENGTH` of its length (1e-6 m on the paper's 0.4 m robot, 2.5e-9 m on a 1 mm one), so that
    the warm-start check asks the same relative agreement of a robot of any size."""
    return SAME_TIP * (robot.length / SAME_TIP_LENGTH)


def _agree(a: SolvedRows, b: SolvedRows, tol: float) -> np.ndarray:
    """Row by row: the same equilibrium (tips within ``tol`` [m], :func:`same_tip`) or neither converged."""
    same_flag = a.converged == b.converged
    close = np.linalg.norm(np.nan_to_num(a.tip_position - b.tip_position, nan=np.inf), axis=1) <= tol
    return same_flag & (~a.converged | close)


def _warm_from(anchors: SolvedRows, t_anchor: np.ndarray, tensions: np.ndarray,
               bounds: TensionBounds) -> np.ndarray | None:
    """Per row of ``tensions``, the unknowns of the nearest anchor that followed the loading path without a
    fold (in tension space scaled by the bounds' span; ties go to the lower index: deterministic)."""
    usable = anchors.converged & anchors.plain
    if not np.any(usable):
        return None
    scale = bounds.span
    tree = cKDTree(t_anchor[usable] / scale)
    _, idx = tree.query(tensions / scale)
    return np.ascontiguousarray(anchors.q[usable][idx])


def _warm_starts(warm: bool | WarmStarts) -> WarmStarts | None:
    """``warm`` as :class:`WarmStarts` (True: the defaults), or None for none."""
    if isinstance(warm, WarmStarts):
        return warm
    if not isinstance(warm, (bool, np.bool_)):
        raise TypeError(f"warm must be True, False or a WarmStarts, got {type(warm).__name__}")
    return WarmStarts() if warm else None


def _anchors(plan: TensionPlan, warm: bool) -> int:
    return min(plan.n_base, max(64, plan.n_base // 8)) if warm else plan.tensions.shape[0]


def solves_needed(plan: TensionPlan, warm: bool | WarmStarts = True) -> int:
    """The solves :func:`solve_plan` makes (the checked subset is solved twice), for a progress bar."""
    how = _warm_starts(warm)
    rest = plan.tensions.shape[0] - _anchors(plan, how is not None)
    return plan.tensions.shape[0] + (min(how.check, rest) if how is not None and rest > 0 else 0)


def equilibria_for(model: Model, equilibria: str | None) -> str:
    """The :data:`EQUILIBRIA` a region of ``model`` holds: ``equilibria`` (checked), or by default
    ``"continuation"`` where the model can continue a solved state, else ``"loading-path"``."""
    if equilibria is None:
        return EQUILIBRIA[0] if model.capabilities.continuation else EQUILIBRIA[1]
    if equilibria not in EQUILIBRIA:
        raise SettingsError("equilibria", f" must be one of {', '.join(EQUILIBRIA)}, got {equilibria!r}")
    if equilibria == EQUILIBRIA[0] and not model.capabilities.continuation:
        raise SettingsError("equilibria", f": model '{model.name}' cannot continue a solved state; use "
                            "'loading-path'")
    return equilibria


def _waves(m: int) -> list[tuple[int, int]]:
    """Rows [a, b) solved together: :data:`FIRST_WAVE`, then each wave as many as were solved before it."""
    out, a = [], 0
    while a < m:
        b = min(m, max(a + FIRST_WAVE, 2 * a))
        out.append((a, b))
        a = b
    return out


def _continued(solver: _Solver, T: np.ndarray,
               bounds: TensionBounds) -> tuple[SolvedRows, np.ndarray, str]:
    """Every row of ``T`` (M, n_tendons) continued from a parent (see :func:`continue_plan`); returns what
    :meth:`_Solver.keep` keeps, row by row, the parents (:data:`ROOT` for the root; -2 where there was no
    stable equilibrium to continue from) and the root's state (:attr:`RegionSamples.root`)."""
    nt = T.shape[1]
    root = solver.keep(solver.batch(np.zeros((1, nt))))
    # internal rows: 0 the root, k + 1 the plan's row k
    store = SolvedRows.concatenated([root, root.blank_rows(T.shape[0])])
    tensions = np.concatenate([np.zeros((1, nt)), T])
    parent = np.full(T.shape[0], -2, dtype=np.int64)
    usable = np.zeros(T.shape[0] + 1, dtype=bool)
    usable[0] = bool(root.converged[0] and root.stable[0] != 0.0)
    scale = bounds.span
    for a, b in _waves(T.shape[0]):
        pool = np.flatnonzero(usable)
        if pool.size == 0:
            if solver.progress is not None:
                solver.progress(b - a)
            continue
        _, near = cKDTree(tensions[pool] / scale).query(T[a:b] / scale)
        p = pool[near]
        start = _batch_of(store, tensions, p, solver.loads, solver.model.name)
        got = solver.solve(T[a:b], start=start)
        store.put(slice(a + 1, b + 1), got)
        parent[a:b] = p - 1
        usable[a + 1:b + 1] = got.converged & (got.stable != 0.0)
    state = ("not converged" if not root.converged[0] else "unstable" if not usable[0]
             else "stable" if root.stable[0] == 1.0 else "stability untested")
    return store.take(slice(1, None)), parent, state


def _blank(dtype: np.dtype) -> float | int | bool:
    """What an unsolved row holds: NaN, False or 0."""
    if np.issubdtype(dtype, np.floating):
        return np.nan
    return False if np.issubdtype(dtype, np.bool_) else 0


def _batch_of(store: SolvedRows | RegionSamples, tensions: np.ndarray, rows: np.ndarray, loads: Loads,
              model: str) -> BatchSolution:
    """The solved rows ``rows`` of ``store`` (its converged, residual, q, tip_position and atol, which samples
    kept) at ``tensions``, solved by ``model`` under ``loads``, as a batch to continue from."""
    q, residual, atol = store.q, store.residual, store.atol
    assert q is not None and residual is not None and atol is not None
    return BatchSolution(tensions=tensions[rows], converged=store.converged[rows], residual=residual[rows],
                         iterations=np.zeros(rows.size, dtype=np.int64), q=q[rows],
                         tip_position=store.tip_position[rows], seconds=0.0,
                         path=np.full(rows.size, "", dtype=object), model=model, atol=atol[rows], loads=loads)


def continue_plan(robot: Robot, loads: Loads, plan: TensionPlan, *, model: str | Model = "pcc",
                  options: ModelOptions | None = None, threads: int | None = None,
                  progress: Callable[[int], None] | None = None) -> RegionSamples:
    """Solve every tension vector of ``plan`` under ``loads`` as the robot reaches it from rest by quasi-static
    tension changes (:data:`EQUILIBRIA` ``"continuation"``), and test each equilibrium.

    The root, zero tension under the load, is solved from rest (every load ramped together); the plan's rows are
    then solved in waves (:data:`FIRST_WAVE` rows, then each wave as many as were solved before it), each row
    continued from its parent, the nearest stable equilibrium solved in an earlier wave or the root (in tension
    space scaled by the bounds' span; ties to the lower row), along the straight segment between their
    tensions (following the branch, snapping where it folds). ``parent`` records it, so that any row can be
    replayed; waves and parents do not depend on ``threads``, nor do the results. ``progress`` is advanced by
    the rows solved. The model must continue solved states (:func:`equilibria_for`).
    """
    m, opts = resolve(model, robot, loads, options, continuation=True)
    solver = _plan_solver(robot, loads, plan, m, opts, threads, progress)
    t0 = time.perf_counter()
    got, parent, root = _continued(solver, plan.tensions, plan.bounds)
    samples = RegionSamples.of(plan.tensions, plan.source, got, plan.n_base, plan_stages(plan),
                               warm=WarmStartCheck("continuation"), seconds=time.perf_counter() - t0)
    return replace(samples, parent=parent, root=root)


def _plan_solver(robot: Robot, loads: Loads, plan: TensionPlan, m: Model, opts: ModelOptions, threads: int | None,
                 progress: Callable[[int], None] | None) -> _Solver:
    """The solver of a plan's rows, once the memory they keep is checked."""
    res = check_resources(m, robot, opts)
    per_row = 8.0 * ((res.unknowns if res else 3 * robot.n_disks) + robot.n_tendons + 18)
    check_memory(f"a workspace study of {plan.tensions.shape[0]:,} tension vectors on robot '{robot.name}'",
                 plan.tensions.shape[0] * per_row, f"{per_row:.0f} bytes per sample kept")
    stability = bool(getattr(m, "capabilities", None) and m.capabilities.stability)
    return _Solver(robot, loads.with_tensions(np.zeros(robot.n_tendons)), m, opts, threads, progress, stability)


def solve_plan(robot: Robot, loads: Loads, plan: TensionPlan, *, model: str | Model = "pcc",
               options: ModelOptions | None = None, threads: int | None = None, warm: bool | WarmStarts = True,
               progress: Callable[[int], None] | None = None) -> RegionSamples:
    """Solve every tension vector of ``plan`` under ``loads`` from rest, every load ramped together (the loading
    path, :data:`EQUILIBRIA` ``"loading-path"``: the paper's), and test each equilibrium (:func:`continue_plan`
    for the equilibria the robot reaches by its own history of tension changes).

    With ``warm`` (True, or :class:`WarmStarts` for its check), an eighth of the Sobol
    points (at least 64) are solved along the loading path first; the rest start from the nearest of them (in
    tension space scaled by the plan's bounds) that reached its equilibrium without a fold. Before they are
    used, a random subset of ``warm.check`` warm-started samples (``warm.seed``) is solved both ways: warm
    starts are kept only if at least :data:`AGREEMENT_REQUIRED` of them agree, otherwise every sample follows
    the loading path. Without ``warm``, every sample follows the loading path. Neighbours and the subset do not
    depend on ``threads``, so neither do the results. ``progress`` is advanced by the solves done
    (:func:`solves_needed` in all).
    """
    how = _warm_starts(warm)
    m, opts = resolve(model, robot, loads, options)
    solver = _plan_solver(robot, loads, plan, m, opts, threads, progress)
    T = plan.tensions
    t0 = time.perf_counter()
    n_anchor = _anchors(plan, how is not None)
    anchors = solver.solve(T[:n_anchor])
    rest = T[n_anchor:]
    report = WarmStartCheck("loading path", anchors=n_anchor if how is not None else 0)
    if how is not None and rest.shape[0]:
        q0 = _warm_from(anchors, T[:n_anchor], rest, plan.bounds)
        out, report = _checked(solver, rest, q0, how.check, how.seed, n_anchor)
    else:
        out = solver.solve(rest) if rest.shape[0] else None
    got = SolvedRows.concatenated([anchors, out]) if out is not None else anchors
    return RegionSamples.of(T, plan.source, got, plan.n_base, plan_stages(plan), warm=report,
                            seconds=time.perf_counter() - t0)


def plan_stages(plan: TensionPlan) -> np.ndarray:
    """Per row of ``plan``, the nested sample size from which it counts (:attr:`RegionSamples.stage`)."""
    k = np.arange(plan.tensions.shape[0])
    sobol = plan.source == 0
    stage = np.zeros(k.size, dtype=np.int8)
    stage[sobol & (k >= max(1, plan.n_base // 4))] = 1
    stage[sobol & (k >= max(1, plan.n_base // 2))] = 2
    return stage


def _checked(solver: _Solver, rest: np.ndarray, q0: np.ndarray | None, check: int, seed: int,
             n_anchor: int) -> tuple[SolvedRows, WarmStartCheck]:
    """Warm-solve ``rest`` if a checked subset agrees with the loading path, else solve it along that path."""
    if q0 is None or check == 0:
        return solver.solve(rest), WarmStartCheck("loading path", anchors=n_anchor)
    rng = np.random.default_rng([seed, 1])
    sub = np.sort(rng.choice(rest.shape[0], min(check, rest.shape[0]), replace=False))
    t0 = time.perf_counter()
    warm_sub = solver.solve(rest[sub], q0[sub])
    t1 = time.perf_counter()
    cold_sub = solver.solve(rest[sub])
    t2 = time.perf_counter()
    agreed = int(np.sum(_agree(warm_sub, cold_sub, same_tip(solver.robot))))
    passed = agreed >= AGREEMENT_REQUIRED * sub.size
    report = WarmStartCheck("warm" if passed else "loading path", n_anchor, int(sub.size), agreed, t1 - t0, t2 - t1)
    others = np.setdiff1d(np.arange(rest.shape[0]), sub)
    out_others = solver.solve(rest[others], q0[others] if passed else None)
    out = cold_sub.blank_rows(rest.shape[0])
    out.put(sub, cold_sub)
    if others.size:
        out.put(others, out_others)
    return out, report

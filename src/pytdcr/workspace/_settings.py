"""What a workspace study is asked to do: one frozen settings object holding every default, range and unit, and
the callbacks that watch it."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..limits import ResourceLimitError, check_memory
from ..validate import SettingsError, check_count, show, unit_vectors
from ._frontier import FOLD_RULES
from ._solve import EQUILIBRIA, equilibria_for
from ._support import fibonacci_directions

if TYPE_CHECKING:
    from ..robot import Robot
    from ..statics import Model
    from ._frontier import SearchRound
    from ._solve import RegionSamples

__all__ = ["MAX_DIRECTIONS", "MIN_VOXEL", "MULTISTABILITY_CHECK", "REACH_RULES", "SEARCH_SOLVES_PER_SAMPLE",
           "VOXELS_PER_LENGTH", "Progress", "WorkspaceHooks", "WorkspaceSettings", "search_budget"]

#: voxels per robot length by default (12.5 mm for the paper robot's 0.4 m)
VOXELS_PER_LENGTH = 32
#: the smallest voxel edge [m]
MIN_VOXEL = 1e-4
#: the boundary search's default budget of solves, per base sample
SEARCH_SOLVES_PER_SAMPLE = 25
#: the most directions of the support function
MAX_DIRECTIONS = 100_000
#: how the largest reach is chosen (:attr:`WorkspaceSettings.reach`)
REACH_RULES = ("search", "farthest", "support", "samples")
#: samples of a region also solved the other way to measure its multistability, by default
MULTISTABILITY_CHECK = 200

#: ``progress(stage, total)`` returns a callable advanced by the work done (total None: unknown)
Progress = Callable[[str, "int | None"], Callable[[int], None]]


#: bytes per voxel of the largest grid a workspace study holds at once: the occupancy (1), its float copy for
#: marching cubes (4), the boundary and closing masks (2) and marching cubes' own work (about 5)
GRID_BYTES_PER_VOXEL = 12.0


def grid_cells(robot: Robot, voxel: float) -> float:
    """Voxels of the largest grid a workspace of ``robot`` can need at edge ``voxel`` [m]: the cube around the
    ball of the robot's length (no tip lies farther from the base), with a voxel of margin on each side."""
    return (2.0 * robot.length / voxel + 3.0) ** 3


def grid_bytes(robot: Robot, voxel: float) -> float:
    """The memory of that grid and its work [bytes] (:data:`GRID_BYTES_PER_VOXEL` a voxel)."""
    return GRID_BYTES_PER_VOXEL * grid_cells(robot, voxel)


def search_budget(n: int) -> int:
    """The boundary search's default budget of solves for ``n`` base samples (25 n)."""
    return SEARCH_SOLVES_PER_SAMPLE * int(n)


def _real(value: object, name: str) -> float:
    if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a real number, got {show(value)} ({type(value).__name__})")
    return float(value)


def _flag(value: object, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {show(value)} ({type(value).__name__})")
    return bool(value)


def _directions(value: object) -> int | tuple[tuple[float, float, float], ...]:
    """A count of Fibonacci directions in [0, MAX_DIRECTIONS], or K >= 1 finite nonzero 3-vectors as tuples
    (of any scale, not all components subnormal: :func:`~pytdcr.validate.unit_vectors`)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
        if not 0 <= value <= MAX_DIRECTIONS:
            raise SettingsError("directions", f" = {value}: must be an integer in [0, {MAX_DIRECTIONS:,}]")
        return int(value)
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"directions must be a count or (K, 3) vectors, got {show(value)} ({type(value).__name__})")
    d = np.asarray(value, dtype=float)
    if d.ndim != 2 or d.shape[1] != 3 or not 1 <= d.shape[0] <= MAX_DIRECTIONS:
        raise SettingsError("directions", f" must have shape (K, 3), 1 <= K <= {MAX_DIRECTIONS}, got {d.shape}")
    if not (np.all(np.isfinite(d)) and np.all(np.any(d, axis=1))):
        raise SettingsError("directions", " must be finite and nonzero")
    unit_vectors(d, "directions")  # any scale is a direction; all-subnormal rows are refused (they have none)
    return tuple((float(x), float(y), float(z)) for x, y, z in d)


@dataclass(frozen=True)
class WorkspaceSettings:
    """What a workspace study (:func:`pytdcr.workspace.workspace_study`) computes, checked when made.

    Attributes
    ----------
    n : int
        Base (scrambled Sobol) samples, >= 1; the box's corners and edges come on top (at most as many).
    seed : int
        Seed of the Sobol points, of the checked warm starts and of the boundary search, >= 0.
    voxel : float or None
        Voxel edge [m], in [0.0001, the robot's length] (:meth:`check`); None: the robot's length / 32
        (:data:`VOXELS_PER_LENGTH`, 12.5 mm for the paper's robot).
    warm : bool
        Warm starts from solved neighbours, used only when a checked subset agrees with the loading path.
    search : bool
        Run the boundary search (without it the region is that of the samples alone).
    budget : int or None
        The boundary search's budget of solves, >= 0; None: 25 n (:func:`search_budget`).
    tol : float
        The boundary search stops when a round adds less than this share of the voxels, in [0, 1].
    directions : int or tuple of (float, float, float)
        The support function h(d): a count of directions on a Fibonacci sphere in [0, 100000] (0: no h(d)),
        or the directions themselves (K, 3), any length (normalised when used).
    reach : str
        How the largest reach is found (:data:`REACH_RULES`):

        - ``"search"``: the reach search (``largest_reach``) from the farthest feasible
          samples, with more starts from the support function's farthest tips (``tdcr workspace``);
        - ``"farthest"``: the farthest of the reach search, the support function's tips and the samples
          (a design study with ``budget.reach_search``);
        - ``"support"``: no reach search, the farther of the support function's farthest tip and the farthest
          sample (a design study without it);
        - ``"samples"``: no search, the farthest feasible sample (``tdcr reproduce`` without directions).

        Every rule falls back to the farthest feasible sample when the model has no tip gradient, and to none
        when no sample is feasible.
    threads : int or None
        Threads of the solves and searches, >= 1 (default: the cores this process may use); the results do not
        depend on them.
    equilibria : str or None
        Which equilibrium of a tension vector the region holds (:data:`pytdcr.workspace.EQUILIBRIA`):
        ``"continuation"``, the one the robot reaches from rest by quasi-static tension changes (each sample
        continued from a solved parent; the boundary search's steps from the samples they step from), or
        ``"loading-path"``, each tension vector solved from rest with every load ramped together (the paper's).
        None (default): ``"continuation"`` where the model can continue a solved state, else ``"loading-path"``.
        ``warm`` applies to ``"loading-path"`` only.
    multistability : int
        Samples of the region also solved the other way (from rest along the loading path for a continued
        region; continued from the root for a loading-path one) to measure how often the equilibrium depends
        on the history, in [0, 100000] (0: not measured; fewer when the region has fewer).
    folds : str
        What a boundary-search step does where its continuation meets a fold (:data:`pytdcr.workspace.FOLD_RULES`):
        ``"snap"`` (default) through to the equilibrium past it, kept as a sample; ``"stop"`` there, keeping
        nothing: the region then grows only along paths without a snap from its samples (which may have snapped),
        at about half the search's cost (docs/workspace.md gives the measured difference). Models without the
        choice snap.
    """

    n: int = 4000
    seed: int = 0
    voxel: float | None = None
    warm: bool = True
    search: bool = True
    budget: int | None = None
    tol: float = 0.002
    directions: int | tuple[tuple[float, float, float], ...] = 200
    reach: str = "search"
    threads: int | None = None
    equilibria: str | None = None
    multistability: int = MULTISTABILITY_CHECK
    folds: str = FOLD_RULES[0]

    #: the equilibria a region can hold (``equilibria``): ``"continuation"``, ``"loading-path"``
    EQUILIBRIA: ClassVar[tuple[str, ...]] = EQUILIBRIA
    #: what a boundary-search step can do at a fold (``folds``): ``"snap"`` through it, ``"stop"`` there
    FOLD_RULES: ClassVar[tuple[str, ...]] = FOLD_RULES
    #: the rules of the largest reach (``reach``)
    REACH_RULES: ClassVar[tuple[str, ...]] = REACH_RULES

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "n", check_count(self.n, "n", lo=1))
        put(self, "seed", check_count(self.seed, "seed", lo=0))
        if self.voxel is not None:  # its range depends on the robot: check()
            put(self, "voxel", _real(self.voxel, "voxel"))
        put(self, "warm", _flag(self.warm, "warm"))
        put(self, "search", _flag(self.search, "search"))
        if self.budget is not None:
            put(self, "budget", check_count(self.budget, "budget", lo=0))
        tol = _real(self.tol, "tol")
        if not (math.isfinite(tol) and 0.0 <= tol <= 1.0):
            raise SettingsError("tol", f" = {tol:g}: must be in [0, 1] (a share of the region's voxels)")
        put(self, "tol", tol)
        put(self, "directions", _directions(self.directions))
        if self.reach not in REACH_RULES:
            raise SettingsError("reach",
                                f" = {show(self.reach)}: must be one of {', '.join(map(repr, REACH_RULES))}")
        if self.threads is not None:
            put(self, "threads", check_count(self.threads, "threads", lo=1))
        if self.equilibria is not None and self.equilibria not in EQUILIBRIA:
            raise SettingsError("equilibria", f" = {show(self.equilibria)}: must be one of "
                                f"{', '.join(map(repr, EQUILIBRIA))} or None (continuation where the model can)")
        put(self, "multistability", check_count(self.multistability, "multistability", lo=0, hi=100_000))
        if self.folds not in FOLD_RULES:
            raise SettingsError("folds", f" = {show(self.folds)}: must be one of {', '.join(map(repr, FOLD_RULES))}")

    def equilibria_of(self, model: Model) -> str:
        """The equilibria a region of ``model`` holds under these settings: :attr:`equilibria` when given
        (``"continuation"`` needs a model that continues a solved state: else SettingsError naming
        ``equilibria``), else ``"continuation"`` where ``model`` can, ``"loading-path"`` otherwise."""
        return equilibria_for(model, self.equilibria)

    def check(self, robot: Robot) -> WorkspaceSettings:
        """These settings if they suit ``robot``, before any work: the voxel lies in [0.0001, the robot's length]
        m, and the voxel grid fits the memory budget (:func:`grid_bytes`; ValueError naming ``voxel``)."""
        v = self.voxel
        if v is not None and not (MIN_VOXEL <= v <= robot.length):
            raise SettingsError("voxel",
                                f" = {v:g}: must be in [{MIN_VOXEL:g}, {robot.length:g}] m (the robot's length)")
        voxel = self.voxel_for(robot)
        cells = grid_cells(robot, voxel)
        try:
            check_memory(f"a grid of {cells:,.0f} voxels of {voxel * 1e3:g} mm", grid_bytes(robot, voxel),
                         "the tips lie within a ball of the robot's length")
        except ResourceLimitError as err:
            raise SettingsError("voxel", f" = {voxel:g}: {err}") from None
        return self

    def voxel_for(self, robot: Robot) -> float:
        """The voxel edge [m] on ``robot``: :attr:`voxel`, or the robot's length / :data:`VOXELS_PER_LENGTH`."""
        return float(self.voxel) if self.voxel is not None else robot.length / VOXELS_PER_LENGTH

    def with_voxel_for(self, robot: Robot) -> WorkspaceSettings:
        """These settings with the voxel fixed at :meth:`voxel_for` ``robot``: one grid for several robots (the
        load cases of a comparison, the designs of a study)."""
        return replace(self, voxel=self.voxel_for(robot))

    @property
    def search_budget(self) -> int:
        """The boundary search's budget of solves: :attr:`budget`, or 25 n."""
        return search_budget(self.n) if self.budget is None else self.budget

    @property
    def direction_count(self) -> int:
        """The number of support-function directions (0: none)."""
        return self.directions if isinstance(self.directions, int) else len(self.directions)

    def direction_vectors(self) -> np.ndarray | None:
        """The support function's unit directions, shape (K, 3) (the Fibonacci sphere's, or those given,
        normalised), or None for none."""
        d = self.directions
        if isinstance(d, int):
            return fibonacci_directions(d) if d else None
        return unit_vectors(np.array(d, dtype=float), "directions")


@dataclass(frozen=True)
class WorkspaceHooks:
    """Callbacks that watch a workspace study (each optional).

    Attributes
    ----------
    progress : callable or None
        ``progress(stage, total)`` returns a callable advanced by the work done in that stage (the solves of the
        sampling and of the boundary search, the directions of h(d)); ``total`` is None when unknown.
    on_round : callable or None
        Sees each round of the boundary search (:class:`pytdcr.workspace.SearchRound`).
    checkpoint : callable or None
        Sees the samples solved so far (:class:`pytdcr.workspace.RegionSamples`) after the sampling and after each
        stage of the boundary search: to save them, so that an interrupted study keeps them.
    """

    progress: Progress | None = None
    on_round: Callable[[SearchRound], None] | None = None
    checkpoint: Callable[[RegionSamples], None] | None = None

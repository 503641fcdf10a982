"""The paper's plain random sampling of the feasible static workspace (its Fig. 3(a) and Fig. 4).

:func:`sample_workspace` solves random tension vectors drawn uniformly in the box (:class:`SamplingConfig`) and
returns their tips as :class:`WorkspaceSamples`; the region study (:func:`pytdcr.workspace.workspace_study`)
is the measured alternative: a region with its volume and error.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..bounds import TensionBounds
from ..limits import check_memory
from ..loads import Loads
from ..results import BatchSolution
from ..robot import Robot
from ..statics import Model, check_resources, resolve, solve_batch
from ..validate import check_count

if TYPE_CHECKING:
    from ..statics.options import ModelOptions

__all__ = ["SamplingConfig", "SamplingInterrupted", "WorkspaceSamples", "sample_workspace"]


@dataclass(frozen=True)
class SamplingConfig:
    """How :func:`sample_workspace` runs (none of it changes the results).

    Attributes
    ----------
    threads : int, optional
        Threads of each batch, as for :func:`pytdcr.solve_batch` (default: all cores).
    block : int
        Samples solved per batch, >= 1.
    progress : callable, optional
        Called with the size of each block solved.
    stability : bool
        Test each block's stability as it is solved (else on first use of ``WorkspaceSamples.stable``).
    """

    threads: int | None = None
    block: int = 1000
    progress: Callable[[int], None] | None = None
    stability: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "block", check_count(self.block, "block"))


@dataclass(frozen=True, eq=False)
class WorkspaceSamples:
    """Random tension vectors and the equilibria they reach.

    Attributes
    ----------
    tensions : ndarray, shape (n, n_tendons)
        Actuator tensions [N].
    tip_position : ndarray, shape (n, 3)
        Tip position [m]; NaN where the solve did not converge.
    converged : ndarray of bool, shape (n,)
    residual : ndarray, shape (n,)
        max |residual| [N m].
    q : ndarray
        Unknowns of every solve (meaningful only where converged): PCC (n, N, 3).
    seed : int
    seconds : float
    batches : tuple of BatchSolution
        The blocks the samples were solved in (for the stability test, on demand).
    """

    tensions: np.ndarray
    tip_position: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    q: np.ndarray
    seed: int
    seconds: float
    batches: tuple[BatchSolution, ...] = ()

    @property
    def stable(self) -> np.ndarray:
        """Per sample: 1.0 stable, 0.0 unstable, NaN not converged or untested (computed on first use)."""
        if not self.batches:
            return np.full(self.converged.shape, np.nan)
        return np.concatenate([b.stable for b in self.batches])

    @property
    def reach(self) -> np.ndarray:
        """||tip|| [m], shape (n,); NaN where not converged."""
        return np.linalg.norm(self.tip_position, axis=1)


class SamplingInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`sample_workspace`: ``samples`` holds the blocks solved before it, ``total`` how many
    were asked for."""

    def __init__(self, samples: WorkspaceSamples, total: int) -> None:
        super().__init__(f"{samples.converged.size} of {total} samples solved")
        self.samples = samples
        self.total = total


def _gather(T: np.ndarray, parts: list[BatchSolution], seed: int, seconds: float) -> WorkspaceSamples:
    n = sum(p.converged.size for p in parts)
    return WorkspaceSamples(
        tensions=T[:n], tip_position=np.concatenate([p.tip_position for p in parts]),
        converged=np.concatenate([p.converged for p in parts]), residual=np.concatenate([p.residual for p in parts]),
        q=np.concatenate([p.q for p in parts]), seed=seed, seconds=seconds, batches=tuple(parts))


def sample_workspace(
    robot: Robot,
    loads: Loads,
    bounds: TensionBounds,
    n: int = 100,
    *,
    seed: int = 0,
    model: str | Model = "pcc",
    options: ModelOptions | None = None,
    config: SamplingConfig | None = None,
) -> WorkspaceSamples:
    """Solve ``n`` random tension vectors drawn uniformly within ``bounds``.

    ``loads`` supplies the external wrenches and friction direction (its
    tensions are ignored). Non-converged samples are kept and flagged.
    ``model`` and ``options`` as for :func:`pytdcr.solve`; ``config``
    (:class:`SamplingConfig`) sets the threads, the blocks the samples are
    solved in (the results do not depend on them), a progress callback and
    whether stability is tested as the blocks are solved. Ctrl-C raises
    :class:`SamplingInterrupted` with the blocks finished so far.
    """
    n = check_count(n, "n")
    cfg = config if config is not None else SamplingConfig()
    if not isinstance(cfg, SamplingConfig):
        raise TypeError(f"config must be a pytdcr.workspace.SamplingConfig, got {type(cfg).__name__}")
    block, progress = cfg.block, cfg.progress
    if not isinstance(bounds, TensionBounds):
        raise TypeError(f"bounds must be a pytdcr.TensionBounds, got {type(bounds).__name__}")
    bounds.check_robot(robot)
    m, opts = resolve(model, robot, loads, options)
    res = check_resources(m, robot, opts)
    per_sample = 8.0 * ((res.unknowns if res else 3 * robot.n_disks) + robot.n_tendons + 12) + 400.0
    check_memory(f"a sample of {int(n):,} tension vectors on robot '{robot.name}'", int(n) * per_sample,
                 f"{per_sample:.0f} bytes per sample kept")
    rng = np.random.default_rng(seed)
    T = bounds.sample(int(n), rng)
    t0 = time.perf_counter()
    parts: list[BatchSolution] = []
    try:
        for start in range(0, int(n), int(block)):
            part = solve_batch(robot, T[start : start + block], loads, model=m, options=opts, threads=cfg.threads)
            if cfg.stability:
                part.stability  # noqa: B018 - computed now, while the block is current
            parts.append(part)
            if progress is not None:
                progress(parts[-1].converged.size)
    except KeyboardInterrupt:
        if parts:
            raise SamplingInterrupted(_gather(T, parts, seed, time.perf_counter() - t0), int(n)) from None
        raise
    return _gather(T, parts, seed, time.perf_counter() - t0)

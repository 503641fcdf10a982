"""Solving the equilibrium equations: damped Newton with an exact Jacobian.

Which equilibrium? A robot under large loads can have several. By default
(``load_stepping="always"``) the solver follows the loading path: every load
(tensions, gravity, external wrenches) is ramped from zero, where the straight
robot is exact, to its full value in adaptive steps, which is the branch that
quasi-static loading reaches. At a fold of that path (a snap-through) it
relaxes to the equilibrium the robot snaps to. Only if that fails does it
settle for any equilibrium at full load (path ``"fallback"``). Each step is a
quasi-Newton iteration with the exact Jacobian, steps limited to
``max_dtheta`` of bend or twist per subsegment and backtracked on the residual
norm. ``"auto"`` tries Newton at full load first (faster, but the branch it
lands on is whichever Newton reaches); a warm start ``q0`` is always followed
directly first.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from ..design import Robot
from ..loads import Loads
from ..results import StaticSolution
from . import _kernels as K
from .cosserat import CosseratModel, CosseratOptions, check_common_options, solve_cosserat
from .model import StaticModel

__all__ = ["MODELS", "BatchSolution", "SolverOptions", "options_for", "solve", "solve_batch", "solve_model",
           "warmup"]

_STEPPING = {"never": 0, "auto": 1, "always": 2}
PATHS = ("direct", "loading", "snap", "fallback")


@dataclass(frozen=True)
class SolverOptions:
    """Options of the static solver.

    Parameters
    ----------
    atol : float
        Converged when max |residual| <= atol [N m].
    max_iter : int
        Newton iterations per attempt (per load step when stepping).
    max_dtheta : float
        Largest change of bend angle or twist of one subsegment per step [rad].
    load_stepping : {'always', 'auto', 'never'}
        'always' (default) follows the loading path from the unloaded robot;
        'auto' tries Newton at full load first and ramps only if it fails;
        'never' is Newton alone.
    """

    atol: float = 1e-9
    max_iter: int = 50
    max_dtheta: float = 0.5
    load_stepping: Literal["always", "auto", "never"] = "always"

    def __post_init__(self) -> None:
        check_common_options(self.atol, self.load_stepping)
        if self.max_iter < 1:
            raise ValueError(f"max_iter must be >= 1, got {self.max_iter}")
        if not (np.isfinite(self.max_dtheta) and self.max_dtheta > 0):
            raise ValueError(f"max_dtheta must be finite and > 0, got {self.max_dtheta}")

    def _kernel(self, warm: bool = False) -> tuple[float, int, float, int]:
        mode = _STEPPING[self.load_stepping]
        if warm and mode == 2:
            mode = 1  # a warm start is followed directly first
        return float(self.atol), int(self.max_iter), float(self.max_dtheta), mode


def _start(model: StaticModel, q0: np.ndarray | None) -> np.ndarray:
    if q0 is None:
        return np.zeros(model.n_unknowns)
    q = np.array(q0, dtype=float).reshape(-1)
    if q.shape != (model.n_unknowns,):
        raise ValueError(f"q0 must have shape ({model.n_unknowns // 3}, 3), got {np.shape(q0)}")
    if not np.all(np.isfinite(q)):
        raise ValueError("q0 must be finite")
    return q


def solve_model(
    model: StaticModel, q0: np.ndarray | None = None, options: SolverOptions | None = None
) -> StaticSolution:
    """Solve a packed :class:`StaticModel`; see :func:`solve`."""
    opts = options or SolverOptions()
    qs = _start(model, q0)
    n = model.sub.shape[0]
    t0 = time.perf_counter()
    work = K.make_work(n, model.holes.shape[0])
    q, ok, res, iters, _nev, steps, path = K.solve_one(qs, *model._args(), *opts._kernel(q0 is not None), work)
    seconds = time.perf_counter() - t0
    pos = np.empty((n + 1, 3))
    rot = np.empty((n + 1, 3, 3))
    K.frames(q, model.sub, pos, rot)
    ok = bool(ok) and bool(np.all(np.isfinite(q)))
    return StaticSolution(
        converged=ok,
        residual=float(res),
        iterations=int(iters),
        load_steps=int(steps),
        path=PATHS[path],
        q=q.reshape(n, 3),
        tensions=model.tensions(q),
        seconds=seconds,
        atol=opts.atol,
        _positions=pos,
        _rotations=rot,
    )


MODELS = ("pcc", "cosserat")


def options_for(model: str, options: SolverOptions | CosseratOptions | None = None
                ) -> SolverOptions | CosseratOptions:
    """``options``, or the default options of ``model`` ('pcc' or 'cosserat') when None."""
    _check_model(model, options)
    if options is not None:
        return options
    return CosseratOptions() if model == "cosserat" else SolverOptions()


def _check_model(model: str, options: SolverOptions | CosseratOptions | None) -> None:
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    want = SolverOptions if model == "pcc" else CosseratOptions
    if options is not None and not isinstance(options, want):
        raise TypeError(f"model {model!r} takes {want.__name__}, got {type(options).__name__}")


def solve(
    robot: Robot,
    loads: Loads,
    *,
    model: str = "pcc",
    q0: np.ndarray | None = None,
    options: SolverOptions | CosseratOptions | None = None,
) -> StaticSolution:
    """Static equilibrium of ``robot`` under ``loads``.

    Parameters
    ----------
    robot : Robot
    loads : Loads
    model : {'pcc', 'cosserat'}
        The paper's piecewise-constant-curvature model (default) or the
        Cosserat rod (:mod:`pytdcr.statics.cosserat`; no friction).
    q0 : array-like, optional
        Warm start: ``solution.q`` of a nearby solve of the same model
        (PCC: (N, 3); Cosserat: (3,)). Default: the straight robot.
    options : SolverOptions (pcc) or CosseratOptions (cosserat), optional

    Returns
    -------
    StaticSolution
        Check ``converged``: a non-converged solution carries its residual and
        refuses to give a shape.
    """
    _check_model(model, options)
    if model == "cosserat":
        return solve_cosserat(CosseratModel.build(robot, loads, options), q0, options)
    return solve_model(StaticModel.build(robot, loads), q0, options)


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """Solutions of many tension vectors under the same external loads.

    Attributes
    ----------
    tensions : ndarray, shape (B, n_tendons)
    converged : ndarray of bool, shape (B,)
    residual : ndarray, shape (B,)
        max |residual| [N m].
    iterations : ndarray of int, shape (B,)
    q : ndarray
        The model's unknowns per case: PCC (B, N, 3), Cosserat (B, 3).
    path : ndarray of str, shape (B,)
        How each equilibrium was reached (see :class:`StaticSolution`).
    tip_position : ndarray, shape (B, 3)
        [m]; NaN where not converged.
    seconds : float
        Wall time of the whole batch [s].
    """

    tensions: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    q: np.ndarray
    tip_position: np.ndarray
    seconds: float
    path: np.ndarray

    @property
    def reach(self) -> np.ndarray:
        """||tip|| [m], shape (B,); NaN where not converged."""
        return np.linalg.norm(self.tip_position, axis=1)


def _batch_cosserat(robot: Robot, T: np.ndarray, base: Loads, q0: np.ndarray | None,
                    options: CosseratOptions | None) -> BatchSolution:
    nb = T.shape[0]
    if q0 is not None:
        Q0 = np.asarray(q0, dtype=float)
        Q0 = np.broadcast_to(Q0.reshape(1, 3), (nb, 3)) if Q0.size == 3 else Q0.reshape(nb, 3)
    model = CosseratModel.build(robot, base, options)
    t0 = time.perf_counter()
    sols = [solve_cosserat(replace(model, packed=replace(model.packed, tension=T[b])),
                           None if q0 is None else Q0[b], options) for b in range(nb)]
    seconds = time.perf_counter() - t0
    ok = np.array([s_.converged for s_ in sols], dtype=bool)
    tips = np.full((nb, 3), np.nan)
    for b in np.flatnonzero(ok):
        tips[b] = sols[b].tip_position
    return BatchSolution(
        tensions=T, converged=ok, residual=np.array([s_.residual for s_ in sols]),
        iterations=np.array([s_.iterations for s_ in sols], dtype=np.int64), q=np.array([s_.q for s_ in sols]),
        tip_position=tips, seconds=seconds, path=np.array([s_.path for s_ in sols], dtype=object),
    )


def solve_batch(
    robot: Robot,
    tensions: np.ndarray,
    loads: Loads | None = None,
    *,
    model: str = "pcc",
    q0: np.ndarray | None = None,
    options: SolverOptions | CosseratOptions | None = None,
) -> BatchSolution:
    """Solve every row of ``tensions`` (B, n_tendons); the PCC model in parallel (all cores).

    ``loads`` gives the external wrenches and friction direction shared by all
    cases (its own tensions are ignored). ``q0`` is one warm start or one per
    case (PCC: (N, 3) or (B, N, 3); Cosserat: (3,) or (B, 3)). ``model`` and
    ``options`` as for :func:`solve`.
    """
    _check_model(model, options)
    T = np.ascontiguousarray(tensions, dtype=float)
    if T.ndim != 2 or T.shape[1] != robot.n_tendons:
        raise ValueError(f"tensions must have shape (B, {robot.n_tendons}), got {T.shape}")
    bad = ~np.isfinite(T) | (T < 0)
    if np.any(bad):
        b, c = np.argwhere(bad)[0]
        raise ValueError(f"tensions[{b}, {c}] must be finite and >= 0 N, got {T[b, c]}")
    base = loads if loads is not None else Loads(tensions=np.zeros(robot.n_tendons))
    if model == "cosserat":
        return _batch_cosserat(robot, T, base.with_tensions(np.zeros(robot.n_tendons)), q0, options)
    opts = options or SolverOptions()
    model = StaticModel.build(robot, base.with_tensions(np.zeros(robot.n_tendons)))
    nb = T.shape[0]
    m = model.n_unknowns
    if q0 is None:
        Q0 = np.zeros((nb, m))
    else:
        Q0 = np.asarray(q0, dtype=float)
        if Q0.size == m:
            Q0 = np.broadcast_to(Q0.reshape(1, m), (nb, m))
        elif Q0.size == nb * m:
            Q0 = Q0.reshape(nb, m)
        else:
            raise ValueError(f"q0 must have shape ({m // 3}, 3) or ({nb}, {m // 3}, 3), got {Q0.shape}")
        if not np.all(np.isfinite(Q0)):
            raise ValueError("q0 must be finite")
        Q0 = np.ascontiguousarray(Q0)
    out_q = np.empty((nb, m))
    out_ok = np.empty(nb, dtype=np.bool_)
    out_res = np.empty(nb)
    out_it = np.empty(nb, dtype=np.int64)
    out_path = np.empty(nb, dtype=np.int64)
    t0 = time.perf_counter()
    K.solve_batch(Q0, model.sub, model.holes, model.anchor, model.fric, T, model.grav, model.pforce,
                  model.pmoment, *opts._kernel(q0 is not None), out_q, out_ok, out_res, out_it, out_path)
    seconds = time.perf_counter() - t0
    n = m // 3
    tips = np.full((nb, 3), np.nan)
    pos = np.empty((n + 1, 3))
    rot = np.empty((n + 1, 3, 3))
    ok = out_ok & np.all(np.isfinite(out_q), axis=1)
    for b in np.flatnonzero(ok):
        K.frames(out_q[b], model.sub, pos, rot)
        tips[b] = pos[-1]
    return BatchSolution(
        tensions=T, converged=ok, residual=out_res, iterations=out_it, q=out_q.reshape(nb, n, 3),
        tip_position=tips, seconds=seconds, path=np.array(PATHS, dtype=object)[out_path],
    )


def _prime() -> None:
    """Load the serial solver kernel before any other (called once, at import).

    Measured with numba 0.68: whether the serial kernel was loaded before the
    parallel batch kernel changes the batch's floating-point results in the
    last bits (the cached parallel code binds to the serial kernel's compiled
    callees when they are already loaded), and under folds such bits can
    decide an equilibrium branch. Loading it first in every process makes a
    run repeat exactly whatever the caller does first.
    """
    from ..design import Backbone, Segment, Tendon

    robot = Robot(backbone=Backbone(youngs_modulus=1e9, poissons_ratio=0.3, outer_radius=1e-3),
                  segments=(Segment(length=0.01, n_disks=1),), tendons=(Tendon(segment=1, radius=2e-3, angle_deg=0),),
                  gravity=(0.0, 0.0, 0.0))
    solve_model(StaticModel.build(robot, Loads(np.zeros(1))))


def warmup() -> float:
    """Compile (or load from the on-disk cache) every kernel; returns the seconds it took."""
    from ..design import rao_robot

    t0 = time.perf_counter()
    robot = rao_robot()
    loads = Loads(np.full(robot.n_tendons, 1.0), tip_force=np.array([0.0, 0.01, 0.0]))
    solve(robot, loads)
    solve_batch(robot, np.ones((2, robot.n_tendons)), loads)
    for ext in (False, True):
        solve(robot, loads, model="cosserat", options=CosseratOptions(shear_extension=ext))
    return time.perf_counter() - t0

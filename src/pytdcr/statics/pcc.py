"""The paper's piecewise-constant-curvature model (MODEL.md) and its solver.

:class:`PCCEquations` packs a robot and its loads into the 3N equilibrium
equations and evaluates them (residual, exact Jacobian, tendon tensions); it
knows nothing of how they are solved. :class:`PCCModel` is the registry's
entry: it solves them (quasi-Newton with an exact Jacobian along the loading
path, see :func:`pytdcr.statics._kernels.solve_one`) for one tension vector
or a batch, and differentiates an equilibrium's tip by the tensions.

Which equilibrium? A robot under large loads can have several. By default
(``load_stepping="always"``) the solver follows the loading path: every load
(tensions, gravity, external wrenches) is ramped from zero, where the straight
robot is exact, to its full value in adaptive steps, which is the branch that
quasi-static loading reaches. At a fold of that path (a snap-through) it
relaxes to the equilibrium the robot snaps to. Only if that fails does it
settle for any equilibrium at full load (path ``"fallback"``). ``"auto"``
tries Newton at full load first (faster, but the branch it lands on is
whichever Newton reaches); a warm start ``q0`` is always followed directly
first.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Literal, NamedTuple

import numpy as np

from ..design import ConstantFriction, ExponentialFriction, NoFriction, Robot
from ..kinematics import tip_jacobian
from ..loads import Loads
from ..results import BatchSolution, StaticSolution
from . import _kernels as K
from ._batch import run_in_chunks
from ._constants import DEFAULT_ATOL, LOAD_STEPPING, PATH_NAMES
from ._options import check_common_options
from .base import Capabilities

__all__ = ["PCC", "Evaluation", "PCCEquations", "PCCModel", "SolverOptions", "friction_params"]


def friction_params(robot: Robot, release: bool) -> np.ndarray:
    """Kernel parameters of the robot's friction law, shape (4,): (code, mu0, decay [1/rad], mode)."""
    law = robot.friction
    mode = -1.0 if release else 1.0
    if isinstance(law, NoFriction):
        return np.array([0.0, 0.0, 0.0, mode])
    if isinstance(law, ConstantFriction):
        return np.array([1.0, law.mu0, 0.0, mode])
    if isinstance(law, ExponentialFriction):
        return np.array([2.0, law.mu0, law.decay_per_deg * 180.0 / np.pi, mode])
    raise TypeError(f"unsupported friction law {type(law).__name__}")  # pragma: no cover


class Evaluation(NamedTuple):
    """One evaluation of the equations: residual (3N,) [N m], Jacobian (3N, 3N) or None, tensions (nt, N) [N]."""

    residual: np.ndarray
    jacobian: np.ndarray | None
    tensions: np.ndarray


@dataclass(frozen=True, eq=False)
class PCCEquations:
    """The 3N equilibrium equations of ``robot`` under ``loads`` (MODEL.md).

    Attributes
    ----------
    robot : Robot
    loads : Loads
    packed : pytdcr.statics._kernels.Packed
        The arrays the kernels take: ``sub`` (N, 5) per subsegment: length [m],
        EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg];
        ``holes`` (n_tendons, 2) hole (x, y) in the disk frame [m]; ``anchor``
        (n_tendons,) 1-based anchor disk; ``fric`` (4,) friction law;
        ``tension`` (n_tendons,) [N]; ``grav`` (3,) [m/s^2]; ``pforce``,
        ``pmoment`` (N, 3) wrench on each disk, base frame [N, N m].
    """

    robot: Robot
    loads: Loads
    packed: K.Packed

    @classmethod
    def build(cls, robot: Robot, loads: Loads) -> PCCEquations:
        """Pack ``robot`` and ``loads``; raises ValueError on a mismatch between them."""
        n = robot.n_disks
        if loads.tensions.shape != (robot.n_tendons,):
            raise ValueError(
                f"tensions must have {robot.n_tendons} entries (one per tendon of robot "
                f"'{robot.name}'), got {loads.tensions.shape[0]}"
            )
        lengths = robot.subsegment_lengths
        bb = robot.backbone
        sub = np.empty((n, 5))
        sub[:, 0] = lengths
        sub[:, 1] = bb.bending_stiffness
        sub[:, 2] = bb.torsional_stiffness
        sub[:, 3] = robot.disk_masses
        sub[:, 4] = bb.mass_per_length * lengths
        pforce = np.zeros((n, 3))
        pmoment = np.zeros((n, 3))
        pforce[n - 1] += loads.tip_force
        pmoment[n - 1] += loads.tip_moment
        for p in loads.point_loads:
            if p.disk > n:
                raise ValueError(f"point load disk must be between 1 and {n}, got {p.disk}")
            pforce[p.disk - 1] += p.force
            pmoment[p.disk - 1] += p.moment
        packed = K.Packed(sub, np.ascontiguousarray(robot.tendon_holes[:, :2]), robot.anchor_disks,
                          friction_params(robot, loads.release), np.array(loads.tensions, dtype=float),
                          np.array(robot.gravity, dtype=float), pforce, pmoment)
        return cls(robot=robot, loads=loads, packed=packed)

    @property
    def n_disks(self) -> int:
        """N."""
        return int(self.packed.sub.shape[0])

    @property
    def n_unknowns(self) -> int:
        """3N."""
        return 3 * self.n_disks

    def with_tensions(self, tensions: np.ndarray) -> PCCEquations:
        """The same equations with other actuator tensions [N], shape (n_tendons,)."""
        return replace(self, packed=self.packed._replace(tension=np.asarray(tensions, dtype=float)))

    def check_q(self, q: np.ndarray, name: str = "q") -> np.ndarray:
        """``q`` as a finite float64 vector (3N,); ValueError naming the expected shape."""
        arr = np.array(q, dtype=float).reshape(-1)
        if arr.shape != (self.n_unknowns,):
            raise ValueError(f"{name} must have {self.n_unknowns} entries (shape ({self.n_disks}, 3)), "
                             f"got shape {np.shape(q)}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite")
        return arr

    def evaluate(self, q: np.ndarray, load_factor: float = 1.0, jacobian: bool = False) -> Evaluation:
        """Residual, optionally the exact Jacobian, and the tendon tensions at ``q`` (3N,) or (N, 3)."""
        q = self.check_q(q)
        m = self.n_unknowns
        r = np.empty(m)
        J = np.empty((m, m)) if jacobian else np.empty((1, 1))
        work = K.make_work(self.n_disks, self.packed.holes.shape[0])
        K.evaluate(q, float(load_factor), self.packed, jacobian, r, J, work)
        tensions = np.ascontiguousarray(work.T[1 : self.n_disks + 1].T)
        return Evaluation(r, J if jacobian else None, tensions)

    def residual(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Equilibrium residual [N m], shape (N, 3): row i in frame i-1.

        Parameters
        ----------
        q : array-like, shape (N, 3) or (3N,)
            (beta, gamma, eps) per subsegment [1/m, 1/m, rad].
        load_factor : float
            Scale on every load (1: the full loads).
        """
        return self.evaluate(q, load_factor).residual.reshape(-1, 3)

    def jacobian(self, q: np.ndarray, load_factor: float = 1.0) -> np.ndarray:
        """Exact Jacobian of the flattened residual, shape (3N, 3N) [N m per unit of q]."""
        return self.evaluate(q, load_factor, jacobian=True).jacobian

    def tensions(self, q: np.ndarray) -> np.ndarray:
        """Tension in every tendon piece [N], shape (n_tendons, N); 0 past the anchor."""
        return self.evaluate(q).tensions


@dataclass(frozen=True)
class SolverOptions:
    """Options of the PCC solver.

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

    atol: float = DEFAULT_ATOL
    max_iter: int = 50
    max_dtheta: float = 0.5
    load_stepping: Literal["always", "auto", "never"] = "always"

    def __post_init__(self) -> None:
        check_common_options(self.atol, self.load_stepping)
        if self.max_iter < 1:
            raise ValueError(f"max_iter must be >= 1, got {self.max_iter}")
        if not (np.isfinite(self.max_dtheta) and self.max_dtheta > 0):
            raise ValueError(f"max_dtheta must be finite and > 0, got {self.max_dtheta}")

    def settings(self, warm: bool = False) -> K.Settings:
        """The kernel's settings; a warm start is followed directly first."""
        mode = LOAD_STEPPING[self.load_stepping]
        if warm and mode == LOAD_STEPPING["always"]:
            mode = LOAD_STEPPING["auto"]
        return K.Settings(float(self.atol), int(self.max_iter), float(self.max_dtheta), mode)


def _start_points(eq: PCCEquations, q0: np.ndarray | None, nb: int) -> np.ndarray:
    """Start points (nb, 3N): zeros, one warm start for all, or one per case (always a fresh, writeable array:
    the kernels are compiled for writeable arrays only)."""
    m = eq.n_unknowns
    if q0 is None:
        return np.zeros((nb, m))
    arr = np.asarray(q0, dtype=float)
    if arr.size == m:
        return np.repeat(eq.check_q(arr, "q0")[None, :], nb, axis=0)
    if arr.size != nb * m:
        raise ValueError(f"q0 must have shape ({eq.n_disks}, 3) or ({nb}, {eq.n_disks}, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("q0 must be finite")
    return np.array(arr.reshape(nb, m), dtype=float, order="C")


class _BatchOut(NamedTuple):
    q: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    load_steps: np.ndarray
    path: np.ndarray


def _solve_rows(eq: PCCEquations, Q0: np.ndarray, T: np.ndarray, settings: K.Settings,
                threads: int | None) -> _BatchOut:
    """Every row of ``T`` (B, nt) from ``Q0`` (B, 3N), in chunks over ``threads`` threads (the GIL released)."""
    nb = T.shape[0]
    out = _BatchOut(np.empty((nb, eq.n_unknowns)), np.empty(nb, dtype=np.bool_), np.empty(nb),
                    np.empty(nb, dtype=np.int64), np.empty(nb, dtype=np.int64), np.empty(nb, dtype=np.int64))

    def chunk(start: int, stop: int) -> None:
        K.solve_range(Q0, eq.packed, T, settings, start, stop, *out)

    run_in_chunks(chunk, nb, threads)
    return out


class PCCModel:
    """The registry's entry for the paper's PCC model (see the module docstring)."""

    name = "pcc"
    description = "the paper's piecewise constant curvature model (first-order balance, MODEL.md)"
    options_type = SolverOptions
    capabilities = Capabilities(friction=True, point_wrenches=True, gradient="exact")
    unknowns = "q: (N, 3), (beta [1/m], gamma [1/m], eps [rad]) per subsegment"
    iteration_unit = "Newton iterations"

    def default_options(self) -> SolverOptions:
        """Default solver options."""
        return SolverOptions()

    def equations(self, robot: Robot, loads: Loads) -> PCCEquations:
        """The packed equations of ``robot`` under ``loads``."""
        return PCCEquations.build(robot, loads)

    def solve(self, robot: Robot, loads: Loads, q0: np.ndarray | None, options: SolverOptions) -> StaticSolution:
        """One equilibrium; see :func:`pytdcr.solve`."""
        eq = self.equations(robot, loads)
        Q0 = _start_points(eq, q0, 1)
        t0 = time.perf_counter()
        out = _solve_rows(eq, Q0, eq.packed.tension[None, :], options.settings(q0 is not None), 1)
        seconds = time.perf_counter() - t0
        return self.solution(eq, out.q[0], bool(out.converged[0]), float(out.residual[0]),
                             int(out.iterations[0]), PATH_NAMES[out.path[0]], seconds, options.atol,
                             int(out.load_steps[0]))

    def solution(self, eq: PCCEquations, q: np.ndarray, converged: bool, residual: float, iterations: int,
                 path: str, seconds: float, atol: float, load_steps: int = 0) -> StaticSolution:
        """Wrap an outcome of the solver as a :class:`StaticSolution`."""
        n = eq.n_disks
        pos = np.empty((n + 1, 3))
        rot = np.empty((n + 1, 3, 3))
        K.frames(q, eq.packed.sub, pos, rot)
        ok = converged and bool(np.all(np.isfinite(q)))
        return StaticSolution(converged=ok, residual=residual, iterations=iterations, load_steps=load_steps,
                              path=path, q=q.reshape(n, 3), tensions=eq.tensions(q), seconds=seconds, atol=atol,
                              _positions=pos, _rotations=rot, model=self.name)

    def solve_batch(self, robot: Robot, tensions: np.ndarray, loads: Loads, q0: np.ndarray | None,
                    options: SolverOptions, threads: int | None = None) -> BatchSolution:
        """Every row of ``tensions`` (B, n_tendons) [N], on ``threads`` threads (default: all cores)."""
        eq = self.equations(robot, loads.with_tensions(np.zeros(robot.n_tendons)))
        nb = tensions.shape[0]
        Q0 = _start_points(eq, q0, nb)
        t0 = time.perf_counter()
        out = _solve_rows(eq, Q0, tensions, options.settings(q0 is not None), threads)
        seconds = time.perf_counter() - t0
        n = eq.n_disks
        tips = np.full((nb, 3), np.nan)
        pos = np.empty((n + 1, 3))
        rot = np.empty((n + 1, 3, 3))
        ok = out.converged & np.all(np.isfinite(out.q), axis=1)
        for b in np.flatnonzero(ok):
            K.frames(out.q[b], eq.packed.sub, pos, rot)
            tips[b] = pos[-1]
        return BatchSolution(tensions=tensions, converged=ok, residual=out.residual, iterations=out.iterations,
                             q=out.q.reshape(nb, n, 3), tip_position=tips, seconds=seconds,
                             path=np.array(PATH_NAMES, dtype=object)[out.path], model=self.name)

    def tip_gradient(self, robot: Robot, loads: Loads, solution: StaticSolution,
                     options: SolverOptions) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (3,) [m] of an equilibrium and its exact derivative by the tensions (3, n_tendons) [m/N].

        Implicit function theorem: ``dq/dT = -J^-1 dr/dT``; the residual is
        affine in the tensions at fixed q, so ``dr/dT_c`` is a difference of
        residuals, and the tip's derivative by q is exact
        (:func:`pytdcr.kinematics.tip_jacobian`).
        """
        eq = self.equations(robot, loads)
        q = eq.check_q(solution.q)
        ev = eq.evaluate(q, jacobian=True)
        nt = robot.n_tendons
        dr = np.empty((q.size, nt))
        for c in range(nt):
            t = eq.packed.tension.copy()
            t[c] += 1.0
            dr[:, c] = eq.with_tensions(t).evaluate(q).residual - ev.residual
        dq = -np.linalg.solve(ev.jacobian, dr)
        return solution.tip_position, tip_jacobian(q, eq.packed.sub) @ dq


#: the registry's instance
PCC = PCCModel()

"""The Python side of the shared compiled solver: what the models it solves (``pcc``, ``pcc2``, ``sscr``) have in
common.

A model here provides its packed equations (:class:`Equations`), which name the compiled functions they are
solved with (:class:`Kernels`): the compiled core's (``pytdcr._core``, C++ built at install: ``pcc`` and ``pcc2``)
or numba's (:mod:`pytdcr.statics.kernels`, compiled at first use: ``sscr``). The base class
:class:`CompiledModel` solves them, one tension vector or a batch (threads over chunks of cases, each by the same
compiled code), wraps the outcome and differentiates the tip by the tensions (implicit function theorem).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple, Protocol, TypeVar

import numpy as np

from ..contact import contact_failure
from ..limits import Resources
from ..loads import Loads
from ..results import BatchSolution, StaticSolution
from ..robot import Robot
from ..runtime import MAX_CHUNK, announce_compiling, check_cancelled, run_in_chunks, single_threaded_blas
from .base import announced, compile_seconds
from .kernels import loading_path as SV
from .kernels.stiffness import jacobian_range, largest_residuals, tip_gradient_range
from .options import (
    FOLDS,
    LOAD_STEPPING,
    SAME_EQUILIBRIUM,
    STEP_CONTINUE,
    SolvePath,
    SolverOptions,
)
from .stability import Stability, conjugate_stiffness, stability_from_eigenvalues, stability_of
from .tolerance import tolerances

if TYPE_CHECKING:
    from types import ModuleType

    from .base import Capabilities

__all__ = ["NUMBA_KERNELS", "CompiledModel", "Equations", "Evaluation", "Kernels", "PackedEquations",
           "kernel_settings"]

#: a packed equation set's own class (what :meth:`PackedEquations.with_tensions` returns)
_P = TypeVar("_P", bound="PackedEquations")


class Evaluation(NamedTuple):
    """One evaluation of the equations: residual (m,) [N m], Jacobian (m, m) or None, tensions (nt, N) [N]."""

    residual: np.ndarray
    jacobian: np.ndarray | None
    tensions: np.ndarray


class Kernels(NamedTuple):
    """The compiled functions that solve and differentiate one kind of packed equations, each taking the equations'
    :attr:`PackedEquations.kernel_model` where numba's take the packed named tuple (same arguments otherwise):
    :func:`pytdcr.statics.kernels.loading_path.solve_range` and :mod:`pytdcr.statics.kernels.stiffness`'s
    ``jacobian_range``, ``largest_residuals`` and ``tip_gradient_range``, or their twins in ``pytdcr._core``."""

    solve_range: Callable[..., None]
    jacobian_range: Callable[..., None]
    largest_residuals: Callable[..., None]
    tip_gradient_range: Callable[..., None]


#: numba's kernels (:mod:`pytdcr.statics.kernels`, compiled at first use), for any packed model registered with
#: the loading-path solver
NUMBA_KERNELS = Kernels(SV.solve_range, jacobian_range, largest_residuals, tip_gradient_range)


class Equations(Protocol):
    """The packed equations of one robot under its loads, for the compiled solver."""

    packed: Any
    kernels: ClassVar[Kernels]

    @property
    def kernel_model(self) -> Any: ...

    @property
    def n_disks(self) -> int: ...

    @property
    def n_unknowns(self) -> int: ...

    def check_q(self, q: np.ndarray, name: str = "q") -> np.ndarray: ...

    def evaluate(self, q: np.ndarray, load_factor: float = 1.0, jacobian: bool = False) -> Evaluation: ...

    def with_tensions(self, tensions: np.ndarray) -> Equations: ...

    def shape(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]: ...

    def tip_jacobian(self, q: np.ndarray) -> np.ndarray: ...


class PackedEquations:
    """What every packed equation set has: counts, a copy with other tensions, the check of its unknowns.

    Subclasses are frozen dataclasses with a ``packed`` named tuple (``sub`` (N, 5), ``tension`` (nt,), ...)
    and set ``per_subsegment``, the unknowns per subsegment.
    """

    per_subsegment: int
    packed: Any
    #: the compiled functions these equations are solved with (numba's unless a subclass names the core's)
    kernels: ClassVar[Kernels] = NUMBA_KERNELS

    @property
    def kernel_model(self) -> Any:
        """What :attr:`kernels` take as the model: the packed named tuple (numba's kernels)."""
        return self.packed

    @property
    def n_disks(self) -> int:
        """N."""
        return int(self.packed.sub.shape[0])

    @property
    def n_unknowns(self) -> int:
        """The unknowns, ``per_subsegment`` * N."""
        return self.per_subsegment * self.n_disks

    def with_tensions(self: _P, tensions: np.ndarray) -> _P:
        """The same equations with other actuator tensions [N], shape (n_tendons,)."""
        return replace(self, packed=self.packed._replace(tension=np.asarray(tensions, dtype=float)))

    def check_q(self, q: np.ndarray, name: str = "q") -> np.ndarray:
        """``q`` as a finite float64 vector (n_unknowns,); ValueError naming the expected shape."""
        arr = np.array(q, dtype=float).reshape(-1)
        if arr.shape != (self.n_unknowns,):
            raise ValueError(f"{name} must have {self.n_unknowns} entries (shape ({self.n_disks}, "
                             f"{self.per_subsegment})), got shape {np.shape(q)}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite")
        return arr



def kernel_settings(options: SolverOptions, warm: bool = False) -> SV.Settings:
    """The compiled solver's settings from ``options``; a warm start is followed directly first."""
    mode = LOAD_STEPPING[options.load_stepping]
    if warm and mode == LOAD_STEPPING["always"]:
        mode = LOAD_STEPPING["auto"]
    return SV.Settings(float(options.atol), int(options.max_iter), float(options.max_dtheta), mode,
                       int(options.step_iter), FOLDS[options.fold], float(options.atol), float(options.step_scale))


def case_tolerances(robot: Robot, loads: Loads, tensions: np.ndarray, atol: float) -> np.ndarray:
    """Each row of ``tensions`` (B, nt) [N]: its convergence and load-step tolerance [N m], shape (B, 2), C-ordered
    (:func:`pytdcr.statics.tolerance.tolerances`)."""
    tol, step = tolerances(robot, loads, tensions, atol)
    return np.ascontiguousarray(np.stack([tol, step], axis=1))


def _start_points(eq: Equations, q0: np.ndarray | None, nb: int) -> np.ndarray:
    """Start points (nb, m): zeros, one warm start for all, or one per case (always a fresh, writeable array:
    the kernels are compiled for writeable arrays only)."""
    m = eq.n_unknowns
    if q0 is None:
        return np.zeros((nb, m))
    arr = np.asarray(q0, dtype=float)
    if arr.size == m:
        return np.repeat(eq.check_q(arr, "q0")[None, :], nb, axis=0)
    if arr.size != nb * m:
        per = m // eq.n_disks
        raise ValueError(f"q0 must have shape ({eq.n_disks}, {per}) or ({nb}, {eq.n_disks}, {per}), got {arr.shape}")
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


def _empty_out(nb: int, m: int) -> _BatchOut:
    return _BatchOut(np.empty((nb, m)), np.empty(nb, dtype=np.bool_), np.empty(nb), np.empty(nb, dtype=np.int64),
                     np.empty(nb, dtype=np.int64), np.empty(nb, dtype=np.int64))


def _solve_rows(eq: Equations, Q0: np.ndarray, T: np.ndarray, settings: SV.Settings, tols: np.ndarray,
                threads: int | None, max_chunk: int = MAX_CHUNK) -> _BatchOut:
    """Every row of ``T`` (B, nt) from ``Q0`` (B, m), each to its tolerances ``tols`` (B, 2) [N m], in chunks of
    at most ``max_chunk`` rows over ``threads`` threads (the GIL released)."""
    out = _empty_out(T.shape[0], eq.n_unknowns)

    def chunk(start: int, stop: int) -> None:
        eq.kernels.solve_range(Q0, eq.kernel_model, eq.kernel_model, T, T, settings, tols, start, stop, *out)

    run_in_chunks(chunk, T.shape[0], threads, max_chunk=max_chunk)
    return out


def _check_in_balance(eq0: Equations, start: BatchSolution, rows: np.ndarray) -> None:
    """Refuse a batch ``start`` whose rows ``rows`` are not equilibria of ``eq0`` (the robot and options of the
    continuation, under the start's loads) at their own tensions: solved for another robot or with other
    options. ValueError naming the first such row."""
    q = np.ascontiguousarray(start.q.reshape(start.q.shape[0], -1), dtype=float)
    atol = start.atol if start.atol is not None else np.zeros(start.q.shape[0])
    res = np.empty(rows.size)
    eq0.kernels.largest_residuals(q, eq0.kernel_model, np.ascontiguousarray(start.tensions, dtype=float), rows, res)
    for b, r in zip(rows, res, strict=True):
        if not r <= SAME_EQUILIBRIUM * max(float(start.residual[b]), float(atol[b])):
            raise ValueError(f"start: row {b} is not an equilibrium of this robot under the loads it carries (max "
                             f"|residual| {r:.3g} N m there, {start.residual[b]:.3g} N m when it was solved): "
                             "continue a batch solved for this robot, model and options")


class _Path(NamedTuple):
    """Continuations along the straight path of the loads: from the equilibria ``Q0`` (B, m) of ``start`` at the
    actuator tensions ``T0`` (B, nt) [N] to ``end`` at ``T1`` (B, nt) [N]."""

    start: Equations
    end: Equations
    Q0: np.ndarray
    T0: np.ndarray
    T1: np.ndarray


def _continue_rows(path: _Path, settings: SV.Settings, tols: np.ndarray, threads: int | None,
                   max_chunk: int = MAX_CHUNK) -> _BatchOut:
    """Every continuation of ``path``, each to its tolerances ``tols`` (B, 2) [N m], in chunks over ``threads``
    threads (:func:`pytdcr.statics.kernels.loading_path.solve_range`)."""
    out = _empty_out(path.T1.shape[0], path.end.n_unknowns)
    settings = settings._replace(stepping=STEP_CONTINUE)

    def chunk(start: int, stop: int) -> None:
        path.end.kernels.solve_range(path.Q0, path.start.kernel_model, path.end.kernel_model, path.T0, path.T1,
                                     settings, tols, start, stop, *out)

    run_in_chunks(chunk, path.T1.shape[0], threads, max_chunk=max_chunk)
    return out


#: the longest a chunk of solves should run between two checks for cancellation, by the time estimate [s]
CHUNK_SECONDS = 0.02


def _tip_derivative(eq: Equations, q: np.ndarray) -> np.ndarray:
    """The tip's derivative by the tensions (3, n_tendons) [m/N] at the equilibrium ``q`` of ``eq``: implicit
    function theorem, ``dq/dT = -J^-1 dr/dT``, where the residual is affine in the tensions at fixed q."""
    ev = eq.evaluate(q, jacobian=True)
    nt = eq.packed.tension.shape[0]
    dr = np.empty((q.size, nt))
    for c in range(nt):
        t = eq.packed.tension.copy()
        t[c] += 1.0
        dr[:, c] = eq.with_tensions(t).evaluate(q).residual - ev.residual
    dq = -np.linalg.solve(ev.jacobian, dr)
    return eq.tip_jacobian(q) @ dq


class CompiledModel:
    """Solving, batching and differentiating for a model whose equations the compiled solver takes.

    Subclasses set the registry attributes, name their compiled kernel module (``kernels``, whose ``Packed``-type
    named tuple the equations carry as ``packed``: :data:`packed_type`) and implement :meth:`equations`. The
    registry registers the kernel module with the compiled solver (:func:`pytdcr.statics.registry.register`).
    """

    #: the kernel module of :mod:`pytdcr.statics.kernels` that evaluates this model's packed equations
    kernels: ModuleType
    #: the named-tuple type of the packed equations (the solver dispatches on it when compiling)
    packed_type: type
    name: str
    description: str
    options_type: type
    capabilities: Capabilities
    unknowns: str
    iteration_unit = "Newton iterations"
    #: unknowns per disk
    unknowns_per_disk = 3
    #: peak working memory of one solve, in dense (unknowns x unknowns) matrices: the Jacobian, its inverse
    #: and LAPACK's copies (measured: 4.0 for pcc at 500-2,000 disks)
    peak_matrices = 5.0
    #: one solve's time per cubed unknown [s] (measured: pcc 1,000 disks 3.0 s, 2,000 disks 20 s)
    seconds_per_cubed_unknown = 1.2e-10
    #: a cold first use's compile time of each part [s], said while it compiles: none for the models of the
    #: compiled core (``pcc``, ``pcc2``, ``sscr``: built at install), whose first use compiles nothing
    compile_seconds: ClassVar[dict[str, float]] = {}
    #: refuse an equilibrium whose backbone passes through itself (:mod:`pytdcr.contact`): the rod models;
    #: the PCC models leave it to the workspace's realisability test, where disks touch long before
    checks_self_contact = False

    def extra_words(self, robot: Robot, nq: int) -> float:
        """Working memory besides the dense matrices [8-byte words]."""
        return robot.n_disks * (300.0 + 60.0 * robot.n_tendons)

    def resources(self, robot: Robot, options: SolverOptions) -> Resources:
        """Peak memory and rough time of one solve (:class:`pytdcr.limits.Resources`)."""
        nq = self.unknowns_per_disk * robot.n_disks
        words = self.peak_matrices * float(nq) ** 2 + self.extra_words(robot, nq)
        return Resources(8.0 * words, self.seconds_per_cubed_unknown * float(nq) ** 3, nq)

    def default_options(self) -> SolverOptions:
        """Default options."""
        return self.options_type()

    def equations(self, robot: Robot, loads: Loads, options: SolverOptions) -> Equations:  # pragma: no cover - abstract
        """The packed equations of ``robot`` under ``loads``."""
        raise NotImplementedError

    @announced("solver")
    def solve(self, robot: Robot, loads: Loads, q0: np.ndarray | None, options: SolverOptions) -> StaticSolution:
        """One equilibrium; see :func:`pytdcr.solve`."""
        check_cancelled()
        eq = self.equations(robot, loads, options)
        Q0 = _start_points(eq, q0, 1)
        t0 = time.perf_counter()
        T = eq.packed.tension[None, :]
        tols = case_tolerances(robot, loads, T, options.atol)
        out = _solve_rows(eq, Q0, T, kernel_settings(options, q0 is not None), tols, 1)
        return self._single(robot, eq, out, time.perf_counter() - t0, float(tols[0, 0]))

    @announced("continuation")
    def solve_from(self, robot: Robot, loads: Loads, start: StaticSolution, options: SolverOptions) -> StaticSolution:
        """Continue the equilibrium ``start`` (checked by the caller: of this model and robot, under
        ``start.loads``) along its branch to ``loads``; see :func:`pytdcr.solve`."""
        check_cancelled()
        eq = self.equations(robot, loads, options)
        t0 = np.array(start.loads.tensions_for(robot.n_tendons), dtype=float)[None, :]
        path = _Path(self.equations(robot, start.loads, options), eq, _start_points(eq, start.q, 1), t0,
                     eq.packed.tension[None, :])
        t0 = time.perf_counter()
        tols = case_tolerances(robot, loads, path.T1, options.atol)
        out = _continue_rows(path, kernel_settings(options), tols, 1)
        return self._single(robot, eq, out, time.perf_counter() - t0, float(tols[0, 0]))

    def _single(self, robot: Robot, eq: Equations, out: _BatchOut, seconds: float, atol: float) -> StaticSolution:
        """The one solution of ``out``, refused where the backbone passes through itself."""
        sol = self.solution(eq, out, 0, seconds, atol)
        failure = self._contact(robot, eq.shape(sol.q)) if sol.converged else ""
        return replace(sol, converged=False, path=SolvePath.SELF_CONTACT, failure=failure) if failure else sol

    def _contact(self, robot: Robot, shape: tuple[np.ndarray, np.ndarray, np.ndarray | None]) -> str:
        """Why the equilibrium of ``shape`` (``Equations.shape``) is refused for contact (``""``: it is not)."""
        if not self.checks_self_contact:
            return ""
        pos, _, curve = shape
        return contact_failure(pos if curve is None else curve, robot.backbone.outer_radius)

    def tangent_stiffness(self, eq: Equations, q: np.ndarray) -> np.ndarray:
        """The tangent stiffness K (m, m) [N m] at the equilibrium ``q`` of ``eq`` whose real eigenvalues the
        stability test reads (:mod:`pytdcr.statics.stability`): :meth:`tangent_stiffnesses` of one row."""
        out = np.empty((1, eq.n_unknowns, eq.n_unknowns))
        self.tangent_stiffnesses(eq, np.ascontiguousarray(q, dtype=float).reshape(1, -1),
                                 np.ascontiguousarray(eq.packed.tension, dtype=float)[None, :], np.zeros(1, np.int64),
                                 0, 1, out)
        return out[0]

    def tangent_stiffnesses(self, eq: Equations, q: np.ndarray, tensions: np.ndarray, rows: np.ndarray, start: int,
                            stop: int, out: np.ndarray) -> None:
        """For k in ``start <= k < stop``: the tangent stiffness at the equilibrium ``q[rows[k]]`` (B, m) of the
        equations ``eq`` at the tensions ``tensions[rows[k]]`` (B, nt) [N], into ``out[k - start]`` (compiled, the
        GIL released). The PCC family's: the residual's exact Jacobian with each residual paired to the variable
        it is conjugate to (:func:`pytdcr.statics.stability.conjugate_stiffness`)."""
        eq.kernels.jacobian_range(q, eq.kernel_model, tensions, rows, start, stop, out)
        out[: stop - start] = conjugate_stiffness(out[: stop - start])

    def stability_at(self, eq: Equations, q: np.ndarray) -> Stability | None:
        """The stability test at the equilibrium ``q`` of ``eq`` (None if the model has none)."""
        if not self.capabilities.stability:
            return None
        # single-threaded LAPACK, as in a batch: its last bits move with its thread count
        with single_threaded_blas(), announce_compiling(f"the {self.name} model's stability test",
                                                        compile_seconds(self, "stability test")):
            return stability_of(self.tangent_stiffness(eq, q))

    def solution(self, eq: Equations, out: _BatchOut, row: int, seconds: float, atol: float) -> StaticSolution:
        """Wrap row ``row`` of the solver's outcome ``out`` as a :class:`StaticSolution` (``seconds``: its time [s],
        ``atol``: its tolerance [N m])."""
        q = out.q[row]
        pos, rot, curve = eq.shape(q)
        ok = bool(out.converged[row]) and bool(np.all(np.isfinite(q)))
        q = q.copy()
        return StaticSolution(converged=ok, residual=float(out.residual[row]), iterations=int(out.iterations[row]),
                              load_steps=int(out.load_steps[row]), path=SolvePath.from_code(int(out.path[row])),
                              q=q.reshape(eq.n_disks, -1), tensions=eq.evaluate(q).tensions, seconds=seconds,
                              atol=atol, _positions=pos, _rotations=rot, model=self.name, _curve=curve,
                              _stability_fn=lambda: self.stability_at(eq, q), loads=eq.loads)

    @announced("solver")
    def solve_batch(self, robot: Robot, tensions: np.ndarray, loads: Loads, q0: np.ndarray | None,
                    options: SolverOptions, threads: int | None = None) -> BatchSolution:
        """Every row of ``tensions`` (B, n_tendons) [N], on ``threads`` threads (default: all cores)."""
        eq = self.equations(robot, loads.with_tensions(np.zeros(robot.n_tendons)), options)
        Q0 = _start_points(eq, q0, tensions.shape[0])
        t0 = time.perf_counter()
        tols = case_tolerances(robot, loads, tensions, options.atol)
        out = _solve_rows(eq, Q0, tensions, kernel_settings(options, q0 is not None), tols, threads,
                          self._chunk(robot, options))
        return self._batch(robot, eq, tensions, out, (time.perf_counter() - t0, tols, threads))

    @announced("continuation")
    def solve_batch_from(self, robot: Robot, tensions: np.ndarray, loads: Loads, start: BatchSolution,
                         options: SolverOptions, threads: int | None = None) -> BatchSolution:
        """Continue row b of ``start`` (checked by the caller: this model and robot, the same rows) along its
        branch to the tensions ``tensions[b]`` (B, n_tendons) [N] under ``loads``' external wrenches. Rows whose
        start did not converge are not solved (path ``"no start"``)."""
        eq = self.equations(robot, loads.with_tensions(np.zeros(robot.n_tendons)), options)
        eq0 = self.equations(robot, start.loads.with_tensions(np.zeros(robot.n_tendons)), options)
        nb = tensions.shape[0]
        rows = np.flatnonzero(start.converged)
        _check_in_balance(eq0, start, rows)
        path = _Path(eq0, eq, np.array(start.q.reshape(nb, -1)[rows], dtype=float, order="C"),
                     np.ascontiguousarray(start.tensions[rows], dtype=float), np.ascontiguousarray(tensions[rows]))
        t0 = time.perf_counter()
        tols = case_tolerances(robot, loads, tensions, options.atol)
        part = _continue_rows(path, kernel_settings(options), np.ascontiguousarray(tols[rows]), threads,
                              self._chunk(robot, options))
        out = _empty_out(nb, eq.n_unknowns)
        out.q[:], out.converged[:], out.residual[:] = np.nan, False, np.nan
        out.iterations[:], out.load_steps[:], out.path[:] = 0, 0, SolvePath.NO_START.code
        for full, got in zip(out, part, strict=True):
            full[rows] = got
        return self._batch(robot, eq, tensions, out, (time.perf_counter() - t0, tols, threads))

    def _chunk(self, robot: Robot, options: SolverOptions) -> int:
        """Cases per chunk of a batch: about :data:`CHUNK_SECONDS` of work by the time estimate."""
        per_solve = self.resources(robot, options).seconds
        return max(1, min(MAX_CHUNK, int(CHUNK_SECONDS / max(per_solve, 1e-9))))

    def _batch(self, robot: Robot, eq: Equations, tensions: np.ndarray, out: _BatchOut,
               run: tuple[float, np.ndarray, int | None]) -> BatchSolution:
        """The batch of ``out``: ``run`` = (its seconds, the tolerances (B, 2) [N m], the threads)."""
        seconds, tols, threads = run
        nb = tensions.shape[0]
        ok = out.converged & np.all(np.isfinite(out.q), axis=1)
        paths = SolvePath.from_codes(out.path)  # code -1: a row not solved (no start)
        pos = np.full((nb, eq.n_disks + 1, 3), np.nan)
        rot = np.full((nb, eq.n_disks + 1, 3, 3), np.nan)
        for b in np.flatnonzero(ok):
            shape = eq.shape(out.q[b])
            if self._contact(robot, shape):
                ok[b], paths[b] = False, SolvePath.SELF_CONTACT
            else:
                pos[b], rot[b] = shape[:2]
        tips = pos[:, -1].copy()

        def stabilities() -> list[Stability | None]:
            found: list[Stability | None] = [None] * nb
            if not self.capabilities.stability:
                return found
            rows = np.flatnonzero(ok)
            q = np.ascontiguousarray(out.q, dtype=float)
            T = np.ascontiguousarray(tensions, dtype=float)

            def chunk(start: int, stop: int) -> None:
                K = np.empty((stop - start, q.shape[1], q.shape[1]))
                self.tangent_stiffnesses(eq, q, T, rows, start, stop, K)
                for k, ev in enumerate(np.linalg.eigvals(K)):  # one LAPACK call a row, the GIL released
                    found[rows[start + k]] = stability_from_eigenvalues(ev)

            with announce_compiling(f"the {self.name} model's stability test", compile_seconds(self, "stability test")):
                run_in_chunks(chunk, rows.size, threads)
            return found

        return BatchSolution(tensions=tensions, converged=ok, residual=out.residual, iterations=out.iterations,
                             q=out.q.reshape(nb, eq.n_disks, -1), tip_position=tips, seconds=seconds,
                             path=paths, model=self.name, _stability_fn=stabilities, disk_positions=pos,
                             disk_rotations=rot, atol=tols[:, 0].copy(), loads=eq.loads)

    @announced("solver")
    def equilibrium_residual(self, robot: Robot, loads: Loads, q: np.ndarray, options: SolverOptions) -> float:
        """max |residual| [N m] of ``robot`` under ``loads`` at the unknowns ``q`` (ValueError for a wrong shape)."""
        eq = self.equations(robot, loads, options)
        return float(np.max(np.abs(eq.evaluate(eq.check_q(q)).residual)))

    @announced("tip gradient")
    def tip_gradient(self, robot: Robot, loads: Loads, solution: StaticSolution,
                     options: SolverOptions) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (3,) [m] of an equilibrium and its exact derivative by the tensions (3, n_tendons) [m/N].

        Implicit function theorem: ``dq/dT = -J^-1 dr/dT``; the residual is affine in the tensions at fixed q,
        so ``dr/dT_c`` is a difference of residuals, and the tip's derivative by q is exact. Compiled:
        :func:`pytdcr.statics.kernels.stiffness.tip_gradient_range`.
        """
        eq = self.equations(robot, loads, options)
        q = eq.check_q(solution.q)
        out = np.full((1, 3, robot.n_tendons), np.nan)
        eq.kernels.tip_gradient_range(q[None, :], eq.kernel_model, np.array([eq.packed.tension], dtype=float), 0, 1,
                                      out)
        return solution.tip_position, out[0]

    @announced("tip gradient")
    def tip_gradients(self, robot: Robot, tensions: np.ndarray, loads: Loads, q: np.ndarray, options: SolverOptions,
                      threads: int | None = None) -> np.ndarray:
        """Derivatives of the tip by the tensions at many equilibria, shape (B, 3, n_tendons) [m/N]: row b at
        ``q[b]`` and ``tensions[b]`` (B, n_tendons) [N]; NaN rows where ``q[b]`` is not finite. Compiled, the rows
        on ``threads`` threads (the GIL released)."""
        tensions = np.ascontiguousarray(tensions, dtype=float)
        eq = self.equations(robot, loads.with_tensions(np.zeros(robot.n_tendons)), options)
        nb = tensions.shape[0]
        flat = np.ascontiguousarray(np.asarray(q, dtype=float).reshape(nb, -1))
        if flat.shape[1] != eq.n_unknowns:
            raise ValueError(f"q must have {eq.n_unknowns} unknowns a row, got shape {np.shape(q)}")
        out = np.full((nb, 3, robot.n_tendons), np.nan)
        run_in_chunks(lambda start, stop: eq.kernels.tip_gradient_range(flat, eq.kernel_model, tensions, start, stop,
                                                                         out), nb, threads)
        return out

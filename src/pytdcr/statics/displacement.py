"""Tendon displacement: how much tendon the motors have pulled in, and solves where tendons are driven by it.

A motor pulls a tendon in at the base by ``Δ`` [m], counted from the straight, unloaded robot with every tendon
just taut. For tendon ``c``, anchored at disk ``a_c`` and threaded through the hole ``h_c`` of every disk's frame
(disk 0 is the base), the pieces between neighbouring disks have in a solved shape the lengths

    ℓ_{c,i} = | p_{i+1} + R_{i+1} h_c − p_i − R_i h_c |,   i = 0 … a_c − 1,

and in the straight robot the subsegment lengths ``l_i``, whose sum is ``L0_c``. A tendon of axial stiffness
``k_c`` [N/m] (its length in the robot, ``L0_c``, under a uniform tension: ``EA_c = k_c L0_c``) carrying the
piece tensions ``T_{c,i}`` (which friction makes vary along it) is Hookean on its unstretched length, so the
motor has pulled in

    Δ_c = L0_c − Σ_i ℓ_{c,i} / (1 + T_{c,i} / EA_c),

``Δ_c = L0_c − Σ_i ℓ_{c,i}`` for an inextensible tendon (``k_c = ∞``). The stretch changes no force: a tendon's
stiffness matters only where a displacement, not a tension, is given.

:func:`solve_displacements` drives any subset of the tendons by displacement (the rest by tension) and finds the
equilibrium with the driven tendons' tensions. A tendon is slack when its displacement would need a negative
tension: it carries none, and the motor's pull-in is less than the shape takes up. The tensions ``T_D`` of the
driven set ``D`` solve the complementarity problem

    T_c ≥ 0,   g_c = Δ_c(T) − Δ*_c ≥ 0,   T_c g_c = 0   (c ∈ D),

along a loading path: the external loads and the targets move together from the robot at rest (gravity alone,
every tendon at 0 N), in stages shortened where one fails; each stage takes Josephy–Newton steps, each the
linear complementarity problem at the current tensions (:func:`lcp`), ``∂Δ/∂T_D`` by forward differences of
continued equilibria and Broyden's update between them. Like a tension-driven solve's loading path, this picks
the equilibrium where the robot has several (docs/MODEL.md, appendix C).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..loads import Loads
from ..results import StaticSolution
from ..robot import Robot
from .base import Model
from .equilibrium import solve
from .options import ModelOptions
from .registry import get_model

__all__ = ["DisplacementOptions", "DisplacementSolution", "lcp", "pulled_in", "pulled_in_of_shape",
           "solve_displacements", "tendon_stiffness"]

#: the scale that makes a displacement [m] and a tension [N] comparable in the complementarity function [N/m]
_SCALE_N_PER_M = 1e3
#: the tension step of the forward differences [N]
_STEP_N = 1e-3
#: the largest change of a tension in one Newton step [N]
_MAX_STEP_N = 5.0
#: Newton steps a stage of the motors' path may take before it is split
_STAGE_STEPS = 8
#: the shortest stage of the motors' path, as a fraction of it
_SMALLEST_STAGE = 1.0 / 256.0


def tendon_stiffness(robot: Robot, stiffness: float | Sequence[float | None] | None) -> np.ndarray:
    """The axial stiffness of every tendon [N/m], shape (n_tendons,), ``inf`` for an inextensible one.

    Parameters
    ----------
    stiffness : float, sequence or None
        None: the robot's own (each tendon's ``stiffness``, inextensible where it has none); one number [N/m]
        for every tendon; or one per tendon (None or ``inf``: that tendon inextensible). Each finite value must
        be > 0.

    Raises
    ------
    ValueError
        Naming ``stiffness`` and what is wrong with it.
    """
    n = robot.n_tendons
    if stiffness is None:
        return np.array([np.inf if t.stiffness is None else float(t.stiffness) for t in robot.tendons])
    values = np.full(n, float(stiffness)) if np.ndim(stiffness) == 0 else np.array(
        [np.inf if s is None else float(s) for s in stiffness])  # type: ignore[union-attr]
    if values.shape != (n,):
        raise ValueError(f"stiffness must give one value or one per tendon ({n}), got {values.size}")
    if not np.all(values > 0):  # NaN fails too
        raise ValueError(f"stiffness must be > 0 N/m (inf for an inextensible tendon), got {values.tolist()}")
    return values


def _straight_lengths(robot: Robot) -> np.ndarray:
    """``L0_c`` [m], shape (n_tendons,): each tendon's length in the straight robot, base to anchor."""
    s = np.concatenate([[0.0], np.cumsum(robot.subsegment_lengths)])
    return s[robot.anchor_disks]


def pulled_in(robot: Robot, solution: StaticSolution,
              stiffness: float | Sequence[float | None] | None = None) -> np.ndarray:
    """How much of each tendon the motors have pulled in to hold ``solution`` [m], shape (n_tendons,).

    ``Δ_c = L0_c − Σ_i ℓ_{c,i} / (1 + T_{c,i} / (k_c L0_c))`` (module docstring): positive when the tendon is
    pulled in, negative when paid out, relative to the straight, unloaded robot with every tendon just taut.
    For a tendon at 0 N it is the pull-in that just takes up its slack.

    Parameters
    ----------
    robot : Robot
    solution : StaticSolution
        A converged solve of ``robot`` (any model).
    stiffness : float, sequence or None
        The tendons' axial stiffness [N/m] (:func:`tendon_stiffness`); default the robot's own (each tendon's
        ``stiffness``, inextensible where it has none).

    Raises
    ------
    ValueError
        When ``solution`` has not converged (it has no shape).
    """
    pos, rot = solution.disk_positions, solution.disk_rotations  # (N+1, 3), (N+1, 3, 3); raise if unconverged
    return pulled_in_of_shape(robot, pos, rot, np.asarray(solution.tensions, dtype=float),
                              tendon_stiffness(robot, stiffness))


def pulled_in_of_shape(robot: Robot, positions: np.ndarray, rotations: np.ndarray, piece_tensions: np.ndarray,
                       stiffness: np.ndarray) -> np.ndarray:
    """:func:`pulled_in` of a shape given by its disks' positions (N+1, 3) [m] and rotations (N+1, 3, 3), the
    tension of every tendon piece (n_tendons, N) [N] and the tendons' stiffness (n_tendons,) [N/m] (``inf``:
    inextensible): ``Δ_c = L0_c − Σ_i ℓ_{c,i} / (1 + T_{c,i} / (k_c L0_c))``, shape (n_tendons,) [m]."""
    holes = robot.tendon_holes
    L0 = _straight_lengths(robot)
    out = np.zeros(robot.n_tendons)
    for c, a in enumerate(robot.anchor_disks):
        points = positions[: a + 1] + rotations[: a + 1] @ holes[c]  # the hole of tendon c in disks 0..a [m]
        pieces = np.linalg.norm(np.diff(points, axis=0), axis=1)
        out[c] = L0[c] - float(np.sum(pieces / (1.0 + piece_tensions[c, :a] / (stiffness[c] * L0[c]))))
    return out


@dataclass(frozen=True)
class DisplacementOptions:
    """How :func:`solve_displacements` meets the displacements.

    Attributes
    ----------
    tol : float
        Tolerance on the displacement conditions [m] (default 0.1 µm): ``|Δ_c − Δ*_c| ≤ tol`` for a taut
        tendon; a tendon below ``K tol`` (0.1 mN, ``K`` = 1 N/mm) is slack.
    max_iterations : int
        Newton steps at most, in all stages of the loading path.
    max_tension : float
        The most a driven tendon may pull [N]: a displacement that needs more is not met (the answer says so).
    """

    tol: float = 1e-7
    max_iterations: int = 200
    max_tension: float = 200.0

    def __post_init__(self) -> None:
        if not (0.0 < self.tol <= 1e-3):
            raise ValueError(f"tol must be in (0, 1e-3] m, got {self.tol!r}")
        if not (isinstance(self.max_iterations, int) and 1 <= self.max_iterations <= 100_000):
            raise ValueError(f"max_iterations must be an integer in [1, 100000], got {self.max_iterations!r}")
        if not (0.0 < self.max_tension <= 1e4):
            raise ValueError(f"max_tension must be in (0, 1e4] N, got {self.max_tension!r}")


@dataclass(frozen=True, eq=False)
class DisplacementSolution:
    """The outcome of :func:`solve_displacements`.

    Attributes
    ----------
    solution : StaticSolution
        The equilibrium (its ``loads`` carry the tensions found); its own ``converged`` is about the equilibrium
        alone.
    displacements : ndarray, shape (n_tendons,)
        The pull-in asked of each displacement-driven tendon [m]; NaN for a tension-driven one.
    tensions : ndarray, shape (n_tendons,)
        The actuator tension of every tendon [N]: found for the displacement-driven ones, given for the others.
    pulled_in : ndarray, shape (n_tendons,)
        Each tendon's pull-in in the equilibrium [m] (:func:`pulled_in`); for a slack tendon, what would take
        up its slack (more than it was given).
    stiffness : ndarray, shape (n_tendons,)
        The tendons' axial stiffness used [N/m] (``inf``: inextensible).
    slack : ndarray of bool, shape (n_tendons,)
        Tendons that carry no tension (0 N at the actuator).
    residual : float
        The largest violation of the displacement conditions [m]: ``|Δ_c − Δ*_c|`` of a taut driven tendon,
        ``max(0, Δ*_c − Δ_c)`` of a slack one.
    converged : bool
        The equilibrium converged, ``residual`` ≤ the tolerance asked and no driven tension exceeds
        ``max_tension`` (:class:`DisplacementOptions`).
    iterations : int
        Newton steps taken.
    solves : int
        Equilibria solved in all (difference solves and rejected trial steps included).
    message : str
        Why it did not converge (empty when it did).
    """

    solution: StaticSolution
    displacements: np.ndarray
    tensions: np.ndarray
    pulled_in: np.ndarray
    stiffness: np.ndarray
    slack: np.ndarray
    residual: float
    converged: bool
    iterations: int
    solves: int
    message: str = ""

    @property
    def driven(self) -> np.ndarray:
        """Which tendons are displacement-driven, shape (n_tendons,) of bool."""
        return np.isfinite(self.displacements)


def _targets(robot: Robot, displacements: Sequence[float | None]) -> np.ndarray:
    """The pull-in asked of each tendon [m] (NaN: tension-driven), checked."""
    d = np.array([np.nan if v is None else float(v) for v in displacements], dtype=float)
    if d.shape != (robot.n_tendons,):
        raise ValueError(f"displacements must give one value (or None) per tendon ({robot.n_tendons}), "
                         f"got {d.size}")
    for k, v in enumerate(d):
        if not np.isnan(v) and not (np.isfinite(v) and abs(v) <= robot.length):
            raise ValueError(f"displacements: value {k + 1} = {v:g} m must be finite and within ±{robot.length:g} m "
                             "(the robot's length)")
    return d


class _Equilibria:
    """Solves of one robot and model at a point ``part`` of the loading path (the external loads and the
    tension-driven tendons' tensions times ``part``) with the driven tendons' tensions given, each continued from
    a solved state; counted."""

    def __init__(self, robot: Robot, loads: Loads, model: Model, options: ModelOptions | None,
                 stiffness: np.ndarray, driven: np.ndarray) -> None:
        self.robot, self.loads, self.model, self.options, self.k = robot, loads, model, options, stiffness
        self.driven, self.given = driven, loads.tensions_for(robot.n_tendons).astype(float)
        self.part, self.count = 0.0, 0

    def tensions(self, tensions: np.ndarray) -> np.ndarray:
        """The actuator tensions [N] at this point of the path: ``tensions``' driven entries, the others'."""
        out = self.given * self.part
        out[self.driven] = np.maximum(tensions[self.driven], 0.0)
        return out

    def at(self, tensions: np.ndarray, start: StaticSolution | None) -> StaticSolution:
        self.count += 1
        loads = self.loads.scaled(self.part).with_tensions(self.tensions(tensions))
        if start is None:
            return solve(self.robot, loads, model=self.model, options=self.options)
        if self.model.capabilities.continuation:
            return solve(self.robot, loads, model=self.model, options=self.options, start=start)
        return solve(self.robot, loads, model=self.model, options=self.options, q0=start.q)

    def pull(self, solution: StaticSolution) -> np.ndarray:
        return pulled_in(self.robot, solution, self.k)


def _violation(tensions: np.ndarray, gap: np.ndarray) -> float:
    """The largest violation of the displacement conditions [m]: ``max |min(T_c / K, g_c)|``."""
    if gap.size == 0:
        return 0.0
    return float(np.max(np.abs(np.minimum(tensions / _SCALE_N_PER_M, gap))))


def solve_displacements(robot: Robot, loads: Loads, displacements: Sequence[float | None], *,
                        stiffness: float | Sequence[float | None] | None = None, model: str | Model = "pcc",
                        options: ModelOptions | None = None, drive: DisplacementOptions | None = None,
                        start: StaticSolution | None = None) -> DisplacementSolution:
    """Equilibrium of ``robot`` with some tendons driven by displacement and the rest by tension.

    Parameters
    ----------
    robot : Robot
    loads : Loads
        External loads, friction direction and the tension-driven tendons' tensions [N] (``loads.tensions``;
        the driven tendons' entries are ignored).
    displacements : sequence of float or None, length n_tendons
        Pull-in of each displacement-driven tendon [m] (negative: paid out), None for a tension-driven one.
    stiffness : float, sequence or None
        Axial stiffness of the tendons [N/m] (:func:`tendon_stiffness`); default the robot's own.
    model : str or Model
        A registered model (:data:`pytdcr.statics.MODELS`) or a model object.
    options : the model's options, optional
    drive : DisplacementOptions, optional
        Tolerance [m], Newton steps and the largest tension [N] (default: :class:`DisplacementOptions`).
    start : StaticSolution, optional
        A converged equilibrium of ``robot`` and ``model`` to continue from (its ``loads`` carry its tensions):
        the motors move from its pull-ins to the ones asked under the full ``loads``, instead of from rest with
        the loads; where it does not converge under ``loads``, the path starts from rest.

    Returns
    -------
    DisplacementSolution
        Check ``converged``: an answer that did not converge says why in ``message``, with its residual.

    Notes
    -----
    The driven tensions solve ``T_c ≥ 0``, ``g_c = Δ_c(T) − Δ*_c ≥ 0``, ``T_c g_c = 0`` (module docstring), along a
    loading path from rest with Josephy–Newton steps (each at most 5 N in any tension). Two inextensible
    opposite tendons, both taut, leave their common tension free: the least-norm tensions are taken.
    """
    m = get_model(model)
    drive = drive if drive is not None else DisplacementOptions()
    tol, max_iterations, max_tension = drive.tol, drive.max_iterations, drive.max_tension
    target = _targets(robot, displacements)
    k = tendon_stiffness(robot, stiffness)
    driven = np.flatnonzero(~np.isnan(target))
    eq = _Equilibria(robot, loads, m, options, k, driven)
    if driven.size == 0:
        eq.part = 1.0
        tensions = eq.tensions(np.zeros(robot.n_tendons))
        return _result(eq, eq.at(tensions, None), target, tensions, tol, 0, "")
    sol, tensions, loads_move = _path_start(eq, start)
    if not sol.converged:
        return _result(eq, sol, target, tensions, tol, 0, "")
    pull0 = eq.pull(sol)
    done, stride, steps, message = 0.0, 1.0, 0, ""
    while done < 1.0 and steps < max_iterations:  # motors (and, from rest, loads) moved together to the targets
        part = min(1.0, done + stride)
        eq.part = part if loads_move else 1.0
        goal = target.copy()
        goal[driven] = pull0[driven] + part * (target[driven] - pull0[driven])
        moved = eq.at(tensions, sol)  # the stage's loads on the last tensions: where its Newton steps start
        new, trial, n, message = (_newton(eq, moved, tensions, driven, goal, tol if part == 1.0 else 10.0 * tol,
                                          min(_STAGE_STEPS, max_iterations - steps)) if moved.converged
                                  else (sol, tensions, 0, "the loads' step has no equilibrium"))
        steps += max(n, 1)
        if message:
            stride /= 4.0
            if stride < _SMALLEST_STAGE:
                message = f"the loading path stalled at {done:.1%} of the loads and displacements: {message}"
                break
            continue
        sol, tensions, done, stride, message = new, trial, part, 2.0 * stride, ""
        if (over := float(np.max(tensions[driven]))) > max_tension:
            c = int(driven[np.argmax(tensions[driven])])
            message = (f"tendon {c + 1} needs {over:.4g} N at {done:.1%} of the loading path, more than "
                       f"max_tension = {max_tension:g} N")
            break
    eq.part = done if loads_move else 1.0
    tensions = eq.tensions(tensions)
    if done < 1.0 and not message:
        message = f"no convergence in {max_iterations} Newton steps"
    return _result(eq, sol, target, tensions, tol, steps, message)


def _path_start(eq: _Equilibria, start: StaticSolution | None) -> tuple[StaticSolution, np.ndarray, bool]:
    """Where the motors' path starts: ``start`` re-solved under the full loads with its tensions (the loads then
    stay), else the robot at rest (gravity alone, every tendon at 0 N; the loads move with the motors). Returns
    the equilibrium, the tensions and whether the loads move."""
    if start is not None and start.converged and start.loads is not None:
        eq.part = 1.0
        tensions = start.loads.tensions_for(eq.robot.n_tendons).astype(float)
        try:
            sol = eq.at(tensions, start)
        except ValueError:  # a state of another robot or friction direction cannot be continued
            sol = None
        if sol is not None and sol.converged:
            return sol, tensions, False
    eq.part = 0.0
    tensions = np.zeros(eq.robot.n_tendons)
    return eq.at(tensions, None), tensions, True


def lcp(M: np.ndarray, q: np.ndarray, max_pivots: int | None = None) -> np.ndarray | None:
    """A solution ``z`` of the linear complementarity problem ``z ≥ 0``, ``w = q + M z ≥ 0``, ``zᵀw = 0``, by
    Murty's least-index principal pivoting (finite for a P-matrix ``M``, where the solution is unique). A
    singular principal block (inextensible antagonistic tendons: a co-contraction that changes no displacement)
    is solved for its least-norm ``z``.

    Parameters
    ----------
    M : ndarray, shape (n, n)
    q : ndarray, shape (n,)
    max_pivots : int, optional
        Pivots at most (default ``50 n + 50``).

    Returns
    -------
    ndarray, shape (n,), or None
        ``z``; None when a singular principal block has no solution or the pivots run out.
    """
    n = q.size
    basic = np.zeros(n, dtype=bool)  # where z is free (w = 0); elsewhere z = 0
    scale = max(float(np.max(np.abs(q))), 1e-300)
    for _ in range(max_pivots if max_pivots is not None else 50 * n + 50):
        z = np.zeros(n)
        if basic.any():  # least norm where the block is singular (a co-contraction the conditions leave free)
            z[basic] = np.linalg.lstsq(M[np.ix_(basic, basic)], -q[basic], rcond=1e-10)[0]
        w = q + M @ z
        if basic.any() and np.max(np.abs(w[basic])) > 1e-9 * scale:
            return None  # a singular block whose equations contradict each other
        bad = np.flatnonzero(np.where(basic, z < -1e-12 * np.max(np.abs(z), initial=1.0), w < -1e-12 * scale))
        if bad.size == 0:
            return np.maximum(z, 0.0)
        basic[bad[0]] = not basic[bad[0]]
    return None


def _newton(eq: _Equilibria, sol: StaticSolution, tensions: np.ndarray, driven: np.ndarray, target: np.ndarray,
            tol: float, max_steps: int) -> tuple[StaticSolution, np.ndarray, int, str]:
    """Josephy–Newton steps from ``sol``: each solves the complementarity problem linearised at the current
    tensions (``T' ≥ 0``, ``g + J (T' − T) ≥ 0``, complementary; :func:`lcp`) and moves there, until the
    displacement conditions hold to ``tol`` [m]. ``J`` is differenced afresh at the start, after a step that did
    not halve the violation and where the updated one gives no answer; Broyden's rule updates it otherwise.
    Returns the last equilibrium, its tensions, the steps taken and why it stopped short (empty when it
    converged)."""
    jac, fresh, last = None, False, np.inf
    for it in range(max_steps + 1):
        gap = eq.pull(sol)[driven] - target[driven]
        violation = _violation(tensions[driven], gap)
        if violation <= tol:
            return sol, tensions, it, ""
        if it == max_steps:
            break
        if jac is None or (violation > 0.5 * last and not fresh):
            jac, fresh = _gap_jacobian(eq, sol, tensions, driven), True
        last, now = violation, tensions[driven]
        nxt = lcp(jac, gap - jac @ now)
        if nxt is None and not fresh:
            jac, fresh = _gap_jacobian(eq, sol, tensions, driven), True
            nxt = lcp(jac, gap - jac @ now)
        if nxt is None:
            return sol, tensions, it, "the linearised displacement conditions have no solution"
        step = nxt - now
        step *= min(1.0, _MAX_STEP_N / max(float(np.max(np.abs(step))), 1e-300))
        new, trial = _stepped(eq, sol, tensions, driven, step)
        if new is None:
            return sol, tensions, it, "no equilibrium along the Newton step"
        done = trial[driven] - now
        moved = eq.pull(new)[driven] - target[driven] - gap
        if float(done @ done) > 0.0:
            jac = jac + np.outer(moved - jac @ done, done) / float(done @ done)  # Broyden's update
        sol, tensions, fresh = new, trial, False
    return sol, tensions, max_steps, f"no convergence in {max_steps} Newton steps"


def _stepped(eq: _Equilibria, sol: StaticSolution, tensions: np.ndarray, driven: np.ndarray,
             step: np.ndarray) -> tuple[StaticSolution | None, np.ndarray]:
    """The equilibrium at the tensions ``T_D + step`` (kept ≥ 0), continued from ``sol``; the step halved up to
    four times while it does not converge. ``(None, tensions)`` when none does."""
    for _ in range(5):
        trial = tensions.copy()
        trial[driven] = np.maximum(tensions[driven] + step, 0.0)
        new = eq.at(trial, sol)
        if new.converged:
            return new, trial
        step = step / 2.0
    return None, tensions


def _gap_jacobian(eq: _Equilibria, sol: StaticSolution, tensions: np.ndarray, driven: np.ndarray) -> np.ndarray:
    """``∂Δ_D/∂T_D`` [m/N] by forward differences of equilibria continued from ``sol``."""
    base = eq.pull(sol)[driven]
    jac = np.zeros((driven.size, driven.size))
    for j, c in enumerate(driven):
        moved = tensions.copy()
        moved[c] += _STEP_N
        other = eq.at(moved, sol)
        if not other.converged:
            moved[c] = max(tensions[c] - _STEP_N, 0.0)
            other = eq.at(moved, sol)
            if not other.converged or moved[c] == tensions[c]:
                continue
        jac[:, j] = (eq.pull(other)[driven] - base) / (moved[c] - tensions[c])
    return jac


def _result(eq: _Equilibria, sol: StaticSolution, target: np.ndarray, tensions: np.ndarray, tol: float,
            iterations: int, message: str) -> DisplacementSolution:
    """The answer at ``sol`` (its tensions ``tensions``), checked against the targets to ``tol`` [m]."""
    robot, k, driven, solves = eq.robot, eq.k, eq.driven, eq.count
    if not sol.converged:
        return DisplacementSolution(sol, target, tensions, np.full(robot.n_tendons, np.nan), k, tensions <= 0.0,
                                    np.inf, False, iterations, solves,
                                    message or f"the equilibrium did not converge (residual {sol.residual:.3g} N m)")
    pull = pulled_in(robot, sol, k)
    residual = _violation(tensions[driven], pull[driven] - target[driven])
    converged = residual <= tol and not message
    if not converged and not message:
        message = f"the displacements are met to {residual:.3g} m, not {tol:g} m"
    slack = tensions <= _SCALE_N_PER_M * tol
    return DisplacementSolution(sol, target, tensions, pull, k, slack, residual, converged, iterations, solves,
                                "" if converged else message)

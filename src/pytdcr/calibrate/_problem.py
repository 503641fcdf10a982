"""The least-squares problem of a calibration: each row's equilibrium at a parameter vector, the whitened
residuals of what was measured, and their exact derivatives by the parameters.

Residuals, per row b and measured quantity (tip position, tip axis, disk positions), divided by their uncertainty:
``e_b = (R(r) p_b(theta) + t - p_b^measured) / sigma_b`` with ``p_b(theta)`` the model's pose at the equilibrium
``r_model(q_b; theta) = 0`` of row b's inputs under the parameters theta.

Derivatives (the implicit function theorem, as the tip gradient): ``dq/dtheta = -J^-1 dr/dtheta|_q`` with J the
model's exact Jacobian at the equilibrium, and ``dp/dtheta = P dq/dtheta + dp/dtheta|_q`` with P the exact pose
Jacobian. The partial derivatives at fixed q (the residual and the shape's direct dependence on theta, such as
the subsegment rod's stiffness in its integration) are central differences of those closed-form maps at a
relative step 1e-5 (no solve inside: their error is ~1e-10 relative), one-sided at a bound; they are exact for
the parameters the residual is affine in (a pretension, a payload).

A row whose tendons are driven by displacement (:func:`pytdcr.solve_displacements`) adds the taut driven
tendons' tensions ``T_A`` to the unknowns and their conditions ``g_A = Delta_A(q, T, theta) - Delta*_A(theta) = 0``
(the pull-in of each equals the motor's) to the equations. With ``X = -J^-1 [dr/dtheta | dr/dT_A]`` at fixed q,
each column of ``(X, I)`` is a direction along which the equilibrium equations hold to first order; the total
derivatives of ``g`` and of the observations along them (``G_theta``, ``G_T``, ``O_theta``, ``O_T``: central
differences of the closed-form shape, pull-ins and observations) give ``dT_A/dtheta = -G_T^-1 G_theta`` and
``d observations/dtheta = O_theta + O_T dT_A/dtheta``. A slack driven tendon keeps its zero tension.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from ..loads import Loads
from ..results import StaticSolution
from ..robot import Robot
from ..statics import Model, solve
from ..statics.displacement import pulled_in_of_shape, solve_displacements, tendon_stiffness
from ..statics.options import ModelOptions
from ._data import Measurements
from ._parameters import Parameter, Setting

__all__ = ["Problem", "RowFailure"]

#: the fit's finite-difference step at fixed q, relative to each parameter's scale
_STEP = 1e-5
#: the step of a driven tendon's tension in those differences [N] (the residual is affine in it)
_TENSION_STEP_N = 1e-3
#: a driven tendon at or below this tension [N] is slack (:class:`pytdcr.DisplacementOptions`' 0.1 mN)
_SLACK_N = 1e-4


class RowFailure(RuntimeError):
    """A row without an equilibrium at the parameters tried: ``row`` (0-based) and the solver's residual [N m]."""

    def __init__(self, row: int, residual: float, failure: str) -> None:
        self.row, self.residual, self.failure = row, residual, failure
        why = f", {failure}" if failure else ""
        super().__init__(f"row {row + 1}: no equilibrium (residual {residual:.3g} N m{why})")


@dataclass
class Problem:
    """A calibration's model of the data: :meth:`residuals` and :meth:`jacobian` at values of the parameters.

    Attributes
    ----------
    robot : Robot
        The robot before the fit.
    data : Measurements
    params : tuple of Parameter
    model : Model
    options : ModelOptions
    stiffness : ndarray, shape (n_tendons,), optional
        The tendons' axial stiffness [N/m] (``inf``: inextensible; default the robot's own), for
        displacement-driven rows.
    solves : int
        Solves so far.
    """

    robot: Robot
    data: Measurements
    params: tuple[Parameter, ...]
    model: Model
    options: ModelOptions
    stiffness: np.ndarray | None = None
    solves: int = 0

    def __post_init__(self) -> None:
        n = self.robot.n_tendons
        k = tendon_stiffness(self.robot, None) if self.stiffness is None else self.stiffness
        self.stiffness = np.asarray(k, dtype=float)
        d = self.data.displacements
        self.driven = np.zeros(n, bool) if d is None else ~np.isnan(d[0])

    # -- values ---------------------------------------------------------------------------------------------
    @property
    def initial(self) -> np.ndarray:
        """The parameters' initial values, each in its unit."""
        return np.array([p.initial for p in self.params])

    @property
    def scales(self) -> np.ndarray:
        """Each parameter's scale (the fit's unit step), in its unit."""
        return np.array([p.scale for p in self.params])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The values' bounds in their units; a pretension's lower bound keeps every row's tension >= 0."""
        lo = np.array([p.lower for p in self.params])
        hi = np.array([p.upper for p in self.params])
        t = np.where(self.driven, np.inf, self.data.tensions)
        for i, p in enumerate(self.params):
            if p.name == "pretension":
                lo[i] = -float(t.min()) if np.isfinite(t.min()) else p.lower
            elif p.name.startswith("pretension_"):
                lo[i] = -float(t[:, int(p.name.rsplit("_", 1)[1]) - 1].min())
        return lo, hi

    @property
    def n_residuals(self) -> int:
        """How many whitened residuals the rows give: per row the tip (3), its axis (3, when measured) and each
        measured disk (3)."""
        d = self.data
        return d.n_rows * 3 * (1 + (d.tip_axis is not None) + len(d.disks))

    def setting(self, values: np.ndarray) -> Setting:
        """The parameters at ``values``."""
        return Setting(self.params, np.asarray(values, dtype=float))

    def loads(self, setting: Setting, robot: Robot, row: int, found: np.ndarray | None = None) -> Loads:
        """Row ``row``'s loads under ``setting``; a displacement-driven tendon pulls ``found`` [N] (its tension in
        the row's equilibrium), or 0 N."""
        d = self.data
        t = np.maximum(setting.tensions(d.tensions[row]), 0.0)
        t[self.driven] = 0.0 if found is None else found[self.driven]
        return Loads(t, tip_force=setting.tip_force(robot, d.tip_force[row]),
                     tip_moment=d.tip_moment[row])

    # -- equilibria -----------------------------------------------------------------------------------------
    def solve_row(self, setting: Setting, robot: Robot, row: int) -> StaticSolution:
        """Row ``row``'s equilibrium: the loading path from rest, the equilibrium the robot reaches when the row's
        inputs are applied to it at rest (as :func:`~pytdcr.solve`), RowFailure when it does not converge.

        Not warm-started from the previous fit step's equilibrium: where a row is multistable that start can hold
        the fit on a branch the loading path does not reach, and the fit then matches equilibria the robot would
        not take."""
        loads = self.loads(setting, robot, row)
        if self.driven.any():
            return self._solve_driven(setting, robot, loads, row)
        sol = solve(robot, loads, model=self.model, options=self.options)
        self.solves += 1
        if not sol.converged:
            raise RowFailure(row, float(sol.residual), sol.failure)
        return sol

    def _solve_driven(self, setting: Setting, robot: Robot, loads: Loads, row: int) -> StaticSolution:
        """Row ``row``'s equilibrium with its driven tendons at their pull-ins (:func:`solve_displacements`); the
        solution's loads carry the tensions found."""
        assert self.data.displacements is not None
        target = setting.displacements(self.data.displacements[row])
        d = solve_displacements(robot, loads, [None if np.isnan(v) else float(v) for v in target],
                                stiffness=setting.stiffness(self.stiffness), model=self.model, options=self.options)
        self.solves += d.solves
        if not d.converged:
            raise RowFailure(row, float(d.solution.residual), d.message)
        return d.solution

    def solutions(self, values: np.ndarray) -> list[StaticSolution]:
        """Every row's equilibrium at ``values`` (RowFailure naming the first row without one)."""
        s = self.setting(values)
        robot = s.robot(self.robot)
        return [self.solve_row(s, robot, b) for b in range(self.data.n_rows)]

    # -- observations ---------------------------------------------------------------------------------------
    def observed(self, setting: Setting, positions: np.ndarray, rotations: np.ndarray, row: int) -> np.ndarray:
        """Row ``row``'s whitened residuals from the model's disk positions (N+1, 3) [m] and rotations (N+1, 3, 3),
        base frame: tip position (3), then tip axis (3, when measured), then each measured disk (3)."""
        d = self.data
        rot, off = setting.frame()
        parts = [(rot @ positions[-1] + off - d.tip_position[row]) / d.sigma[row]]
        if d.tip_axis is not None and d.sigma_axis is not None:
            parts.append((rot @ rotations[-1][:, 2] - d.tip_axis[row]) / d.sigma_axis[row])
        for k, measured in d.disks:
            parts.append((rot @ positions[k] + off - measured[row]) / d.sigma[row])
        return np.concatenate(parts)

    def residuals(self, values: np.ndarray, solutions: list[StaticSolution]) -> np.ndarray:
        """The whitened residuals of every row at ``values``, shape (B * per_row,)."""
        s = self.setting(values)
        return np.concatenate([self.observed(s, sol.disk_positions, sol.disk_rotations, b)
                               for b, sol in enumerate(solutions)])

    def tip_errors(self, values: np.ndarray, solutions: list[StaticSolution]) -> tuple[np.ndarray, np.ndarray]:
        """Every row's predicted tip in the measurement frame (B, 3) [m] and its distance from the measured one
        (B,) [m]."""
        rot, off = self.setting(values).frame()
        tips = np.array([rot @ sol.tip_position + off for sol in solutions])
        return tips, np.linalg.norm(tips - self.data.tip_position, axis=1)

    # -- derivatives ----------------------------------------------------------------------------------------
    def _fixed_q(self, values: np.ndarray, row: int, q: np.ndarray, found: np.ndarray, taut: np.ndarray
                 ) -> np.ndarray:
        """At the fixed unknowns ``q``, with the displacement-driven tendons pulling ``found`` [N]: the model's
        residual, row ``row``'s whitened observations and the pull-in gaps of the ``taut`` driven tendons [m],
        as one vector (the maps the implicit function theorem differentiates)."""
        s = self.setting(values)
        robot = s.robot(self.robot)
        eq = self.model.equations(robot, self.loads(s, robot, row, found), self.options)
        ev = eq.evaluate(q)
        pos, rot = eq.shape(q)[:2]
        parts = [ev.residual, self.observed(s, pos, rot, row)]
        if taut.any():
            assert self.data.displacements is not None
            pull = pulled_in_of_shape(robot, pos, rot, ev.tensions, s.stiffness(self.stiffness))
            parts.append(pull[taut] - s.displacements(self.data.displacements[row])[taut])
        return np.concatenate(parts)

    def _along(self, f: Callable[[float], np.ndarray], h: float, side: int) -> np.ndarray:
        """d f(t) / dt at t = 0 by central differences of step ``h`` (``side`` 0), or second-order one-sided ones
        forward (``side`` 1: a step back would leave the bounds) or backward (``side`` -1)."""
        if side == 0:
            return (f(h) - f(-h)) / (2 * h)
        return side * (-3 * f(0.0) + 4 * f(side * h) - f(2 * side * h)) / (2 * h)

    def _partials(self, values: np.ndarray, row: int, q: np.ndarray, bounds: tuple[np.ndarray, np.ndarray],
                  found: np.ndarray, taut: np.ndarray, moves: np.ndarray | None = None) -> np.ndarray:
        """d(residual, observations, gaps)/d value at fixed q, one column per parameter, then one per taut driven
        tendon's tension; with ``moves`` (m, columns), along each column's direction with q moving by it (the
        total derivatives of the module docstring)."""
        taut_idx = np.flatnonzero(taut)
        lo, hi = bounds
        out = []
        for i in range(values.size + taut_idx.size):
            dq = np.zeros_like(q) if moves is None else moves[:, i]
            if i < values.size:
                h, e = _STEP * self.scales[i], np.eye(values.size)[i]
                side = 1 if values[i] - h < lo[i] else -1 if values[i] + h > hi[i] else 0

                def f(t: float, e: np.ndarray = e, dq: np.ndarray = dq) -> np.ndarray:
                    return self._fixed_q(values + t * e, row, q + t * dq, found, taut)
            else:
                c = taut_idx[i - values.size]
                h, side = min(_TENSION_STEP_N, 0.5 * found[c]), 0
                e = np.zeros_like(found)
                e[c] = 1.0

                def f(t: float, e: np.ndarray = e, dq: np.ndarray = dq) -> np.ndarray:
                    return self._fixed_q(values, row, q + t * dq, found + t * e, taut)
            out.append(self._along(f, h, side))
        return np.column_stack(out)

    def jacobian(self, values: np.ndarray, solutions: list[StaticSolution]) -> np.ndarray:
        """d residuals / d values at ``values`` (whose equilibria are ``solutions``), shape (B * per_row, n_params),
        per unit of each parameter (module docstring)."""
        s = self.setting(values)
        robot = s.robot(self.robot)
        bounds = self.bounds()
        rot, _ = s.frame()
        n = robot.n_tendons
        blocks = []
        for b, sol in enumerate(solutions):
            found = sol.loads.tensions_for(n).astype(float) if sol.loads is not None else np.zeros(n)
            taut = self.driven & (found > _SLACK_N)
            eq = self.model.equations(robot, self.loads(s, robot, b, found), self.options)
            q = eq.check_q(sol.q)
            lu = lu_factor(eq.evaluate(q, jacobian=True).jacobian)
            partial = self._partials(values, b, q, bounds, found, taut)
            nq = q.size
            moves = -lu_solve(lu, partial[:nq])  # (m, n_params + n_taut): dq per unit, the equilibrium kept
            if not taut.any():
                moved = np.einsum("kij,jp->kip", eq.pose_jacobians(q), moves)  # (N+1, 6, n_params)
                blocks.append(partial[nq:] + self._moved_observations(rot, moved, sol, b))
                continue
            total = self._partials(values, b, q, bounds, found, taut, moves)[nq:]  # observations, then gaps
            n_obs, p = total.shape[0] - int(taut.sum()), values.size
            dt = -np.linalg.solve(total[n_obs:, p:], total[n_obs:, :p])  # dT_taut / d values
            blocks.append(total[:n_obs, :p] + total[:n_obs, p:] @ dt)
        return np.vstack(blocks)

    def _moved_observations(self, rot: np.ndarray, moved: np.ndarray, sol: StaticSolution, b: int) -> np.ndarray:
        """The whitened observations' change from the disks' moves ``moved`` (N+1, 6, n_params) (position, then the
        turn w of each frame), in the order of :meth:`observed`."""
        d = self.data
        parts = [rot @ moved[-1, :3] / d.sigma[b]]
        if d.tip_axis is not None and d.sigma_axis is not None:
            z = sol.disk_rotations[-1][:, 2]
            parts.append(rot @ np.cross(moved[-1, 3:].T, z).T / d.sigma_axis[b])
        for k, _ in d.disks:
            parts.append(rot @ moved[k, :3] / d.sigma[b])
        return np.vstack(parts)

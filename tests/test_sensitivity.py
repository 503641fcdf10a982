"""Exact derivatives of an equilibrium (issue 28, items 2 and 3): the tip's compliance against the cantilever's
closed forms and against solves under small tip wrenches, and the Jacobians by the tensions against central
differences of solves."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import rod
from scipy.spatial.transform import Rotation

from pytdcr import Loads, NoFriction, equilibrium_jacobians, solve, tip_compliance
from pytdcr.paper import paper_loads
from pytdcr.results import NotConvergedError

#: the compliance and the Jacobians against central differences of solves: relative to the largest entry
FD_RELATIVE = 1e-4
#: tensions with every tendon pulled (central differences need room on both sides of each tension) [N]
TENSIONS = np.array([4.0, 1.0, 0.5, 1.5, 2.0, 1.0, 0.5, 1.0])


def _turn(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation vector from frame b to frame a (base frame) [rad]."""
    return Rotation.from_matrix(a @ b.T).as_rotvec()


@pytest.mark.parametrize("n, bound", [(20, 0.0369), (40, 0.0186)])
def test_the_straight_robots_compliance_is_the_cantilevers(backbone, n, bound):
    """A straight rod clamped at the base: displacement by a tip force L^3/3EI, by a tip moment and rotation by a
    force L^2/2EI, rotation by a moment L/EI, twist L/GJ; no stretch (inextensible); a symmetric matrix. The
    PCC model's discretisation error in the force columns is the cantilever's (test_statics_physics: 3.7 % at
    20 disks, halving with each doubling); the rotation by a force is the discrete sum of the moments at the
    subsegments' bases, sum_k F k l * l / EI = F L^2 (1 + 1/N) / 2EI exactly; a pure moment bends the rod into
    an exact arc. The matrix is symmetric to the same 1/N (the balance about each base is first order)."""
    L = 0.4
    robot = rod(backbone, n, L)
    loads = Loads(np.zeros(0))
    c = tip_compliance(robot, loads, solve(robot, loads)).matrix
    EI, GJ = backbone.bending_stiffness, backbone.torsional_stiffness
    assert c[0, 0] == pytest.approx(L**3 / (3 * EI), rel=bound) and c[0, 0] > L**3 / (3 * EI)
    assert c[1, 1] == pytest.approx(c[0, 0], rel=1e-9)
    for force, moment, sign in ((0, 4, 1.0), (1, 3, -1.0)):  # Fx turns the tip about +y, Fy about -x
        assert sign * c[moment, force] == pytest.approx(L**2 * (1 + 1 / n) / (2 * EI), rel=1e-9)
        assert sign * c[force, moment] == pytest.approx(L**2 / (2 * EI), rel=1e-9)
    assert c[3, 3] == pytest.approx(L / EI, rel=1e-9) and c[4, 4] == pytest.approx(L / EI, rel=1e-9)
    assert c[5, 5] == pytest.approx(L / GJ, rel=1e-9)
    assert abs(c[2, 2]) <= 1e-12 * c[0, 0]
    np.testing.assert_allclose(c, c.T, atol=1.0 / n * np.abs(c).max())


@pytest.mark.parametrize("model", ["pcc", "pcc2", "sscr"])
def test_the_compliance_is_the_tips_yield_to_small_wrenches(paper, model):
    """Under the paper's load, friction and gravity: the compliance against central differences of solves
    continued under tip wrenches of +-1e-4 N and N m."""
    loads = paper_loads(TENSIONS)
    sol = solve(paper, loads, model=model)
    c = tip_compliance(paper, loads, sol, model=model).matrix
    h = 1e-4
    fd = np.empty((6, 6))
    for k in range(6):
        dw = np.zeros(6)
        dw[k] = h
        a, b = (solve(paper, replace(loads, tip_force=loads.tip_force + s * dw[:3],
                                     tip_moment=loads.tip_moment + s * dw[3:]), model=model, start=sol)
                for s in (1.0, -1.0))
        fd[:3, k] = (a.tip_position - b.tip_position) / (2 * h)
        fd[3:, k] = _turn(a.disk_rotations[-1], b.disk_rotations[-1]) / (2 * h)
    assert np.abs(fd - c).max() <= FD_RELATIVE * np.abs(c).max()


@pytest.mark.parametrize("model", ["pcc", "sscr"])
def test_the_jacobians_are_the_shapes_change_with_the_tensions(paper, model):
    loads = paper_loads(TENSIONS)
    sol = solve(paper, loads, model=model)
    jac = equilibrium_jacobians(paper, loads, sol, model=model)
    nt = paper.n_tendons
    assert jac.tip_position.shape == (3, nt) and jac.tip_pose.shape == (6, nt)
    assert jac.disk_positions.shape == (paper.n_disks + 1, 3, nt) and np.all(jac.disk_positions[0] == 0.0)
    np.testing.assert_array_equal(jac.disk_positions[-1], jac.tip_position)
    h = 1e-4
    fd_disks = np.empty_like(jac.disk_positions)
    fd_axis = np.empty_like(jac.tip_axis)
    for c in range(nt):
        a, b = (solve(paper, loads.with_tensions(TENSIONS + s * h * np.eye(nt)[c]), model=model, start=sol)
                for s in (1.0, -1.0))
        fd_disks[:, :, c] = (a.disk_positions - b.disk_positions) / (2 * h)
        fd_axis[:, c] = (a.disk_rotations[-1][:, 2] - b.disk_rotations[-1][:, 2]) / (2 * h)
    assert np.abs(fd_disks - jac.disk_positions).max() <= FD_RELATIVE * np.abs(jac.disk_positions).max()
    assert np.abs(fd_axis - jac.tip_axis).max() <= FD_RELATIVE * np.abs(jac.tip_axis).max()
    # the axis is a unit vector: its change is perpendicular to it
    z = sol.disk_rotations[-1][:, 2]
    assert np.abs(z @ jac.tip_axis).max() <= 1e-12 * np.abs(jac.tip_axis).max()
    out = json.loads(json.dumps(jac.to_dict()))
    assert len(out["tip_axis"]) == 3 and len(out["disk_positions"]) == paper.n_disks + 1


def test_bad_requests_are_refused(paper):
    loads = paper_loads(TENSIONS)
    sol = solve(paper, loads)
    with pytest.raises(ValueError, match=r"not an equilibrium|not a solution"):
        tip_compliance(paper, paper_loads(TENSIONS + 1.0), sol)
    with pytest.raises(ValueError, match="solved by model 'pcc'"):
        equilibrium_jacobians(paper, loads, sol, model="sscr")
    plain = paper.with_friction(NoFriction())
    rod_sol = solve(plain, loads, model="cosserat")
    with pytest.raises(ValueError, match="no exact pose derivatives"):
        tip_compliance(plain, loads, rod_sol, model="cosserat")
    bad = replace(sol, converged=False)
    with pytest.raises(NotConvergedError):
        tip_compliance(paper, loads, bad)


def test_tdcr_solve_prints_the_compliance_and_the_jacobians(capsys):
    from pytdcr.cli import main

    args = ["solve", "--tensions", ",".join(str(t) for t in TENSIONS), "--tip-force", "0.1,0.1,-0.1"]
    assert main([*args, "--compliance", "--jacobians", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    c = np.array(out["compliance"]["compliance"])
    assert c.shape == (6, 6) and c[0, 0] > 0
    lo, hi = out["compliance"]["translational_stiffness_range_N_per_m"]
    assert 0 < lo <= hi
    assert np.array(out["jacobians"]["tip_position"]).shape == (3, 8)
    assert main([*args, "--compliance"]) == 0
    assert "translational stiffness" in capsys.readouterr().out
    code = main([*args, "--friction", "none", "--model", "cosserat", "--compliance"])
    err = capsys.readouterr().err
    assert code == 2 and "--compliance" in err and "exact derivatives" in err


@pytest.mark.parametrize("model", ["pcc", "pcc2", "sscr"])
def test_the_compiled_tip_gradients_are_the_implicit_function_theorems(paper, model):
    """The compiled derivative is the reference arithmetic of the Python one, row by row, whatever
    the threads; a row without an equilibrium stays NaN."""
    from pytdcr.statics import solve_batch, tip_gradient
    from pytdcr.statics.compiled import _tip_derivative
    from pytdcr.statics.registry import resolve

    loads = paper_loads()
    T = np.random.default_rng(3).uniform(0.0, 20.0, (24, paper.n_tendons))
    batch = solve_batch(paper, T, loads, model=model, threads=1)
    ok = batch.converged
    assert ok.sum() >= 20
    m, opts = resolve(model, paper, loads, None)
    eq = m.equations(paper, loads, opts)
    ref = np.array([_tip_derivative(eq.with_tensions(t), q.reshape(-1))
                    for t, q in zip(T[ok], batch.q[ok], strict=True)])
    q = batch.q.copy()
    q[~ok] = np.nan
    one = m.tip_gradients(paper, T, loads, q, opts, threads=1)
    two = m.tip_gradients(paper, T, loads, q, opts, threads=2)
    assert np.array_equal(one, two, equal_nan=True)
    assert np.all(np.isnan(one[~ok]))
    assert np.allclose(one[ok], ref, rtol=0.0, atol=1e-12 * np.abs(ref).max())
    row = int(np.flatnonzero(ok)[0])
    sol = solve(paper, loads.with_tensions(T[row]), model=model)
    tip, grad = tip_gradient(paper, loads.with_tensions(T[row]), sol, model=model)
    assert np.array_equal(tip, sol.tip_position)
    assert np.allclose(grad, _tip_derivative(eq.with_tensions(T[row]), sol.q.reshape(-1)), rtol=0.0,
                       atol=1e-12 * np.abs(ref).max())
    with pytest.raises(ValueError, match="unknowns a row"):
        m.tip_gradients(paper, T, loads, q[:, :-1], opts)

"""Solver behaviour: honest convergence reports, warm starts, load stepping, batches."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SAME_SHAPE

from pytdcr import Loads, NotConvergedError, PCCEquations, SolverOptions, solve, solve_batch
from pytdcr.paper import PAPER_TIP_FORCE, PAPER_TIP_MOMENT

PAPER_LOAD = {"tip_force": PAPER_TIP_FORCE, "tip_moment": PAPER_TIP_MOMENT}


def test_non_convergence_is_reported_and_has_no_shape(paper):
    loads = Loads(np.array([19.2, 14.5, 10.8, 5.5, 3.2, 19.4, 10.3, 2.3]), **PAPER_LOAD)
    sol = solve(paper, loads, options=SolverOptions(max_iter=1, load_stepping="never"))
    assert not sol.converged
    assert sol.residual > sol.atol
    assert np.isfinite(sol.residual)
    for attr in ("tip_position", "disk_positions", "disk_rotations", "reach"):
        with pytest.raises(NotConvergedError, match="did not converge"):
            getattr(sol, attr)
    d = sol.to_dict()
    assert d["converged"] is False and d["tip_position"] is None and d["residual"] == sol.residual


def test_paper_load_needs_and_gets_load_stepping(paper):
    loads = Loads(np.array([19.2, 14.5, 10.8, 5.5, 3.2, 19.4, 10.3, 2.3]), **PAPER_LOAD)
    direct = solve(paper, loads, options=SolverOptions(load_stepping="never"))
    stepped = solve(paper, loads)
    assert stepped.converged
    assert stepped.residual <= stepped.atol
    if not direct.converged:
        assert stepped.load_steps > 0
    assert stepped.reach <= paper.length


def test_warm_start_reaches_the_same_equilibrium_faster(paper):
    t = np.array([4.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 3.0])
    cold = solve(paper, Loads(t))
    warm = solve(paper, Loads(t * 1.02), q0=cold.q)
    again = solve(paper, Loads(t * 1.02))
    assert warm.converged and again.converged
    assert np.allclose(warm.disk_positions, again.disk_positions, atol=SAME_SHAPE)
    assert warm.iterations <= again.iterations
    with pytest.raises(ValueError, match="q0 must have shape"):
        solve(paper, Loads(t), q0=np.zeros((3, 3)))


def test_stepping_and_direct_agree_when_unique(paper):
    t = np.array([6.0, 2.0, 0.0, 0.0, 1.0, 0.0, 5.0, 0.0])
    a = solve(paper, Loads(t), options=SolverOptions(load_stepping="never"))
    b = solve(paper, Loads(t), options=SolverOptions(load_stepping="always"))
    assert a.converged and b.converged and b.load_steps > 0
    assert np.allclose(a.disk_positions, b.disk_positions, atol=SAME_SHAPE)


def test_batch_matches_single_solves(paper):
    rng = np.random.default_rng(5)
    T = rng.uniform(0, 20, (12, 8))
    base = Loads(np.zeros(8), **PAPER_LOAD)
    batch = solve_batch(paper, T, base)
    for b in range(T.shape[0]):
        one = solve(paper, Loads(T[b], **PAPER_LOAD))
        assert one.converged == batch.converged[b]
        if one.converged:
            assert np.allclose(batch.tip_position[b], one.tip_position, atol=1e-12)
        else:
            assert np.all(np.isnan(batch.tip_position[b]))
    with pytest.raises(ValueError, match=r"tensions must have shape \(B, 8\)"):
        solve_batch(paper, T[:, :4])
    bad = T.copy()
    bad[3, 2] = -1.0
    with pytest.raises(ValueError, match=r"tensions\[3, 2\] \(case 4, tendon 3\) must be finite and >= 0"):
        solve_batch(paper, bad)


def test_model_checks_its_inputs(paper, rao):
    with pytest.raises(ValueError, match="tensions must have 8 entries"):
        PCCEquations.build(paper, Loads(np.zeros(6)))
    model = PCCEquations.build(rao, Loads(np.zeros(6)))
    with pytest.raises(ValueError, match="q must have 60 entries"):
        model.residual(np.zeros(5))
    with pytest.raises(ValueError, match=r"atol must be in \[1e-14, 0.0001\] N m"):
        SolverOptions(atol=-1)
    with pytest.raises(ValueError, match="load_stepping"):
        SolverOptions(load_stepping="sometimes")  # type: ignore[arg-type]


def test_default_follows_the_loading_branch(paper):
    """A tension vector with two equilibria under the paper's load (found by the GA).

    Ramping the loads in 100 small steps reaches the near-straight one (reach 0.39281 m); Newton at full
    load from the straight robot lands on a curled one. The default solve must give the loading branch.
    """
    t = np.array([15.111, 1.571, 20.0, 16.559, 20.0, 20.0, 12.737, 11.946])
    loads = Loads(t, **PAPER_LOAD)
    from pytdcr.kinematics import forward_kinematics

    q = np.zeros(3 * paper.n_disks)
    for lam in np.linspace(0.01, 1.0, 100):  # the loading path, by hand
        robot = paper.with_gravity(tuple(lam * np.array(paper.gravity)))
        q = solve(robot, loads.scaled(lam), q0=q.reshape(-1, 3),
                  options=SolverOptions(load_stepping="never")).q.ravel()
    ref = np.linalg.norm(forward_kinematics(q, paper.subsegment_lengths)[0][-1])
    default = solve(paper, loads)
    direct = solve(paper, loads, options=SolverOptions(load_stepping="never"))
    assert default.converged and direct.converged
    assert default.path == "loading"
    assert default.reach == pytest.approx(ref, abs=1e-8)
    assert abs(direct.reach - ref) > 0.05  # the other equilibrium


def test_batch_results_do_not_depend_on_what_ran_first():
    # numba's cached parallel kernel gave other last bits when the serial kernel had been loaded before it;
    # pytdcr.statics now loads the serial kernel at import, so every process computes the same bits
    import subprocess
    import sys

    code = (
        "import hashlib, sys, numpy as np\n"
        "from pytdcr import Loads, paper_loads, paper_robot, rao_robot, solve, solve_batch\n"
        "if sys.argv[1] == 'serial-first': solve(rao_robot(), Loads(np.ones(6)))\n"
        "T = np.random.default_rng(0).uniform(0, 20, (60, 8))\n"
        "b = solve_batch(paper_robot(), T, paper_loads())\n"
        "print(hashlib.sha1(b.q.tobytes()).hexdigest())\n"
    )
    out = [subprocess.run([sys.executable, "-c", code, mode], capture_output=True, text=True, check=True).stdout
           for mode in ("batch-first", "serial-first")]
    assert out[0] == out[1] and len(out[0].strip()) == 40


@pytest.mark.parametrize("model", ["sscr", "pcc"])
def test_a_converged_solve_is_an_equilibrium_at_full_load(paper, model):
    """Every row reported converged satisfies the equations at full load, re-evaluated at its own unknowns
    (to its own tolerance). Under the paper's load the sscr solver's arclength continuation once let its
    corrector carry the load factor past 1 and reported that equilibrium as the one at full load: row 30 of
    this batch, 2e-3 N m out of balance."""
    from pytdcr.paper import paper_loads
    from pytdcr.statics import resolve

    T = np.random.default_rng(0).uniform(0, 20, (40, paper.n_tendons))
    loads = paper_loads()
    batch = solve_batch(paper, T, loads, model=model)
    m, opts = resolve(model, paper, loads, None)
    assert batch.converged.sum() >= 38
    for k in np.flatnonzero(batch.converged):
        r = m.equilibrium_residual(paper, loads.with_tensions(T[k]), batch.q[k], opts)
        assert r <= max(batch.atol[k], batch.residual[k]) * 10, (k, r, batch.residual[k])

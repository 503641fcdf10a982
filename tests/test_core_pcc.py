"""The compiled PCC kernel (pytdcr._core.PccModel, src/cpp/pcc.hpp) against the numba kernel it twins
(pytdcr.statics.kernels.pcc).

The C++ kernel does the numba kernel's operations in the same order (no FMA contraction, no fast-math; the complex
step in std::complex with numba's own algorithms for complex division, sqrt, sin and cos, kinematics.hpp), so the
residual, the Jacobian, the tendon tensions and everything but the tip Jacobian must agree bit for bit. The tip
Jacobian's numba twin multiplies 3x3 matrices with BLAS (its own order of summation and fused multiply-adds), so
it agrees to round-off only. The Jacobian is also checked against central differences of the C++ residual alone.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from pytdcr import ConstantFriction, Loads, NoFriction, PointLoad, _core, paper_loads, paper_robot
from pytdcr.robot import Robot
from pytdcr.statics.kernels import pcc as K
from pytdcr.statics.pcc import PCCEquations

PccModel = _core.PccModel

N = 20  # the paper robot's disks
M = 3 * N
LAMS = (0.0, 0.3, 1.0)


def roundoff(reference: np.ndarray) -> float:
    """The round-off bound of a comparison that cannot be bit for bit: 1e-13 max(1, max |reference|)."""
    return 1e-13 * max(1.0, float(np.abs(reference).max()))


def robot_for(friction: str) -> Robot:
    """The paper robot (gravity on) with one of the friction laws: none, constant (mu = 0.3; mu = 1 clips the
    tension ratio under large bends) or the paper's exponential law."""
    law = {"none": NoFriction(), "constant": ConstantFriction(mu=0.3), "clipping": ConstantFriction(mu=1.0),
           "paper": None}[friction]
    return paper_robot(law)


def loads_for(case: str, rng: np.random.Generator, release: bool) -> Loads:
    """Tensions uniform in [0, 20] N (two of them exactly 0) under: the paper's tip wrench; a wrench at an
    intermediate disk (7) and another at the tip."""
    t = rng.uniform(0.0, 20.0, 8)
    t[[2, 5]] = 0.0
    if case == "tip":
        return paper_loads(t, release=release)
    mid = PointLoad(7, force=(0.05, -0.2, 0.1), moment=(0.02, 0.03, -0.04))
    return Loads(t, tip_force=(-0.1, 0.05, 0.2), tip_moment=(0.0, -0.05, 0.03), point_loads=(mid,), release=release)


def states(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Unknowns q (3N,): straight (exactly 0: the series branch, and straight tendons at the friction law's
    non-smooth point), near-straight, moderate and large bends, and a mix (series branch in some subsegments only:
    theta^2 = l^2 (beta^2 + gamma^2) < 1e-2 with l = 0.02 m means |kappa| < 5 /m)."""
    mixed = rng.normal(size=M) * 20.0
    mixed[: M // 2] *= 1e-3
    return {"zero": np.zeros(M), "tiny": rng.normal(size=M) * 1e-3, "moderate": rng.normal(size=M) * 3.0,
            "large": rng.normal(size=M) * 30.0, "mixed": mixed}


def numba_evaluate(packed: K.Packed, q: np.ndarray, lam: float, want_jac: bool):
    """r, J (or None) and the work's T (N+2, nt) from the numba kernel with fresh scratch."""
    r = np.empty(M)
    J = np.empty((M, M)) if want_jac else np.empty((1, 1))
    work = K.make_model_work(packed)
    K.evaluate(q, float(lam), packed, want_jac, r, J, work)
    return r, (J if want_jac else None), work.T.copy()


CASES = [(friction, release, load, balance)
         for friction in ("none", "constant", "paper")
         for release in (False, True)
         for load in ("tip", "mid")
         for balance in (K.BALANCE_BASE, K.BALANCE_MIDPOINT)
         if not (friction == "none" and release)]  # the mode does not act without friction


@pytest.mark.slow
@pytest.mark.parametrize(("friction", "release", "load", "balance"), CASES)
def test_evaluate_bit_identical(friction: str, release: bool, load: str, balance: int) -> None:
    rng = np.random.default_rng(zlib.crc32(repr((friction, release, load, balance)).encode()))
    packed = PCCEquations.build(robot_for(friction), loads_for(load, rng, release), balance=balance).packed
    model = PccModel.from_packed(packed)
    assert model.n_disks == N and model.n_unknowns == M and model.balance == balance
    for name, q in states(rng).items():
        for lam in LAMS:
            r0, J0, T0 = numba_evaluate(packed, q, lam, True)
            r1, J1, T1 = model.evaluate(q, lam, True)
            assert np.isfinite(J0).all(), name
            np.testing.assert_array_equal(r1, r0, err_msg=f"residual, q {name}, lam {lam}")
            np.testing.assert_array_equal(J1, J0, err_msg=f"Jacobian, q {name}, lam {lam}")
            np.testing.assert_array_equal(T1, T0, err_msg=f"tensions, q {name}, lam {lam}")
            # without the Jacobian: the same residual and tensions, no Jacobian
            r2, J2, T2 = model.evaluate(q, lam)
            assert J2 is None
            np.testing.assert_array_equal(r2, r0)
            np.testing.assert_array_equal(T2, T0)
            r3, _, T3 = numba_evaluate(packed, q, lam, False)
            np.testing.assert_array_equal(r3, r0)
            np.testing.assert_array_equal(T3, T0)
    # the loads act: tensions (lam = 1) and the wrenches change the residual
    q = states(rng)["moderate"]
    assert not np.array_equal(model.evaluate(q, 1.0)[0], model.evaluate(q, 0.0)[0])


@pytest.mark.slow
@pytest.mark.parametrize("balance", [K.BALANCE_BASE, K.BALANCE_MIDPOINT])
def test_clipped_tension_ratio_bit_identical(balance: int) -> None:
    """mu = 1 under large bends clips the tension ratio to 0 before the anchor (no tension beyond it)."""
    rng = np.random.default_rng(7 + balance)
    packed = PCCEquations.build(robot_for("clipping"), loads_for("tip", rng, False), balance=balance).packed
    model = PccModel.from_packed(packed)
    anchors = np.asarray(packed.anchor)
    clipped = 0
    for _ in range(3):
        q = rng.normal(size=M) * 40.0
        for lam in LAMS:
            r0, J0, T0 = numba_evaluate(packed, q, lam, True)
            r1, J1, T1 = model.evaluate(q, lam, True)
            np.testing.assert_array_equal(r1, r0)
            np.testing.assert_array_equal(J1, J0)
            np.testing.assert_array_equal(T1, T0)
        # pieces 2..anchor of a pulled tendon with T = 0: a clipped ratio upstream
        clipped += sum(int(np.sum(T1[2 : a + 1, c] == 0.0)) for c, a in enumerate(anchors) if T1[1, c] > 0)
    assert clipped > 0


def central_difference(model: PccModel, q: np.ndarray, lam: float) -> np.ndarray:
    """The Jacobian (3N, 3N) by central differences of the C++ residual, step 1e-6 max(1, |q_j|)."""
    out = np.empty((M, M))
    for j in range(M):
        h = 1e-6 * max(1.0, abs(q[j]))
        qp = q.copy()
        qm = q.copy()
        qp[j] += h
        qm[j] -= h
        out[:, j] = (model.evaluate(qp, lam)[0] - model.evaluate(qm, lam)[0]) / (qp[j] - qm[j])
    return out


@pytest.mark.parametrize("balance", [K.BALANCE_BASE, K.BALANCE_MIDPOINT])
@pytest.mark.parametrize("friction", ["none", "paper"])
def test_jacobian_matches_central_differences(friction: str, balance: int) -> None:
    """The exact Jacobian against central differences of the residual (O(h^2) truncation, round-off
    eps |r| / h): a check of the derivative chain that does not lean on the numba kernel."""
    rng = np.random.default_rng(11)
    packed = PCCEquations.build(robot_for(friction), loads_for("mid", rng, False), balance=balance).packed
    model = PccModel.from_packed(packed)
    q = rng.normal(size=M) * 4.0
    _, J, _ = model.evaluate(q, 1.0, True)
    fd = central_difference(model, q, 1.0)
    # column by column (each unknown's lane, down to the weakest), measured here at <= 4e-8 of the column
    scale = np.abs(J).max(axis=0)
    assert scale.min() > 0.0
    assert np.all(np.abs(J - fd).max(axis=0) <= 1e-6 * scale)


@pytest.mark.slow
def test_tip_jacobian_and_largest_angle() -> None:
    rng = np.random.default_rng(5)
    packed = PCCEquations.build(robot_for("paper"), loads_for("tip", rng, False)).packed
    model = PccModel.from_packed(packed)
    for name, q in states(rng).items():
        ref = K.tip_jacobian_of(q, packed, K.make_model_work(packed))
        got = model.tip_jacobian(q)
        assert got.shape == (3, M)
        # not bit for bit: numba's subsegment_derivatives multiplies 3x3 matrices with BLAS (its own summation
        # order and fused multiply-adds); the C++ sums left to right without FMA
        assert np.abs(got - ref).max() <= roundoff(ref), name
        if name == "zero":  # every product is exact on the straight robot
            np.testing.assert_array_equal(got, ref)
        dq = rng.normal(size=M) * np.array([50.0, 50.0, 0.5] * N)
        assert model.largest_angle(dq) == K.largest_angle(dq, packed)
        assert model.largest_angle(q) == K.largest_angle(q, packed)
    # the tip Jacobian against central differences of the C++ forward kinematics
    q = states(rng)["large"] * 0.3
    J = model.tip_jacobian(q)
    for j in range(M):
        qp = q.copy()
        qm = q.copy()
        qp[j] += 1e-6
        qm[j] -= 1e-6
        fd = (_core.frames(qp, packed.sub)[0][-1] - _core.frames(qm, packed.sub)[0][-1]) / 2e-6
        assert np.abs(fd - J[:, j]).max() <= 1e-8


@pytest.mark.slow
def test_with_tension_and_blend() -> None:
    rng = np.random.default_rng(9)
    robot = robot_for("paper")
    pa = PCCEquations.build(robot, loads_for("tip", rng, False)).packed
    pb = PCCEquations.build(robot.with_gravity((0.0, -9.81, 0.0)), loads_for("mid", rng, False)).packed
    a = PccModel.from_packed(pa)
    b = PccModel.from_packed(pb)
    q = states(rng)["moderate"]

    t = rng.uniform(0.0, 20.0, 8)
    mt = a.with_tension(t)
    np.testing.assert_array_equal(mt.tension, t)
    np.testing.assert_array_equal(a.tension, pa.tension)  # a itself unchanged
    ref = K.with_tension(pa, t)
    for lam in LAMS:
        r0, J0, T0 = numba_evaluate(ref, q, lam, True)
        r1, J1, T1 = mt.evaluate(q, lam, True)
        np.testing.assert_array_equal(r1, r0)
        np.testing.assert_array_equal(J1, J0)
        np.testing.assert_array_equal(T1, T0)

    for s in (0.0, 0.37, 1.0):
        ref = K.blend(pa, pb, s)
        got = a.blend(b, s)
        for field in ("sub", "holes", "fric", "tension", "grav", "pforce", "pmoment"):
            np.testing.assert_array_equal(getattr(got, field), getattr(ref, field), err_msg=f"{field}, s {s}")
        np.testing.assert_array_equal(np.asarray(got.anchor), ref.anchor)
        assert got.balance == ref.balance
        for lam in (0.3, 1.0):
            r0, J0, T0 = numba_evaluate(ref, q, lam, True)
            r1, J1, T1 = got.evaluate(q, lam, True)
            np.testing.assert_array_equal(r1, r0)
            np.testing.assert_array_equal(J1, J0)
            np.testing.assert_array_equal(T1, T0)
    # exactly a at s = 0 and b at s = 1, strictly between at 0.37
    np.testing.assert_array_equal(a.blend(b, 0.0).grav, pa.grav)
    np.testing.assert_array_equal(a.blend(b, 1.0).pforce, pb.pforce)
    mid = a.blend(b, 0.37).grav
    assert mid[1] < 0.0 and mid[2] < 0.0
    with pytest.raises(ValueError, match="same robot"):
        a.blend(PccModel.from_packed(PCCEquations.build(robot.with_disks(5), Loads(np.zeros(8))).packed), 0.5)


def test_bad_shapes_raise_value_error() -> None:
    packed = PCCEquations.build(robot_for("paper"), paper_loads(np.ones(8))).packed
    good = dict(packed._asdict())
    model = PccModel(**good)
    for field, bad, match in (("sub", packed.sub[:, :4], "sub must have shape"),
                              ("holes", packed.holes[:, :1], "holes must have shape"),
                              ("anchor", packed.anchor[:3], "anchor must have shape"),
                              ("anchor", np.full(8, N + 1), "anchor disks must be between"),
                              ("fric", packed.fric[:3], "fric must have shape"),
                              ("tension", np.ones(7), "tension must have shape"),
                              ("grav", np.zeros(2), "grav must have shape"),
                              ("pforce", np.zeros((N, 2)), "pforce must have shape"),
                              ("pmoment", np.zeros((N - 1, 3)), "pmoment must have shape"),
                              ("balance", 2, "balance must be")):
        with pytest.raises(ValueError, match=match):
            PccModel(**{**good, field: bad})
    for call in (lambda: model.evaluate(np.zeros(M - 1), 1.0), lambda: model.tip_jacobian(np.zeros((N, 3))),
                 lambda: model.largest_angle(np.zeros(M + 3)), lambda: model.with_tension(np.ones(9))):
        with pytest.raises(ValueError, match="must have shape"):
            call()

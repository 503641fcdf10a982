"""The compiled core's subsegment Cosserat rod (``pytdcr._core.SscrModel``, src/cpp/sscr.hpp) against the numba
kernel it twins (:mod:`pytdcr.statics.kernels.sscr`): the same operations in the same order, so the same bits.

Bit-identical: the residual, its Jacobian, the tensions, the tip and pose Jacobians, the shape, the wrenches from
poses, ``largest_angle``, ``with_tension`` and ``blend``. Numba's ``@`` on 3x3 matrices calls BLAS, whose FMA
accumulation the C++ reproduces with ``std::fma`` (sscr.hpp, ``blas_dot3``); where BLAS rounds otherwise (a CPU
without FMA), the derivatives are checked to round-off instead (:func:`blas_rounds_as_the_core`). The tangent
stiffness differs in the last bits everywhere: numba solves with LAPACK (``np.linalg.solve``), the C++ with
linalg.hpp's LU (both to round-off times the condition of the pose sensitivities).
"""

from __future__ import annotations

import threading
import zlib
from dataclasses import dataclass
from fractions import Fraction
from functools import cache

import numpy as np
import pytest

import pytdcr
from pytdcr import _core
from pytdcr.loads import Loads, PointLoad
from pytdcr.robot import ConstantFriction, NoFriction, Robot
from pytdcr.statics.kernels import sscr as SK
from pytdcr.statics.options import SSCROptions
from pytdcr.statics.sscr import SSCREquations

#: actuator tensions [N]: one tendon of each segment (anchored at disks 10 and 20) pulled
TENSIONS = np.array([2.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0])
LAMS = (0.0, 0.4, 1.0)


@dataclass(frozen=True)
class Case:
    """One robot under one load with one set of rod options."""

    name: str
    friction: str  # "paper" (the robot's exponential law), "none" or "constant"
    loads: str  # "paper" (tip wrench, pull), "release" or "points" (intermediate point wrenches)
    options: SSCROptions

    def robot(self) -> Robot:
        """The paper robot (gravity on) with this case's friction law."""
        friction = {"paper": None, "none": NoFriction(), "constant": ConstantFriction(mu=0.2)}[self.friction]
        return pytdcr.paper_robot(friction)

    def the_loads(self) -> Loads:
        """The loads of this case."""
        if self.loads == "paper":
            return pytdcr.paper_loads(TENSIONS)
        if self.loads == "release":
            return pytdcr.paper_loads(TENSIONS, release=True)
        points = (PointLoad(7, (0.05, -0.02, 0.01), (0.0, 0.01, -0.005)), PointLoad(13, (0.0, 0.03, 0.0)))
        return Loads(TENSIONS, tip_force=(0.0, 0.0, -0.05), point_loads=points)


CASES = [
    Case("paper", "paper", "paper", SSCROptions()),
    Case("paper-shear", "paper", "paper", SSCROptions(shear_extension=True)),
    Case("paper-7steps", "paper", "paper", SSCROptions(steps_per_subsegment=7)),
    Case("release", "paper", "release", SSCROptions()),
    Case("none-points", "none", "points", SSCROptions()),
    Case("constant-points-shear-1step", "constant", "points",
         SSCROptions(shear_extension=True, steps_per_subsegment=1)),
    Case("constant-release-shear", "constant", "release", SSCROptions(shear_extension=True)),
]


@cache
def equations(case: Case) -> SSCREquations:
    """The numba packed equations of a case."""
    return SSCREquations.build(case.robot(), case.the_loads(), case.options)


@cache
def solved_q(friction: str, loads: str) -> np.ndarray:
    """An equilibrium (6N,) of the paper robot under these loads, solved by the numba sscr solver (default rod)."""
    case = Case("solve", friction, loads, SSCROptions())
    sol = pytdcr.solve(case.robot(), case.the_loads(), model="sscr")
    assert sol.converged
    return np.ascontiguousarray(sol.q, dtype=float).reshape(-1)


def states(case: Case) -> dict[str, np.ndarray]:
    """q at which to compare: a solved state, it perturbed and a random moderate one (bending ~0.2 rad/disk)."""
    q = solved_q(case.friction, case.loads)
    rng = np.random.default_rng(zlib.crc32(case.name.encode()))
    return {"solved": q, "perturbed": q + rng.normal(scale=0.003, size=q.size),
            "random": rng.normal(scale=0.02, size=q.size)}


def numba_evaluate(p: SK.SSCRPacked, q: np.ndarray, lam: float, want_jac: bool
                   ) -> tuple[np.ndarray, np.ndarray | None, SK.SSCRWork]:
    """The numba kernel's residual, Jacobian (or None) and work at q."""
    m = q.size
    r = np.empty(m)
    J = np.empty((m, m)) if want_jac else np.empty((1, 1))
    work = SK.make_model_work(p)
    SK.evaluate(q, float(lam), p, want_jac, r, J, work)
    return r, (J if want_jac else None), work


def assert_same_bits(got: np.ndarray, want: np.ndarray, what: str) -> None:
    """Equal to the bit (the sign of a zero included; NaN where NaN), with the largest difference in the message."""
    got = np.ascontiguousarray(got, dtype=float)
    want = np.ascontiguousarray(want, dtype=float)
    assert got.shape == want.shape, (what, got.shape, want.shape)
    nan = np.isnan(want)
    if not (np.array_equal(np.isnan(got), nan) and np.array_equal(got[~nan].view(np.int64), want[~nan].view(np.int64))):
        diff = np.nanmax(np.abs(got - want))
        pytest.fail(f"{what}: not bit-identical, max |diff| = {diff:.3e} (max |ref| = {np.nanmax(np.abs(want)):.3e})")


@cache
def blas_rounds_as_the_core() -> bool:
    """Whether numba's 3x3 ``@`` (BLAS dgemm) rounds as sscr.hpp's ``blas_dot3``: a0 b0, then two fused
    multiply-adds (OpenBLAS on x86-64 with FMA). Exact sums of rationals give the correctly rounded fma."""
    from numba import njit

    def fma(x: float, y: float, z: float) -> float:
        return float(Fraction(x) * Fraction(y) + Fraction(z))

    product = njit(lambda a, b: a @ b.T)
    rng = np.random.default_rng(5)
    for _ in range(10):
        a, b = rng.normal(size=(2, 3, 3))
        want = [[fma(a[i, 2], b[j, 2], fma(a[i, 1], b[j, 1], a[i, 0] * b[j, 0])) for j in range(3)] for i in range(3)]
        if not np.array_equal(product(a, b), np.array(want)):
            return False
    return True


def assert_jacobian_twin(got: np.ndarray, want: np.ndarray, what: str) -> None:
    """A derivative (it goes through numba's 3x3 ``@``): to the bit where BLAS rounds as the core's ``blas_dot3``
    (this project's machines); elsewhere to round-off, max |diff| <= 1e-12 max(1, max |ref|)."""
    if blas_rounds_as_the_core():
        assert_same_bits(got, want, what)
    else:
        assert np.abs(got - want).max() <= 1e-12 * max(1.0, np.abs(want).max()), what


# --------------------------------------------------------------------------------------------- bit-identical
@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_residual_jacobian_and_tensions_are_the_numba_kernels_to_the_bit(case: Case) -> None:
    p = equations(case).packed
    model = _core.SscrModel.from_packed(p)
    for kind, q in states(case).items():
        for lam in LAMS:
            r, J, work = numba_evaluate(p, q, lam, True)
            rc, Jc, Tc = model.evaluate(q, lam, True)
            where = f"{case.name}, {kind} q, lam {lam}"
            assert np.all(np.isfinite(r)), where
            assert_same_bits(rc, r, f"residual ({where})")
            assert_jacobian_twin(Jc, J, f"Jacobian ({where})")
            assert_same_bits(Tc, work.T, f"tensions ({where})")
            # without the Jacobian: the same residual and tensions, no Jacobian
            rc0, Jc0, Tc0 = model.evaluate(q, lam)
            assert Jc0 is None
            assert_same_bits(rc0, r, f"residual without Jacobian ({where})")
            assert_same_bits(Tc0, work.T, f"tensions without Jacobian ({where})")
    # the tendons carry load: the pulled ones, friction dropping (pull) or rising (release) along them
    _, _, T = model.evaluate(states(case)["solved"], 1.0)
    assert T[1, 0] == 2.0 and T[1, 5] == 1.0 and T[11, 0] == 0.0 and T[21, 5] == 0.0


@pytest.mark.slow
def test_a_crushed_rod_gives_the_numba_kernels_nans() -> None:
    # an axial strain below -1 in subsegment 13 (shear and extension): no equilibrium, NaN from that disk on; the
    # C++ shortcuts past the sensitivities' zero columns stand down where a factor is not finite
    case = CASES[1]
    p = equations(case).packed
    model = _core.SscrModel.from_packed(p)
    q = states(case)["solved"].copy()
    q[6 * 12 + 2] = -2.0 * p.rod[1] * p.sub[12, 0]
    for lam in (0.4, 1.0):
        r, J, work = numba_evaluate(p, q, lam, True)
        rc, Jc, Tc = model.evaluate(q, lam, True)
        assert np.isnan(r).any() and np.isnan(J).any() and np.isfinite(r[:6 * 11]).all()
        assert_same_bits(rc, r, "crushed residual")
        if blas_rounds_as_the_core():
            assert_same_bits(Jc, J, "crushed Jacobian")
        else:
            np.testing.assert_array_equal(np.isnan(Jc), np.isnan(J))
        assert_same_bits(Tc, work.T, "crushed tensions")


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES[:3] + CASES[4:5], ids=lambda c: c.name)
def test_tip_and_pose_jacobians_are_the_numba_kernels_to_the_bit(case: Case) -> None:
    eq = equations(case)
    model = _core.SscrModel.from_packed(eq.packed)
    n = eq.n_disks
    for kind, q in states(case).items():
        S = model.pose_jacobians(q)
        assert_jacobian_twin(S, eq.pose_jacobians(q), f"pose Jacobians ({case.name}, {kind})")
        assert_jacobian_twin(model.tip_jacobian(q), eq.tip_jacobian(q), f"tip Jacobian ({case.name}, {kind})")
        assert S.shape == (n + 1, 6, 6 * n) and not S[0].any()  # the base does not move
        # the kernel's tip_jacobian_of reads the work of the last evaluation with the Jacobian
        _, _, work = numba_evaluate(eq.packed, q, 1.0, True)
        assert_jacobian_twin(model.tip_jacobian(q), SK.tip_jacobian_of(q, eq.packed, work), "tip_jacobian_of")


@pytest.mark.slow
@pytest.mark.parametrize("case", [CASES[0], CASES[2], CASES[5]], ids=lambda c: c.name)
def test_shape_and_wrenches_from_poses_are_the_numba_kernels_to_the_bit(case: Case) -> None:
    eq = equations(case)
    model = _core.SscrModel.from_packed(eq.packed)
    steps = case.options.steps_per_subsegment
    for kind, q in states(case).items():
        pos, rot, curve = model.record_shape(q)
        ref = eq.shape(q)
        for got, want, what in zip((pos, rot, curve), ref, ("positions", "rotations", "curve"), strict=True):
            assert_same_bits(got, want, f"{what} ({case.name}, {kind})")
        assert curve.shape == (eq.n_disks * steps + 1, 3)
        np.testing.assert_array_equal(curve[::steps], pos)  # the curve passes through every disk
        qw = np.empty(q.size)
        SK.wrenches_from_poses(ref[0], ref[1], eq.packed, qw)
        assert_same_bits(model.wrenches_from_poses(pos, rot), qw, f"wrenches from poses ({case.name}, {kind})")


@pytest.mark.slow
def test_largest_angle_is_the_numba_kernels_to_the_bit() -> None:
    p = equations(CASES[0]).packed
    model = _core.SscrModel.from_packed(p)
    rng = np.random.default_rng(11)
    for scale in (1e-6, 1e-2, 1.0):
        for _ in range(20):
            dq = rng.normal(scale=scale, size=model.n_unknowns)
            assert model.largest_angle(dq) == SK.largest_angle(dq, p)
    dq = np.zeros(model.n_unknowns)
    dq[0:3] = 5.0  # a force alone bends nothing
    assert model.largest_angle(dq) == 0.0
    dq[6 * 4 + 4] = 0.1  # l |dm| / min(EI, GJ) of subsegment 5
    sub = p.sub[4]
    assert model.largest_angle(dq) == sub[0] * 0.1 / min(sub[1], sub[2])


@pytest.mark.slow
def test_with_tension_and_blend_are_the_numba_kernels_to_the_bit() -> None:
    pa = equations(CASES[0]).packed  # paper tip wrench, gravity
    pb = equations(Case("b", "paper", "points", SSCROptions())).packed  # other loads, same robot
    a, b = _core.SscrModel.from_packed(pa), _core.SscrModel.from_packed(pb)
    q = states(CASES[0])["perturbed"]
    t = np.array([0.0, 3.0, 0.0, 1.5, 0.7, 0.0, 0.2, 0.0])
    mt, pt = a.with_tension(t), SK.with_tension(pa, t)
    np.testing.assert_array_equal(mt.tension, t)
    r, J, work = numba_evaluate(pt, q, 1.0, True)
    rc, Jc, Tc = mt.evaluate(q, 1.0, True)
    assert_same_bits(rc, r, "residual with other tensions")
    assert_jacobian_twin(Jc, J, "Jacobian with other tensions")
    assert_same_bits(Tc, work.T, "tensions with other tensions")
    np.testing.assert_array_equal(a.tension, pa.tension)  # a itself unchanged
    for s in (0.0, 0.37, 1.0):
        mc, pn = a.blend(b, s), SK.blend(pa, pb, s)
        for attr in ("tension", "grav", "pforce", "pmoment", "rod"):
            assert_same_bits(getattr(mc, attr), np.asarray(getattr(pn, attr)), f"blend {attr}, s = {s}")
        r, J, _ = numba_evaluate(pn, q, 0.4, True)
        rc, Jc, _ = mc.evaluate(q, 0.4, True)
        assert_same_bits(rc, r, f"blended residual, s = {s}")
        assert_jacobian_twin(Jc, J, f"blended Jacobian, s = {s}")
    # exactly a at s = 0 and b at s = 1
    for s, end in ((0.0, a), (1.0, b)):
        assert_same_bits(a.blend(b, s).evaluate(q, 1.0)[0], end.evaluate(q, 1.0)[0], f"blend at s = {s}")
    assert not np.array_equal(a.blend(b, 0.37).pforce, b.pforce)


# ------------------------------------------------------------------------------- to round-off, and physics
def test_the_jacobian_is_the_central_difference_of_the_residual() -> None:
    for case in (CASES[0], CASES[5]):
        model = _core.SscrModel.from_packed(equations(case).packed)
        for kind in ("solved", "random"):
            q = states(case)[kind]
            _, J, _ = model.evaluate(q, 1.0, True)
            h = 1e-7  # [N m]: truncation ~ h^2, rounding ~ 1e-16 |r| / h, both far below the bound
            fd = np.empty_like(J)
            for j in range(q.size):
                e = np.zeros(q.size)
                e[j] = h
                fd[:, j] = (model.evaluate(q + e, 1.0)[0] - model.evaluate(q - e, 1.0)[0]) / (2 * h)
            err = np.abs(fd - J).max()
            assert err <= 1e-6 * np.abs(J).max(), (case.name, kind, err, np.abs(J).max())


@pytest.mark.slow
def test_tangent_stiffness_agrees_with_the_numba_kernel_to_round_off() -> None:
    for case in (CASES[0], CASES[1], CASES[3], CASES[5]):
        eq = equations(case)
        model = _core.SscrModel.from_packed(eq.packed)
        n = eq.n_disks
        # the rod tangent_stiffness evaluates: with its real EA and GA
        fields = {f: np.asarray(getattr(eq.packed, f)) for f in SK.SSCRPacked._fields}
        fields["rod"] = fields["rod"].copy()
        fields["rod"][3] = 1.0
        ext = _core.SscrModel(**fields)
        for kind in ("solved", "perturbed"):
            q = states(case)[kind]
            m = q.size
            K = np.empty((m, m))
            SK.tangent_stiffness(q, eq.packed, SK.make_model_work(eq.packed), K)
            Kc = model.tangent_stiffness(q)
            # B: the residual's Jacobian, each disk's rows turned to the world; P: the disks' poses by the unknowns
            # (positions / l_i)
            _, J, _ = ext.evaluate(q, 1.0, True)
            rot = ext.record_shape(q)[1]
            B = np.einsum("iab,ihbj->ihaj", rot[1:], J.reshape(n, 2, 3, m)).reshape(m, m)
            P = ext.pose_jacobians(q)[1:].copy()
            P[:, :3, :] /= eq.packed.sub[:, 0, None, None]
            P = P.reshape(m, m)
            # not the same operations: numba solves P^T K^T = B^T with LAPACK (np.linalg.solve), the C++ with
            # linalg.hpp's LU with partial pivoting, row by row of K (B and P are the same bits). Two
            # backward-stable solves differ by up to ~eps cond(P) |K|; cond(P) ~ 4e5-9e5 here, measured
            # differences 4.9e-13 to 1.9e-12 of max |K| (above the 1e-12 kept for other round-off differences),
            # 1/100 of this bound
            scale = max(1.0, np.abs(K).max())
            bound = np.finfo(float).eps * np.linalg.cond(P) * scale
            assert np.abs(Kc - K).max() <= bound, (case.name, kind, np.abs(Kc - K).max(), bound)
            # and K is what it says: K P = B
            resid = np.abs(Kc @ P - B).max()
            assert resid <= 1e-10 * np.abs(B).max(), (case.name, kind, resid)


@pytest.mark.slow
def test_stiffness_range_writes_the_callers_array_with_the_gil_released() -> None:
    eq = equations(CASES[0])
    model = _core.SscrModel.from_packed(eq.packed)
    q0 = states(CASES[0])["solved"]
    qs = np.stack([q0, states(CASES[0])["perturbed"]])
    tensions = np.stack([TENSIONS, 0.8 * TENSIONS])
    rows = np.array([1, 0, 1], dtype=np.int64)
    m = q0.size
    out = np.full((2, m, m), np.nan)
    _core.stiffness_range_sscr(qs, model, tensions, rows, 1, 3, out)
    ref = np.full((2, m, m), np.nan)
    SK.stiffness_range(qs, eq.packed, tensions, rows, 1, 3, ref)
    for k, b in enumerate(rows[1:3]):
        assert_same_bits(out[k], model.with_tension(tensions[b]).tangent_stiffness(qs[b]), f"row {k}")
        # LAPACK vs this LU, as in the test above (eps cond(P) |K| ~ 1e-10 |K| there; measured below 1e-12)
        assert np.abs(out[k] - ref[k]).max() <= 1e-11 * max(1.0, np.abs(ref[k]).max())
    # two threads at once (the GIL released) compute the same
    outs = [np.zeros((2, m, m)) for _ in range(2)]
    threads = [threading.Thread(target=_core.stiffness_range_sscr, args=(qs, model, tensions, rows, 1, 3, o))
               for o in outs]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for o in outs:
        assert_same_bits(o, out, "threaded stiffness_range")
    with pytest.raises(TypeError):  # the caller's array or nothing: no silent copy to write into
        _core.stiffness_range_sscr(qs, model, tensions, rows, 1, 3, np.zeros((2, m, m), dtype=np.float32))
    with pytest.raises(ValueError, match="rows"):
        _core.stiffness_range_sscr(qs, model, tensions, np.array([0, 5]), 0, 2, out)
    with pytest.raises(ValueError, match="out must have shape"):
        _core.stiffness_range_sscr(qs, model, tensions, rows, 0, 3, out)


def test_a_model_refuses_wrong_shapes_with_a_clear_message() -> None:
    p = equations(CASES[0]).packed
    args = {f: np.asarray(getattr(p, f)) for f in SK.SSCRPacked._fields}
    _core.SscrModel(**args)
    for field, bad, message in (("sub", np.zeros((20, 4)), r"sub must have shape \(N, 5\)"),
                                ("rod", np.zeros(4), r"rod must have shape \(5,\), got \(4,\)"),
                                ("pforce", np.zeros((19, 3)), r"pforce must have shape \(20, 3\)"),
                                ("tension", np.zeros(7), r"tension must have shape \(8,\)"),
                                ("anchor", np.full(8, 21), "anchor disks must be between 1 and 20")):
        with pytest.raises(ValueError, match=message):
            _core.SscrModel(**{**args, field: bad})
    model = _core.SscrModel(**args)
    with pytest.raises(ValueError, match=r"q must have shape \(120,\), got \(60,\)"):
        model.evaluate(np.zeros(60))

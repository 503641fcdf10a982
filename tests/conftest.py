"""Shared fixtures and the tolerances of the validation tests (set in one place)."""

from __future__ import annotations

import os
import tempfile

import numpy as np
import pytest

from pytdcr import Backbone, Robot, Segment, paper_robot, rao_robot
from pytdcr.runtime import cache_dir

# the tests keep inverse statics' start pools in a folder of their own, not in the user's cache; the compiled
# kernels stay in the user's (a kernel cache is keyed by its sources, so no test can see a stale one), or every
# command a test runs in a new process would compile them afresh
if "PYTDCR_KERNEL_CACHE_DIR" not in os.environ and (_user_cache := cache_dir()) is not None:
    os.environ["PYTDCR_KERNEL_CACHE_DIR"] = str(_user_cache / "kernels")
os.environ["PYTDCR_CACHE_DIR"] = tempfile.mkdtemp(prefix="pytdcr-test-cache-")

#: solver tolerance on max |residual| [N m] (the library default)
ATOL = 1e-9
#: agreement expected between two converged solves of the same equilibrium [m]
SAME_SHAPE = 1e-9
#: finite-difference step and agreement for Jacobian checks (central differences)
FD_STEP = 1e-6
FD_AGREE = 1e-7


@pytest.fixture(scope="session")
def paper() -> Robot:
    return paper_robot()


@pytest.fixture(scope="session")
def rao() -> Robot:
    return rao_robot()


@pytest.fixture(scope="session")
def backbone() -> Backbone:
    return Backbone(youngs_modulus=54e9, poissons_ratio=0.3, outer_radius=0.7e-3)


def rod(backbone: Backbone, n: int, length: float = 0.4, **kw) -> Robot:
    """A single-segment robot without tendons or gravity (for closed-form checks)."""
    kw.setdefault("gravity", (0.0, 0.0, 0.0))
    kw.setdefault("tendons", ())
    return Robot(backbone=backbone, segments=(Segment(length=length, n_disks=n),), **kw)


def fd_jacobian(model, q: np.ndarray, h: float = FD_STEP) -> np.ndarray:
    """Central finite differences of ``model.residual`` at ``q`` (3N,)."""
    q = np.asarray(q, dtype=float).ravel()
    J = np.empty((q.size, q.size))
    for j in range(q.size):
        qp = q.copy()
        qm = q.copy()
        qp[j] += h
        qm[j] -= h
        J[:, j] = (model.residual(qp).ravel() - model.residual(qm).ravel()) / (2 * h)
    return J

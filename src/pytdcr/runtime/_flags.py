"""The numba options every kernel of the package is compiled with (:func:`pytdcr.runtime.njit` applies them).

Kept apart from the cache logic so that the kernel cache's key (:data:`pytdcr.runtime.KERNEL_SOURCES`) covers
them without covering the rest of the runtime: a kernel compiled under other options is never loaded.

- ``error_model="numpy"``: a float division by zero gives inf or NaN, as NumPy's does, instead of raising
  ``ZeroDivisionError`` out of a solve. The solvers read a non-finite residual as no equilibrium there (a line
  search backs off, a load step is halved, a solve ends not converged with its residual), so a trial step that
  overflows a chord's length is an unconverged answer, never a crash; where no division by zero happens the
  compiled arithmetic is the same.
"""

from __future__ import annotations

__all__ = ["KERNEL_OPTIONS"]

#: options passed to ``numba.njit`` for every kernel, unless a kernel sets them itself
KERNEL_OPTIONS: dict[str, object] = {"error_model": "numpy"}

"""Constants every solver shares, defined once: how an equilibrium was reached, and default tolerances.

The compiled kernels read the path codes as globals (frozen at compile time).
"""

from __future__ import annotations

__all__ = ["DEFAULT_ATOL", "LOAD_STEPPING", "PATH_DIRECT", "PATH_FALLBACK", "PATH_LOADING", "PATH_NAMES",
           "PATH_SELF_CONTACT", "PATH_SNAP", "TIGHT_ATOL"]

#: Newton from the start point at full load
PATH_DIRECT = 0
#: continuation along the loading path from the unloaded robot
PATH_LOADING = 1
#: the loading path, relaxed through a fold (snap-through)
PATH_SNAP = 2
#: the loading path failed; another equilibrium at full load
PATH_FALLBACK = 3
#: ``StaticSolution.path`` by path code
PATH_NAMES = ("direct", "loading", "snap", "fallback")
#: ``path`` of an equilibrium refused because the backbone passes through itself (:mod:`pytdcr.contact`)
PATH_SELF_CONTACT = "self-contact"

#: load-stepping modes by name, as the kernels take them
LOAD_STEPPING = {"never": 0, "auto": 1, "always": 2}

#: default convergence tolerance on max |residual| [N m] (MODEL.md)
DEFAULT_ATOL = 1e-9
#: tolerance of the solves a gradient search differentiates, and of the figures of an optimum [N m]
TIGHT_ATOL = 1e-12

"""The options of every model and the constants every solver shares, defined once.

- :class:`SolverOptions`: the compiled solver of the PCC family (``pcc``, ``pcc2``); :class:`SSCROptions` adds
  the subsegment Cosserat rod's; :class:`CosseratOptions`: the smeared Cosserat rod's shooting solver.
- How an equilibrium was reached (:class:`SolvePath`, and the integer ``PATH_*`` codes derived from it), the
  load-stepping modes and what the solver does at a fold (``FOLD_*``); the compiled kernels read these codes as
  globals (frozen at compile time).
- The default tolerances and the range every solver accepts (:func:`check_common_options`).
"""

from __future__ import annotations

import operator
from dataclasses import dataclass
from enum import StrEnum
from typing import Literal

import numpy as np

from ..validate import SettingsError, check_count, check_real, show_number

__all__ = ["DEFAULT_ATOL", "FOLDS", "FOLD_ARCLENGTH", "FOLD_RELAX", "FOLD_STOP", "LOAD_STEPPING", "MAX_ATOL",
           "MIN_ATOL", "MIN_STEP_SCALE", "PATH_CONTINUED", "PATH_DIRECT", "PATH_FALLBACK", "PATH_FOLD",
           "PATH_LOADING", "PATH_SNAP", "SAME_EQUILIBRIUM", "STEP_CONTINUE", "TIGHT_ATOL",
           "CosseratOptions", "ModelOptions", "SSCROptions", "SolvePath", "SolverOptions", "check_common_options"]


class SolvePath(StrEnum):
    """How an equilibrium was reached: ``StaticSolution.path`` and the entries of ``BatchSolution.path``.

    A member is a ``str`` equal to its value (``SolvePath.LOADING == "loading"``), and prints, formats and
    serialises as that value (``str``, f-strings, ``json.dumps``, ``csv``, pandas): the files written keep their
    text, and a path read back from one compares equal to its member (``SolvePath(text)`` gives the member).

    Each member has an integer :attr:`code` (:meth:`from_code` is its inverse). The six the compiled kernels
    return are 0 to 5, the ``PATH_*`` integers the kernels read as globals (:data:`PATH_DIRECT` ... derived
    from the members, so the values cannot drift apart). The two the Python side decides get negative codes,
    which no kernel returns: ``NO_START`` (-1, what the Python side writes into the kernels' code array for a
    row it did not solve) and ``SELF_CONTACT`` (-2, the verdict of :mod:`pytdcr.contact` on a converged
    equilibrium). ``SELF_CONTACT`` has a code rather than none so that every member round-trips through an
    integer array (a compact column, or the kernels' own code array overwritten after the contact check)
    and :attr:`code` never fails; a negative code always means "decided outside the kernels".
    """

    #: Newton from the start point at full load (``load_stepping`` ``"never"`` or ``"auto"``, or a warm start)
    DIRECT = "direct", 0
    #: continuation along the loading path, every load ramped from the unloaded robot to full load
    LOADING = "loading", 1
    #: the loading path, relaxed through a fold (the robot snapped through to another branch)
    SNAP = "snap", 2
    #: the loading path failed; another equilibrium at full load, found from the start point
    FALLBACK = "fallback", 3
    #: continuation from a solved state along the straight path of the loads to the new ones
    #: (``solve(..., start=solution)``)
    CONTINUED = "continued", 4
    #: the path met a fold and stopped there (``fold="stop"``): not converged, no snap-through sought
    FOLD = "fold", 5
    #: a batch row not continued because its start did not converge (``solve_batch(..., start=batch)``)
    NO_START = "no start", -1
    #: an equilibrium refused because the backbone passes through itself (:mod:`pytdcr.contact`); not converged
    SELF_CONTACT = "self-contact", -2

    _code: int

    def __new__(cls, value: str, code: int) -> SolvePath:
        member = str.__new__(cls, value)
        member._value_ = value
        member._code = code
        return member

    @property
    def code(self) -> int:
        """The member's integer code: the kernels' (0 to 5), or negative where Python decides (see the class)."""
        return self._code

    @classmethod
    def from_code(cls, code: int) -> SolvePath:
        """The member whose :attr:`code` is ``code`` (an integer; TypeError otherwise, ValueError if unknown)."""
        if isinstance(code, bool) or not isinstance(code, (int, np.integer)):
            raise TypeError(f"a path code must be an integer, got {type(code).__name__}")
        for member in cls:
            if member._code == operator.index(code):
                return member
        known = ", ".join(f"{m._code} ({m.value})" for m in cls)
        raise ValueError(f"unknown path code {code}: the codes are {known}")

    @classmethod
    def from_codes(cls, codes: np.ndarray) -> np.ndarray:
        """The members of an integer array of codes (any shape), as an object array of that shape (TypeError for
        codes that are not integers, ValueError naming an unknown one)."""
        codes = np.asarray(codes)
        if codes.size and not np.issubdtype(codes.dtype, np.integer):
            raise TypeError(f"path codes must be integers, got an array of {codes.dtype}")
        low = min(m._code for m in cls)
        table = np.array([cls.from_code(k) for k in range(low, max(m._code for m in cls) + 1)], dtype=object)
        index = codes.astype(np.int64) - low
        bad = (index < 0) | (index >= table.size)
        if np.any(bad):
            cls.from_code(int(codes[bad].flat[0]))  # raises, naming the codes there are
        return table[index]


#: the kernels' integer codes (read by :mod:`pytdcr.statics.kernels.loading_path` as compile-time globals:
#: plain ints, derived from :class:`SolvePath`)
PATH_DIRECT: int = SolvePath.DIRECT.code
PATH_LOADING: int = SolvePath.LOADING.code
PATH_SNAP: int = SolvePath.SNAP.code
PATH_FALLBACK: int = SolvePath.FALLBACK.code
PATH_CONTINUED: int = SolvePath.CONTINUED.code
PATH_FOLD: int = SolvePath.FOLD.code

#: how far past its own residual and tolerance a solution may be out of balance for the robot and loads it is
#: given with (a gradient's solution, a continuation's start) and still count as theirs
SAME_EQUILIBRIUM = 100.0

#: load-stepping modes by name, as the kernels take them
LOAD_STEPPING = {"never": 0, "auto": 1, "always": 2}
#: the kernels' stepping code of a continuation from a solved state (``solve(..., start=solution)``)
STEP_CONTINUE = 3

#: default convergence tolerance on max |residual| [N m] (MODEL.md)
DEFAULT_ATOL = 1e-9
#: tolerance of the solves a gradient search differentiates, and of the figures of an optimum [N m]
TIGHT_ATOL = 1e-12

#: at a fold, relax at full load from the last equilibrium (pseudo-transient continuation): the snap-through
FOLD_RELAX = 0
#: at a fold, follow the equilibrium curve through its turning points (pseudo-arclength) to full load
FOLD_ARCLENGTH = 1
#: at a fold, stop: the solve is not converged (path ``"fold"``) and no snap-through is sought; for callers that
#: only want equilibria reached without one (the workspace's boundary search, ``folds="stop"``)
FOLD_STOP = 2
#: fold handling by name, as the kernels take it
FOLDS = {"relax": FOLD_RELAX, "arclength": FOLD_ARCLENGTH, "stop": FOLD_STOP}

#: the loosest convergence tolerance accepted [N m]: a looser one passes poses visibly out of balance
MAX_ATOL = 1e-4
#: the tightest [N m]: below it the rounding of the moment balance itself decides convergence
MIN_ATOL = 1e-14
#: the finest load steps, as a fraction of the default ones (SolverOptions.step_scale)
MIN_STEP_SCALE = 1e-3
#: the most Newton iterations per attempt or load step (SolverOptions.max_iter, step_iter): the compiled solver
#: counts them in 64-bit integers, and more never converges what fewer did not
MAX_ITERATIONS = 100_000
#: the most shooting integrations of one root solve (CosseratOptions.max_eval)
MAX_EVALUATIONS = 1_000_000
#: the smallest bend of a subsegment one load step may aim at [rad] (SolverOptions.max_dtheta)
MIN_DTHETA = 1e-4


def check_common_options(atol: float, load_stepping: str) -> None:
    """Validate the options every solver shares; ValueError naming the field and its range."""
    if isinstance(atol, bool) or not isinstance(atol, (int, float, np.floating)):
        raise TypeError(f"atol must be a real number, got {type(atol).__name__}")
    if not (np.isfinite(atol) and MIN_ATOL <= atol <= MAX_ATOL):
        raise SettingsError("atol", f" must be in [{MIN_ATOL:g}, {MAX_ATOL:g}] N m (a looser tolerance passes poses "
                         f"visibly out of balance; a tighter one is below the rounding of the balance), got "
                         f"{show_number(atol, MIN_ATOL, MAX_ATOL)}")
    if load_stepping not in LOAD_STEPPING:
        raise SettingsError("load_stepping", f" must be one of {sorted(LOAD_STEPPING)}, got {load_stepping!r}")


@dataclass(frozen=True)
class SolverOptions:
    """Options of the compiled solver (the ``pcc`` and ``pcc2`` models).

    Parameters
    ----------
    atol : float
        Converged when max |residual| <= atol [N m].
    max_iter : int
        Newton iterations per attempt (per load step when stepping).
    max_dtheta : float
        Largest change of bend angle or twist of one subsegment per step [rad].
    load_stepping : {'always', 'auto', 'never'}
        'always' (default) follows the loading path from the unloaded robot;
        'auto' tries Newton at full load first and ramps only if it fails;
        'never' is Newton alone.
    step_iter : int
        Newton iterations allowed per load step before the step is halved.
    fold : {'relax', 'arclength', 'stop'}
        Where the loading path meets a fold: 'relax' at full load from the
        last equilibrium (pseudo-transient continuation: the snap-through),
        'arclength': follow the equilibrium curve through its turning
        points (pseudo-arclength continuation) to full load, or 'stop': the
        solve ends there, not converged (path ``"fold"``; no snap-through).
    step_scale : float
        Scales the loading path's steps: the bend or twist a load step aims at and the largest step
        (default 1; 0.25 takes steps four times finer: the reference the solver's path is checked against).
    """

    atol: float = DEFAULT_ATOL
    max_iter: int = 50
    max_dtheta: float = 0.5
    load_stepping: Literal["always", "auto", "never"] = "always"
    step_iter: int = 8
    fold: Literal["relax", "arclength", "stop"] = "relax"
    step_scale: float = 1.0

    def __post_init__(self) -> None:
        check_common_options(self.atol, self.load_stepping)
        object.__setattr__(self, "max_iter", check_count(self.max_iter, "max_iter", 1, MAX_ITERATIONS))
        object.__setattr__(self, "max_dtheta", check_real(self.max_dtheta, "max_dtheta", MIN_DTHETA, np.pi, "rad",
                                                          "at most half a turn; finer, the loading path takes "
                                                          "millions of steps"))
        object.__setattr__(self, "step_iter", check_count(self.step_iter, "step_iter", 1, MAX_ITERATIONS))
        if self.fold not in FOLDS:
            raise SettingsError("fold", f" must be one of {sorted(FOLDS)}, got {self.fold!r}")
        if isinstance(self.step_scale, bool) or not isinstance(self.step_scale, (int, float, np.floating)):
            raise TypeError(f"step_scale must be a real number, got {type(self.step_scale).__name__}")
        if not (np.isfinite(self.step_scale) and MIN_STEP_SCALE <= self.step_scale <= 1.0):
            raise SettingsError("step_scale", f" must be in [{MIN_STEP_SCALE:g}, 1] (a fraction of the default load "
                             f"steps), got {show_number(self.step_scale, MIN_STEP_SCALE, 1.0)}")


@dataclass(frozen=True)
class SSCROptions(SolverOptions):
    """Options of the subsegment Cosserat rod: the solver's (see :class:`SolverOptions`) and the rod's.

    Defaults differ from the PCC solver's where this model needs it: 12 Newton
    iterations per load step (its base-wrench unknowns make each step more
    nonlinear), and pseudo-arclength continuation through folds.

    Parameters
    ----------
    steps_per_subsegment : int
        Classical Runge-Kutta steps between neighbouring disks.
    shear_extension : bool
        The rod shears (GA) and stretches (EA); default inextensible and unshearable.
    """

    step_iter: int = 12
    fold: Literal["relax", "arclength", "stop"] = "arclength"
    steps_per_subsegment: int = 4
    shear_extension: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "steps_per_subsegment",
                           check_count(self.steps_per_subsegment, "steps_per_subsegment", 1, 1000))


@dataclass(frozen=True)
class CosseratOptions:
    """Options of the Cosserat model and its solver.

    Parameters
    ----------
    atol : float
        Converged when max |tip moment residual| <= atol [N m].
    max_eval : int
        Shooting integrations allowed per root solve.
    steps_per_subsegment : int
        Classical Runge-Kutta steps between neighbouring disks.
    shear_extension : bool
        Model shear (GA) and extension (EA) of the backbone; default inextensible.
    load_stepping : {'always', 'auto', 'never'}
        'always' (default) follows the loading path from the unloaded robot, as
        the PCC solver does; 'auto' solves at full load first; 'never' only that.
    """

    atol: float = DEFAULT_ATOL
    max_eval: int = 200
    steps_per_subsegment: int = 4
    shear_extension: bool = False
    load_stepping: Literal["always", "auto", "never"] = "always"

    def __post_init__(self) -> None:
        check_common_options(self.atol, self.load_stepping)
        object.__setattr__(self, "max_eval", check_count(self.max_eval, "max_eval", 4, MAX_EVALUATIONS))
        object.__setattr__(self, "steps_per_subsegment",
                           check_count(self.steps_per_subsegment, "steps_per_subsegment", 1, 1000))


#: the options of any registered model: what ``solve``, ``solve_batch``, the registry and the searches take as
#: ``options`` (each model takes its own class: :attr:`pytdcr.statics.Model.options_type`)
ModelOptions = SolverOptions | CosseratOptions | SSCROptions

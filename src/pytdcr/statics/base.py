"""What a static model is: the protocol every registered model satisfies, and the one refusal error.

A model turns a robot and its loads into equilibria. It declares what it
supports (:class:`Capabilities`); :func:`pytdcr.statics.registry.resolve`
checks a request against that declaration, in one place, before any model
code runs, and raises :class:`UnsupportedFeatureError` naming the model and
the feature.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Protocol, TypeVar, runtime_checkable

from ..runtime import announce_compiling

if TYPE_CHECKING:
    import numpy as np

    from ..limits import Resources
    from ..loads import Loads
    from ..results import BatchSolution, StaticSolution
    from ..robot import Robot
    from .options import ModelOptions

__all__ = ["Capabilities", "Model", "UnsupportedFeatureError", "announced", "compile_seconds"]

_M = TypeVar("_M", bound=Callable)


def announced(part: str) -> Callable[[_M], _M]:
    """Decorate a model's method that compiles ``part`` of the model (``"solver"``, ``"continuation"``, ``"tip
    gradient"``, ...) at its first call: while it runs, the first kernel compile of the process for that part
    says so once on stderr (:func:`pytdcr.runtime.announce_compiling`), with the time the model's
    ``compile_seconds[part]`` gives (measured cold on 2 cores by ``bench/compile_profile.py``)."""

    def decorate(method: _M) -> _M:
        @functools.wraps(method)
        def call(self: Model, *args: object, **kwargs: object) -> object:
            with announce_compiling(f"the {self.name} model's {part}", compile_seconds(self, part)):
                return method(self, *args, **kwargs)

        return call  # type: ignore[return-value]

    return decorate


def compile_seconds(model: Model, part: str) -> float:
    """About how long ``part`` of ``model`` takes to compile at its first use [s] (60 where not measured)."""
    return float(getattr(model, "compile_seconds", {}).get(part, 60.0))



class UnsupportedFeatureError(ValueError):
    """A model was asked for something it does not model.

    Attributes
    ----------
    model : str
        The model's registered name.
    feature : str
        What it was asked for.
    setting : str
        The setting that asked for it (``"model"``: the request itself; ``"multistability"``, ...), for the
        command line to name its option.
    """

    def __init__(self, model: str, feature: str, hint: str = "", *, setting: str = "model") -> None:
        self.model = model
        self.feature = feature
        self.setting = setting
        super().__init__(f"model '{model}' does not support {feature}" + (f"; {hint}" if hint else ""))


@dataclass(frozen=True)
class Capabilities:
    """What a model supports.

    Attributes
    ----------
    friction : bool
        Tendon-disk friction laws (constant, exponential; pull and release).
        Without it, only robots whose law is frictionless are accepted.
    point_wrenches : bool
        External wrenches at disks other than the tip.
    gradient : {'exact', 'finite differences'} or None
        How :meth:`Model.tip_gradient` differentiates the tip by the tensions.
    stability : bool
        The model tests an equilibrium's static stability (the eigenvalues of
        its tangent stiffness, :mod:`pytdcr.statics.stability`); without it,
        ``StaticSolution.stable`` is None.
    continuation : bool
        The model continues a solved equilibrium to other loads along its branch
        (``solve(..., start=solution)``, :func:`pytdcr.statics.solve`).
    """

    friction: bool
    point_wrenches: bool
    gradient: Literal["exact", "finite differences"] | None
    stability: bool = False
    continuation: bool = False


@runtime_checkable
class Model(Protocol):
    """A static model of a tendon-driven continuum robot.

    Attributes
    ----------
    name : str
        Its name in the registry (``--model NAME``).
    description : str
        One line for ``--help``.
    options_type : type
        A frozen dataclass with ``atol`` [N m] and ``load_stepping``; its
        defaults are the model's defaults.
    capabilities : Capabilities
    unknowns : str
        What ``StaticSolution.q`` holds for this model.
    iteration_unit : str
        What ``StaticSolution.iterations`` counts.
    """

    name: str
    description: str
    options_type: type
    capabilities: Capabilities
    unknowns: str
    iteration_unit: str

    def default_options(self) -> ModelOptions:
        """An ``options_type`` with the model's defaults."""

    def solve(self, robot: Robot, loads: Loads, q0: np.ndarray | None, options: ModelOptions) -> StaticSolution:
        """One equilibrium (inputs already checked by the registry)."""

    def solve_batch(self, robot: Robot, tensions: np.ndarray, loads: Loads, q0: np.ndarray | None,
                    options: ModelOptions, threads: int | None = None) -> BatchSolution:
        """One equilibrium per row of ``tensions`` (B, n_tendons) [N] under ``loads``' external wrenches."""

    def equilibrium_residual(self, robot: Robot, loads: Loads, q: np.ndarray, options: ModelOptions) -> float:
        """max |residual| [N m] of the model's equations for ``robot`` under ``loads`` at the unknowns ``q``
        (ValueError when ``q`` has another shape than this robot's unknowns)."""

    def tip_gradient(self, robot: Robot, loads: Loads, solution: StaticSolution,
                     options: ModelOptions) -> tuple[np.ndarray, np.ndarray]:
        """Tip (3,) [m] of a converged equilibrium and its derivative by the tensions (3, n_tendons) [m/N]."""

    def tip_gradients(self, robot: Robot, tensions: np.ndarray, loads: Loads, q: np.ndarray, options: ModelOptions,
                      threads: int | None = None) -> np.ndarray:
        """:meth:`tip_gradient` at many equilibria ``q`` (B, ...) at ``tensions`` (B, n_tendons) [N]: shape
        (B, 3, n_tendons) [m/N], NaN rows where ``q[b]`` is not finite."""

    def resources(self, robot: Robot, options: ModelOptions) -> Resources:
        """The peak memory and rough time of one solve, for the memory budget (:mod:`pytdcr.limits`)."""

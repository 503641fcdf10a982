"""The registry of static models: names to models, and the one place a request is checked.

Adding a model: one module that defines a class satisfying
:class:`~pytdcr.statics.base.Model` (for a model the shared compiled solver
solves, a :class:`~pytdcr.statics.compiled.CompiledModel` that names its kernel
module under :mod:`pytdcr.statics.kernels`), one line in :data:`MODELS`, and
its tests. :func:`register` makes the kernels known to the compiled solver.
Everything else (``solve``, ``solve_batch``, the comparison, the workspace,
the optimiser, ``--model`` on the command line) finds it here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from ..limits import Resources, check_memory, human_seconds
from ..loads import Loads
from ..records import JsonDict
from ..robot import Robot
from ..validate import SettingsError
from .base import Model, UnsupportedFeatureError
from .cosserat import COSSERAT
from .kernels.loading_path import register_kernels
from .options import ModelOptions
from .pcc import PCC
from .pcc2 import PCC2
from .sscr import SSCR

__all__ = ["MODELS", "check_resources", "configure", "get_model", "get_models", "options_record", "register",
           "resolve"]


def register(*models: Model) -> dict[str, Model]:
    """``models`` by name; each compiled model's kernel module is registered with the shared compiled solver
    (:func:`pytdcr.statics.kernels.loading_path.register_kernels`), keyed by its packed-equation type."""
    out: dict[str, Model] = {}
    for m in models:
        if m.name in out:
            raise ValueError(f"two models named {m.name!r}")
        if getattr(m, "kernels", None) is not None:
            register_kernels(m.packed_type, m.kernels)
        out[m.name] = m
    return out


#: every registered model by name (the one registry: adding a model is one entry here)
MODELS: dict[str, Model] = register(PCC, PCC2, SSCR, COSSERAT)


def get_model(model: str | Model) -> Model:
    """The model registered under ``model``, or ``model`` itself if it is a :class:`Model`.

    Raises
    ------
    ValueError
        For an unknown name, listing the registered ones.
    TypeError
        For anything else.
    """
    if isinstance(model, str):
        try:
            return MODELS[model]
        except KeyError:
            raise ValueError(f"model must be one of {list(MODELS)}, got {model!r}") from None
    if any(model is m for m in MODELS.values()):  # a registered model (the protocol check costs 30 us a call)
        return model
    if isinstance(model, Model):
        return model
    raise TypeError(f"model must be a registered name ({', '.join(MODELS)}) or a Model, got {type(model).__name__}")


def get_models(models: Sequence[str | Model], field: str = "models") -> tuple[Model, ...]:
    """The models of ``models`` (registered names or :class:`Model` objects), in order.

    Raises
    ------
    SettingsError
        Naming ``field`` and the first unknown name, listing the registered ones.
    """
    for m in models:
        if isinstance(m, str) and m not in MODELS:
            raise SettingsError(field, f": {m!r} is not a model; choose from {', '.join(MODELS)}")
    return tuple(get_model(m) for m in models)


def configure(model: str | Model, options: ModelOptions | None = None, **overrides: object) -> ModelOptions:
    """``options`` (default: the model's defaults) with ``overrides`` applied.

    An override the model's options do not have is a feature the model does
    not support: :class:`UnsupportedFeatureError`.
    """
    m = get_model(model)
    opts = m.default_options() if options is None else options
    if not isinstance(opts, m.options_type):
        raise TypeError(f"model {m.name!r} takes {m.options_type.__name__}, got {type(opts).__name__}")
    fields = {f.name for f in dataclasses.fields(opts)}
    for key in overrides:
        if key not in fields:
            raise UnsupportedFeatureError(m.name, f"the option {key!r}",
                                          f"its options are {', '.join(sorted(fields))}")
    return dataclasses.replace(opts, **overrides) if overrides else opts


def resolve(model: str | Model, robot: Robot, loads: Loads | None = None, options: ModelOptions | None = None, *,
            gradient: bool = False, stability: bool = False,
            continuation: bool = False) -> tuple[Model, ModelOptions]:
    """Check a request against the model's capabilities; return the model and its options.

    Parameters
    ----------
    model : str or Model
    robot : Robot
    loads : Loads, optional
    options : the model's options type, optional
        Default: the model's defaults.
    gradient : bool
        The caller needs :meth:`Model.tip_gradient`.
    stability : bool
        The caller needs the static stability test.
    continuation : bool
        The caller continues a solved state (``start=``).

    Raises
    ------
    UnsupportedFeatureError
        Naming the model and the feature it does not model.
    ResourceLimitError
        When one solve would need more memory than the budget (:mod:`pytdcr.limits`), with the estimate.
    TypeError
        When ``robot``, ``loads`` or ``options`` have the wrong type.
    """
    m = get_model(model)
    opts = configure(m, options)
    if not isinstance(robot, Robot):
        raise TypeError(f"robot must be a pytdcr.Robot, got {type(robot).__name__}")
    if loads is not None and not isinstance(loads, Loads):
        raise TypeError(f"loads must be a pytdcr.Loads, got {type(loads).__name__}")
    caps = m.capabilities
    if not caps.friction and not robot.friction.is_frictionless:
        raise UnsupportedFeatureError(m.name, "tendon friction",
                                      f"robot '{robot.name}' has law '{robot.friction.law}': use friction 'none' "
                                      "(--friction none)")
    if not caps.point_wrenches and loads is not None and any(p.disk != robot.n_disks for p in loads.point_loads):
        raise UnsupportedFeatureError(m.name, "wrenches at disks other than the tip")
    if gradient and caps.gradient is None:
        raise UnsupportedFeatureError(m.name, "a tip gradient (needed by the gradient search)")
    if stability and not caps.stability:
        raise UnsupportedFeatureError(m.name, "the static stability test")
    if continuation and not caps.continuation:
        raise UnsupportedFeatureError(m.name, "continuation from a solved state (start=)",
                                      "solve from rest, or with q0= as a start point at full load")
    check_resources(m, robot, opts)
    return m, opts


def check_resources(model: Model, robot: Robot, options: ModelOptions, concurrent: int = 1, extra_bytes: float = 0.0,
                    what: str = "") -> Resources | None:
    """Refuse work on ``robot`` that needs more memory than the budget (:mod:`pytdcr.limits`).

    ``concurrent`` solves at once (a batch's threads) plus ``extra_bytes`` (its results). Returns the
    model's estimate for one solve (None for a model object that gives none).
    """
    estimate = getattr(model, "resources", None)
    if estimate is None:
        return None
    res = estimate(robot, options)
    label = what or (f"a '{model.name}' solve of robot '{robot.name}' ({robot.n_disks} disks"
                     + (f", {concurrent} at once" if concurrent > 1 else "") + ")")
    check_memory(label, concurrent * res.bytes + extra_bytes,
                 f"{res.unknowns:,} unknowns, a dense {res.unknowns:,} x {res.unknowns:,} Jacobian; an unloaded "
                 f"solve would take about {human_seconds(res.seconds)}, a loaded one several times longer")
    return res


def options_record(model: str | Model, options: ModelOptions | None = None) -> JsonDict:
    """The model's name and its options (defaults filled in), JSON-ready."""
    m = get_model(model)
    return {"model": m.name, **dataclasses.asdict(configure(m, options))}

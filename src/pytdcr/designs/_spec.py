"""A design study's file (TOML), validated strictly before any work: the base robot, the parameters to vary,
how designs are chosen, the load cases, the tension bounds, the model, the per-design budget and the measures.

An example (``examples/design_study_small.toml`` is a complete one)::

    name = "routing"
    robot = "paper"            # a built-in robot or a robot TOML file (relative to the study file)
    seed = 7
    bounds = [0.0, 20.0]       # every tendon's tension bounds [N]
    model = "pcc"

    [designs]
    method = "grid"            # "grid" (every combination), "sobol" (count points, seeded) or "optimize"
                               # (NSGA-II: population designs a generation, for generations)

    [parameters]
    routing_radius_2 = { values = [0.006, 0.008] }
    segment_length_1 = { range = [0.15, 0.25], steps = 3 }

    [budget]
    samples = 200              # base samples per design and load case
    search = 0                 # boundary-search solves per design and load case (fills the region: without
                               # them the volume is only the voxels the samples hit, far below the FSW's)
    voxel = 0.05               # the volume's voxel edge [m] (default the base robot's length / 32)
    folds = "stop"             # where a search step meets a fold: "snap" through it (default) or "stop" there

    [loads]
    cases = ["paper wrench"]   # names of tdcr workspace --compare-loads; custom ones below
    custom.heavy = { tip_force = [0.0, 0.0, -0.5] }

    [measures]
    directions = { up = [0.0, 0.0, 1.0] }   # h(d) along each named direction

    [[objectives]]             # what "best" means: the Pareto front, the optimiser's goals (default: the
    measure = "volume_m3"      # FSW volume, max, and the peak stress, min, under the first load case)
    goal = "max"
    load_case = "paper wrench"
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..io import format_validation_error, load_robot, read_toml
from ..loads import Loads
from ..paper import workspace_load_cases
from ..records import JsonObject
from ..robot import Robot
from ..statics import MODELS
from ..validate import unit_vector
from ..workspace import WorkspaceSettings
from ._space import apply_parameters, parameter_info

__all__ = ["LOAD_CASE_NAMES", "MAX_DESIGNS", "MEASURES", "DesignStudy", "Objective", "Parameter", "StudyError",
           "load_study", "measures_for", "study_from_dict"]

#: the most designs one study may hold (a grid multiplies quickly)
MAX_DESIGNS = 100_000
#: the load cases a study may name (those of ``tdcr workspace --compare-loads``)
LOAD_CASE_NAMES = ("no load", "gravity only", "payload 5 g", "payload 10 g", "payload 20 g", "paper wrench")
#: the measures of every row, with their units (h along the study's named directions come after, ``h_<name>_m``)
MEASURES = {
    "volume_m3": "FSW volume (converged, stable equilibria) [m^3]",
    "volume_err_m3": "its error [m^3]",
    "realisable_volume_m3": "volume of the realisable region (no disk below the base, no disks touching) [m^3]",
    "realisable_volume_err_m3": "its error [m^3]",
    "fsw_dimension": "dimensions the FSW's tips span at the voxel's resolution (0-3); below 3 its volume is 0",
    "largest_reach_m": "largest ||tip|| over the feasible samples and the tips attaining h (searched when "
                       "budget.reach_search) [m]",
    "fraction_converged": "converged samples / samples solved",
    "fraction_realisable": "realisable samples / converged samples",
    "peak_stress_pa": "largest backbone bending stress E kappa r over the converged samples [Pa]",
    "arc_length_m": "the robot's length [m]",
}


def measures_for(model: str) -> dict[str, str]:
    """:data:`MEASURES` as they hold for a study solved by ``model``: the FSW's samples are its converged
    equilibria, the unstable ones left out where the model tests stability, and said to be untested where it
    does not (:func:`pytdcr.statics.feasible_words`)."""
    from ..statics import feasible_words, stability_test

    test = stability_test(model)
    if test == "run":
        return dict(MEASURES)
    return {**MEASURES, "volume_m3": f"FSW volume ({feasible_words(test)} equilibria) [m^3]"}


class StudyError(ValueError):
    """A study file that cannot be used: names the key, the value and what is allowed."""


class _Strict(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", strict=True)


Finite = Annotated[float, Field(allow_inf_nan=False)]
Vector = Annotated[list[Finite], Field(min_length=3, max_length=3)]
Pair = Annotated[list[Finite], Field(min_length=2, max_length=2)]


class Parameter(_Strict):
    """One varied parameter: a list of ``values``, or a ``range`` [lo, hi] (with ``steps`` for a grid)."""

    values: list[Finite] | None = Field(default=None, min_length=1, max_length=10_000)
    range: Pair | None = None
    steps: Annotated[int, Field(ge=1, le=10_000)] | None = None

    @model_validator(mode="after")
    def _one_kind(self) -> Parameter:
        if (self.values is None) == (self.range is None):
            raise ValueError("give either values = [...] or range = [lo, hi]")
        if self.range is not None and not self.range[0] <= self.range[1]:
            raise ValueError(f"range = {list(self.range)}: lo must not exceed hi")
        if self.values is not None and self.steps is not None:
            raise ValueError("steps goes with range, not with values")
        if self.values is not None and not all(np.isfinite(v) for v in self.values):
            raise ValueError("values must be finite numbers")
        return self


class Designs(_Strict):
    """How designs are chosen: every combination (``grid``), or ``count`` scrambled Sobol points (``sobol``)."""

    method: Literal["grid", "sobol", "optimize"] = "grid"
    count: Annotated[int, Field(ge=1, le=MAX_DESIGNS)] | None = None
    population: Annotated[int, Field(ge=4, le=10_000)] | None = None
    generations: Annotated[int, Field(ge=1, le=10_000)] | None = None

    @model_validator(mode="after")
    def _count(self) -> Designs:
        if self.method == "sobol" and self.count is None:
            raise ValueError("method = 'sobol' needs count = N (designs)")
        if self.method != "sobol" and self.count is not None:
            raise ValueError(f"count goes with method = 'sobol', not {self.method!r}")
        wants = self.method == "optimize"
        for key in ("population", "generations"):
            if wants and getattr(self, key) is None:
                raise ValueError(f"method = 'optimize' needs {key} = N")
            if not wants and getattr(self, key) is not None:
                raise ValueError(f"{key} goes with method = 'optimize', not {self.method!r}")
        if wants and self.population * self.generations > MAX_DESIGNS:
            raise ValueError(f"population x generations = {self.population * self.generations:,} designs; at most "
                             f"{MAX_DESIGNS:,}")
        return self

    @property
    def total(self) -> int | None:
        """The number of designs for optimize (population x generations); None otherwise."""
        return self.population * self.generations if self.method == "optimize" else None


class Budget(_Strict):
    """Work per design and load case: base samples, boundary-search solves, whether to search the largest reach,
    the volume's voxel edge [m] (the same for every design; default the base robot's length / 32), and what a
    search step does at a fold (:attr:`~pytdcr.workspace.WorkspaceSettings.FOLD_RULES`: ``"snap"`` through it,
    or ``"stop"`` there, about half the search's cost under a load)."""

    samples: Annotated[int, Field(ge=16, le=1_000_000)] = 500
    search: Annotated[int, Field(ge=0, le=100_000_000)] = 0
    reach_search: bool = False
    voxel: Annotated[float, Field(gt=1e-4, le=1.0, allow_inf_nan=False)] | None = None
    folds: Literal[WorkspaceSettings.FOLD_RULES] = WorkspaceSettings.FOLD_RULES[0]  # type: ignore[valid-type]


class CustomLoad(_Strict):
    """A load case of the study's own: a tip wrench (base frame) with or without gravity."""

    tip_force: Vector = [0.0, 0.0, 0.0]
    tip_moment: Vector = [0.0, 0.0, 0.0]
    gravity: bool = True


class LoadCases(_Strict):
    """Named cases (:data:`LOAD_CASE_NAMES`) and custom ones."""

    cases: list[Literal[LOAD_CASE_NAMES]] = ["paper wrench"]  # type: ignore[valid-type]
    custom: dict[str, CustomLoad] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _some(self) -> LoadCases:
        if not self.cases and not self.custom:
            raise ValueError("no load case: name at least one in cases = [...] or add a custom one")
        for name in self.custom:
            if not name.strip() or not all(c.isprintable() and c not in "|`" for c in name):
                raise ValueError(f"custom load case name {name!r}: printable, not empty, without | or ` (it names "
                                 "rows and report lines)")
        clash = set(self.cases) & set(self.custom)
        if clash:
            raise ValueError(f"custom load case {sorted(clash)[0]!r} has the name of a built-in case")
        return self


class Measures(_Strict):
    """What is measured beyond the fixed set: h(d) along each named direction."""

    directions: dict[str, Vector] = Field(default_factory=dict)

    @field_validator("directions")
    @classmethod
    def _unit(cls, v: dict[str, list[float]]) -> dict[str, list[float]]:
        for name, d in v.items():
            if not name.isidentifier():
                raise ValueError(f"direction name {name!r}: letters, digits and _ only (it names a column)")
            if not np.any(d):
                raise ValueError(f"direction {name!r} is zero")
            unit_vector(d, f"direction {name!r}")  # any scale is a direction; all-subnormal has none
        return v


class Objective(_Strict):
    """One goal: a measure (:data:`MEASURES` or ``h_<direction>_m``) to ``max``imise or ``min``imise under a
    load case (default: the study's first)."""

    measure: str
    goal: Literal["max", "min"]
    load_case: str | None = None


def _default_objectives() -> list[Objective]:
    return [Objective(measure="volume_m3", goal="max"), Objective(measure="peak_stress_pa", goal="min")]


class DesignStudy(_Strict):
    """A validated study file (see the module's docstring); ``robot`` is the base robot's name or file."""

    name: Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.\- ]+$")] = "study"
    robot: str = "paper"
    seed: Annotated[int, Field(ge=0, le=2**63 - 1)] = 0
    bounds: Pair = [0.0, 20.0]
    model: str = "pcc"
    designs: Designs = Field(default_factory=Designs)
    parameters: dict[str, Parameter] = Field(min_length=1)
    budget: Budget = Field(default_factory=Budget)
    loads: LoadCases = Field(default_factory=LoadCases)
    measures: Measures = Field(default_factory=Measures)
    objectives: list[Objective] = Field(default_factory=_default_objectives, min_length=1, max_length=6)
    reference: bool = True

    @field_validator("model")
    @classmethod
    def _model(cls, v: str) -> str:
        if v not in MODELS:
            raise ValueError(f"unknown model {v!r}; one of {sorted(MODELS)}")
        return v

    @field_validator("bounds")
    @classmethod
    def _bounds(cls, v: list[float]) -> list[float]:
        if not 0.0 <= v[0] < v[1] <= 1e4:
            raise ValueError(f"bounds = {list(v)}: need 0 <= lo < hi <= 10000 N")
        return v

    @field_validator("parameters")
    @classmethod
    def _known(cls, v: dict[str, Parameter]) -> dict[str, Parameter]:
        names = list(v)
        for i, name in enumerate(names):
            info = parameter_info(name)  # ValueError naming the parameter and the known ones
            for other in names[:i]:
                o = parameter_info(other)
                if o.base == info.base and (None in (o.segment, info.segment) or o.segment == info.segment):
                    raise ValueError(f"{other} and {name} set the same field (one for every segment, one for "
                                     "segment k): keep one, or give each segment its own")
        return v

    @model_validator(mode="after")
    def _grid_size(self) -> DesignStudy:
        if self.designs.method != "grid":
            for name, p in self.parameters.items():
                if p.steps is not None:
                    raise ValueError(f"parameters.{name}.steps goes with method = 'grid' (method = "
                                     f"{self.designs.method!r} samples the range)")
        if self.designs.method == "grid":
            size = 1
            for p in self.parameters.values():
                size *= len(p.values) if p.values is not None else (p.steps or 3)
            if size > MAX_DESIGNS:
                raise ValueError(f"the grid holds {size:,} designs; at most {MAX_DESIGNS:,} (fewer values or steps, "
                                 "or method = 'sobol' with a count)")
        return self

    @model_validator(mode="after")
    def _objectives(self) -> DesignStudy:
        measures = [m for m in MEASURES if not m.endswith("_err_m3")] + [f"h_{k}_m" for k in self.measures.directions]
        cases = [*self.loads.cases, *self.loads.custom]
        for k, o in enumerate(self.objectives):
            if o.measure not in measures:
                raise ValueError(f"objectives.{k}.measure = {o.measure!r}: one of {measures}")
            if o.load_case is not None and o.load_case not in cases:
                raise ValueError(f"objectives.{k}.load_case = {o.load_case!r}: not a load case of the study {cases}")
        keys = [(o.measure, self.objective_case(o)) for o in self.objectives]
        if len(set(keys)) != len(keys):
            raise ValueError("objectives: the same measure and load case twice")
        return self

    def objective_case(self, objective: Objective) -> str:
        """The load case an objective is measured under (its own, else the study's first)."""
        return objective.load_case or [*self.loads.cases, *self.loads.custom][0]

    def digest(self) -> str:
        """A hash of the validated study: two files that mean the same study have the same digest."""
        text = json.dumps(self.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def load_cases(self, robot: Robot) -> dict[str, tuple[Robot, Loads]]:
        """The study's load cases on ``robot``, in the file's order (named, then custom): name → (robot, loads)."""
        named = workspace_load_cases(robot)
        out = {name: named[name] for name in self.loads.cases}
        heavy = named["gravity only"][0]
        for name, c in self.loads.custom.items():
            r = heavy if c.gravity else robot.with_gravity((0.0, 0.0, 0.0))
            out[name] = (r, Loads(np.zeros(robot.n_tendons), tip_force=c.tip_force, tip_moment=c.tip_moment))
        return out


def study_from_dict(data: JsonObject, source: str = "study", base_dir: Path | None = None
                    ) -> tuple[DesignStudy, Robot]:
    """Validate a study ``data`` (as read from TOML, unchecked) and load its base robot; every parameter's range
    is tried on the base robot, one parameter at a time, so an impossible range is refused here, naming its key,
    and every load case against the model's capabilities (:func:`check_capabilities`), naming ``model``.

    Raises
    ------
    StudyError
    """
    try:
        study = DesignStudy.model_validate(data)
    except ValidationError as err:
        raise StudyError(f"{source}: {format_validation_error(err)}") from None
    spec = study.robot
    if base_dir is not None and spec.endswith(".toml") and not Path(spec).is_absolute():
        spec = str(base_dir / spec)
    try:
        robot = load_robot(spec)
    except ValueError as err:
        raise StudyError(f"{source}: robot: {err}") from None
    for name, p in study.parameters.items():
        info = parameter_info(name)
        ends = p.values if p.values is not None else p.range
        for value in ends:
            if info.integer and float(value) != int(value):
                raise StudyError(f"{source}: parameters.{name} = {value!r}: must be a whole number ({info.doc})")
            try:
                apply_parameters(robot, {name: value})
            except ValueError as err:
                raise StudyError(f"{source}: parameters.{name} = {value!r}: {err}") from None
    from ._evaluate import check_capabilities  # it imports this module

    check_capabilities(study, robot, source)
    return study, robot


def load_study(path: str | Path) -> tuple[DesignStudy, Robot, str]:
    """Read and validate a study file; returns the study, its base robot and the file's text."""
    path = Path(path)
    try:
        data = read_toml(path, "study file")
    except ValueError as err:
        raise StudyError(str(err)) from None
    study, robot = study_from_dict(data, str(path), path.parent)
    return study, robot, path.read_text(encoding="utf-8")


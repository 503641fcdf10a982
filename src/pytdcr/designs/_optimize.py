"""What "best" means for a study, and the search for it: the objectives of a design, its Pareto front, and
NSGA-II (pymoo) over the design parameters.

The optimiser works in the unit cube of the parameters (:func:`from_unit` maps a point to a design) and is
stepped by ask/tell: each generation's new designs go to the executor as one batch, so they run in parallel
wherever the study runs. Its randomness is pymoo's own generator, seeded by the study's seed; the objectives
it is told come from the designs' results alone. So the same study makes the same designs, in the same order,
on any executor, and a stopped run replays its finished generations from their files.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ._records import DesignRecord
from ._space import from_unit
from ._spec import DesignStudy

if TYPE_CHECKING:
    from pymoo.core.population import Population

__all__ = ["DesignSearch", "measures_nothing", "objective_matrix", "pareto_front"]

#: a batch of new designs: (generation, [(design index, parameter values)])
Batch = tuple[int, list[tuple[int, dict[str, float]]]]
#: evaluates a batch of new designs ``(generation, [(index, values)])`` into their records by index
Evaluate = Callable[[int, list[tuple[int, dict[str, float]]]], Mapping[int, DesignRecord]]


def objective_matrix(study: DesignStudy, records: Sequence[DesignRecord]) -> tuple[np.ndarray, np.ndarray]:
    """The objectives of designs (their records), to minimise: F (n, n_objectives), a max goal negated; and
    ``ok`` (n,), False for a failed design or one with a missing (NaN) objective (its row of F is 0): a
    design without a row for the objective's load case, or whose row lacks the measure (NaN)."""
    F = np.zeros((len(records), len(study.objectives)))
    ok = np.ones(len(records), dtype=bool)
    for i, rec in enumerate(records):
        for j, o in enumerate(study.objectives):
            row = rec.row(study.objective_case(o))
            v = np.nan if row is None else float(row.measure(o.measure))
            if not rec.ok or not np.isfinite(v):
                ok[i] = False
                continue
            F[i, j] = -v if o.goal == "max" else v
    F[~ok] = 0.0
    return F, ok


def measures_nothing(values: npt.ArrayLike) -> bool:
    """True when a measure is 0 for every design that has it (the volume of designs whose regions are all planar,
    dimension below 3): it ranks nothing, and no design is named best by it."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return v.size > 0 and bool(np.all(v == 0.0))


def pareto_front(F: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Which designs no other ok design dominates (at least as good in every objective, better in one): a
    boolean (n,); False where not ok."""
    front = np.zeros(len(F), dtype=bool)
    idx = np.flatnonzero(ok)
    for i in idx:
        others = F[idx]
        dominated = np.any(np.all(others <= F[i], axis=1) & np.any(others < F[i], axis=1))
        front[i] = not dominated
    return front


class DesignSearch:
    """NSGA-II over a study's parameters, stepped by the caller: iterate to get each generation's batch of new
    designs, then :meth:`tell` their records before asking for the next.

    A design that comes up again (a list of values, or whole numbers, map many points to one design) is not
    evaluated twice: it is told the first evaluation's objectives and gets no new index.
    """

    def __init__(self, study: DesignStudy) -> None:
        from pymoo.algorithms.moo.nsga2 import NSGA2
        from pymoo.core.problem import Problem

        self.study = study
        n = len(study.parameters)
        self.problem = Problem(n_var=n, n_obj=len(study.objectives), n_ieq_constr=1, xl=np.zeros(n),
                               xu=np.ones(n))
        self.algo = NSGA2(pop_size=int(study.designs.population), eliminate_duplicates=True)
        self.algo.setup(self.problem, termination=("n_gen", int(study.designs.generations)), seed=int(study.seed),
                        verbose=False)
        self.seen: dict[str, int] = {}
        self.records: dict[int, DesignRecord] = {}
        self._asked: Population | None = None
        self._keys: list[str] = []

    @staticmethod
    def _key(params: dict[str, float]) -> str:
        return repr(sorted(params.items()))

    def __iter__(self) -> Iterator[Batch]:
        generation = 0
        while self.algo.has_next():
            self._asked = self.algo.ask()
            designs = [from_unit(x, self.study.parameters) for x in self._asked.get("X")]
            self._keys = [self._key(d) for d in designs]
            batch = []
            for d, key in zip(designs, self._keys, strict=True):
                if key not in self.seen:
                    self.seen[key] = len(self.seen)
                    batch.append((self.seen[key], d))
            yield generation, batch
            generation += 1

    def tell(self, records: Mapping[int, DesignRecord]) -> None:
        """Hand over the records of the last batch (by design index); every design asked must have one."""
        from pymoo.core.evaluator import Evaluator
        from pymoo.problems.static import StaticProblem

        self.records.update(records)
        F, ok = objective_matrix(self.study, [self.records[self.seen[k]] for k in self._keys])
        G = np.where(ok, -1.0, 1.0)[:, None]  # a failed design violates the one constraint: ranked last
        Evaluator().eval(StaticProblem(self.problem, F=F, G=G), self._asked)
        self.algo.tell(infills=self._asked)


def design_batches(study: DesignStudy, designs: list[dict[str, float]] | None,
                   evaluate: Evaluate) -> dict[int, int]:
    """Run the study's designs through ``evaluate(generation, batch) -> records``: a grid or Sobol set as one
    batch (``designs``), the optimiser generation by generation. Returns each design's generation."""
    if study.designs.method != "optimize":
        evaluate(0, list(enumerate(designs or [])))
        return dict.fromkeys(range(len(designs or [])), 0)
    search = DesignSearch(study)
    generation_of: dict[int, int] = {}
    for generation, batch in search:
        generation_of.update({k: generation for k, _ in batch})
        search.tell(evaluate(generation, batch))
    return generation_of

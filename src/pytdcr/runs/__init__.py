"""The paper's feasible-static-workspace study: runs that write data, figures and a report.

Each run takes typed settings (frozen dataclasses checked on construction, the same for Python and the ``tdcr``
command of the same name: :class:`SolveSettings`, :class:`SampleSettings`, :class:`OptimizeSettings`,
:class:`CompareSettings`, :class:`AccuracySettings`, :class:`ReproduceSettings`), built of the groups the runs
share (:class:`RobotSpec`, :class:`LoadSpec`, :class:`ModelSpec`, :class:`BoundsSpec`), and an output folder,
and returns a typed result (:class:`SolveRun`, :class:`SampleRun`, :class:`OptimizeRun`, :class:`CompareRun`,
:class:`AccuracyRun`, :class:`ReproduceRun`, :class:`WorkspaceRun`). The files a run writes are typed records with
``to_json()`` and ``from_json()`` and a schema version (:class:`SolveRecord`, :class:`SampleRecord`,
:class:`OptimizeRecord`, :class:`CompareResult`, :class:`AccuracyResult`, :class:`WorkspaceRecord`,
:class:`WorkspaceComparison`), read with :mod:`pytdcr.records`.

Every run writes the exact inputs (robot, loads, bounds, seeds, solver
options) beside its results, so it can be repeated exactly. Every run's
folder follows one rule (:func:`pytdcr.runtime.output_folder`): a manifest with
the status, a lock while it writes, files written atomically, a previous run
replaced as a whole. Importing this
package changes no global state (the command line alone picks a matplotlib
backend).
"""

from ._accuracy import AccuracyResult, AccuracyRun, run_accuracy
from ._calibrate import CalibrationRun, CalibrationSettings, run_calibration
from ._compare import CaseSource, CompareResult, CompareRun, run_compare
from ._inverse import (
    InverseRun,
    WorkspaceInputs,
    WorkspacePool,
    inside_bounds,
    inverse_columns,
    inverse_rows,
    read_workspace_inputs,
    read_workspace_pool,
)
from ._output import inputs_record
from ._reproduce import ReproduceRun, ReproduceSettings, check_reproduce, reproduce_estimate, run_reproduce
from ._reproduce_records import PassiveSolveRecord, SamplingRecord
from ._reproduce_report import number_text
from ._runs import (
    OptimizeRecord,
    OptimizeRun,
    SampleRecord,
    SampleRun,
    SampleRunCounts,
    SampleSummary,
    run_optimize,
    run_sample,
    sample_into,
    write_optimize,
)
from ._settings import (
    AccuracySettings,
    CompareSettings,
    OptimizeSettings,
    SampleSettings,
    SolveSettings,
    read_cases,
    read_targets,
)
from ._solve import (
    SolutionRecord,
    SolveRecord,
    SolveRun,
    case_rows,
    check_csv_path,
    check_figure_path,
    run_solve,
    write_shape_csv,
)
from ._specs import MAX_FRICTION, BoundsSpec, LoadSpec, ModelSpec, RobotSpec, RunInputs
from ._workspace import (
    WorkspaceCase,
    WorkspaceCaseSpec,
    WorkspaceRun,
    WorkspaceRunOptions,
    check_workspace_cases,
    run_workspace,
    run_workspace_compare,
)
from ._workspace_records import (
    CaseComparison,
    FailedCase,
    ModelsSection,
    PairComparison,
    WorkspaceComparison,
    WorkspaceRecord,
    WorkspaceSection,
)
from ._workspace_report import format_measure_of

__all__ = [
    "MAX_FRICTION",
    "AccuracyResult",
    "AccuracyRun",
    "AccuracySettings",
    "BoundsSpec",
    "CalibrationRun",
    "CalibrationSettings",
    "CaseComparison",
    "CaseSource",
    "CompareResult",
    "CompareRun",
    "CompareSettings",
    "FailedCase",
    "InverseRun",
    "LoadSpec",
    "ModelSpec",
    "ModelsSection",
    "OptimizeRecord",
    "OptimizeRun",
    "OptimizeSettings",
    "PairComparison",
    "PassiveSolveRecord",
    "ReproduceRun",
    "ReproduceSettings",
    "RobotSpec",
    "RunInputs",
    "SampleRecord",
    "SampleRun",
    "SampleRunCounts",
    "SampleSettings",
    "SampleSummary",
    "SamplingRecord",
    "SolutionRecord",
    "SolveRecord",
    "SolveRun",
    "SolveSettings",
    "WorkspaceCase",
    "WorkspaceCaseSpec",
    "WorkspaceComparison",
    "WorkspaceInputs",
    "WorkspacePool",
    "WorkspaceRecord",
    "WorkspaceRun",
    "WorkspaceRunOptions",
    "WorkspaceSection",
    "case_rows",
    "check_csv_path",
    "check_figure_path",
    "check_reproduce",
    "check_workspace_cases",
    "format_measure_of",
    "inputs_record",
    "inside_bounds",
    "inverse_columns",
    "inverse_rows",
    "number_text",
    "read_cases",
    "read_targets",
    "read_workspace_inputs",
    "read_workspace_pool",
    "reproduce_estimate",
    "run_accuracy",
    "run_calibration",
    "run_compare",
    "run_optimize",
    "run_reproduce",
    "run_sample",
    "run_solve",
    "run_workspace",
    "run_workspace_compare",
    "sample_into",
    "write_optimize",
    "write_shape_csv",
]

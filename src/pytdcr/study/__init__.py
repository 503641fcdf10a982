"""The paper's feasible-static-workspace study: runs that write data, figures and a report.

Every run writes the exact inputs (robot, loads, bounds, seeds, solver
options) beside its results, so it can be repeated exactly. Every run's
folder follows one rule (:func:`pytdcr.runtime.output_folder`): a manifest with
the status, a lock while it writes, files written atomically, a previous run
replaced as a whole. Importing this
package changes no global state (the command line alone picks a matplotlib
backend).
"""

from ._accuracy import run_accuracy
from ._output import inputs_record
from ._reproduce import ReproduceSettings, run_reproduce
from ._runs import SampleRun, run_compare, run_optimize, run_sample, sample_into, write_optimize
from ._workspace import WorkspaceCase, WorkspaceRun, WorkspaceRunOptions, run_workspace, run_workspace_compare

__all__ = ["ReproduceSettings", "SampleRun", "WorkspaceCase", "WorkspaceRun", "WorkspaceRunOptions", "inputs_record",
           "run_accuracy", "run_compare", "run_optimize", "run_reproduce", "run_sample", "run_workspace",
           "run_workspace_compare", "sample_into", "write_optimize"]

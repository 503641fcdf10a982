"""The paper's feasible-static-workspace study: runs that write data, figures and a report.

Every run writes the exact inputs (robot, loads, bounds, seeds, solver
options) beside its results, so it can be repeated exactly. Importing this
package changes no global state (the command line alone picks a matplotlib
backend).
"""

from ._accuracy import run_accuracy
from ._output import inputs_record
from ._reproduce import ReproduceSettings, run_reproduce
from ._runs import SampleRun, run_compare, run_optimize, run_sample, write_optimize

__all__ = ["ReproduceSettings", "SampleRun", "inputs_record", "run_accuracy", "run_compare", "run_optimize",
           "run_reproduce", "run_sample", "write_optimize"]

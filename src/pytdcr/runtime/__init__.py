"""Shared infrastructure, public to the whole library: cancellation, worker threads, atomic files and the
output-folder rule.

- **Cancellation** (:func:`cancellable`, :func:`check_cancelled`, :func:`saving`): a command line's Ctrl-C, or
  your own thread, stops work between chunks of at most :data:`MAX_CHUNK` solves; work that is writing results
  is waited for.
- **Threads** (:func:`run_in_chunks`, :func:`worker_pool`, :func:`default_threads`): batches of independent
  solves on all cores, with BLAS kept on one thread meanwhile; results do not depend on the thread count.
- **Files** (:func:`atomic_write`, :func:`write_json`, :func:`write_csv`): every file whole or absent.
- **Output folders** (:func:`output_folder`, :func:`resumable_folder`): one rule for every run's folder: a
  manifest, a lock, staging beside it, a previous run replaced as a whole, foreign files refused.
"""

from ._cancel import Cancelled, CancelScope, cancellable, check_cancelled, current_scope, mark_saving, saving
from ._files import (
    FileRefused,
    atomic_write,
    atomic_write_text,
    dump_json,
    to_jsonable,
    writable_file,
    write_csv,
    write_json,
)
from ._folders import (
    MANIFEST,
    RESULT_LIBRARIES,
    FolderError,
    OutputRun,
    RunInterrupted,
    StudyChanged,
    check_output_folder,
    library_versions,
    output_folder,
    resumable_folder,
)
from ._stages import duration, end_stage
from ._threads import MAX_CHUNK, default_threads, run_in_chunks, single_threaded_blas, submit_in_context, worker_pool

__all__ = [
    "MANIFEST",
    "MAX_CHUNK",
    "RESULT_LIBRARIES",
    "CancelScope",
    "Cancelled",
    "FileRefused",
    "FolderError",
    "OutputRun",
    "RunInterrupted",
    "StudyChanged",
    "atomic_write",
    "atomic_write_text",
    "cancellable",
    "check_cancelled",
    "check_output_folder",
    "current_scope",
    "default_threads",
    "dump_json",
    "duration",
    "end_stage",
    "library_versions",
    "mark_saving",
    "output_folder",
    "resumable_folder",
    "run_in_chunks",
    "saving",
    "single_threaded_blas",
    "submit_in_context",
    "to_jsonable",
    "worker_pool",
    "writable_file",
    "write_csv",
    "write_json",
]

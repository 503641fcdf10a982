"""Shared infrastructure, public to the whole library: cancellation, worker threads, atomic files and the
output-folder rule.

- **Cancellation** (:func:`cancellable`, :func:`check_cancelled`, :func:`saving`): a command line's Ctrl-C, or
  your own thread, stops work between chunks of at most :data:`MAX_CHUNK` solves; work that is writing results
  is waited for.
- **Threads** (:func:`run_in_chunks`, :func:`worker_pool`, :func:`default_threads`): batches of independent
  solves on all cores, with BLAS kept on one thread meanwhile; results do not depend on the thread count.
- **Files** (:func:`atomic_write`, :func:`write_json`, :func:`write_csv`): every file whole or absent.
- **Compiled kernels** (:func:`njit`, :func:`kernel_cache_dir`, :func:`announce_compiling`): numba's cache in a
  folder keyed by the version and the kernels' sources; one line on stderr while a first use compiles.
- **Cache** (:func:`cache_dir`, :func:`read_arrays`, :func:`write_arrays`): entries kept between runs, read only
  when they are this user's whole regular files and written never through a link; a cache that cannot be read
  or written is rebuilt or not kept, never an error.
- **Another run's folder** (:class:`RunFolder`): every file and field read back from a folder another run wrote
  is checked strictly (its type, its range, paths inside the folder), refused with one line naming the field.
- **Worker processes** (:func:`process_pool`, :func:`hold_lifeline`): every process pytdcr starts ends with the
  process that started it, even one killed outright.
- **Output folders** (:func:`output_folder`, :func:`resumable_folder`): one rule for every run's folder: a
  manifest, a lock, staging beside it, a previous run replaced as a whole, foreign files refused.
"""

from ._cache import MAX_ENTRY_BYTES, cache_dir, read_arrays, read_entry, write_arrays, write_entry
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
    versions_record,
)
from ._jit import KERNEL_SOURCES, announce_compiling, kernel_cache_dir, kernel_key, njit, set_compile_notice
from ._lifeline import LIFELINE_POLL_S, PARENT_GONE_EXIT, hold_lifeline, process_pool
from ._readback import MAX_JSON_BYTES, RunDoc, RunFolder, regular_file_bytes
from ._stages import duration, end_stage
from ._threads import MAX_CHUNK, default_threads, run_in_chunks, single_threaded_blas, submit_in_context, worker_pool

__all__ = [
    "KERNEL_SOURCES",
    "LIFELINE_POLL_S",
    "MANIFEST",
    "MAX_CHUNK",
    "MAX_ENTRY_BYTES",
    "MAX_JSON_BYTES",
    "PARENT_GONE_EXIT",
    "RESULT_LIBRARIES",
    "CancelScope",
    "Cancelled",
    "FileRefused",
    "FolderError",
    "OutputRun",
    "RunDoc",
    "RunFolder",
    "RunInterrupted",
    "StudyChanged",
    "announce_compiling",
    "atomic_write",
    "atomic_write_text",
    "cache_dir",
    "cancellable",
    "check_cancelled",
    "check_output_folder",
    "current_scope",
    "default_threads",
    "dump_json",
    "duration",
    "end_stage",
    "hold_lifeline",
    "kernel_cache_dir",
    "kernel_key",
    "library_versions",
    "mark_saving",
    "njit",
    "output_folder",
    "process_pool",
    "read_arrays",
    "read_entry",
    "regular_file_bytes",
    "resumable_folder",
    "run_in_chunks",
    "saving",
    "set_compile_notice",
    "single_threaded_blas",
    "submit_in_context",
    "to_jsonable",
    "versions_record",
    "worker_pool",
    "writable_file",
    "write_arrays",
    "write_csv",
    "write_entry",
    "write_json",
]

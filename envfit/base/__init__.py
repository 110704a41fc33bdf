r"""Plumbing every layer may use: errors, argument checks, atomic writes, the verified resumable
store, the memory guard, progress bars. Imports nothing else of envfit.

Modules:

* :mod:`~envfit.base._atomic` — Atomic file writes: a result file is either the old one or
  the complete new one.
* :mod:`~envfit.base._checks` — Checks of user-given names, integers and positive numbers
  shared by the pipelines (validate, advise).
* :mod:`~envfit.base._errors` — The exception types of envfit.
* :mod:`~envfit.base._html` — Compact HTML tables of results, for Jupyter's rich display
  (``_repr_html_``).
* :mod:`~envfit.base._lock` — The advisory lock of an output folder: one envfit run per
  folder.
* :mod:`~envfit.base._progress` — Progress bars (tqdm on stderr), switched off by ``quiet``,
  and notes printed past them.
* :mod:`~envfit.base._resources` — Memory budget: check before allocating, fail with a clear
  message instead of swapping.
* :mod:`~envfit.base._store` — A resumable result store: one JSON file per finished cell,
  written atomically, checked on read.
* :mod:`~envfit.base._stored_json` — Stored JSON read without a traceback, and its values
  checked.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {
    "DuplicatePointsError": "_errors", "EnvfitError": "_errors", "EnvMapFileError": "_errors",
    "EnvMapFormatError": "_errors", "MemoryBudgetError": "_errors", "NonFiniteError": "_errors",
    "ParameterError": "_errors",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "ExecutorError": "_errors",
    "FolderLock": "_store",
    "MEMORY_FRACTION": "_resources",
    "NO_SUCH_FILE": "_files",
    "Note": "_notes",
    "NoteKind": "_notes",
    "OutputError": "_errors",
    "Plan": "_resources",
    "ResultStore": "_store",
    "SOLVERS": "_resources",
    "Stage": "_resources",
    "array_fingerprint": "_store",
    "as_square_points": "_checks",
    "as_unit_vectors": "_checks",
    "atomic_write_bytes": "_atomic",
    "atomic_write_csv": "_atomic",
    "atomic_write_json": "_atomic",
    "atomic_write_text": "_atomic",
    "available_memory_bytes": "_resources",
    "budget_words": "_resources",
    "canonical_sha256": "_store",
    "check_int": "_checks",
    "check_ints": "_checks",
    "check_memory": "_resources",
    "check_names": "_checks",
    "check_positive": "_checks",
    "check_s": "_checks",
    "check_same_code": "_code",
    "check_writable_dir": "_atomic",
    "check_writable_file": "_atomic",
    "code_state": "_code",
    "format_bytes": "_resources",
    "html_result": "_html",
    "interpolator_nbytes": "_resources",
    "iterative_coarse_nodes": "_resources",
    "json_type": "_store",
    "largest_feasible_n": "_resources",
    "largest_n_within": "_resources",
    "lazy_exports": "_lazy",
    "machine_cores": "_resources",
    "memory_budget_bytes": "_resources",
    "move_aside": "_store",
    "note_kind": "_notes",
    "number": "_store",
    "number_problem": "_store",
    "one_of": "_store",
    "open_regular": "_files",
    "os_reason": "_atomic",
    "peak_rss_bytes": "_resources",
    "plan_memory": "_resources",
    "probe_writable": "_atomic",
    "progress": "_progress",
    "progress_bar": "_progress",
    "read_json_file": "_store",
    "regular_file_problem": "_files",
    "replace_via_temporary": "_atomic",
    "rss_bytes": "_resources",
    "s_key": "_keys",
    "s_value": "_keys",
    "time_limit_seconds": "_resources",
    "time_limit_words": "_resources",
    "to_jsonable": "_atomic",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

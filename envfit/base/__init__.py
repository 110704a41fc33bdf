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

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

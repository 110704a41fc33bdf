r"""Libraries of maps: one factorisation per (s, N) for all maps, tasks, local and dask
executors, the driver loop and the library report.

Modules:

* :mod:`~envfit.batch._advise_renderer` — The Python entry point of the renderer answer,
  ``envfit.advise_renderer``: one map (:func:`envfit.advisor.advise_with` of
  :class:`~envfit.advisor.RendererAdviseOptions`) or a library.
* :mod:`~envfit.batch._executor` — Where a sweep's tasks run: in this process, a local
  process pool, or a dask cluster.
* :mod:`~envfit.batch._fit_tasks` — Worker-side tasks of a library fit: sample a map;
  evaluate the fit criterion at one s for many maps with one factorisation.
* :mod:`~envfit.batch._library` — The paper's Table 2 (Sec. 9.1) over a whole library of
  maps, one factorisation per (s, N).
* :mod:`~envfit.batch._library_advise` — A library of maps advised in a renderer's terms: one
  row per map, the spp that meets the target on 50/90/100 % of the maps, resumable, on a
  local pool or dask (:func:`advise_library`, :class:`LibraryAdvice`).
* :mod:`~envfit.batch._library_fit` — Fit the Sobolev smoothness s of every map of a library,
  one factorisation per s.
* :mod:`~envfit.batch._library_result` — What every library run reports, whatever it computes
  per map: the maps' labels and slugs, the value scale and sampling, the shared
  factorisations, time, executor, notes, unwritten cells and the files written; one summary
  row and one result per map; and how every library run reads its maps and where its tasks
  run (:class:`LibraryOptions`).
* :mod:`~envfit.batch._report` — Files of a library run: per-map CSV, a summary across maps
  (CSV + JSON), a histogram of s.
* :mod:`~envfit.batch._scheduler` — The driver loop of a sweep: submit tasks by priority,
  handle results as they arrive.
* :mod:`~envfit.batch._tasks` — Worker-side tasks of a library sweep: sample a map, factorise
  once for many maps, evaluate one map. Module-level functions of picklable arguments, so
  that a process pool or a dask worker can run them; each loads at most one map at a time.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "LibraryTable2Result": "_library", "run_table2_library": "_library",
    "fit_smoothness_library": "_library_fit", "LibraryFitResult": "_library_fit",
    "LibraryOptions": "_library_result",
    "advise_library": "_library_advise", "LibraryAdvice": "_library_advise",
    "MapRow": "_library_advise", "advise_renderer": "_advise_renderer",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "check_executor_choice": "_executor",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

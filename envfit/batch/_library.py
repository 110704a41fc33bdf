r"""The paper's Table 2 (Sec. 9.1) over a whole library of maps, one factorisation per (s, N).

The kernel matrix :math:`K^{(s)}_{ij} = K_{gd}^{(s)}(p_i, p_j)` (Eq. 14) depends on the
sample directions and s only, not on the map. With the same N directions for every map,
each (s, N) matrix is built and Cholesky-factorised **once** and solved for all maps and
channels as right-hand sides (:func:`envfit.batch._tasks.solve_task`); then each map is
loaded again, reconstructed at its own pixel centres and compared, one map at a time
(:func:`~envfit.batch._tasks.evaluate_task`: maps may differ in resolution, never in
``up``). At N = 20000 the factorisation (N^3/3 flops, 3.2 GB) dominates a cell, so a
library of M maps costs about one factorisation plus M evaluations instead of M
factorisations (docs/guides/libraries.md).

Execution. Three kinds of tasks — sample each map at every N it still needs, factorise
each (s, N), evaluate each (map, s, N) — run on an executor (:mod:`envfit.batch._executor`:
inline, a local process pool, or a dask cluster) under :func:`envfit.batch._scheduler.drive`,
which writes every finished cell into ``OUT/<map-slug>/cells/`` (the format of
:func:`~envfit.fit._table2.run_table2`) atomically as it arrives. A re-run with the same ``out``
skips finished (map, s, N) cells and factorises only the (s, N) that some map still lacks;
a killed worker loses only the tasks it was running. A stored cell that is not sound (edited,
corrupt, another cell's; :mod:`envfit.base._store`) is recomputed with a note in ``lib.notes``, and
the driver holds the lock of ``out`` for the whole run (a second run on it is refused; the
workers never touch the store). Only O(N C) coefficients per map
travel between processes, never an N x N factor.

Results: per map a :class:`~envfit.fit._table2.Table2Result` (its cells, ``s_best``), and
across maps a summary (:meth:`LibraryTable2Result.summary_rows`) written, when ``out`` is
given, as CSV, JSON and a histogram of the best s per map (:mod:`envfit.batch._report`).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.data_gen._gp import gaussian_process_map
>>> maps = [EnvMap(gaussian_process_map(1.5, 16, seed=k, channels=3) + 3.0, name=f"gp{k}")
...         for k in range(3)]
>>> lib = run_table2_library(maps, [1.3, 1.7], [50, 100], scale="linear",
...                          options=LibraryOptions(workers=1))
>>> lib.factorizations, len(lib.maps), lib.maps[0].rmse_table().shape
(4, 3, (2, 2))
"""
from __future__ import annotations

import contextlib
import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from envfit.maps import check_sample_count
from envfit.base import ParameterError
from envfit.defaults import SOLVERS
from envfit.batch._library_result import LibraryOptions, LibraryResult, distinct_labels
from envfit.batch._tasks import SweepSpec, evaluate_task, sample_task, solve_task
from envfit.maps import MapSource, resolve_map_sources
from envfit.base import interpolator_nbytes, memory_budget_bytes, plan_memory
from envfit.maps import SCALES, check_not_constant
from envfit.batch._scheduler import Task, drive
from envfit.base import FolderLock, ResultStore
from envfit.fit import cell_checks
from envfit.fit import (PAPER_N, PAPER_S, TABLE2_FIELDS, Table2Cell, Table2Result, check_grid,
                        table2_cell_key, table2_recon_stem)

__all__ = ["LibraryTable2Result", "run_table2_library", "RHS_BUDGET_BYTES"]

#: right-hand sides (samples + coefficients) one factorisation task may hold; a larger
#: library is split into groups of maps, one factorisation per group
RHS_BUDGET_BYTES = 1 << 30
#: channels per map assumed when planning memory (loading keeps at most 3)
_PLAN_CHANNELS = 3
_FIELDS = TABLE2_FIELDS  # required of a stored cell; the solver's fields are optional (older
_SOLVER_FIELDS = ("solver", "iterations", "residual", "rmse_change_bound")  # cells: defaults)


def _cell(d: dict) -> Table2Cell:
    """A :class:`Table2Cell` from a stored or fresh cell dict (solver fields if present)."""
    return Table2Cell(**{k: d[k] for k in _FIELDS + _SOLVER_FIELDS if k in d})


@dataclass(kw_only=True)
class LibraryTable2Result(LibraryResult):
    """Table 2 for every map of a library (``maps[k]`` is map k's :class:`Table2Result`);
    the common fields are :class:`~envfit.batch._library_result.LibraryResult`'s."""
    maps: list[Table2Result]
    s_values: list[float]
    n_values: list[int]
    cells_computed: int = 0
    cells_resumed: int = 0

    def per_map(self) -> list[Table2Result]:
        return self.maps

    def s_best(self) -> np.ndarray:
        """The s with the lowest per-pixel RMSE at the largest N, per map."""
        return np.array([r.s_best for r in self.maps])

    def summary_rows(self) -> list[dict]:
        """One row per map: slug, name, height, best s, RMSE at the largest N for every s."""
        n_max = self.n_values[-1]
        rows = []
        for slug, r in zip(self.slugs, self.maps):
            col = r.rmse_table()[:, -1]
            row = {"slug": slug, "map": r.map, "height": r.height, "s_best": r.s_best}
            row.update({f"rmse_s{s:g}_n{n_max}": float(v) for s, v in zip(self.s_values, col)})
            rows.append(row)
        return rows

    def _header(self) -> dict:
        return {"s_values": self.s_values, "n_values": self.n_values,
                "cells_computed": self.cells_computed, "cells_resumed": self.cells_resumed}


def _chunks(items: list[int], n: int, budget: int) -> list[list[int]]:
    per = max(1, int(budget // (2 * 8 * n * _PLAN_CHANNELS)))
    return [items[k:k + per] for k in range(0, len(items), per)]


def run_table2_library(maps: Sequence, s_values: Sequence[float] = PAPER_S,
                       n_values: Sequence[int] = PAPER_N, *, pointset: str = "sf",
                       scale: str = "display", seed: int = 0, solver: str = "cholesky",
                       out: str | Path | None = None, save_reconstructions: bool = False,
                       on_cell: Callable[[str, Table2Cell, bool], None] | None = None,
                       rhs_budget_bytes: int = RHS_BUDGET_BYTES,
                       options: LibraryOptions | None = None) -> LibraryTable2Result:
    """Run the (s, N) sweep on every map of ``maps``; see the module docstring.

    Parameters
    ----------
    maps : files, folders, glob patterns and/or :class:`~envfit.maps._envmap.EnvMap` objects
        (:func:`~envfit.maps._lazy_maps.resolve_map_sources`); files are read lazily with
        ``options.load_options``.
    s_values, n_values, pointset, scale, seed : as :func:`~envfit.fit._table2.run_table2`.
    solver : "cholesky" (one dense factor per (s, N) for all maps), "iterative" (CG with the
        near/far product, all maps' columns side by side: one preconditioner for all), or
        "auto" (Cholesky where the dense matrix fits, else iterative); each cell records it
        (:class:`~envfit.fit._table2.Table2Cell`).
    out : folder: ``OUT/<slug>/cells`` per map (resumable), summary CSV/JSON/PNG at the top.
    save_reconstructions : also write each map's reconstructions at the largest N
        (EXR + PNG into ``OUT/<slug>/``; off by default: a library's images are large).
    on_cell : ``on_cell(map_label, cell, resumed)`` after each cell, in the driver.
    rhs_budget_bytes : memory for one factorisation's right-hand sides; more maps are
        split into groups (one factorisation per group).
    options : how the maps are read and where the tasks run (executor, workers, dask
        scheduler, load options, progress bars):
        :class:`~envfit.batch._library_result.LibraryOptions`.
    """
    t_start = time.perf_counter()
    options = LibraryOptions.of(options)
    s_values, n_values = check_grid(s_values, n_values)
    if scale not in SCALES:
        raise ParameterError(f"unknown scale {scale!r}; choose one of {', '.join(SCALES)}")
    sources = distinct_labels(resolve_map_sources(maps, options.load_options))
    _plan_library_memory(len(sources), n_values[-1], solver, rhs_budget_bytes)
    spec = SweepSpec(pointset=pointset, seed=int(seed), scale=scale, up=sources[0].up,
                     solver=solver)
    spec.points(4)  # an unknown point set fails here, before any work
    out = Path(out) if out is not None else None
    notes: list[str] = []                       # the stores' notes (cells recomputed), …
    # one lock for the whole --out folder, taken before any cell is read (module store)
    with FolderLock(out, on_note=notes.append) if out is not None else contextlib.nullcontext():
        stores = [_store(out, src, spec, notes) for src in sources]
        cells, missing, resumed = _resume(stores, sources, s_values, n_values, on_cell)
        lib = LibraryTable2Result(maps=[], labels=[s.label for s in sources],
                                  slugs=[s.slug for s in sources], s_values=s_values,
                                  n_values=n_values, scale=scale, pointset=pointset,
                                  seed=int(seed), cells_resumed=resumed, notes=notes)
        sweep = _Sweep(lib, sources, stores, cells, spec, out, keep=save_reconstructions,
                       on_cell=on_cell)
        if missing:
            _compute(sweep, missing, options, rhs_budget_bytes)
        lib.maps = [_map_result(src, cells[i], lib) for i, src in enumerate(sources)]
        lib.unwritten = [u for st in stores for u in st.unwritten]
        lib.seconds = time.perf_counter() - t_start
        if out is not None:
            from envfit.batch._report import write_table2_library
            write_table2_library(lib, out)
    return lib


def _plan_library_memory(maps: int, n_max: int, solver: str, budget: int) -> None:
    """The memory guard of the largest N — one factorisation task: the interpolator with the
    right-hand sides of one group of maps — before any sample point is made (and the solver
    name checked)."""
    group = min(maps, max(1, int(budget // (2 * 8 * n_max * _PLAN_CHANNELS))))
    if solver not in SOLVERS:
        raise ParameterError(f"solver must be auto, cholesky or iterative; got {solver!r}")
    dense_fits = interpolator_nbytes(n_max, _PLAN_CHANNELS * group) <= memory_budget_bytes()
    plan_memory(n_max, "library table2", channels=_PLAN_CHANNELS * group,
                solver="cholesky" if solver == "cholesky" or (solver == "auto" and dense_fits)
                else "iterative")


def _store(out: Path | None, src: MapSource, spec: SweepSpec, notes: list[str]) -> ResultStore:
    """Map ``src``'s cell store under ``out`` (in memory only without ``out``); the driver
    holds the folder's lock."""
    return ResultStore(out / src.slug if out is not None else None,
                       {"map": src.identity(), "scale": spec.scale, "pointset": spec.pointset,
                        "seed": spec.seed, "up": spec.up}, kind="table2", lock=False,
                       on_note=notes.append)


def _map_result(src, cells: dict[str, dict], lib: LibraryTable2Result) -> Table2Result:
    """One map's :class:`Table2Result` from its cells (all of the grid present)."""
    some = next(iter(cells.values()))
    r = Table2Result(map=src.label, scale=lib.scale,
                     scale_description=some.get("scale_description", ""),
                     pointset=lib.pointset, seed=lib.seed, height=int(some.get("height", 0)),
                     s_values=lib.s_values, n_values=lib.n_values)
    r.cells = [_cell(cells[table2_cell_key(s, n)]) for n in lib.n_values for s in lib.s_values]
    return r


def _resume(stores, sources, s_values, n_values, on_cell):
    """``(cells, missing, resumed)``: the sound stored cells per map, the maps still missing
    each (s, N), and how many cells were resumed (unsound cells count as missing)."""
    cells: list[dict[str, dict]] = [{} for _ in sources]
    missing: dict[tuple[float, int], list[int]] = {}
    resumed = 0
    for i, st in enumerate(stores):
        for n in n_values:
            for s in s_values:
                d = st.get(table2_cell_key(s, n), fields=_FIELDS, checks=cell_checks(s, n))
                if d is None:
                    missing.setdefault((s, n), []).append(i)
                    continue
                cells[i][table2_cell_key(s, n)] = d
                resumed += 1
                if on_cell:
                    on_cell(sources[i].label, _cell(d), True)
    return cells, missing, resumed


@dataclass
class _Sweep:
    """One library run's state in the driver: the result being filled, the maps, their
    stores and cells (map index → cell key → cell dict), the sweep's sampling, ``out``,
    whether reconstructions are kept and the per-cell callback."""
    lib: LibraryTable2Result
    sources: list[MapSource]
    stores: list[ResultStore]
    cells: list[dict[str, dict]]
    spec: SweepSpec
    out: Path | None
    keep: bool = False
    on_cell: Callable[[str, Table2Cell, bool], None] | None = None


def _compute(sweep: _Sweep, missing, options: LibraryOptions, budget: int) -> None:
    """Plan the tasks for the missing cells and drive them (fills the sweep's cells and
    result)."""
    lib = sweep.lib
    chunks = _plan_chunks(lib, missing, budget)
    biggest = max(interpolator_nbytes(n, _PLAN_CHANNELS * len(c)) for _, n, c in chunks)
    ex, notes = options.make_executor(max_useful=len(chunks), bytes_per_task=biggest)
    lib.notes.extend(notes)
    lib.executor = ex.describe()
    from envfit.base import progress_bar
    bar = progress_bar(sum(len(c) for _, _, c in chunks), desc="library table2",
                       quiet=options.quiet, unit="cell")
    run = _Table2Run(sweep, chunks, bar)
    try:
        drive(ex, run.sample_tasks())
    finally:
        bar.close()
        options.close(ex)


def _plan_chunks(lib, missing, budget) -> list[tuple[float, int, list[int]]]:
    """``(s, n, [map indices])`` per factorisation: the maps missing each (s, N), in groups
    whose right-hand sides fit ``budget`` (noted when a group is split)."""
    chunks = []
    for (s, n), idx in sorted(missing.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        chunks.extend((s, n, c) for c in _chunks(idx, n, budget))
    if any(len(_chunks(idx, n, budget)) > 1 for (s, n), idx in missing.items()):
        lib.notes.append("the library's samples exceed the right-hand-side budget for one "
                         "factorisation: maps are split into groups, one factorisation each")
    return chunks


class _Table2Run:
    """The task graph of the missing cells: sample each map once (at the N it needs), then a
    factorisation per chunk as soon as its maps are sampled, then each map's evaluation;
    samples are dropped once the last chunk using them has been submitted."""

    def __init__(self, sweep: _Sweep, chunks, bar):
        self.chunks, self.bar = chunks, bar
        self.lib, self.sources, self.stores = sweep.lib, sweep.sources, sweep.stores
        self.cells, self.spec, self.out = sweep.cells, sweep.spec, sweep.out
        self.keep, self.on_cell = sweep.keep, sweep.on_cell
        self.n_max = sweep.lib.n_values[-1]
        self.needs: dict[int, set[int]] = {}       # map -> the N it must be sampled at
        self.waiting: dict[int, set[int]] = {}     # chunk -> maps whose samples are missing
        self.uses: dict[tuple[int, int], int] = {}  # (map, N) -> chunks still to be submitted
        for cid, (s, n, idx) in enumerate(chunks):
            self.waiting[cid] = set(idx)
            for i in idx:
                self.needs.setdefault(i, set()).add(n)
                self.uses[(i, n)] = self.uses.get((i, n), 0) + 1
        self.samples: dict[int, dict[int, np.ndarray]] = {}

    def sample_tasks(self) -> list[Task]:
        return [Task(1, sample_task, (self.sources[i], self.spec, sorted(ns)),
                     label=f"map {self.sources[i].label}",
                     on_done=functools.partial(self.sample_done, i))
                for i, ns in sorted(self.needs.items())]

    def solve_args(self, cid):
        s, n, idx = self.chunks[cid]
        cols = [self.samples[i][n] for i in idx]
        for i in idx:
            self.uses[(i, n)] -= 1
            if self.uses[(i, n)] == 0:
                del self.samples[i][n]
        return self.spec, s, n, np.hstack(cols), [c.shape[1] for c in cols]

    def sample_done(self, i, res) -> list[Task]:
        # N against the map's pixel count and a constant map, before any factorisation
        n_top = max(res["values"])
        check_sample_count(n_top, res["width"], res["height"], name=self.sources[i].label)
        check_not_constant(res["values"][n_top], self.spec.scale, self.sources[i].label,
                           where=f" at its {n_top} samples")
        self.samples[i] = res["values"]
        ready = []
        for cid in [c for c, w in self.waiting.items() if i in w]:
            self.waiting[cid].discard(i)
            if not self.waiting[cid]:
                del self.waiting[cid]
                s, n, _ = self.chunks[cid]
                ready.append(Task(2, solve_task, functools.partial(self.solve_args, cid),
                                  label=f"factorisation s={s:g} N={n}",
                                  on_done=functools.partial(self.solve_done, cid)))
        return ready

    def solve_done(self, cid, res) -> list[Task]:
        s, n, idx = self.chunks[cid]
        self.lib.factorizations += 1
        return [Task(0, evaluate_task, (self.sources[i], self.spec, s, n, a,
                                        self.keep and n == self.n_max),
                     label=f"map {self.sources[i].label} (s={s:g}, N={n})",
                     on_done=functools.partial(self.eval_done, i, res["seconds"], len(idx),
                                               solve))
                for i, a, solve in zip(idx, res["alphas"], res["solves"])]

    def eval_done(self, i, fit_seconds, shared, solve, res) -> None:
        recon, preview = res.pop("reconstruction", None), res.pop("preview", None)
        res.pop("seconds_load", None)
        cell = {**res, "seconds_fit": fit_seconds, "seconds": fit_seconds + res["seconds_evaluate"],
                "shared_by": shared, "solver": solve["solver"],
                "iterations": solve["iterations"], "residual": solve["residual"],
                "rmse_change_bound": (solve["error_bound"] / res["rmse"]
                                      if res["rmse"] > 0 else 0.0)}
        if recon is not None and self.out is not None:
            _save_pair(self.out / self.sources[i].slug, recon, preview, cell["s"], cell["n"],
                       self.spec.up)
        key = table2_cell_key(cell["s"], cell["n"])
        self.stores[i].put(key, cell)
        self.cells[i][key] = cell
        self.lib.cells_computed += 1
        self.bar.update(1)
        if self.on_cell:
            self.on_cell(self.sources[i].label, _cell(cell), False)


def _save_pair(folder: Path, recon: np.ndarray, preview: np.ndarray, s: float, n: int, up: str) -> None:
    """EXR of a reconstruction (on the comparison scale) and its display-referred PNG."""
    from envfit.maps import EnvMap
    from envfit.maps import save_envmap
    stem = table2_recon_stem(s, n)
    save_envmap(folder / f"{stem}.exr", EnvMap(recon, up=up, name=stem))
    save_envmap(folder / f"{stem}.png", EnvMap(preview, up=up, name=stem))

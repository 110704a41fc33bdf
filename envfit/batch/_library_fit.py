r"""Fit the Sobolev smoothness s of every map of a library, one factorisation per s.

:func:`envfit.fit._smoothness.fit_smoothness` evaluates its criterion (profiled GP likelihood,
closed-form leave-one-out or hold-out RMSE; :func:`envfit.fit._criterion.evaluate_criterion`)
at ~20–30 values of s, each needing the Cholesky factor of :math:`K^{(s)}` at the sample
directions — which do not depend on the map. Here every map is sampled at the same N
directions and each s is factorised once for all maps
(:func:`envfit.batch._fit_tasks.criterion_task`).

Each map runs the lattice search of :mod:`envfit.fit._search` — the search the single-map
fit runs — whose every request lies on one lattice (the coarse grid
:data:`~envfit.fit._search.S_GRID`, refined ``refine`` times, default step 0.025), so maps
ask for the same s values; :func:`~envfit.fit._search.run_searches` collects the requests of
all maps round after round. ŝ and its interval equal the single-map fit's to rounding
(tests); σ̂ at ŝ is read off a spline through the lattice values
(:attr:`envfit.fit._search.SearchResult.sigma`),
where the single map spends one more factorisation on the exact value (they agree to ~1e-7
relative for s ≳ 1.3; :mod:`envfit.fit._search`). Each round factorises each distinct s
requested once, so a library needs about one search's ~20 factorisations plus those where
the maps' brackets and intervals differ, never more than the lattice's ~40 points per round,
whatever its size. Every (map, s) evaluation is a resumable cell in
``OUT/<slug>/fit_<method>_n<N>/cells``.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.data_gen._gp import gaussian_process_map
>>> maps = [EnvMap(gaussian_process_map(1.5, 16, seed=k, channels=1) + 3.0, name=f"gp{k}")
...         for k in range(2)]
>>> lib = fit_smoothness_library(maps, n=200, scale="linear",
...                              options=LibraryOptions(workers=1))
>>> [1.0 < f.s < 2.0 for f in lib.fits]
[True, True]
"""
from __future__ import annotations

import contextlib
import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from envfit.base import check_int
from envfit.maps import check_sample_count
from envfit.base import ParameterError
from envfit.batch._library_result import LibraryOptions, LibraryResult, distinct_labels
from envfit.fit import DEFAULT_REFINE, SmoothnessSearch, lattice, run_searches, search_lattice
from envfit.fit import DEFAULT_METHOD, DEFAULT_N, METHODS, S_GRID, SCORE_NAMES, FitResult, fit_notes
from envfit.base import interpolator_nbytes
from envfit.batch._fit_tasks import criterion_task, fit_sample_task
from envfit.batch._tasks import SweepSpec
from envfit.maps import resolve_map_sources
from envfit.base import plan_memory
from envfit.maps import SCALES, check_not_constant
from envfit.batch._scheduler import Task, drive
from envfit.base import FolderLock, ResultStore

__all__ = ["LibraryFitResult", "fit_smoothness_library", "DEFAULT_REFINE", "lattice"]


@dataclass(kw_only=True)
class LibraryFitResult(LibraryResult):
    """Per-map :class:`~envfit.fit._smoothness.FitResult` (``fits[k]`` for map ``labels[k]``);
    the common fields are :class:`~envfit.batch._library_result.LibraryResult`'s."""
    fits: list[FitResult]
    method: str
    n: int
    #: rounds of shared evaluations, and evaluations read back from ``out``
    rounds: int = 0
    evaluations_resumed: int = 0

    def per_map(self) -> list[FitResult]:
        return self.fits

    def summary_rows(self) -> list[dict]:
        """One row per map: slug, name, ŝ, its interval, σ̂ per channel."""
        return [{"slug": slug, "map": label, "s": f.s, "s_low": f.s_interval[0],
                 "s_high": f.s_interval[1], "sigma": list(f.sigma)}
                for slug, label, f in zip(self.slugs, self.labels, self.fits)]

    def _header(self) -> dict:
        return {"method": self.method, "n": self.n, "rounds": self.rounds,
                "evaluations_resumed": self.evaluations_resumed}

    def _map_dict(self, label: str, result: FitResult) -> dict:
        return {"map": label, **result.to_dict()}


def _key(s: float) -> str:
    return f"s{s:.8f}"


def fit_smoothness_library(maps: Sequence, *, method: str = DEFAULT_METHOD, n: int = DEFAULT_N,
                           scale: str = "display", pointset: str = "sf", seed: int = 0,
                           n_holdout: int = 20000, s_grid=S_GRID, refine: int = DEFAULT_REFINE,
                           out: str | Path | None = None,
                           on_round: Callable[[int, int], None] | None = None,
                           options: LibraryOptions | None = None) -> LibraryFitResult:
    """Fit s (interval, σ̂) for every map of ``maps``; see the module docstring.

    ``maps`` as :func:`envfit.batch._library.run_table2_library`; ``method``, ``n``, ``scale``,
    ``pointset``, ``seed``, ``n_holdout``, ``s_grid``, ``refine`` as
    :func:`envfit.fit._smoothness.fit_smoothness` (``s_grid`` must be uniform). ``out``:
    resumable cells per map and the summary files (:func:`envfit.batch._report.write_fit_library`).
    ``on_round(round, factorisations)`` is called after each round of shared evaluations.
    ``options``: how the maps are read and where the tasks run (executor, workers, dask
    scheduler, load options, progress bars;
    :class:`~envfit.batch._library_result.LibraryOptions`).
    """
    t_start = time.perf_counter()
    options = LibraryOptions.of(options)
    if method not in METHODS:
        raise ParameterError(f"unknown fit method {method!r}; choose one of {', '.join(METHODS)}")
    if scale not in SCALES:
        raise ParameterError(f"unknown scale {scale!r}; choose one of {', '.join(SCALES)}")
    n = check_int(n, "the number of samples n", 10)
    grid = search_lattice(s_grid, refine)[0]
    sources = distinct_labels(resolve_map_sources(maps, options.load_options))
    # the memory guard (one criterion task: the interpolator with every map's samples as
    # right-hand sides, as the executor is sized below), before any sample is made
    plan_memory(n, "the library fit", channels=2 * 3 * len(sources),
                fixed_bytes=8 * 4 * min(int(n_holdout), 2 ** 62) * len(sources)
                if method == "holdout" else 0, smallest=10, n_name="n")
    spec = SweepSpec(pointset=pointset, seed=int(seed), scale=scale, up=sources[0].up)
    spec.points(4)
    out = Path(out) if out is not None else None
    config = {"method": method, "n": n, "scale": scale, "pointset": pointset, "seed": int(seed),
              "up": spec.up, "s_grid": grid, "refine": int(refine),
              "n_holdout": int(n_holdout) if method == "holdout" else None}
    lib = LibraryFitResult(fits=[], labels=[s.label for s in sources],
                           slugs=[s.slug for s in sources], method=method, n=n, scale=scale,
                           pointset=pointset, seed=int(seed))
    # one lock for the whole --out folder, taken before any cell is read (module store)
    with (FolderLock(out, on_note=lib.notes.append) if out is not None
          else contextlib.nullcontext()):
        stores = [ResultStore(out / src.slug / f"fit_{method}_n{n}" if out is not None else None,
                              {"map": src.identity(), **config}, kind="fit", lock=False,
                              on_note=lib.notes.append) for src in sources]
        searches = [SmoothnessSearch(method, n, grid, refine) for _ in sources]
        meta = _resume(lib, stores, searches)
        run = _LibraryRun(lib, sources, stores, searches, meta, spec, n_holdout,
                          on_round=on_round, options=options)
        with run:
            results = run_searches(searches, run.evaluate_round)
            run.sample([i for i in range(len(sources)) if i not in meta])
        _finish(lib, searches, results, meta, run.cost)
        lib.unwritten = [u for st in stores for u in st.unwritten]
        lib.seconds = time.perf_counter() - t_start
        if out is not None:
            from envfit.batch._report import write_fit_library
            write_fit_library(lib, out)
    return lib


def _resume(lib: LibraryFitResult, stores, searches) -> dict[int, dict]:
    """Give each search its map's stored evaluations (unsound cells are noted by the store and
    left out); returns the maps' stored meta cells by map index."""
    meta: dict[int, dict] = {}
    for i, st in enumerate(stores):
        for key, cell in st.items():
            if key == "meta":
                meta[i] = cell
            else:
                searches[i].add(float(cell["s"]), cell)
                lib.evaluations_resumed += 1
    return meta


class _LibraryRun:
    """The rounds of shared evaluations: sample the maps once (kept in memory), then per round
    one :func:`~envfit.batch._fit_tasks.criterion_task` per distinct s requested, for all the
    maps requesting it; every evaluation is stored as it arrives. A context manager: the
    executor is made at the first round and closed at the end (unless it was given)."""

    def __init__(self, lib, sources, stores, searches, meta, spec, n_holdout, *, on_round,
                 options: LibraryOptions):
        self.lib, self.sources, self.stores, self.searches = lib, sources, stores, searches
        self.meta, self.spec, self.on_round = meta, spec, on_round
        self.n_holdout = n_holdout if lib.method == "holdout" else None
        self.options, self.quiet = options, options.quiet
        self.grid_set = set(searches[0].grid) if searches else set()
        self.samples: dict[int, dict] = {}
        #: per map, its share of the factorisations' seconds
        self.cost = [0.0] * len(sources)
        self.ex = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.options.close(self.ex)

    def _executor(self):
        if self.ex is None:
            self.ex, notes = self.options.make_executor(
                max_useful=len(self.grid_set),
                bytes_per_task=interpolator_nbytes(self.lib.n, 2 * 3 * len(self.sources)))
            self.lib.notes.extend(notes)
            self.lib.executor = self.ex.describe()
        return self.ex

    def evaluate_round(self, wanted: dict[int, list[float]]) -> None:
        """One round: every s in ``wanted`` (map → s values) evaluated once for its maps."""
        self.lib.rounds += 1
        self.sample([i for i in wanted if i not in self.samples])
        by_s: dict[float, list[int]] = {}
        for i, req in wanted.items():
            for s in req:
                by_s.setdefault(float(s), []).append(i)
        shared: dict[tuple, object] = {}
        tasks = [Task(2, criterion_task, functools.partial(self._criterion_args, s, tuple(idx),
                                                           shared),
                      label=f"fit criterion at s={s:.4f}",
                      on_done=functools.partial(self._done, s, tuple(idx)))
                 for s, idx in sorted(by_s.items())]
        from envfit.base import progress_bar
        bar = progress_bar(len(tasks), desc=f"library fit, round {self.lib.rounds}",
                           quiet=self.quiet, unit="s")
        for t in tasks:
            t.on_done = _then(t.on_done, lambda _r: bar.update(1))
        try:
            drive(self._executor(), tasks)
        finally:
            bar.close()
        if self.on_round:
            self.on_round(self.lib.rounds, self.lib.factorizations)

    def _criterion_args(self, s: float, idx: tuple, shared: dict):
        """The task's arguments; the maps' samples are shared once per group of maps."""
        if idx not in shared:
            holdout = self.lib.method == "holdout"
            shared[idx] = self._executor().share({
                "values": np.hstack([self.samples[i]["values"] for i in idx]),
                "widths": [self.samples[i]["values"].shape[1] for i in idx],
                "holdout": [self.samples[i]["holdout"] for i in idx] if holdout else None})
        return (self.spec, self.lib.method, s, self.lib.n, shared[idx], s in self.grid_set)

    def _done(self, s: float, idx: tuple, res: dict) -> None:
        self.lib.factorizations += 1
        share = res["seconds"] / len(idx)
        for i, cell in zip(idx, res["maps"]):
            cell = {"s": s, **cell}
            self.stores[i].put(_key(s), cell)
            self.searches[i].add(s, cell)
            self.cost[i] += share

    def sample(self, todo: list[int]) -> None:
        """Sample the maps ``todo`` (one task each), keep the samples, store their meta
        cells (also for a map whose every evaluation was resumed but whose meta was not)."""
        if not todo:
            return
        lib, spec = self.lib, self.spec

        def done(i, res):
            # n against the map's pixel count and a constant map, before any factorisation
            label = self.sources[i].label
            check_sample_count(lib.n, res["width"], res["height"], name=label, what="n")
            check_not_constant(res["values"], spec.scale, label, where=f" at its {lib.n} samples")
            self.samples[i] = res
            self.meta[i] = {"height": res["height"], "width": res["width"],
                            "channels": res["channels"],
                            "scale_description": res["scale_description"]}
            self.stores[i].put("meta", self.meta[i])

        drive(self._executor(), [Task(1, fit_sample_task,
                                      (self.sources[i], spec, lib.n, self.n_holdout),
                                      label=f"map {self.sources[i].label}",
                                      on_done=functools.partial(done, i)) for i in todo])


def _finish(lib, searches, results, meta, cost) -> None:
    """Each map's :class:`FitResult` from its search, into ``lib.fits``."""
    for i, (search, res) in enumerate(zip(searches, results)):
        notes = []
        if lib.method == "holdout":
            notes.append("holdout: pixel centres drawn with probability proportional to solid angle")
        constant = ([c for c, x in enumerate(res.sigma) if x == 0.0]
                    if lib.method == "likelihood" else [])
        notes.extend(fit_notes(res.s_interval, constant, lib.scale))
        lib.fits.append(FitResult(
            s=res.s, s_interval=res.s_interval, sigma=res.sigma, method=lib.method,
            scale=lib.scale, n=lib.n,
            scale_description=meta.get(i, {}).get("scale_description", ""),
            curve=search.curve(), score_name=SCORE_NAMES[lib.method],
            seconds=cost[i], notes=notes))


def _then(first, second):
    def both(result):
        first(result)
        second(result)
    return both

r"""Fit the Sobolev smoothness s of every map of a library, one factorisation per s.

:func:`envfit.fit.smoothness.fit_smoothness` evaluates its criterion (profiled GP likelihood,
closed-form leave-one-out or hold-out RMSE; see :mod:`envfit.fit.smoothness`) at ~30 values of s,
each needing the Cholesky factor of :math:`K^{(s)}` at the sample directions — which do not
depend on the map. Here every map is sampled at the same N directions and each s is
factorised once for all maps (:func:`envfit.batch.fit_tasks.criterion_task`).

Sharing needs every map to be evaluated at the *same* s values, so the continuous
refinement is a shared lattice instead of per-map Brent iterations:

1. the coarse grid :data:`envfit.fit.smoothness.S_GRID` (step 0.075), for every map;
2. per map, its bracket around the grid minimum (the grid neighbours, as
   :func:`~envfit.fit.smoothness.fit_smoothness_samples`) on a lattice of step 0.075/``refine``
   (default 3, step 0.025); the estimate is the minimum of the cubic spline through the
   bracket's lattice values;
3. likelihood: the 95 % profile interval :math:`2N(\mathrm{score}(s) - \mathrm{score}(\hat
   s)) \le \chi^2_{1,0.95}` — lattice points are added outward from :math:`\hat s` until
   the criterion crosses the threshold on both sides (or the edge of (1, 2) is reached), and
   the crossing is solved on the spline; loo/holdout: the bootstrap interval on the grid,
   as the single-map fit.
   σ̂ at :math:`\hat s` is the spline of :math:`\log\hat\sigma` through the same lattice.

Maps whose brackets coincide share every evaluation; a library needs at most the ~40
lattice points of (1, 2) factorisations whatever its size. The estimate and the interval
ends are within ~1e-5 of the exact optimum and crossings (GP maps, N = 400, against a
1e-7 Brent search), i.e. closer than the single-map search, whose tolerance is 2e-3; the
criterion values at shared s equal the single-map ones to rounding (tests). Every (map, s)
evaluation is a resumable cell in ``OUT/<slug>/fit_<method>_n<N>/cells``.

Example
-------
>>> import numpy as np
>>> from envfit.maps.envmap import EnvMap
>>> from envfit.data_gen.gp import gaussian_process_map
>>> maps = [EnvMap(gaussian_process_map(1.5, 16, seed=k, channels=1) + 3.0, name=f"gp{k}")
...         for k in range(2)]
>>> lib = fit_smoothness_library(maps, n=200, scale="linear", workers=1)
>>> [1.0 < f.s < 2.0 for f in lib.fits]
[True, True]
"""
from __future__ import annotations

import contextlib
import functools
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
from scipy import optimize
from scipy.interpolate import CubicSpline

from envfit.base.checks import check_int
from envfit.maps.envmap import check_sample_count
from envfit.base.errors import ParameterError
from envfit.batch.executor import make_executor
from envfit.fit.smoothness import (CHI2_1_95, DEFAULT_METHOD, DEFAULT_N, METHODS, S_GRID, SCORE_NAMES,
                  FitResult, bootstrap_argmin_interval)
from envfit.base.resources import interpolator_nbytes
from envfit.batch.fit_tasks import criterion_task, fit_sample_task
from envfit.batch.tasks import SweepSpec
from envfit.maps.mapsource import LoadOptions, resolve_map_sources
from envfit.base.resources import plan_memory
from envfit.maps.scales import SCALES, check_not_constant
from envfit.batch.scheduler import Task, drive
from envfit.base.store import FolderLock, ResultStore

__all__ = ["LibraryFitResult", "fit_smoothness_library", "DEFAULT_REFINE", "lattice"]

DEFAULT_REFINE = 3
EDGE_LO, EDGE_HI = 1.0 + 1e-6, 2.0 - 1e-6
#: lattice points requested per side and round while looking for the interval's ends
_WALK_BATCH = 4


@dataclass
class LibraryFitResult:
    """Per-map :class:`~envfit.fit.smoothness.FitResult` (``fits[k]`` for map ``labels[k]``)."""
    fits: list[FitResult]
    labels: list[str]
    slugs: list[str]
    method: str
    n: int
    scale: str
    pointset: str
    seed: int
    factorizations: int = 0
    rounds: int = 0
    evaluations_resumed: int = 0
    seconds: float = 0.0
    executor: str = ""
    notes: list[str] = field(default_factory=list)
    #: ``(path, reason)`` of cells that could not be written (kept in memory, reported)
    unwritten: list[tuple[str, str]] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)

    def summary_rows(self) -> list[dict]:
        return [{"slug": slug, "map": label, "s": f.s, "s_low": f.s_interval[0],
                 "s_high": f.s_interval[1], "sigma": list(f.sigma)}
                for slug, label, f in zip(self.slugs, self.labels, self.fits)]

    def to_dict(self) -> dict:
        return {"method": self.method, "n": self.n, "scale": self.scale,
                "pointset": self.pointset, "seed": self.seed,
                "factorizations": self.factorizations, "rounds": self.rounds,
                "evaluations_resumed": self.evaluations_resumed, "seconds": self.seconds,
                "executor": self.executor, "notes": self.notes, "summary": self.summary_rows(),
                "maps": {slug: {"map": label, **f.to_dict()}
                         for slug, label, f in zip(self.slugs, self.labels, self.fits)},
                "files": self.files}


def lattice(grid: Sequence[float], refine: int) -> np.ndarray:
    """The grid refined ``refine`` times (same origin), inside (1, 2), plus both edges.

    >>> lattice([1.2, 1.5, 1.8], 1)[:3].tolist()
    [1.000001, 1.2, 1.5]
    """
    g = np.asarray(grid, dtype=float)
    h = (g[1] - g[0]) / refine if len(g) > 1 else 0.075 / refine
    j = np.arange(int(np.floor((1.0 - g[0]) / h)) - 1, int(np.ceil((2.0 - g[0]) / h)) + 2)
    pts = np.round(g[0] + j * h, 10)
    pts = pts[(pts > EDGE_LO) & (pts < EDGE_HI)]
    return np.concatenate([[EDGE_LO], pts, [EDGE_HI]])


def _key(s: float) -> str:
    return f"s{s:.8f}"


class _MapFit:
    """The evaluations of one map and the lattice logic deciding what it needs next."""

    def __init__(self, grid, lat, method: str, n: int):
        self.grid, self.lat, self.method, self.n = grid, lat, method, n
        self.ev: dict[float, dict] = {}
        self.cost = 0.0

    def score(self, s):
        return self.ev[s]["score"]

    def bracket(self) -> tuple[float, float]:
        k = int(np.argmin([self.score(s) for s in self.grid]))
        lo = self.grid[k - 1] if k > 0 else EDGE_LO
        hi = self.grid[k + 1] if k < len(self.grid) - 1 else EDGE_HI
        return lo, hi

    def inner(self) -> list[float]:
        """Lattice points of the bracket, strictly inside (1, 2) (the edges are only
        evaluated when an interval reaches them, as in the single-map fit)."""
        lo, hi = self.bracket()
        return [float(s) for s in self.lat if lo <= s <= hi and EDGE_LO < s < EDGE_HI]

    def _spline(self, run, key="score"):
        y = np.array([self.ev[s][key] for s in run]) if key == "score" else \
            np.log(np.array([self.ev[s]["sigma"] for s in run]))
        return CubicSpline(np.asarray(run), y)

    def _minimum(self, run, lo, hi) -> tuple[float, float]:
        cs = self._spline(run)
        cand = [lo, hi, *[float(r) for r in cs.derivative().roots(extrapolate=False)
                          if lo <= r <= hi]]
        vals = cs(np.array(cand))
        k = int(np.argmin(vals))
        return float(cand[k]), float(vals[k])

    def _walk(self, s_hat, target, side) -> tuple[float | None, list[float]]:
        """(outermost lattice point needed on this side, or None; points still to evaluate)."""
        outer = self.lat[self.lat < s_hat][::-1] if side < 0 else self.lat[self.lat > s_hat]
        for pos, s in enumerate(outer):
            if s not in self.ev:
                return None, [x for x in outer[pos:pos + _WALK_BATCH] if x not in self.ev]
            if self.score(s) > target:
                return float(s), []
        return float(outer[-1]) if len(outer) else s_hat, []

    def requests(self) -> list[float]:
        """Lattice points this map still needs (empty: ready to finish)."""
        missing = [s for s in self.grid if s not in self.ev]
        if missing:
            return missing
        inner = self.inner()
        missing = [s for s in inner if s not in self.ev]
        if missing or self.method != "likelihood":
            return missing
        s_hat, best = self._minimum(inner, inner[0], inner[-1])
        target = best + CHI2_1_95 / (2 * self.n)
        return [*self._walk(s_hat, target, -1)[1], *self._walk(s_hat, target, +1)[1]]

    def finish(self) -> tuple[float, tuple[float, float], list[float]]:
        inner = self.inner()
        lo, hi = inner[0], inner[-1]
        s_hat, best = self._minimum(inner, lo, hi)
        if self.method == "likelihood":
            target = best + CHI2_1_95 / (2 * self.n)
            left, _ = self._walk(s_hat, target, -1)
            right, _ = self._walk(s_hat, target, +1)
            run = [float(s) for s in self.lat if left <= s <= right]
            s_hat, best = self._minimum(run, lo, hi)
            cs = self._spline(run)
            f = lambda x: float(cs(x)) - target  # noqa: E731
            lo_s = left if f(left) <= 0 else optimize.brentq(f, left, s_hat, xtol=1e-6)
            hi_s = right if f(right) <= 0 else optimize.brentq(f, s_hat, right, xtol=1e-6)
            interval = (float(lo_s), float(hi_s))
        else:
            run = inner
            means = np.array([self.ev[s]["boot"] for s in self.grid]).T
            b_lo, b_hi = bootstrap_argmin_interval(self.grid, means)
            interval = (min(b_lo, s_hat), max(b_hi, s_hat))
        sigma = np.exp(self._spline(run, "sigma")(s_hat))
        return s_hat, interval, [float(x) for x in np.atleast_1d(sigma)]


def fit_smoothness_library(maps: Sequence, *, method: str = DEFAULT_METHOD, n: int = DEFAULT_N,
                           scale: str = "display", pointset: str = "sf", seed: int = 0,
                           n_holdout: int = 20000, s_grid=S_GRID, refine: int = DEFAULT_REFINE,
                           out: str | Path | None = None, executor="local",
                           workers: int | None = None, scheduler: str | None = None,
                           load_options: LoadOptions | None = None, quiet: bool = True,
                           on_round: Callable[[int, int], None] | None = None) -> LibraryFitResult:
    """Fit s (interval, σ̂) for every map of ``maps``; see the module docstring.

    ``maps``, ``executor``, ``workers``, ``scheduler``, ``load_options`` as
    :func:`envfit.batch.library.run_table2_library`; ``method``, ``n``, ``scale``, ``pointset``,
    ``seed``, ``n_holdout``, ``s_grid`` as :func:`envfit.fit.smoothness.fit_smoothness` (``s_grid``
    must be uniform). ``out``: resumable cells per map and the summary files
    (:func:`envfit.batch.report.write_fit_library`). ``on_round(round, factorisations)``
    is called after each round of shared evaluations.
    """
    t_start = time.perf_counter()
    if method not in METHODS:
        raise ParameterError(f"unknown fit method {method!r}; choose one of {', '.join(METHODS)}")
    if scale not in SCALES:
        raise ParameterError(f"unknown scale {scale!r}; choose one of {', '.join(SCALES)}")
    n = check_int(n, "the number of samples n", 10)
    grid = [float(s) for s in s_grid]
    if len(grid) < 3 or not np.allclose(np.diff(grid), grid[1] - grid[0]) or grid[1] <= grid[0]:
        raise ParameterError("a library fit needs a uniform, increasing s grid of 3 or more values")
    if int(refine) < 1:
        raise ParameterError(f"refine must be at least 1, got {refine}")
    lat = lattice(grid, int(refine))
    grid = [float(lat[np.argmin(np.abs(lat - g))]) for g in grid]   # the lattice's own floats
    sources = resolve_map_sources(maps, load_options)
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
        fits = [_MapFit(grid, lat, method, n) for _ in sources]
        meta: dict[int, dict] = {}
        for i, st in enumerate(stores):
            for key, cell in st.items():         # unsound cells are noted and left out
                if key == "meta":
                    meta[i] = cell
                else:
                    fits[i].ev[float(cell["s"])] = cell
                    lib.evaluations_resumed += 1
        _rounds(lib, fits, stores, meta, sources, spec, grid, n_holdout, quiet=quiet,
                on_round=on_round, executor=executor, workers=workers, scheduler=scheduler)
        _finish(lib, fits, meta)
        lib.unwritten = [u for st in stores for u in st.unwritten]
        lib.seconds = time.perf_counter() - t_start
        if out is not None:
            from envfit.batch.report import write_fit_library
            write_fit_library(lib, out)
    return lib


def _rounds(lib, fits, stores, meta, sources, spec, grid, n_holdout, *, quiet, on_round,
            executor, workers, scheduler) -> None:
    """Evaluate, round after round, the lattice points the maps still request (each s
    factorised once for all maps); every evaluation is stored as it arrives."""
    method, n = lib.method, lib.n
    ex = None
    samples: dict[int, dict] = {}
    grid_set = set(grid)
    try:
        while True:
            wanted = {i: f.requests() for i, f in enumerate(fits)}
            # a map without its meta cell (an unsound file) is sampled again, to rewrite it
            wanted = {i: r for i, r in wanted.items() if r or i not in meta}
            if not wanted:
                break
            if ex is None:
                ex, notes = make_executor(
                    executor, workers=workers, scheduler=scheduler, max_useful=len(grid),
                    bytes_per_task=interpolator_nbytes(n, 2 * 3 * len(sources)))
                lib.notes.extend(notes)
                lib.executor = ex.describe()
            lib.rounds += 1
            _sample(ex, sources, spec, n, n_holdout if method == "holdout" else None,
                    [i for i in wanted if i not in samples], samples, meta, stores)
            by_s: dict[float, list[int]] = {}
            for i, req in wanted.items():
                for s in req:
                    by_s.setdefault(float(s), []).append(i)
            shared: dict[tuple, object] = {}

            def payload(idx):
                if idx not in shared:
                    shared[idx] = ex.share({
                        "values": np.hstack([samples[i]["values"] for i in idx]),
                        "widths": [samples[i]["values"].shape[1] for i in idx],
                        "holdout": ([samples[i]["holdout"] for i in idx]
                                    if method == "holdout" else None)})
                return shared[idx]

            def done(s, idx, res):
                lib.factorizations += 1
                share = res["seconds"] / len(idx)
                for i, cell in zip(idx, res["maps"]):
                    cell = {"s": s, **cell}
                    stores[i].put(_key(s), cell)
                    fits[i].ev[s] = cell
                    fits[i].cost += share

            tasks = [Task(2, criterion_task,
                          functools.partial(lambda s, idx: (spec, method, s, n, payload(idx),
                                                            s in grid_set), s, tuple(idx)),
                          label=f"fit criterion at s={s:.4f}",
                          on_done=functools.partial(done, s, tuple(idx)))
                     for s, idx in sorted(by_s.items())]
            from envfit.base.progress import progress_bar
            bar = progress_bar(len(tasks), desc=f"library fit, round {lib.rounds}", quiet=quiet,
                               unit="s")
            for t in tasks:
                t.on_done = _then(t.on_done, lambda _r: bar.update(1))
            try:
                drive(ex, tasks)
            finally:
                bar.close()
            if on_round:
                on_round(lib.rounds, lib.factorizations)
    finally:
        if ex is not None and ex is not executor:
            ex.close()


def _finish(lib, fits, meta) -> None:
    """Each map's estimate, interval and σ̂ from its evaluations, into ``lib.fits``."""
    method, n, scale = lib.method, lib.n, lib.scale
    for i, f in enumerate(fits):
        s_hat, interval, sigma = f.finish()
        notes = []
        if method == "holdout":
            notes.append("holdout: pixel centres drawn with probability proportional to solid angle")
        if interval[0] <= 1.0 + 1e-3 or interval[1] >= 2.0 - 1e-3:
            notes.append("the interval reaches the edge of (1, 2): the map may be rougher/smoother "
                         "than this kernel family can express")
        curve = [{"s": float(s), "score": float(c["score"])} for s, c in sorted(f.ev.items())]
        lib.fits.append(FitResult(
            s=s_hat, s_interval=interval, sigma=sigma, method=method, scale=scale, n=n,
            scale_description=meta.get(i, {}).get("scale_description", ""), curve=curve,
            score_name=SCORE_NAMES[method], seconds=f.cost, notes=notes))


def _then(first, second):
    def both(result):
        first(result)
        second(result)
    return both


def _sample(ex, sources, spec, n, n_holdout, todo, samples, meta, stores) -> None:
    """Sample the maps ``todo`` (one task each); keep the samples in memory."""
    def done(i, res):
        # n against the map's pixel count and a constant map, before any factorisation
        check_sample_count(n, res["width"], res["height"], name=sources[i].label, what="n")
        check_not_constant(res["values"], spec.scale, sources[i].label,
                           where=f" at its {n} samples")
        samples[i] = res
        meta[i] = {"height": res["height"], "width": res["width"],
                   "channels": res["channels"], "scale_description": res["scale_description"]}
        stores[i].put("meta", meta[i])

    drive(ex, [Task(1, fit_sample_task, (sources[i], spec, n, n_holdout),
                    label=f"map {sources[i].label}", on_done=functools.partial(done, i))
               for i in todo])

r"""``envfit validate --renderer``: the renderer estimators' predicted RMSE against the measured one.

For every lobe (diffuse; glossy with the run's shininess), strategy of
:data:`envfit.sampling._rules.STRATEGIES` (``brdf``, ``map``, ``mis``, ``split``),
point set (default random, sobol, sf) and N (default 16, 64, 256, 1024) — one *cell* —:

* **predicted** — :func:`envfit.predict.renderer._predictor.predict_rule` on the warped-integrand spectra
  of the map (:func:`envfit.predict.renderer._predictor.renderer_model`, one model per lobe, built only
  for the strategies of the cells still to compute), with its predictor's name
  (``warped-spectrum`` or ``random-variance``);
* **measured** — :func:`envfit.measure._rules.measure_rule`: the RMSE over uniform
  random axes with its BCa bootstrap 95 % interval, doubling the axes from ``axes_start`` until
  the interval is within ±``target_relative`` (or ``max_axes`` are measured); one seed for
  every rule, so the axes and their ground truths are shared;
* **agreement** — :func:`envfit.measure._adaptive_rmse.agreement_with_interval`: the ratio
  predicted/measured, ``within_band`` (\|ratio − 1\| ≤ 20 %), ``inside_interval`` and
  ``agrees`` (either of the two).

Summaries: per rule (lobe × strategy × point set) the median ratio over N, the fraction of its
cells that agree and the worst ratio (farthest from 1 in log); per lobe the same over all its
cells and, at each N, the strategy with the lowest measured RMSE (its best point set) beside
the runner-up strategy. The bright sources split off (:meth:`BrightSource.summary`) and the
seconds of each step are recorded.

The integrand is the run's scaled map (``--scale linear`` is what renderers integrate).
Every cell is a checksummed cell of the run's :class:`envfit.base._store.ResultStore` (key
:func:`renderer_cell_key`), holding the settings it was computed with; a stored cell whose
settings are this run's is not recomputed (neither its prediction nor its measurement, and a
lobe whose cells are all stored builds no spectra).

Steps of :func:`run_renderer_validation`: :func:`_prepare` (the sampler and the sources),
:func:`_stored_cells` (resume), :func:`_models` (the spectra the missing cells need),
:func:`_compute_cell` for each missing cell, :func:`summarize_rules` /
:func:`summarize_lobes`.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> env = EnvMap(np.full((8, 16, 1), 2.0), name="const")
>>> cfg = renderer_quick_config(strategies=("brdf",), pointsets=("sobol",), lobes=("diffuse",),
...                             n_values=(16,), grid=16, spectrum_axes=4, axes_start=20,
...                             max_axes=20, resamples=100)
>>> res = run_renderer_validation(env, cfg)
>>> c = res.cells[0]
>>> (c.strategy, c.pointset, c.n, c.predictor, round(c.predicted_rmse, 9), round(c.measured_rmse, 9))
('brdf', 'sobol', 16, 'warped-spectrum', 0.0, 0.0)
>>> res.rules[0].cells, res.to_json()["cells"][0]["n"]
(1, 16)
"""
from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field, fields
from typing import Callable, Sequence

from envfit.base._checks import check_int, check_ints, check_names, check_positive
from envfit.base._errors import ParameterError
from envfit.base._progress import progress_bar
from envfit.base._resources import machine_cores
from envfit.base._store import ResultStore, array_fingerprint
from envfit.maps._envmap import EnvMap
from envfit.predict.renderer._predictor import predict_rule, renderer_model
from envfit.measure._adaptive_rmse import agreement_with_interval
from envfit.measure._rules import AXIS_SAMPLING, RendererSetup, measure_rule
from envfit.sampling._rules import STRATEGIES, RendererRule
from envfit.theory._pointsets import POINTSETS

from envfit.defaults import (BRDFS, DEFAULT_SHININESS, QUICK_RENDERER_GRID, QUICK_SPECTRUM_AXES,
                             RENDERER_AXES_START, RENDERER_GRID, RENDERER_MAX_AXES,
                             VALIDATE_RENDERER_POINTSETS, VALIDATE_SPECTRUM_AXES)

__all__ = ["RendererValidationConfig", "renderer_quick_config", "renderer_config",
           "RendererCell", "RendererRuleSummary", "RendererLobeSummary", "RendererValidation",
           "run_renderer_validation", "renderer_cell_key", "summarize_rules", "summarize_lobes",
           "worst_ratio", "summary_lines", "RENDERER_POINTSETS", "RENDERER_N", "RENDERER_QUICK_N",
           "RENDERER_CELL_FORMAT"]

#: the default point sets of the renderer rules (random: plain Monte Carlo; envfit.defaults)
RENDERER_POINTSETS = VALIDATE_RENDERER_POINTSETS
RENDERER_N = (16, 64, 256, 1024)
RENDERER_QUICK_N = (16, 256)
#: bumped when what a stored renderer cell holds changes (older cells are recomputed)
RENDERER_CELL_FORMAT = 2


# ----------------------------------------------------------------------------- configuration

@dataclass
class RendererValidationConfig:
    """What :func:`run_renderer_validation` runs (the defaults are the full run).

    Attributes
    ----------
    strategies : of :data:`envfit.sampling._rules.STRATEGIES`.
    pointsets : of :data:`envfit.theory._pointsets.POINTSETS` (default random, sobol, sf).
    lobes, shininess : "diffuse" and/or "glossy" (n = ``shininess``).
    n_values : the sample counts N ≥ 2.
    grid, spectrum_axes : the warped spectra's grid and axes (:func:`renderer_model`).
    axes_start, max_axes, target_relative, resamples : the adaptive measurement
        (:func:`measure_rule`).
    axis_sampling : how the measurement draws its axes (:data:`AXIS_SAMPLING`):
        "importance" (default; the map's axis proposal, weighted) or "uniform".
    band : the relative band of the agreement (:func:`agreement_with_interval`).
    seed : the measurement's seed (axes, twists, shifts, random sets).
    quick : only recorded (:func:`renderer_quick_config` made it).
    """

    strategies: Sequence[str] = tuple(STRATEGIES)
    pointsets: Sequence[str] = RENDERER_POINTSETS
    lobes: Sequence[str] = BRDFS
    shininess: float = DEFAULT_SHININESS
    n_values: Sequence[int] = RENDERER_N
    grid: int = RENDERER_GRID
    spectrum_axes: int = VALIDATE_SPECTRUM_AXES
    axes_start: int = 500
    max_axes: int = 16000
    target_relative: float = 0.10
    resamples: int = 2000
    axis_sampling: str = "importance"
    band: float = 0.2
    seed: int = 0
    quick: bool = False

    def __post_init__(self) -> None:
        self.strategies = tuple(check_names(self.strategies, tuple(STRATEGIES), "strategy"))
        self.pointsets = tuple(check_names(self.pointsets, tuple(POINTSETS), "point set"))
        self.lobes = tuple(check_names(self.lobes, BRDFS, "BRDF"))
        self.shininess = check_positive(self.shininess, "shininess")
        self.n_values = tuple(sorted(set(check_ints(self.n_values, "N", 2))))
        self.grid = check_int(self.grid, "the spectra's grid", 8)
        self.spectrum_axes = check_int(self.spectrum_axes, "the spectra's axes", 1)
        self.axes_start = check_int(self.axes_start, "axes_start", 2)
        self.max_axes = check_int(self.max_axes, "max_axes", self.axes_start)
        self.target_relative = check_positive(self.target_relative, "target_relative")
        self.resamples = check_int(self.resamples, "resamples", 10)
        self.axis_sampling = check_names([self.axis_sampling], tuple(AXIS_SAMPLING),
                                         "axis sampling")[0]
        self.band = check_positive(self.band, "band")
        self.seed = check_int(self.seed, "seed", 0)
        if not self.strategies or not self.pointsets or not self.lobes or not self.n_values:
            raise ParameterError("the renderer validation needs at least one strategy, point "
                                 "set, BRDF and N")

    def to_dict(self) -> dict:
        """The configuration as JSON-ready values (tuples as lists)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def cell_settings(self, lobe: str) -> dict:
        """What a cell of ``lobe`` depends on besides its rule and the map (a stored cell with
        other settings is recomputed)."""
        return {"format": RENDERER_CELL_FORMAT, "grid": self.grid,
                "spectrum_axes": self.spectrum_axes, "axes_start": self.axes_start,
                "max_axes": self.max_axes, "target_relative": self.target_relative,
                "resamples": self.resamples, "band": self.band, "seed": self.seed,
                "axis_sampling": self.axis_sampling,
                "shininess": self.shininess if lobe == "glossy" else None}


def renderer_quick_config(**overrides) -> RendererValidationConfig:
    """The ``--quick`` preset: N 16, 256; spectra grid 256 with 32 axes; 250 → 4000 axes.

    >>> c = renderer_quick_config()
    >>> c.n_values, c.grid, c.spectrum_axes, c.axes_start, c.max_axes
    ((16, 256), 256, 32, 250, 4000)
    """
    base = dict(n_values=RENDERER_QUICK_N, grid=QUICK_RENDERER_GRID,
                spectrum_axes=QUICK_SPECTRUM_AXES, axes_start=RENDERER_AXES_START,
                max_axes=RENDERER_MAX_AXES, quick=True)
    base.update(overrides)
    return RendererValidationConfig(**base)


def renderer_config(quick: bool = False, **overrides) -> RendererValidationConfig:
    """The full configuration, or with ``quick`` :func:`renderer_quick_config`; None values
    of ``overrides`` are left at the preset's default.

    >>> renderer_config(True, n_values=None, lobes=["glossy"]).n_values
    (16, 256)
    """
    over = {k: v for k, v in overrides.items() if v is not None}
    return renderer_quick_config(**over) if quick else RendererValidationConfig(**over)


# ----------------------------------------------------------------------------- results

def _finite_or_none(x):
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass
class RendererCell:
    """One lobe × strategy × point set × N: predicted and measured RMSE, their agreement.

    ``measured_low``/``measured_high`` the 95 % interval, ``axes`` how many were measured,
    ``target_met`` whether the interval reached ±``target_relative``; ``ratio`` =
    predicted/measured (None if undefined); ``within_band``, ``inside_interval``, ``agrees``
    (either) as :class:`envfit.measure._adaptive_rmse.Agreement`; ``settings``
    (:meth:`RendererValidationConfig.cell_settings`); seconds of the prediction and the
    measurement; ``resumed`` whether it was read from the store; ``axis_sampling`` how its
    axes were drawn ("importance" or "uniform"; records older than the field: "uniform").
    """

    lobe: str
    strategy: str
    pointset: str
    n: int
    predictor: str
    predicted_rmse: float
    measured_rmse: float
    measured_low: float
    measured_high: float
    relative_half_width: float
    axes: int
    target_met: bool
    interval_method: str
    ratio: float | None
    within_band: bool
    inside_interval: bool
    agrees: bool
    settings: dict
    seconds_predict: float = 0.0
    seconds_measure: float = 0.0
    resumed: bool = False
    axis_sampling: str = "uniform"

    @property
    def rule_label(self) -> str:
        """``strategy/pointset``."""
        return f"{self.strategy}/{self.pointset}"

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_json(cls, d: dict) -> "RendererCell":
        return cls(**{f.name: d[f.name] for f in fields(cls) if f.name in d})


@dataclass
class RendererRuleSummary:
    """One lobe × strategy × point set over its N: median ratio, fraction of cells that
    agree, the worst ratio (farthest from 1 in log) and the N where it occurs."""

    lobe: str
    strategy: str
    pointset: str
    cells: int
    median_ratio: float | None
    fraction_agree: float
    worst_ratio: float | None
    worst_n: int | None

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class RendererLobeSummary:
    """All cells of one lobe: median ratio, fraction that agree, worst ratio and its rule;
    ``lowest_by_n``: per N the strategy with the lowest measured RMSE (at its best point set)
    and the runner-up strategy (None when only one strategy was measured)."""

    lobe: str
    cells: int
    median_ratio: float | None
    fraction_agree: float
    worst_ratio: float | None
    worst_rule: str | None
    worst_n: int | None
    lowest_by_n: list[dict] = field(default_factory=list)

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class RendererValidation:
    """What :func:`run_renderer_validation` returns; ``to_json()`` is the ``renderer``
    section of ``envfit validate``'s JSON, :meth:`from_json` reads it back."""

    map: str
    map_size: list[int]
    scale: str
    config: dict
    sources: list[dict]
    cells: list[RendererCell]
    rules: list[RendererRuleSummary]
    lobes: list[RendererLobeSummary]
    timings: dict
    resumed_cells: int = 0

    def to_json(self) -> dict:
        return {"map": self.map, "map_size": list(self.map_size), "scale": self.scale,
                "config": self.config, "sources": self.sources,
                "cells": [c.to_json() for c in self.cells],
                "rules": [r.to_json() for r in self.rules],
                "lobes": [x.to_json() for x in self.lobes], "timings": self.timings,
                "resumed_cells": self.resumed_cells}

    @classmethod
    def from_json(cls, d: dict) -> "RendererValidation":
        return cls(map=d["map"], map_size=list(d["map_size"]), scale=d["scale"],
                   config=d["config"], sources=d["sources"],
                   cells=[RendererCell.from_json(c) for c in d["cells"]],
                   rules=[RendererRuleSummary(**r) for r in d["rules"]],
                   lobes=[RendererLobeSummary(**x) for x in d["lobes"]], timings=d["timings"],
                   resumed_cells=int(d.get("resumed_cells", 0)))

    def cell(self, lobe: str, strategy: str, pointset: str, n: int) -> RendererCell:
        """The cell of one rule and N; KeyError if none."""
        for c in self.cells:
            if (c.lobe, c.strategy, c.pointset, c.n) == (lobe, strategy, pointset, int(n)):
                return c
        raise KeyError(f"no renderer cell {lobe}/{strategy}/{pointset}/{n}")


# ----------------------------------------------------------------------------- summaries

def _median(xs: list[float]) -> float | None:
    xs = sorted(x for x in xs if x is not None)
    if not xs:
        return None
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def worst_ratio(cells: Sequence[RendererCell]) -> RendererCell | None:
    """The cell whose ratio is farthest from 1 in log (a ratio of 0 is the farthest; cells
    without a ratio are skipped).

    >>> cs = [RendererCell("diffuse", "map", "sf", n, "warped-spectrum", r, 1.0, 0.9, 1.1, 0.1,
    ...                    100, True, "bca", r, True, True, True, {}) for n, r in ((16, 1.3), (64, 0.7))]
    >>> worst_ratio(cs).n
    64
    """
    ok = [c for c in cells if c.ratio is not None]
    if not ok:
        return None
    return max(ok, key=lambda c: math.inf if c.ratio <= 0 else abs(math.log(c.ratio)))


def summarize_rules(cells: Sequence[RendererCell]) -> list[RendererRuleSummary]:
    """One :class:`RendererRuleSummary` per lobe × strategy × point set, in the cells' order."""
    groups: dict[tuple, list[RendererCell]] = {}
    for c in cells:
        groups.setdefault((c.lobe, c.strategy, c.pointset), []).append(c)
    out = []
    for (lobe, strategy, pointset), cs in groups.items():
        w = worst_ratio(cs)
        out.append(RendererRuleSummary(
            lobe, strategy, pointset, len(cs), _median([c.ratio for c in cs]),
            sum(c.agrees for c in cs) / len(cs), None if w is None else w.ratio,
            None if w is None else w.n))
    return out


def _lowest_by_n(cells: Sequence[RendererCell]) -> list[dict]:
    """Per N: the strategy with the lowest measured RMSE (its best point set) and the runner-up."""
    out = []
    for n in sorted({c.n for c in cells}):
        best: dict[str, RendererCell] = {}
        for c in cells:
            if c.n == n and (c.strategy not in best or c.measured_rmse < best[c.strategy].measured_rmse):
                best[c.strategy] = c
        ranked = sorted(best.values(), key=lambda c: c.measured_rmse)
        out.append({"n": n, "lowest": _lowest_entry(ranked[0]),
                    "runner_up": _lowest_entry(ranked[1] if len(ranked) > 1 else None)})
    return out


def _lowest_entry(c: RendererCell | None) -> dict | None:
    return None if c is None else {
        "strategy": c.strategy, "pointset": c.pointset, "measured_rmse": c.measured_rmse,
        "measured_low": c.measured_low, "measured_high": c.measured_high}


def summarize_lobes(cells: Sequence[RendererCell]) -> list[RendererLobeSummary]:
    """One :class:`RendererLobeSummary` per lobe, in the cells' order."""
    out = []
    for lobe in dict.fromkeys(c.lobe for c in cells):
        cs = [c for c in cells if c.lobe == lobe]
        w = worst_ratio(cs)
        out.append(RendererLobeSummary(
            lobe, len(cs), _median([c.ratio for c in cs]), sum(c.agrees for c in cs) / len(cs),
            None if w is None else w.ratio, None if w is None else w.rule_label,
            None if w is None else w.n, _lowest_by_n(cs)))
    return out


# ----------------------------------------------------------------------------- the steps

def renderer_cell_key(lobe: str, strategy: str, pointset: str, n: int) -> str:
    """The store key of a renderer cell.

    >>> renderer_cell_key("glossy", "mis", "sobol", 64)
    'renderer_glossy_mis_sobol_64'
    """
    return f"renderer_{lobe}_{strategy}_{pointset}_{int(n)}"


def _all_rules(cfg: RendererValidationConfig) -> list[tuple[str, RendererRule]]:
    return [(lobe, RendererRule(s, ps, n)) for lobe in cfg.lobes for s in cfg.strategies
            for ps in cfg.pointsets for n in cfg.n_values]


def _prepare(envmap: EnvMap) -> tuple[RendererSetup, list[dict]]:
    """Step 1: the map's samplers and bright sources (:meth:`RendererSetup.of`), and the
    sources' summaries."""
    setup = RendererSetup.of(envmap)
    return setup, [s.summary() for s in setup.sources]


def _stored_cells(store: ResultStore, cfg: RendererValidationConfig) -> dict[str, RendererCell]:
    """Step 2: the stored cells computed with this configuration's settings, by key."""
    found = {}
    for lobe, rule in _all_rules(cfg):
        key = renderer_cell_key(lobe, rule.strategy, rule.pointset, rule.n)
        d = store.get(key)
        if d is None or d.get("settings") != cfg.cell_settings(lobe):
            continue
        try:
            cell = RendererCell.from_json(d)
        except TypeError:                   # a sound file lacking a field: recompute it
            continue
        cell.resumed = True
        found[key] = cell
    return found


def _models(setup: RendererSetup, cfg: RendererValidationConfig, todo, bar) -> tuple[dict, dict]:
    """Step 3: per lobe with cells to compute, the spectra of the strategies they need
    (:func:`renderer_model`); and the seconds per lobe."""
    models, seconds = {}, {}
    for lobe in cfg.lobes:
        strategies = list(dict.fromkeys(r.strategy for lb, r in todo if lb == lobe))
        if not strategies:
            continue
        t0 = time.perf_counter()
        models[lobe] = renderer_model(
            setup, lobe, cfg.shininess, strategies=strategies, grid=cfg.grid,
            axes=cfg.spectrum_axes,
            progress=lambda label, lobe=lobe: bar.set_postfix_str(f"spectrum {lobe} {label}"))
        seconds[lobe] = time.perf_counter() - t0
    return models, seconds


def _compute_cell(setup: RendererSetup, model, cfg: RendererValidationConfig, lobe: str,
                  rule: RendererRule) -> RendererCell:
    """Step 4 for one cell: the prediction, the measurement and their agreement."""
    t0 = time.perf_counter()
    pred = predict_rule(model, rule)            # point seed 0: the sets measure_rule uses
    t1 = time.perf_counter()
    meas = measure_rule(setup, rule, lobe, cfg.shininess, seed=cfg.seed,
                        target_relative=cfg.target_relative, axes_start=cfg.axes_start,
                        max_axes=cfg.max_axes, resamples=cfg.resamples,
                        sampling=cfg.axis_sampling)
    t2 = time.perf_counter()
    iv = meas.interval
    agr = agreement_with_interval(pred.rmse, iv, band=cfg.band)
    return RendererCell(
        lobe=lobe, strategy=rule.strategy, pointset=rule.pointset, n=rule.n,
        predictor=pred.name, predicted_rmse=float(pred.rmse), measured_rmse=float(iv.rmse),
        measured_low=float(iv.low), measured_high=float(iv.high),
        relative_half_width=float(iv.relative_half_width), axes=int(meas.axes),
        target_met=bool(meas.target_met), interval_method=iv.method,
        axis_sampling=meas.sampling,
        ratio=_finite_or_none(agr.ratio), within_band=bool(agr.within_band),
        inside_interval=bool(agr.inside), agrees=bool(agr.either),
        settings=cfg.cell_settings(lobe), seconds_predict=t1 - t0, seconds_measure=t2 - t1)


def _open_store(envmap: EnvMap, scale: str, seed: int, out) -> ResultStore:
    """A store of its own when :func:`run_renderer_validation` is not given the run's."""
    return ResultStore(out, {"map": envmap.name, "fingerprint": array_fingerprint(envmap.data),
                             "up": envmap.up, "scale": scale, "seed": seed},
                       kind="validate_renderer")


def run_renderer_validation(envmap: EnvMap, config: RendererValidationConfig | None = None, *,
                            scale: str = "linear", store: ResultStore | None = None, out=None,
                            quiet: bool = True,
                            on_cell: Callable[[str, bool], None] | None = None
                            ) -> RendererValidation:
    """Validate the renderer rules' predictions on ``envmap`` (see the module docstring).

    Parameters
    ----------
    envmap : the integrand, already on its value scale (``envfit validate`` passes its
        scaled map).
    config : :class:`RendererValidationConfig` (default: the full run).
    scale : the name of ``envmap``'s value scale (recorded).
    store : the run's :class:`ResultStore` (``envfit validate``'s); None: a store of its own in
        ``out`` (kind ``validate_renderer``; None: in memory), closed at the end.
    quiet : no progress bar.
    on_cell : called as ``on_cell(key, resumed)`` after every cell.

    Returns
    -------
    :class:`RendererValidation`.
    """
    cfg = config or RendererValidationConfig()
    t_start = time.perf_counter()
    own = store is None
    store = _open_store(envmap, scale, cfg.seed, out) if own else store
    try:
        t0 = time.perf_counter()
        setup, sources = _prepare(envmap)
        timings = {"setup": time.perf_counter() - t0}
        rules = _all_rules(cfg)
        stored = _stored_cells(store, cfg)
        todo = [(lb, r) for lb, r in rules
                if renderer_cell_key(lb, r.strategy, r.pointset, r.n) not in stored]
        cells = _run_cells(setup, cfg, store, rules, stored, todo, timings, quiet, on_cell)
    finally:
        if own:
            store.close()
    t0 = time.perf_counter()
    rule_summaries, lobe_summaries = summarize_rules(cells), summarize_lobes(cells)
    timings["summary"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    timings["compute"] = sum(timings.get("spectra_by_lobe", {}).values()) + sum(
        c.seconds_predict + c.seconds_measure for c in cells)
    return RendererValidation(envmap.name, [envmap.width, envmap.height], scale, cfg.to_dict(),
                              sources, cells, rule_summaries, lobe_summaries, timings,
                              resumed_cells=len(stored))


def _run_cells(setup, cfg, store, rules, stored, todo, timings, quiet, on_cell):
    """Steps 3–4 under one progress bar: the resumed cells, the spectra, the missing cells
    (each stored as soon as it is done); the cells in the order of ``rules``."""
    bar = progress_bar(len(rules), desc="validate: renderer", quiet=quiet, unit="cell")
    try:
        for key in stored:
            bar.update(1)
            if on_cell:
                on_cell(key, True)
        models, timings["spectra_by_lobe"] = _models(setup, cfg, todo, bar)
        timings["spectra"] = sum(timings["spectra_by_lobe"].values())
        done, t_cells = {}, time.perf_counter()
        # the cells on all cores (threads: numpy, ducc0 and the compiled lookups release the
        # GIL; each cell's random streams are its own, so the numbers do not depend on the
        # thread count); stored, counted and reported in the main thread as each finishes
        with ThreadPoolExecutor(max_workers=max(1, min(machine_cores(), len(todo)))) as pool:
            futures = {pool.submit(_compute_cell, setup, models[lobe], cfg, lobe, rule):
                       renderer_cell_key(lobe, rule.strategy, rule.pointset, rule.n)
                       for lobe, rule in todo}
            try:
                for fut in as_completed(futures):
                    key = futures[fut]
                    done[key] = fut.result()
                    store.put(key, done[key].to_json())
                    bar.set_postfix_str(key)
                    bar.update(1)
                    if on_cell:
                        on_cell(key, False)
            except BaseException:
                for fut in futures:                   # an error or a signal: start no more
                    fut.cancel()
                raise
        timings["cells"] = time.perf_counter() - t_cells
    finally:
        bar.close()
    timings["predict"] = sum(c.seconds_predict for c in done.values())
    timings["measure"] = sum(c.seconds_measure for c in done.values())
    all_cells = {**stored, **done}
    return [all_cells[renderer_cell_key(lb, r.strategy, r.pointset, r.n)] for lb, r in rules]


# ----------------------------------------------------------------------------- printing

def _g(v, fmt=".4g"):
    return "–" if v is None else format(v, fmt)


def summary_lines(renderer: dict) -> list[str]:
    """The compact table (rule, N, predicted, measured [low, high], ratio, agrees) and the
    per-rule summary of a ``renderer`` JSON section, as printed by ``envfit validate``."""
    lines = [f"renderer rules on {renderer['map']} ({renderer['scale']} scale): predicted vs "
             "measured RMSE (95 % interval)",
             f"  {'rule':22s} {'N':>5s} {'predicted':>10s} {'measured [low, high]':>32s} "
             f"{'ratio':>6s} agrees"]
    for c in renderer["cells"]:
        rule = f"{c['lobe']} {c['strategy']}/{c['pointset']}"
        meas = f"{_g(c['measured_rmse'])} [{_g(c['measured_low'])}, {_g(c['measured_high'])}]"
        flag = "yes" if c["agrees"] else "NO"
        if not c["target_met"]:
            flag += " (interval > target)"
        lines.append(f"  {rule:22s} {c['n']:5d} {_g(c['predicted_rmse']):>10s} {meas:>32s} "
                     f"{_g(c['ratio'], '.2f'):>6s} {flag}")
    lines.append("per rule: median ratio, cells that agree, worst ratio (at N)")
    for r in renderer["rules"]:
        lines.append(f"  {r['lobe'] + ' ' + r['strategy'] + '/' + r['pointset']:22s} "
                     f"{_g(r['median_ratio'], '.2f'):>6s} {r['fraction_agree']:5.0%} "
                     f"{_g(r['worst_ratio'], '.2f'):>6s} (N = {_g(r['worst_n'], 'd')})")
    for s in renderer["sources"]:
        d = ", ".join(f"{x:+.2f}" for x in s["direction"])
        lines.append(f"split off: source at ({d}), {s['solid_angle']:.3g} sr, "
                     f"{s['share']:.0%} of the power")
    return lines

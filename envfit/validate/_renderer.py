r"""``envfit validate --renderer``: the renderer estimators' predicted RMSE against the measured one.

For every lobe (diffuse; glossy with the run's shininess), strategy of
:data:`envfit.sampling.STRATEGIES` (``brdf``, ``map``, ``mis``, ``split``),
point set (default random, sobol, sf) and N (default 16, 64, 256, 1024) — one *cell* —:

* **predicted** — :func:`envfit.predict.predict` of the rule's renderer predictor
  (:func:`envfit.predict.renderer_predictor`: ``warped-spectrum`` or ``random-variance``) on
  a context holding the warped-integrand spectra of the map
  (:func:`envfit.predict.renderer_model`, one model per lobe, built only for the strategies
  of the cells still to compute), with the predictor's name;
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
:func:`summarize_lobes`. The result objects and the printed table are in
:mod:`envfit.validate._renderer_results`.

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
from dataclasses import asdict, dataclass
from typing import Callable, Sequence

from envfit.base import check_int, check_ints, check_names, check_positive
from envfit.base import ParameterError
from envfit.base import progress_bar
from envfit.base import machine_cores
from envfit.base import ResultStore, array_fingerprint
from envfit.maps import EnvMap
from envfit.predict import PredictionContext, predict, renderer_model, renderer_predictor
from envfit.measure import agreement_with_interval
from envfit.measure import AXIS_SAMPLING, RendererSetup, measure_rule
from envfit.sampling import STRATEGIES, RendererRule
from envfit.theory import POINTSETS

from envfit.validate._renderer_results import (RendererCell, RendererLobeSummary,
                                               RendererRuleSummary, RendererValidation,
                                               summarize_lobes, summarize_rules, summary_lines,
                                               worst_ratio)
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
    strategies : of :data:`envfit.sampling.STRATEGIES`.
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


# ----------------------------------------------------------------------------- the steps

def _finite_or_none(x):
    return None if x is None or not math.isfinite(x) else float(x)


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
    # point seed 0: the sets measure_rule uses
    pred = predict(renderer_predictor(rule), PredictionContext(renderer=model), rule)
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
        stored = _stored_cells(store, cfg)
        cells = _run_cells(setup, cfg, store, stored, timings, quiet, on_cell)
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


def _run_cells(setup, cfg, store, stored, timings, quiet, on_cell):
    """Steps 3–4 under one progress bar: the resumed cells, the spectra, the missing cells
    (each stored as soon as it is done); the cells in the order of :func:`_all_rules`."""
    rules = _all_rules(cfg)
    todo = [(lb, r) for lb, r in rules
            if renderer_cell_key(lb, r.strategy, r.pointset, r.n) not in stored]
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

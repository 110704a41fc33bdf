r"""The advisor's renderer rows: how many samples per shading point for BRDF sampling, map
importance sampling, MIS and the source split, with a given point set, for the target error.

A renderer rule (:class:`envfit.sampling.RendererRule`) is a strategy of
:data:`~envfit.sampling.STRATEGIES` — ``brdf`` (BRDF sampling), ``map`` (map
importance sampling ∝ luminance × solid angle, as physically based renderers do), ``mis`` (multi-sample
MIS, balance heuristic, N/2 each) or ``split`` (the bright sources integrated exactly, MIS on
the rest of the map) — a point set and N. Its RMSE over uniform axes is predicted from the
warped integrand's spectrum (:func:`envfit.predict.renderer_model`, once per map, lobe and
technique; then :func:`envfit.predict.predict` of :func:`envfit.predict.renderer_predictor`
on a context holding the model, one NUFFT per N):
exact in expectation for random points ("random-variance") and for the QMC sets up to
N ≈ (grid/8)² ("warped-spectrum"; beyond it the frequencies above the box are counted at the
Monte Carlo rate: an extrapolation, not a bound — on a night map with lamps brdf/sf at
N = 24576 measured 1.48× it — so a row there says "extrapolated …; not checked", and after
the check what the measurement says of it, :func:`extrapolation_note`).

Rows (:func:`search_renderer_row`): one per strategy × point set (defaults: the four
strategies; sobol, sf, random). N runs over a renderer's grid (:func:`renderer_n_grid`):
powers of two for sobol (a Sobol net's sizes), 2^k and 3·2^(k−1) for the others, from
``nmin`` to ``nmax``. The largest N is predicted first; if it misses the target the row says
"N > nmax" with the prediction there (the search assumes the prediction decreases with N,
as the paper rows' :func:`envfit.advisor._search.smallest_n` does); otherwise the grid is
scanned upward and the row's N is the *smallest* grid N whose prediction is at most the
target (so the grid N below it misses). Cost per shading point: N samples; for ``split``
also the exact integral over the sources, which visits every source pixel once per shading
point (``sum(pixels)`` of :attr:`RendererSetup.sources
<envfit.measure._rules.RendererSetup>`), reported beside N and added to it
(:attr:`RendererRow.cost`). The recommendation (:func:`renderer_recommendation`) is the
reached row of least cost, ties broken by the lower prediction.

Model resolution (:data:`RENDERER_GRID`, :data:`RENDERER_SPECTRUM_AXES`): grid 512 and 32
axes, chosen from measurements on city.exr (1024×512, a sun of 1245 pixels, diffuse lobe;
predictions of the 4 strategies × sobol, sf, random at N = 16…16384 against grid 512 and 64
axes, the resolution ``envfit validate`` measured at predicted/measured 0.95–1.15; CPU
seconds of the four spectra on the shared 2-core machine):

==========  =====  ====================================  =====================================
grid/axes   CPU s  ratio to 512/64, N = 16…1024          MIS with sobol/sf, N = 256…4096
==========  =====  ====================================  =====================================
512/64      71     1                                     1
512/32      32     0.96–1.08 (every N)                   1.01
256/32      20     0.86–1.08 (0.64 at N = 16384)         0.80–0.92
256/48      26     0.82–1.03 (0.61 at N = 16384)         0.76–0.87
256/64      33     0.86–1.04                             0.80–0.92
384/48      35     0.75–1.03                             0.71–0.85
==========  =====  ====================================  =====================================

Fewer axes only scatter a strategy's variance by a constant factor (±8 % at 32 axes, the
same at every N); a coarser grid under-predicts MIS with QMC points by 10–40 % exactly where
the rows land for a 1 % target (N ≈ 256–4096), which a check at 1.25× the target would not
absorb. So grid 512 (the box exact for QMC to N ≈ (512/8)² = 4096) with 32 axes: the
validated accuracy at less than half its cost. These comparisons used the map technique's
spectrum from a uniform grid, before its exact quadrature nodes; with the nodes, the
single-precision NUFFT and the 8B lobe grid of :mod:`envfit.predict.warped._warped_spectrum` the four
spectra take 35 s wall on city.exr (2 cores, load 3–4, raised priority;
docs/guides/advise.md, "Renderer rules in envfit advise").

The spectra are cached (:mod:`envfit.advisor._rule_rows_cache`, in :mod:`envfit.advisor._cache`,
kind ``"renderer"``): one checksummed
JSON file per (technique, on the rest map), keyed by the map's fingerprint
(:func:`envfit.advisor._model.map_key`), scale, lobe, grid, axes, technique, on_rest and the
sources' pixel count; a spectrum is stored by
:meth:`~envfit.predict.warped._warped_spectrum.WarpedSpectrum.to_json` and read back exactly by
:meth:`~envfit.predict.warped._warped_spectrum.WarpedSpectrum.from_json` (``cross`` as real
and imaginary lists), so cached predictions are bit-identical to fresh ones.

``check`` (:func:`check_renderer_rows`): every reached row measured at its N with
:func:`envfit.measure._rules.measure_rule` (one :class:`RendererSetup`, one seed:
the axes and their ground truths are shared by all rows), its bootstrap 95 % interval,
measured/target and measured/predicted.

Example
-------
>>> renderer_n_grid("sobol", 4, 64), renderer_n_grid("sf", 4, 64)
([4, 8, 16, 32, 64], [4, 6, 8, 12, 16, 24, 32, 48, 64])
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

from envfit.advisor._cache import AdviseCache
from envfit.base import ParameterError
from envfit.defaults import (ADVISE_RENDERER_POINTSETS, ADVISE_SPECTRUM_AXES, DEFAULT_SHININESS,
                             RENDERER_GRID)
from envfit.maps import EnvMap
from envfit.advisor._rule_rows_cache import cached_renderer_model, source_cost
from envfit.measure import RendererSetup, measure_rule
from envfit.predict import PredictionContext, RendererModel, predict, renderer_predictor
from envfit.sampling import STRATEGIES, RendererRule

__all__ = ["RENDERER_GRID", "RENDERER_SPECTRUM_AXES", "DEFAULT_STRATEGIES",
           "DEFAULT_RENDERER_POINTSETS", "STRATEGY_NAMES", "RendererRow", "RuleRowsAdvice",
           "renderer_n_grid", "search_renderer_row", "best_renderer_row",
           "renderer_recommendation", "check_renderer_rows", "advise_rule_rows"]

# RENDERER_GRID (envfit.defaults): the warped spectra's grid G for advise (the box B = G/4;
# QMC exact to N ≈ (G/8)²)
#: axes of the spectra's importance sample over the sphere, for advise
RENDERER_SPECTRUM_AXES = ADVISE_SPECTRUM_AXES
DEFAULT_STRATEGIES = tuple(STRATEGIES)
DEFAULT_RENDERER_POINTSETS = ADVISE_RENDERER_POINTSETS
#: strategy → its name in sentences
STRATEGY_NAMES = {"brdf": "BRDF sampling", "map": "map importance sampling", "mis": "MIS",
                  "split": "the source split (sources exact + MIS on the rest)"}
#: point sets whose natural sizes are powers of two
_POWER_OF_TWO_SETS = ("sobol",)


def renderer_n_grid(pointset: str, nmin: int, nmax: int) -> list[int]:
    """The N a renderer would use, in [max(nmin, 2), nmax]: powers of two for sobol, 2^k and
    3·2^(k−1) for the other point sets.

    >>> renderer_n_grid("random", 2, 12)
    [2, 3, 4, 6, 8, 12]
    """
    lo, hi = max(2, int(nmin)), int(nmax)
    out, p = set(), 2
    while p <= hi:
        out.add(p)
        if pointset not in _POWER_OF_TWO_SETS:
            out.add(3 * p // 2)                    # 3·2^(k−1), between 2^k and 2^(k+1)
        p *= 2
    out = {n for n in out if lo <= n <= hi}
    return sorted(set(out))


# ----------------------------------------------------------------------------- rows

@dataclass
class RendererRow:
    """One renderer rule of the table: strategy, point set and the smallest N of its grid
    whose prediction is at most the target (None when ``nmax`` misses it).

    ``extra_cost`` is the source pixels the split's exact integral visits per shading point
    (0 for the other strategies); ``cost`` = N + ``extra_cost`` (None when not reached).
    ``predicted_rmse`` is the prediction at N (at ``searched_max`` when not reached),
    ``predictor`` its name (:func:`envfit.predict.renderer_predictor`), ``curve``
    ``{"n": [...], "predicted": [...]}`` the predictions at every evaluated grid N.
    ``measured_*`` are filled by the check (:func:`check_renderer_rows`).
    """

    strategy: str
    pointset: str
    n: int | None = None
    extra_cost: int = 0
    cost: int | None = None
    predicted_rmse: float | None = None
    predictor: str = ""
    searched_max: int | None = None
    evaluations: int = 0
    note: str = ""
    curve: dict = field(default_factory=dict)
    measured_rmse: float | None = None
    measured_low: float | None = None
    measured_high: float | None = None
    measured_axes: int | None = None
    measured_target_met: bool | None = None
    measured_over_target: float | None = None
    measured_over_predicted: float | None = None
    #: (grid/8)² when N is beyond the spectrum's box (the prediction extrapolated), else None
    box: int | None = None

    @property
    def label(self) -> str:
        """"strategy/pointset"."""
        return f"{self.strategy}/{self.pointset}"

    @property
    def reached(self) -> bool:
        """Whether a grid N ≤ nmax meets the target."""
        return self.n is not None

    @property
    def setting(self) -> str:
        """"N = n" or "N > nmax"."""
        return f"N = {self.n}" if self.n is not None else f"N > {self.searched_max}"

    def to_dict(self) -> dict:
        """Every field, with ``label``, ``reached`` and ``setting``."""
        return {**asdict(self), "label": self.label, "reached": self.reached,
                "setting": self.setting}


def search_renderer_row(rmodel: RendererModel, strategy: str, pointset: str, target: float,
                        nmin: int, nmax: int, extra_cost: int = 0, *,
                        full_curve: bool = False) -> RendererRow:
    """The row of ``strategy``/``pointset``: the largest grid N first (a miss: "N > nmax"),
    else the grid scanned upward to the first N whose prediction ≤ ``target``
    (:func:`envfit.predict.predict` of :func:`envfit.predict.renderer_predictor` on a context
    holding ``rmodel``);
    with ``full_curve`` every grid N is predicted (for the plot). ``extra_cost`` is added to
    a reached row's cost (the split's source pixels)."""
    grid = renderer_n_grid(pointset, nmin, nmax)
    if not grid:
        raise ParameterError(f"no N of the {pointset} grid in [{nmin}, {nmax}] (N >= 2)")
    row = RendererRow(strategy=strategy, pointset=pointset, searched_max=grid[-1],
                      extra_cost=int(extra_cost) if strategy == "split" else 0)
    seen: dict[int, float] = {}
    ctx = PredictionContext(renderer=rmodel)

    def pred(n: int) -> float:
        if n not in seen:
            rule = RendererRule(strategy, pointset, n)
            p = predict(renderer_predictor(rule), ctx, rule)
            seen[n], row.predictor = float(p.rmse), p.name
        return seen[n]

    if pred(grid[-1]) > target:
        row.predicted_rmse = seen[grid[-1]]
        row.note = f"target not reached for N <= {grid[-1]}"
    else:
        row.n = next(n for n in grid if pred(n) <= target)
        row.predicted_rmse, row.cost = seen[row.n], row.n + row.extra_cost
    row.evaluations = len(seen)
    if full_curve:
        for n in grid:
            pred(n)
    box = (rmodel_grid(rmodel) // 8) ** 2
    if row.n is not None and row.n > box and pointset != "random":
        row.box = box
        row.note = extrapolation_note(row)
    ns = sorted(seen)
    row.curve = {"n": ns, "predicted": [seen[n] for n in ns]}
    return row


def extrapolation_note(row: RendererRow) -> str:
    """The note of a row sized beyond its spectrum's box (N > ``row.box`` = (grid/8)²), true of
    the numbers it has: the frequencies above the box are counted at the Monte Carlo rate, an
    extrapolation that is no bound; before a check "not checked", after it what the measured
    bootstrap 95 % interval (``measured_low``…``measured_high``) says of the prediction — "conservative
    here" only when the whole interval lies at or below it, "not conservative here" when
    it lies above, else that the measurement cannot tell.

    >>> r = RendererRow("brdf", "sf", n=24576, predicted_rmse=0.01, box=4096)
    >>> extrapolation_note(r)
    "N > (grid/8)^2 = 4096: extrapolated beyond the spectrum's box (frequencies above it at the Monte Carlo rate); not checked"
    >>> r.measured_rmse, r.measured_low, r.measured_high = 0.0148, 0.0141, 0.0155
    >>> extrapolation_note(r).split("; ")[-1]
    'measured 1.48x the prediction (0.0141…0.0155): not conservative here'
    """
    head = (f"N > (grid/8)^2 = {row.box}: extrapolated beyond the spectrum's box (frequencies "
            f"above it at the Monte Carlo rate)")
    m, p = row.measured_rmse, row.predicted_rmse
    if m is None or not p:
        return head + "; not checked"
    lo = row.measured_low if row.measured_low is not None else m
    hi = row.measured_high if row.measured_high is not None else m
    what = (f"measured {m / p:.2f}x the prediction ({lo:.3g}…{hi:.3g}): " +
            ("conservative here" if hi <= p else "not conservative here" if lo > p
             else "the measurement cannot tell whether it is conservative"))
    return f"{head}; {what}"


def rmodel_grid(rmodel: RendererModel) -> int:
    """The grid G of the model's spectra."""
    return int(next(iter(rmodel.spectra.values())).grid)


def best_renderer_row(rows) -> RendererRow | None:
    """The reached row of least cost (N + the split's source pixels), ties by the lower
    prediction, then label; None when no row is reached."""
    ok = [r for r in rows if r.reached]
    return min(ok, key=lambda r: (r.cost, r.predicted_rmse, r.label)) if ok else None


def _fraction(target: float, mean: float, relative: float | None) -> str:
    """The target in words: "1 % of the mean shading" or "RMSE 0.005"."""
    if relative is not None:
        return f"{relative * 100:g} % of the mean shading"
    return f"RMSE {target:.3g}" + (f" ({target / mean:.2%} of the mean shading)" if mean > 0
                                   else "")


def _others(rows, best: RendererRow) -> list[str]:
    """Per other strategy: what its cheapest row needs (reached or not)."""
    out = []
    for s in dict.fromkeys(r.strategy for r in rows):
        if s == best.strategy:
            continue
        mine = [r for r in rows if r.strategy == s]
        b = best_renderer_row(mine)
        if b is not None:
            extra = f" + {b.extra_cost} source pixels" if b.extra_cost else ""
            out.append(f"{STRATEGY_NAMES[s]} needs {b.pointset} N = {b.n}{extra}")
        else:
            top = max(mine, key=lambda r: r.searched_max or 0)
            out.append(f"{STRATEGY_NAMES[s]} would need N > {top.searched_max} (predicted "
                       f"{min(r.predicted_rmse for r in mine):.3g} there)")
    return out


def renderer_recommendation(rows, target: float, mean: float,
                            relative: float | None = None) -> str:
    """One sentence on the renderer rows: the cheapest rule meeting the target and what the
    other strategies need, or that none meets it (with the closest prediction)."""
    best = best_renderer_row(rows)
    goal = _fraction(target, mean, relative)
    if best is None:
        if not rows:
            return "renderer: no renderer rule was sized"
        close = min(rows, key=lambda r: r.predicted_rmse)
        return (f"renderer: no renderer rule meets {goal} (target RMSE {target:.3g}) for "
                f"N <= {close.searched_max}; the closest is {close.label} (predicted "
                f"{close.predicted_rmse:.3g} at N = {close.searched_max}): raise --nmax or "
                f"relax the target")
    extra = (f" + {best.extra_cost} source pixels = cost {best.cost}" if best.extra_cost else "")
    text = (f"renderer: use {best.label} with N = {best.n}{extra} per shading point: it meets "
            f"{goal} (predicted RMSE {best.predicted_rmse:.3g} <= target {target:.3g})")
    others = _others(rows, best)
    return text + ("; " + "; ".join(others) if others else "")


# ----------------------------------------------------------------------------- check

def check_renderer_rows(setup: RendererSetup, rows, brdf: str, shininess: float, target: float,
                        *, seed: int = 0, axes_start: int = 250, max_axes: int = 4000,
                        target_relative: float = 0.10) -> None:
    """Measure every reached row at its N with :func:`measure_rule` on ``setup`` (filled in
    place): the RMSE, its bootstrap 95 % interval, the axes used, whether the interval met
    ±``target_relative``, measured/target and measured/predicted; a row beyond its
    spectrum's box gets the note of that measurement (:func:`extrapolation_note`)."""
    for r in rows:
        if not r.reached:
            continue
        out = measure_rule(setup, RendererRule(r.strategy, r.pointset, r.n), brdf, shininess,
                           seed=seed, target_relative=target_relative, axes_start=axes_start,
                           max_axes=max_axes)
        iv = out.interval
        r.measured_rmse, r.measured_low, r.measured_high = float(iv.rmse), float(iv.low), \
            float(iv.high)
        r.measured_axes, r.measured_target_met = int(out.axes), bool(out.target_met)
        r.measured_over_target = r.measured_rmse / target
        if r.predicted_rmse:
            r.measured_over_predicted = r.measured_rmse / r.predicted_rmse
        if r.box is not None:                    # the extrapolation's note, now checked
            r.note = extrapolation_note(r)


# ----------------------------------------------------------------------------- all rows

@dataclass
class RuleRowsAdvice:
    """The renderer section of :class:`envfit.advisor._result.Advice`: the rows (sorted by
    cost, unreached last), the recommendation, the sources and the model's resolution."""

    rows: list[RendererRow]
    recommendation: str
    target_rmse: float
    strategies: list[str]
    pointsets: list[str]
    nmin: int
    nmax: int
    grid: int
    spectrum_axes: int
    sources: list[dict]
    source_pixels: int
    spectra_cached: int = 0
    spectra_computed: int = 0
    check: dict | None = None
    timings: dict = field(default_factory=dict)

    def best(self) -> RendererRow | None:
        """The recommended row (:func:`best_renderer_row`)."""
        return best_renderer_row(self.rows)

    def to_dict(self) -> dict:
        """Every field, the rows by :meth:`RendererRow.to_dict`, and the best row's label."""
        d = {k: v for k, v in asdict(self).items() if k != "rows"}
        b = self.best()
        return {**d, "rows": [r.to_dict() for r in self.rows],
                "best": None if b is None else b.label}

    def table_lines(self) -> list[str]:
        """The renderer table as text (what the CLI prints)."""
        chk = self.check is not None
        head = (f"  {'renderer rule':<14s} {'N':>9s} {'cost':>12s} {'predicted':>10s} "
                f"{'predictor':<16s}")
        if chk:
            head += f" {'measured [95% interval]':>34s} {'meas/target':>11s} {'meas/pred':>9s}"
        lines = [head + "  note"]
        for r in self.rows:
            cost = "–" if r.cost is None else (f"{r.n}+{r.extra_cost}" if r.extra_cost
                                               else str(r.cost))
            line = (f"  {r.label:<14s} {r.setting.replace('N = ', ''):>9s} {cost:>12s} "
                    f"{r.predicted_rmse:>10.3e} {r.predictor:<16s}")
            if chk:
                m = ("–" if r.measured_rmse is None else
                     f"{r.measured_rmse:.3e} [{r.measured_low:.3e}, {r.measured_high:.3e}]")
                line += (f" {m:>34s} "
                         f"{_num(r.measured_over_target, 11)} {_num(r.measured_over_predicted, 9)}")
            lines.append(line + (f"  {r.note}" if r.note else ""))
        return lines


def _num(v, w: int) -> str:
    return f"{'–':>{w}s}" if v is None else f"{v:>{w}.2f}"


def _sort(rows) -> list[RendererRow]:
    return sorted(rows, key=lambda r: (r.cost is None, r.cost or 0, r.predicted_rmse, r.label))


def advise_rule_rows(envmap: EnvMap, scaled: EnvMap, map_key: dict, opts, target: float,
                    mean: float, store: AdviseCache) -> tuple[RuleRowsAdvice, RendererSetup]:
    """The renderer rows of ``opts`` (:class:`~envfit.advisor._options.AdviseOptions`:
    ``strategies``, ``renderer_pointsets``, ``nmin``, ``nmax``, ``renderer_grid``,
    ``renderer_spectrum_axes``, ``check``) on ``scaled`` (the map on the options' scale),
    with the spectra cached under ``map_key``; (the section, its :class:`RendererSetup`)."""
    t0 = time.perf_counter()
    setup = RendererSetup.of(scaled)
    shin = opts.shininess if opts.shininess is not None else DEFAULT_SHININESS
    rmodel, n_loaded, n_new = cached_renderer_model(
        setup, map_key, opts.brdf, shin, opts.strategies, opts.renderer_grid,
        opts.renderer_spectrum_axes, store, quiet=opts.quiet)
    t1 = time.perf_counter()
    pixels = source_cost(setup)
    rows = [search_renderer_row(rmodel, s, ps, target, opts.nmin, opts.nmax, pixels,
                                full_curve=opts.renderer_curves)
            for s in opts.strategies for ps in opts.renderer_pointsets]
    rows = _sort(rows)
    sec = RuleRowsAdvice(
        rows=rows, recommendation=renderer_recommendation(rows, target, mean,
                                                          opts.target_relative),
        target_rmse=target, strategies=list(opts.strategies),
        pointsets=list(opts.renderer_pointsets), nmin=opts.nmin, nmax=opts.nmax,
        grid=opts.renderer_grid, spectrum_axes=opts.renderer_spectrum_axes,
        sources=[s.summary() for s in setup.sources], source_pixels=pixels,
        spectra_cached=n_loaded, spectra_computed=n_new)
    sec.timings = {"model": t1 - t0, "search": time.perf_counter() - t1}
    return sec, setup


def run_renderer_check(sec: RuleRowsAdvice, setup: RendererSetup, opts) -> None:
    """``check``: :func:`check_renderer_rows` on every reached row with the options' seed and
    axes, and the summary in ``sec.check``."""
    t0 = time.perf_counter()
    shin = opts.shininess if opts.shininess is not None else DEFAULT_SHININESS
    check_renderer_rows(setup, sec.rows, opts.brdf, shin, sec.target_rmse, seed=opts.seed,
                        axes_start=opts.renderer_axes_start, max_axes=opts.renderer_max_axes)
    done = [r for r in sec.rows if r.measured_rmse is not None]
    mt = [r.measured_over_target for r in done]
    sec.check = {"axes_start": opts.renderer_axes_start, "max_axes": opts.renderer_max_axes,
                 "seed": opts.seed, "rows": len(done),
                 "max_measured_over_target": max(mt) if mt else None,
                 "rows_over_1_25": [r.label for r in done if r.measured_over_target > 1.25]}
    b = sec.best()
    if b is not None and b.measured_rmse is not None:
        sec.check["recommended_measured_over_target"] = b.measured_over_target
    sec.timings["check"] = time.perf_counter() - t0

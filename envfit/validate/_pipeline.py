r"""Predicted errors checked against ground-truth shading integrals on a map (Figs. 7–8).

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 5, 7.2, 8 and 9.2.

What is measured
----------------
The map is put on a value scale (:func:`envfit.maps._scales.fit_scale`, ``display`` as the
paper's Table 2 or ``linear``); the scaled map's bilinear interpolant is the integrand f.
M axes :math:`a_m` are drawn uniformly on the sphere (seeded). For each BRDF p (diffuse,
glossy n = 30), the ground truth :math:`I(a_m) = \frac{1}{2\pi r_s}\int f\,p(u\cdot a_m)dS`
comes from :func:`envfit.shading._ground_truth.shading_integral` (exact SH of the bilinear interpolant).

* **Quadrature** (Eq. 34, Fig. 7): for each point set (``envfit.theory._pointsets``: sf, sobol,
  lp, bnot, random, jitter), N and weighting, the N points are morphed for p (importance
  sampling, Sec. 7.2: :math:`z = \sqrt{z'}` / Eq. 67), rotated into the frame of each axis
  (:func:`envfit.theory._pointsets.frame_from_axis`) with an independent seeded twist about the
  axis, and :math:`\tilde I(a_m) = \sum_j w_j f(R_m u_j)` with equal weights 1/N or the
  optimal sample weights (OSW, :func:`envfit.theory._weights.optimal_weights`, computed for the
  s used for the prediction). Measured: :math:`\mathrm{RMSE} = (\frac{1}{MC}\sum_{m,c}
  (\tilde I - I)^2)^{1/2}` (:func:`envfit.shading._estimators.rmse_over_axes`). Stochastic point
  sets use one realisation per N (seeded); its own worst-case error is the prediction.
* **Truncation** (Eq. 35, Fig. 8): SH truncation at degree L
  (:func:`envfit.shading._estimators.sh_truncation_curve`) on the full map and all axes; HSH
  truncation (:func:`envfit.shading._estimators.hsh_truncation_curve`, a clipped hemispherical
  quadrature per axis, the expensive part) on the map downscaled to
  ``hsh_max_height`` rows and the first ``hsh_axes`` axes, against a ground truth on
  that same downscaled map.

What is predicted
-----------------
The worst-case error E(s) of the rule (Eq. 41, the value of
:func:`envfit.theory._quadrature.worst_case_error`; rotation invariant, so one number per
rule) or of the truncation (Eqs. 51–52, :func:`envfit.theory._truncation.truncation_error_curve`),
for the map's fitted smoothness s (``envfit fit``; or a given s). Prediction (a) is fitted
here; (b), (b′) and (c) are the named predictors of :data:`envfit.predict.PREDICTORS`
(``plain``, ``bandlimited``, ``spectral``: each ``f(PredictionContext, Rule) -> Prediction``),
which :func:`run_validation` and :func:`envfit.validate._agreement.agreement` loop over; their
result keys are :data:`envfit.validate._keys.PREDICTION_KEYS`. Four predictions of the RMSE:

(a) *shape only* (the paper, Sec. 9.2: "in accordance ... up to a multiplicative factor"):
    :math:`\hat R = c_p\,E`, one factor per BRDF p fitted in log space across all its rules
    (every point set, weighting and N): the least-squares solution of
    :math:`\min_c \sum (\log R_{meas} - \log c - \log E)^2`, i.e.
    :math:`\log c_p = \mathrm{mean}(\log R_{meas} - \log E)` — the geometric mean of the
    ratios (:func:`shape_constant`). The residual
    :math:`(\mathrm{mean}(\log_{10}R_{meas} - \log_{10}E - \log_{10}c_p)^2)^{1/2}` (dex,
    :func:`shape_residual`) says how well the theory's *shape* holds; it is also computed
    for other s (:data:`S_CANDIDATES`) to see which s makes the shapes match best (Sec. 9's
    claim that s ≈ 1.5 suits radiance maps).
(b) *absolute* (beyond the paper): under the Gaussian-process reading of the Sobolev
    model, f ~ GP(0, σ² K_gd^(s)), the error of any linear rule is Gaussian with
    :math:`E_f[(\tilde I - I)^2] = \sigma^2 E(s)^2` (E is the norm of the error's
    representer, Eq. 39). With σ̂ from the profiled likelihood (``envfit fit --method
    likelihood``, per channel, combined as RMS: :math:`\sigma = (\frac1C\sum_c
    \hat\sigma_c^2)^{1/2}`, matching the RMSE's mean over channels), the prediction
    :math:`\sigma E` uses no measured error at all (``predicted_rmse``,
    :func:`envfit.predict.predict_plain`).
(b') *refined absolute* (beyond the paper, ``predicted_rmse_refined``,
    :func:`envfit.predict.predict_bandlimited`): the same model made
    exact for what a lat-long map is. (i) An H-row map holds no degree above H − 1 (the
    GP maps of :mod:`envfit.data_gen._gp` are band-limited exactly there), so the error spectrum
    Eq. 42 is summed only to l = H − 1 (:func:`bandlimited_worst_case_error`); (ii) the fit
    is of a zero-mean GP after removing the map's mean :math:`\bar m`, and a rule whose
    weights do not sum to 1 (OSW) errs by :math:`\bar m(\sum_j w_j - 1)` on it, for every
    axis: :math:`\hat R = (\sigma'^2 E'^2 + (\sum_j w_j - 1)^2\,\overline{m^2})^{1/2}`
    (:math:`\overline{m^2}` the mean over channels of the squared solid-angle mean);
    (iii) s and σ come from the likelihood of the same band-limited model
    (:mod:`envfit.sobolev._bandlimited`: the kernel truncated at degree H − 1, samples at pixel
    centres), fitted beside the paper's fit (``s_refined``, ``sigma_refined``): the full
    kernel and bilinear lookups read a finite-resolution map as smoother than it is (ŝ
    about 0.04 too high on 256-row GP maps with s₀ = 1.5, 0.16 on 64-row ones), which made
    (b') 10 % low for random points; (iv) the estimators integrate the bilinear
    interpolant, whose power at degree l is the pixel field's times
    :math:`\tau_l` (:func:`envfit.shading._spectra.lookup_transfer`, ``lookup_transfer``; 1 at low
    degrees, 0.25 at H − 1), so degree l of the error spectrum is weighted by
    :math:`\tau_l`: :math:`E'^2 = \sum_{l\le H-1} a_l(\hat s')\,\tau_l\,e_l`
    (without it (b') was up to 35 % high for spherical Fibonacci points at N = 4096 on
    256-row maps, whose error lives near the band limit).
    One map is one realisation of the model: its power in degree l scatters as
    :math:`\chi^2_{(2l+1)C}`, so its RMSE departs from (b') by an expected relative standard
    deviation :func:`model_scatter` (``model_scatter``, large for rules whose error sits in a
    few low degrees: random points with equal weights) — reported beside the ratio.
(c) *spectral* (beyond the paper, no model, ``predicted_rmse_spectral``,
    :func:`envfit.predict.predict_spectral`): the map's own power
    per degree :math:`\hat P_l` (:func:`map_degree_power`) times the rule's error power
    :math:`e_l` (:func:`rule_error_power`), :math:`(\frac1C\sum_{c,l}\hat P_{l,c}e_l)^{1/2}`
    (:func:`spectral_rmse`): the exact mean over random rotations on *this* map. It agrees with
    the measurement to its Monte Carlo error whenever the machinery is right; where (c) agrees
    and (b') does not, the map departs from the l^(-2s) model.

Agreement figures (:func:`envfit.validate._agreement.agreement`): fitted log-log slopes over N ∈ [64, 4096]
(:func:`loglog_slope`, ``np.polyfit``) measured vs predicted; the ratio measured/predicted
across N; the rank order of the point sets (Kendall's τ, ``scipy.stats.kendalltau``, of the
geometric-mean levels over the slope range); the shape residual per candidate s; for (b),
(b′) and (c) the ratio predicted/measured per cell.

Costs (defaults, 1024×512 map, 2 idle cores; forest.exr: 159 s in all, 172 s with plots)
-----------------------------------------------------------------------------------------
* quadrature cells ≈ 134 s: N = 4096 alone 64 s, 2048 26 s, the rest < 45 s; OSW cells
  76 s against 58 s for equal weights (on 2 shared cores the same run took 290–420 s).
* bilinear lookups: M·ΣN = 2000·8176 ≈ 16 M per (BRDF, point set), ≈ 4 s with 2 threads;
  equal weights and OSW share them (:func:`quadrature_estimates_multi`);
* OSW: one float64 Cholesky of an N×N matrix per (BRDF, point set, N), ≈ 1–1.5 s at 4096
  (plus the 134 MB kernel matrix);
* BNOT: ≈ 15 s at N = 4096, ≈ 30 s for 16…4096 (cached in-process per (N, seed), shared by
  the two BRDFs): its cells cost 44 s against 16–19 s for the other sets;
* worst-case errors: O(N²), ≈ 0.05 s at 4096, once per candidate s (6 values);
  the band-limited spectrum (ducc0 adjoint SHT to degree H − 1) ≈ 0.05 s;
* the two fits of s (the paper's and the band-limited one; ``fit_n`` = 1500 samples, ~36
  Cholesky factorisations each) ≈ 4 s; the lookup transfer τ ≈ 0.7 s;
* HSH projections: ≈ 12 s for 250 axes on 128 rows up to L = 16 (the truncation part
  altogether ≈ 12–18 s);
* QMC-equivalent N (bisection over SF point sets up to ``equivalent_nmax`` = 4096) ≈ 5 s.

Resumable: every (brdf, pointset, weights, N) cell, the fit and each truncation curve is a
:class:`envfit.base._store.ResultStore` cell; so is every renderer cell of ``renderer=``
(``--renderer``, :mod:`envfit.validate._renderer`: the renderer estimators' predicted RMSE
against the measured one with its 95 % interval, on the same scaled map).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.data_gen._gp import gaussian_process_map
>>> env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp")
>>> cfg = ValidateConfig(s=1.5, brdfs=("diffuse",), pointsets=("sf",), weights=("equal",),
...                      n_values=(16, 64), axes=50, scale="linear", truncation=False,
...                      fit_n=200)
>>> res = run_validation(env, cfg)
>>> r = res.rule("diffuse", "sf", "equal")
>>> r["pointset"], r["n"], len(r["measured_rmse"])
('sf', [16, 64], 2)
>>> bool(np.isclose(r["predicted_rmse"][0], res.sigma * r["predicted_wce"][0]))
True
>>> res.to_json()["results"][0] is r
True
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from envfit.base import ParameterError
from envfit.base import s_key
from envfit.base import progress_bar
from envfit.base import Plan, Stage, plan_memory
from envfit.base import ResultStore, array_fingerprint
from envfit.maps import EnvMap, check_sample_count
from envfit.maps import Scale, check_not_constant, fit_scale
from envfit.predict import PredictionContext
from envfit.shading import shading_integral, weight_function
from envfit.shading import LOOKUP_BLOCK, quadrature_estimates_multi, random_axes
from envfit.shading import (bandlimited_worst_case_errors, low_degree_power_ratio, rule_error_power,
                            rule_power_cost, sh_analysis_cost)
from envfit.theory import TheoryParameterError
from envfit.theory import generate
from envfit.theory import worst_case_error
from envfit.theory import equal_weights, optimal_weights

from envfit.validate._agreement import SLOPE_RANGE, agreement
from envfit.validate._cells import cell_is_current, cell_key, error_stats, twist_seed
from envfit.validate._config import QUICK_DESCRIPTION, ValidateConfig
from envfit.validate._fitting import fit_both
from envfit.validate._renderer import (RendererValidation, RendererValidationConfig,
                                       run_renderer_validation)
from envfit.validate._report_verdicts import report_verdicts
from envfit.validate._results import (ValidationResult, compute_costs, fill_measured_equivalents,
                                      fill_shape, map_statistics, rule_entry)
from envfit.validate._truncation import truncation_curves

__all__ = ["run_validation", "plan_validation_memory"]


def plan_validation_memory(envmap: EnvMap, cfg: ValidateConfig) -> None:
    """The memory guard of :func:`run_validation` (:func:`envfit.base._resources.plan_memory`),
    before any point is made: the quadrature rules at the largest N (the N x N kernel matrix
    of the OSW weights when ``"osw"`` is among the weightings; points, weights and
    ``workers`` lookup blocks) and the smoothness fit of ``fit_n`` samples."""
    from envfit.fit import plan_fit_memory
    c = envmap.channels
    workers = max(1, int(cfg.workers))
    lookup = 8 * (8 + 2 * c) * workers                  # per direction of a lookup block
    plan_memory(cfg.n_values[-1], "validate's quadrature rules", channels=c,
                kernel="osw" in cfg.weights, per_n_bytes=8 * 16 + lookup,
                fixed_bytes=LOOKUP_BLOCK * lookup + 8 * envmap.width * envmap.height * (c + 4)
                + 8 * cfg.axes * (9 + 2 * c * len(cfg.weights)))
    plan_fit_memory(cfg.fit_n, envmap.width, envmap.height, c, method=cfg.fit_method,
                    what="validate's smoothness fit", n_name="fit_n")
    _spectral_plan(envmap, cfg).check(hint="--max-height reads the map at fewer rows")


def _spectral_plan(envmap: EnvMap, cfg: ValidateConfig) -> Plan:
    """The stages after the fit whose size grows with the map (checked before the fit): the
    map's power per degree to the band limit H − 1 (prediction (c),
    :func:`envfit.shading._spectra.sh_analysis_cost`) and one rule's error power at the
    largest N to the same degree (:func:`envfit.shading._spectra.rule_power_cost`); resident:
    the scaled map and its per-pixel arrays (as the quadrature rules' guard above)."""
    h, c, lmax = envmap.height, envmap.channels, envmap.height - 1
    n = int(cfg.n_values[-1])
    nb, t = sh_analysis_cost(h, c, lmax)
    rb, rt = rule_power_cost(n, lmax)
    return Plan("validate", [
        Stage("map power", nb, t, f"SH coefficients of the interpolant to l = {lmax}"),
        Stage("rule error power", rb, rt, f"N = {n} points to l = {lmax}")],
        resident=8 * envmap.width * envmap.height * (c + 4))


# ----------------------------------------------------------------------------- the run's state

@dataclass
class _Run:
    """What the steps of one :func:`run_validation` share: the configuration, the scaled
    map, its store, the axes, the ground truths (computed once per BRDF), the timings and
    when the run started."""

    envmap: EnvMap
    cfg: ValidateConfig
    scale: Scale
    scaled: EnvMap
    store: ResultStore
    axes: np.ndarray
    quiet: bool
    on_cell: Callable[[str, bool], None] | None
    t_start: float
    timings: dict = field(default_factory=lambda: {"fit": 0.0, "truth": 0.0, "quadrature": 0.0,
                                                   "truncation": 0.0, "equivalents": 0.0})
    truths: dict = field(default_factory=dict)

    def truth(self, brdf: str) -> np.ndarray:
        """The ground truth I(a_m) of ``brdf`` on every axis (computed once, timed)."""
        if brdf not in self.truths:
            t0 = time.perf_counter()
            self.truths[brdf] = shading_integral(self.scaled, self.axes, brdf,
                                                 self.cfg.shininess)
            self.timings["truth"] += time.perf_counter() - t0
        return self.truths[brdf]

    def cell_done(self, key: str, resumed: bool) -> None:
        if self.on_cell:
            self.on_cell(key, resumed)


def _start(envmap: EnvMap, cfg: ValidateConfig, out, quiet: bool, on_cell,
           t_start: float) -> _Run:
    """Step 1: the guards (memory, sample count, a constant map), the value scale, the store
    of the resumable cells (its configuration: what makes a stored cell this run's) and the
    seeded axes."""
    plan_validation_memory(envmap, cfg)          # before anything of size N or fit_n
    check_sample_count(cfg.fit_n, envmap.width, envmap.height, name=envmap.name, what="fit_n")
    sc = fit_scale(cfg.scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, cfg.scale, envmap.name)
    store_cfg = {"map": envmap.name, "fingerprint": array_fingerprint(envmap.data),
                 "up": envmap.up, "scale": cfg.scale, "s": cfg.s, "fit_method": cfg.fit_method,
                 "fit_n": cfg.fit_n, "seed": cfg.seed, "axes": cfg.axes,
                 "shininess": cfg.shininess, "s_candidates": list(cfg.s_candidates),
                 "hsh_axes": cfg.hsh_axes, "hsh_max_height": cfg.hsh_max_height,
                 "equivalent_nmax": cfg.equivalent_nmax}
    store = ResultStore(out, store_cfg, kind="validate")
    return _Run(envmap=envmap, cfg=cfg, scale=sc, scaled=scaled, store=store,
                axes=random_axes(cfg.axes, [cfg.seed, 11]), quiet=quiet, on_cell=on_cell,
                t_start=t_start)


def _s_values(cfg: ValidateConfig, s_used: float) -> list[float]:
    """The candidate s of the shape residual with the used s exactly (the OSW weights' s)."""
    s_by_key = {s_key(x): float(x) for x in cfg.s_candidates}
    s_by_key[s_key(s_used)] = s_used
    return [s_by_key[k] for k in sorted(s_by_key)]


# ----------------------------------------------------------------------------- quadrature cells

def _rule_weights(pts, wf, n: int, todo: list[str], s_used: float):
    """The weights of each weighting in ``todo`` ({w: weights}), the messages of those that
    failed ({w: str}) and the seconds each took."""
    wsets, errors, t_w = {}, {}, {}
    for w in todo:
        t1 = time.perf_counter()
        if w == "equal":
            wsets[w] = equal_weights(n)
        else:
            try:
                wsets[w] = optimal_weights(pts, wf, s_used)
            except (TheoryParameterError, ParameterError) as exc:
                errors[w] = str(exc)
        t_w[w] = time.perf_counter() - t1
    return wsets, errors, t_w


def _failed_cell(brdf, pointset, w, n, s_list, band_lmax, msg, seconds) -> dict:
    return {"brdf": brdf, "pointset": pointset, "weights": w, "n": int(n),
            "measured_rmse": None, "measured_rmse_channels": None, "measured_rel_se": None,
            "error_kurtosis": None, "wce": {s_key(s): None for s in s_list},
            "wce_bandlimited": None, "band_lmax": band_lmax,
            "wce_bandlimited_by_s": {s_key(s): None for s in s_list},
            "error_power": None, "weight_sum": None, "error": msg, "seconds": seconds}


def _compute_cells(run: _Run, brdf: str, wf, pointset: str, n: int, todo: list[str],
                   ctx: PredictionContext, s_list: list[float]) -> dict[str, dict]:
    """Compute the cells (brdf, pointset, n, w) for the weightings in ``todo`` (shared lookups),
    with the wce at every s of ``s_list`` and the band-limited ones to ``ctx.band_lmax``."""
    cfg, s_used, band_lmax = run.cfg, ctx.s, ctx.band_lmax
    t0 = time.perf_counter()
    pts = generate(pointset, n, seed=cfg.seed, morph=wf.morph)
    t_pts = time.perf_counter() - t0
    wsets, errors, t_w = _rule_weights(pts, wf, n, todo, s_used)
    out: dict[str, dict] = {}
    ok = [w for w in todo if w in wsets]
    if ok:
        truth_b = run.truth(brdf)
        t1 = time.perf_counter()
        est = quadrature_estimates_multi(run.scaled, run.axes, pts, [wsets[w] for w in ok],
                                         seed=twist_seed(cfg.seed, brdf, pointset, n),
                                         workers=cfg.workers)
        t_est = (time.perf_counter() - t1) / len(ok)
        for k, w in enumerate(ok):
            t2 = time.perf_counter()
            wce = {s_key(s): worst_case_error(pts, wsets[w], wf, s, workers=cfg.workers)
                   for s in s_list}
            power = rule_error_power(pts, wsets[w], wf, band_lmax)
            band = dict(zip(map(s_key, s_list),
                            bandlimited_worst_case_errors(pts, wsets[w], wf, s_list, band_lmax,
                                                          power=power)))
            cell = {"brdf": brdf, "pointset": pointset, "weights": w, "n": int(n),
                    **error_stats(est[k], truth_b), "wce": wce,
                    "wce_bandlimited": band[s_key(s_used)], "wce_bandlimited_by_s": band,
                    "band_lmax": band_lmax, "error_power": power.tolist(),
                    "weight_sum": float(np.sum(wsets[w])), "error": None}
            cell["seconds"] = t_pts / len(todo) + t_w[w] + t_est + (time.perf_counter() - t2)
            out[w] = cell
    for w, msg in errors.items():
        out[w] = _failed_cell(brdf, pointset, w, n, s_list, band_lmax, msg, t_w[w])
    return out


def _quadrature_cells(run: _Run, ctx: PredictionContext, s_list: list[float]) -> dict[str, dict]:
    """Step 3: every (BRDF, point set, weighting, N) cell, resumed when current
    (:func:`envfit.validate._cells.cell_is_current`), else computed (the weightings of one
    (BRDF, point set, N) share their point set and lookups) and stored."""
    cfg = run.cfg
    total = len(cfg.brdfs) * len(cfg.pointsets) * len(cfg.weights) * len(cfg.n_values)
    bar = progress_bar(total, desc="validate: quadrature", quiet=run.quiet, unit="cell")
    cells: dict[str, dict] = {}
    s_keys = list(map(s_key, s_list))
    t_quad = time.perf_counter()
    try:
        for b in cfg.brdfs:
            wf = weight_function(b, cfg.shininess)
            for ps in cfg.pointsets:
                for n in cfg.n_values:
                    keys = {w: cell_key(b, ps, w, n) for w in cfg.weights}
                    todo = []
                    for w, k in keys.items():
                        c = run.store.get(k)
                        if cell_is_current(c, ctx.band_lmax, s_keys):
                            cells[k] = c
                            bar.update(1)
                            run.cell_done(k, True)
                        else:
                            todo.append(w)
                    if not todo:
                        continue
                    done = _compute_cells(run, b, wf, ps, n, todo, ctx, s_list)
                    for w, c in done.items():
                        run.store.put(keys[w], c)
                        cells[keys[w]] = c
                        bar.update(1)
                        run.cell_done(keys[w], False)
    finally:
        bar.close()
    run.timings["quadrature"] = time.perf_counter() - t_quad - run.timings["truth"]
    return cells


def _rule_results(run: _Run, cells: dict, ctx: PredictionContext, s_list) -> list[dict]:
    """Step 4: one entry per (BRDF, point set, weighting) with every predictor
    (:func:`envfit.validate._results.rule_entry`)."""
    cfg = run.cfg
    return [rule_entry(b, ps, w, cfg.n_values, [cells[cell_key(b, ps, w, n)] for n in cfg.n_values],
                       ctx, s_list)
            for b in cfg.brdfs for ps in cfg.pointsets for w in cfg.weights]


# ----------------------------------------------------------------------------- the pipeline

def _renderer_cells(run: _Run, renderer: RendererValidationConfig | None
                    ) -> RendererValidation | None:
    """Step 6 (``--renderer``): the renderer rules on the run's scaled map, their cells in
    the run's store (:func:`envfit.validate._renderer.run_renderer_validation`)."""
    if renderer is None:
        return None
    t0 = time.perf_counter()
    rend = run_renderer_validation(run.scaled, renderer, scale=run.cfg.scale, store=run.store,
                                   quiet=run.quiet, on_cell=run.on_cell)
    run.timings["renderer"] = time.perf_counter() - t0
    return rend


def _finish(run: _Run, fit: dict, fit_ref: dict, ctx: PredictionContext, results: list[dict],
            trunc: list[dict], agr: dict,
            rend: RendererValidation | None = None) -> ValidationResult:
    """Step 7: timings, costs, notes (closing the store first), the result and the report's
    verdicts on it (:func:`envfit.validate._report_verdicts.report_verdicts`)."""
    envmap, cfg, timings = run.envmap, run.cfg, run.timings
    timings["total"] = time.perf_counter() - run.t_start
    # what the whole result cost to compute, resumed parts included (stored per cell)
    timings["compute"] = (float(fit.get("seconds") or 0.0) + timings["truth"]
                          + sum(float(s or 0.0) for e in results for s in e["seconds"])
                          + sum(float(t.get("seconds") or 0.0) for t in trunc)
                          + (0.0 if rend is None else rend.timings["compute"]))
    notes = list(envmap.notes)
    run.store.close()             # every cell is written: release the --out folder's lock
    notes.extend(run.store.notes)  # cells recomputed because they were not sound (also on stderr)
    notes.extend(fit.get("notes", []))
    notes.extend(f"refined fit: {x}" for x in fit_ref.get("notes", []))
    stats = {**map_statistics(envmap, run.scaled, run.scale),
             "power_ratio_low_degrees": low_degree_power_ratio(
                 run.scaled, list(ctx.sigma_bandlimited_channels), ctx.s_bandlimited)}
    res = ValidationResult(
        map=envmap.name, map_size=[envmap.width, envmap.height], channels=envmap.channels,
        s=ctx.s, sigma=ctx.sigma, sigma_channels=[float(x) for x in fit["sigma_channels"]],
        s_refined=ctx.s_bandlimited, sigma_refined=ctx.sigma_bandlimited,
        sigma_refined_channels=list(ctx.sigma_bandlimited_channels),
        fit_refined={k: v for k, v in fit_ref.items() if k != "resumed"},
        lookup_transfer=[float(x) for x in ctx.transfer], scale=cfg.scale,
        scale_description=run.scale.describe(),
        fit={k: v for k, v in fit.items() if k != "resumed"}, config=cfg.to_dict(),
        quick_description=QUICK_DESCRIPTION if cfg.quick else None, axes=cfg.axes,
        seed=cfg.seed, results=results, truncation=trunc, agreement=agr, map_stats=stats,
        timings=timings, costs=compute_costs(results), notes=notes,
        unwritten=[list(u) for u in run.store.unwritten],
        renderer=None if rend is None else rend.to_json())
    res.verdicts = [v.to_json() for v in report_verdicts(res.to_json())]
    return res


def run_validation(envmap: EnvMap, config: ValidateConfig | None = None, *,
                   out: str | Path | None = None, quiet: bool = True,
                   on_cell: Callable[[str, bool], None] | None = None,
                   renderer: RendererValidationConfig | None = None) -> ValidationResult:
    """Run the validation on ``envmap`` (see the module docstring).

    Parameters
    ----------
    envmap : the map on its raw (linear) values; ``config.scale`` is applied here.
    config : :class:`ValidateConfig` (default: the full run).
    out : folder of the resumable cells (:class:`envfit.base._store.ResultStore`); None = memory.
    quiet : no progress bar.
    on_cell : called as ``on_cell(key, resumed)`` after every stored cell.
    renderer : :class:`envfit.validate._renderer.RendererValidationConfig` to validate the
        renderer estimators too (``--renderer``), after the paper's cells, on the same scaled
        map and store; None: not run.

    Returns
    -------
    ValidationResult
        :class:`envfit.validate._results.ValidationResult`; its ``to_json()`` is the JSON-ready
        dict ``{"map", "s", "sigma", "sigma_channels", "scale", "fit", "config", "results",
        "truncation", "agreement", "timings", "notes", "map_stats", …}`` with ``results`` and
        ``truncation`` as documented in the CLI (per rule: ``n``, ``measured_rmse``,
        ``predicted_wce``, one key per predictor of :data:`envfit.predict.PREDICTORS` —
        ``predicted_rmse`` = σ·wce, ``predicted_rmse_refined``, ``predicted_rmse_spectral`` —,
        ``predicted_shape`` = c_p·wce, ``slope_measured``, ``slope_predicted``, …).

    Steps: :func:`_start` (guards, scale, store, axes); the two fits
    (:func:`envfit.validate._fitting.fit_both`) and the map's
    :class:`envfit.predict.PredictionContext`; :func:`_quadrature_cells`;
    :func:`_rule_results` (every predictor); the truncation curves
    (:func:`envfit.validate._truncation.truncation_curves`); the agreement statistics and
    prediction (a); :func:`_renderer_cells` (with ``renderer``); :func:`_finish`.
    """
    cfg = config or ValidateConfig()
    t_start = time.perf_counter()
    run = _start(envmap, cfg, out, quiet, on_cell, t_start)
    fit, fit_ref, run.timings["fit"] = fit_both(envmap, cfg, run.store, quiet, on_cell)
    ctx = PredictionContext.from_map(run.scaled, float(fit["s"]), fit["sigma_channels"],
                                     float(fit_ref["s"]), fit_ref["sigma_channels"])
    s_list = _s_values(cfg, ctx.s)
    cells = _quadrature_cells(run, ctx, s_list)
    results = _rule_results(run, cells, ctx, s_list)
    trunc = []
    if cfg.truncation:
        t_tr = time.perf_counter()
        trunc = truncation_curves(run, ctx)
        run.timings["truncation"] = time.perf_counter() - t_tr - run.timings["equivalents"]
    agr = agreement(results, trunc, s_used=ctx.s, slope_range=SLOPE_RANGE)
    fill_shape(results, trunc, agr)
    fill_measured_equivalents(results, trunc)
    rend = _renderer_cells(run, renderer)
    return _finish(run, fit, fit_ref, ctx, results, trunc, agr, rend)

r"""The advisor: how many samples, or which SH/HSH degree, for this map, this BRDF and a target error?

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals": the worst-case error of a quadrature
rule (Eq. 41) and of an SH/HSH truncation (Eqs. 51–52), turned into an *absolute* predicted
RMS error with the map's fitted smoothness s' and scale σ' (``envfit fit --kernel
bandlimited``), then inverted: the smallest N (or L) whose predicted error is at most the
target.

Prediction (the refined absolute prediction (b') of :mod:`envfit.validate._pipeline`)
-------------------------------------------------------------------------
Under the Gaussian-process reading of the Sobolev model, f − m̄ ~ GP(0, σ² K_gd^(s)) (Eq. 14),
the error of a linear rule at a random axis has mean square :math:`\sigma^2\sum_l a_l e_l`
(:math:`a_l^{(s)}` the kernel's Legendre coefficients, Eqs. 15–16; :math:`e_l` the rule's
squared error on the degree-l harmonics, the bracket of Eq. 42,
:func:`envfit.shading._spectra.rule_error_power`). A lat-long map is not that field, and (b') models
what it is (points (i)–(iv) of the validation's (b')):

* it holds no degree above its Nyquist degree H − 1 (H rows): the sum stops at l = H − 1;
* s' and σ' are fitted under that model — the likelihood of the kernel band-limited at
  H − 1 with the samples at pixel centres (:func:`envfit.fit._smoothness.fit_smoothness` with
  ``kernel="bandlimited"``; for a given s, σ' by
  :func:`envfit.validate._pipeline.bandlimited_profiled_sigma`). The full kernel and bilinear lookups
  read a finite-resolution map as smoother than it is (ŝ ≈ 0.04 high on 256-row GP maps);
* the estimators integrate the map's *bilinear interpolant*, whose power at degree l is the
  pixel field's times :math:`\tau_l` (:func:`envfit.shading._spectra.lookup_transfer` of the map's
  :func:`~envfit.shading._spectra.map_degree_power` over its
  :func:`~envfit.shading._spectra.pixel_degree_power`; 1 at low degrees, ≈ 0.25 at H − 1), so degree
  l is weighted by :math:`\tau_l`. Without it (b') was up to 35 % high for spherical
  Fibonacci at large N, whose error lives near the band limit;

and a rule whose weights do not sum to 1 (OSW) also errs by :math:`\bar m(\sum_j w_j - 1)`
on the map's mean, for every axis:

.. math:: \hat R(N) = \Big(\sigma'^2 E'(N)^2 + (\textstyle\sum_j w_j - 1)^2\,\overline{m^2}\Big)^{1/2},
          \qquad E'^2 = \sum_{l=0}^{H-1} a_l(s')\,\tau_l\,e_l

(:math:`\sigma' = (\frac1C\sum_c\sigma'^2_c)^{1/2}`, :func:`envfit.validate._pipeline.combine_sigma`;
:math:`\overline{m^2}` the mean over channels of the squared solid-angle mean;
``wce_bandlimited`` = E'). On ensembles of GP maps this agrees with the measured RMSE to
≈ 5 %. For the stochastic point sets (random, jitter, bnot) :math:`e_l` and
:math:`(\sum w - 1)^2` are averaged over ``seeds`` realisations per N (the expected error
of the sampler, not of one draw; E'² is linear in :math:`e_l`, so averaging the power is
averaging E'²). OSW weights are those of the kernel at s'. The unrestricted
:math:`\sigma'\,\mathrm{wce}(N)` (Eq. 41 at s', prediction (b) of the validation with the
band-limited fit; it over-predicts by up to 2× for spherical Fibonacci at large N on a map)
is reported beside it at the chosen N but not used for the choice.

Truncation (Eqs. 51–52): :math:`\hat R(L) = \sigma' E'(L)`, the truncation error with the
l-sum stopped at the map's band limit, at s'. SH truncation keeps degrees ≤ L exactly, so
its error is degree l > L of the interpolant, in expectation
:math:`E'^2(L) = \sum_{l=L+1}^{H-1} a_l\,\tau_l\,b_l^2` (Eq. 52 with :math:`e_l = b_l^2`
for l > L, weighted by τ exactly as a rule's). HSH truncation is not diagonal in l
(:math:`b_l - b'_l` non-zero at every l, and the hemispherical projection is not of the
interpolant's SH power), so it keeps ``truncation_error_curve(..., lmax=H-1)`` without τ;
its error lives at low degrees (τ₂₀ ≈ 0.99 on 256-row maps, 0.97 on 128-row ones):
weighting its Eq. 51 terms by τ would lower E by under 1 % for L ≤ 16 on 256-row maps,
3 % on 128-row ones (glossy n = 30, s = 1.2 and 1.5). SH and HSH truncation keep
:math:`b_0` exactly, so there is no mean term. SH truncation at L = H − 1 keeps every degree the map holds: error 0.

Prediction (c) and which prediction sizes a row (:mod:`envfit.advisor._choice`)
-----------------------------------------------------------------------------
Beside (b′) every quadrature and SH row carries prediction (c) of ``envfit validate``
(:func:`envfit.predict.predict_spectral`), extended above the band limit: the map's own
realised power per degree :math:`\hat P_{l,c}` of its bilinear interpolant
(:func:`envfit.shading._spectra.map_degree_power`, computed once per map and cached) times the
rule's error power,

.. math:: \hat R_c^2 = \frac1C\sum_c\sum_{l=0}^{2H-1}\hat P_{l,c}\,e_l

(:func:`envfit.shading._spectra.spectral_rmse`; SH truncation: :math:`e_l = b_l^2` for l > L,
:func:`envfit.predict._spectral.spectral_truncation_curve`), exact in expectation over
Haar-random rotations for the interpolant's content up to 2H − 1. The interpolant is not
band-limited: on 32-row GP and sun maps the sum to H − 1 alone is 0.61–0.99 of the RMSE
measured over 4000 axes (spherical Fibonacci with N ≥ H² / 4 the lowest), the sum to 4H − 1
0.96–1.06. The fitted Sobolev tail :math:`\sigma'^2 a_l(s')` in place of the interpolant's
own power above H − 1 over-predicts 1.4–2.9× for spherical Fibonacci on the same maps
(:math:`a_l e_l \sim l^{1-2s}` with s′ ≈ 1.0–1.2: the model's tail barely converges, while
the interpolant's power falls as about :math:`l^{-6}`), so the tail is the map's own power
(:func:`envfit.advisor._model.spectral_lmax`: why 2H − 1). The rule's :math:`e_l` is cached to
2H − 1 (≈ 0.09 s at N = 4096 instead of 0.025 s to H − 1); (b′) uses its first H degrees.
With ``predictor="auto"`` (default) a row is sized by (c) on the linear scale, and on the
others by (b′) unless (b′) and (c) differ by more than 1.25× at the chosen N/L (then by (c),
with the line ``rule X: (b′) and (c) disagree (ratio r at N = n); using (c)`` in
``Advice.warnings``). HSH rows are (b′) only, and are not sized (with a warning) where (b′)
and (c) of SH truncation disagree at their L (:func:`envfit.advisor._search._hsh_unsupported`).

Search
------
N: the prediction at ``nmax`` first — the search assumes :math:`\hat R` decreases with N, so
a row that misses the target there is "not reached" after one evaluation — then doubling
from ``nmin`` until :math:`\hat R(N) \le` target (:math:`\hat R` the row's predictor) and
bisection between the last failing and the first passing N (:func:`smallest_n`): at most
~2 log₂(N) + 1 evaluations.
:math:`\hat R` is monotone in N for the averaged random sets only in expectation and for
spherical Fibonacci only nearly, so the answer is a *crossing*,
:math:`\hat R(N) \le \text{target} < \hat R(N-1)` (the smallest such N when :math:`\hat R` is
monotone; the tests compare it with a brute-force scan). OSW needs an N×N Cholesky solve per
N and is searched up to ``osw_nmax`` (default 4096); beyond ``nmax`` (or ``osw_nmax``) a row
says that the target is not reached instead of failing. L: the first L of the band-limited
curve at or below the target.

Cost column: N (samples per shading point) for quadrature, (L+1)² coefficients for SH/HSH;
the rows are sorted by it. For the diffuse lobe, HSH truncation is exact from L = 1
(:math:`\tilde b_l = 0` for l ≥ 2, errata): the hemispherical projection *is* the shading
integral, so that row is listed but never recommended.

Cache (:mod:`envfit.advisor._cache`)
----------------------------------
JSON files, so that another target (or another run) on the same map recomputes nothing:

* the fit (keyed by the map's fingerprint, ``up``, scale, s/``fit_n``/seed and
  ``"kernel": "bandlimited"``, so fits of the full kernel are never reused);
* τ (keyed by the map's fingerprint, ``up`` and scale);
* :math:`\hat P_{l,c}`, l = 0…2H − 1 (keyed by the map's fingerprint, ``up``, scale and
  2H − 1);
* every evaluated point of every curve, keyed by s rounded to 1e-6 (the OSW weights' s),
  BRDF, shininess, point set, weighting, the realisation seeds, the band limit H − 1 and
  2H − 1, holds *map-independent* terms: the error power :math:`e_l` (l = 0…2H − 1, averaged
  over the realisations), :math:`(\sum w-1)^2`, :math:`\sum w` and, at the chosen N, the
  plain wce². The map's numbers — :math:`a_l(s')\tau_l`, σ', :math:`\overline{m^2}`,
  :math:`\hat P_l` and the target — are applied afresh (:func:`degree_weights`, :func:`band_e2`), so one curve
  serves every map of that size fitted to the same s'. JSON round-trips floats exactly and
  E'² is the same correctly rounded sum (``math.fsum``) of the same products, so a cached
  answer is identical to a fresh one.

``check=True`` measures the RMSE over ``axes`` random axes at the chosen N/L on the map
(:mod:`envfit.advisor._check`).

The pipeline (:func:`advise_with`; :func:`advise` builds its :class:`AdviseOptions` from
keywords)
------------------------------------------------------------------------------------------
1. the options, checked (:mod:`envfit.advisor._options`), the memory and time plan of every
   stage (:mod:`envfit.advisor._budget`: a map of more than 1024 rows, or one whose plan does
   not fit the memory budget, is downsampled to the height the plan allows, with a note; one
   line when nothing fits) and the memory guard (:func:`plan_advise_memory`), before any point
   is made;
2. the map's model: scale, target, fit of s' and σ', τ (:mod:`envfit.advisor._model`);
3. the curves and their searches, one row per rule (:mod:`envfit.advisor._search`, from the
   terms of :mod:`envfit.advisor._prediction`);
4. the rows into an :class:`Advice` with its recommendation (:mod:`envfit.advisor._result`);
5. with ``renderer`` (default), the renderer rows — strategy × point set × N, sized by the
   warped spectra (:mod:`envfit.advisor._rule_rows`), ``Advice.renderer``;
6. with ``check``, the measurement (:mod:`envfit.advisor._check`; the renderer rows by
   :func:`envfit.measure._rules.measure_rule`).

Example
-------
>>> import tempfile
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.data_gen._gp import gaussian_process_map
>>> env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp")
>>> adv = advise(env, "diffuse", 0.05, scale="linear", s=1.5, fit_n=200, pointsets=("sf",),
...              weights=("equal",), bases=("sh",), cache_dir=tempfile.mkdtemp())
>>> [(r.method, r.n is not None or r.L is not None) for r in adv.rows]
[('sh', True), ('quadrature', True)]
>>> from envfit.advisor._prediction import row_prediction, row_prediction_spectral
>>> from envfit.advisor._search import smallest_n
>>> r = next(r for r in adv.rows if r.method == "quadrature")
>>> r.predictor, bool(r.predicted <= 0.05)           # linear scale: sized by (c)
('spectral', True)
>>> r.n == smallest_n(lambda n: row_prediction_spectral(adv, r, n), 0.05, 4, 65536)[0]
True
>>> bool(abs(row_prediction(adv, r, r.n) / r.predicted_rmse - 1) < 1e-12)   # (b') beside it
True
>>> opts = AdviseOptions(brdf="diffuse", target_rmse=0.05, scale="linear", s=1.5, fit_n=200,
...                      pointsets=("sf",), weights=("equal",), bases=("sh",), cache=False)
>>> [(r.label, r.n, r.L) for r in advise_with(env, opts).rows] == [(r.label, r.n, r.L) for r in adv.rows]
True
"""
from __future__ import annotations

import time

import numpy as np

from envfit.advisor._budget import PREDICTION_MAX_HEIGHT, lobe_rows, prediction_height
from envfit.advisor._cache import AdviseCache
from envfit.advisor._check import check_rows
from envfit.advisor._model import MapModel, map_key, map_model
from envfit.advisor._options import AdviseOptions
from envfit.advisor._prediction import check_lobe_resolved
from envfit.advisor._rule_rows import advise_rule_rows, run_renderer_check
from envfit.advisor._result import Advice, AdviceRow, recommendation_text
from envfit.advisor._search import search_rules
from envfit.base import ParameterError
from envfit.base import format_bytes, memory_budget_bytes, peak_rss_bytes, plan_memory, rss_bytes
from envfit.sobolev import max_samples
from envfit.maps import EnvMap

__all__ = ["advise", "advise_with", "plan_advise_memory"]

#: bytes per point of a quadrature rule while its error power is computed (points, square
#: points, weights, the SH synthesis' angles and temporaries)
_RULE_BYTES_PER_POINT = 8 * 24


def plan_advise_memory(envmap: EnvMap, *, pointsets, weights, nmin: int, nmax: int,
                       osw_nmax: int, fit_n: int, check: bool = False, workers: int = 2) -> None:
    """The advisor's memory guard (:func:`envfit.base._resources.plan_memory`), before any point
    is made: the equal-weight search up to ``nmax`` (O(N): points, weights, error-power
    temporaries, and with ``check`` the lookup blocks), the OSW search up to
    ``min(nmax, osw_nmax)`` (an N x N solve per N) and the band-limited fit (``fit_n``
    capped at half the map's H² degrees of freedom).

    Raises
    ------
    envfit.base._errors.MemoryBudgetError
        A search or the fit would not fit in memory (naming the largest N that fits).
    """
    c = envmap.channels
    fixed = 8 * envmap.width * envmap.height * (c + 4)
    per_point = _RULE_BYTES_PER_POINT + (8 * (8 + 2 * c) * max(1, int(workers)) if check else 0)
    if pointsets and "equal" in weights:
        plan_memory(nmax, "advise's quadrature search (equal weights)", channels=c,
                    kernel=False, per_n_bytes=per_point, fixed_bytes=fixed, n_name="nmax",
                    smallest=nmin)
    if pointsets and "osw" in weights:
        plan_memory(max(nmin, min(nmax, osw_nmax)), "advise's OSW search (an NxN solve per N)",
                    channels=c, per_n_bytes=per_point, fixed_bytes=fixed, n_name="osw_nmax",
                    smallest=nmin)
    n_fit = min(int(fit_n), max(10, max_samples(envmap.height - 1)))
    plan_memory(n_fit, "advise's band-limited fit", channels=c, fixed_bytes=fixed,
                n_name="fit_n", smallest=10)


def advise(envmap: EnvMap, brdf: str = "diffuse", target_rmse: float | None = None,
           **kw) -> Advice:
    """Smallest N per point set and weighting, and smallest SH/HSH degree L, whose predicted
    RMS shading error on ``envmap`` is at most the target (see the module docstring).

    Parameters
    ----------
    envmap : EnvMap
        The map on its raw (linear) values; the options' ``scale`` is applied here.
    brdf : str
        "diffuse" or "glossy" (lobe exponent n = ``shininess``).
    target_rmse : float, optional
        The target RMS error on the ``scale`` values; or give ``target_relative``.
    **kw
        The other fields of :class:`AdviseOptions`: ``target_relative``, ``shininess``,
        ``scale``, ``pointsets``, ``weights``, ``bases``, ``s``, ``fit_n``, ``seed``,
        ``nmin``, ``nmax``, ``osw_nmax``, ``seeds``, ``check``, ``axes``,
        ``check_hsh_height``, ``check_hsh_axes``, ``cache``, ``cache_dir``, ``renderer``,
        ``strategies``, ``renderer_pointsets``, ``renderer_grid``, ``renderer_spectrum_axes``,
        ``renderer_axes_start``, ``renderer_max_axes``, ``renderer_curves``, ``workers``,
        ``quiet``.

    Returns
    -------
    Advice
        As :func:`advise_with` with ``AdviseOptions(brdf=brdf, target_rmse=target_rmse, **kw)``.

    Raises
    ------
    envfit.base._errors.ParameterError
        Bad input (see :class:`AdviseOptions` and :func:`advise_with`).
    TypeError
        A keyword that is not a field of :class:`AdviseOptions`.
    """
    unknown = sorted(set(kw) - set(AdviseOptions.names()))
    if unknown:
        raise TypeError(f"advise() got unexpected keyword argument(s) {', '.join(unknown)}; "
                        f"the options are {', '.join(AdviseOptions.names())}")
    _check_envmap(envmap)
    return advise_with(envmap, AdviseOptions(brdf=brdf, target_rmse=target_rmse, **kw))


def _check_envmap(envmap) -> None:
    """``envmap`` is an :class:`EnvMap` of at least 4 rows."""
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    if envmap.height < 4:
        raise ParameterError(f"the map needs at least 4 rows, got {envmap.height}")


def advise_with(envmap: EnvMap, options):
    """The advisor's one entry point: ``options`` say what is asked, and each answer runs the
    same steps — options checked on construction → the model → the search → a result.

    * :class:`AdviseOptions`: envfit's own rules (:func:`_advise_rules`): memory guard → the
      map's model (scale, target, fit, τ) → curves and searches → rows and recommendation →
      check; an :class:`~envfit.advisor._result.Advice`.
    * :class:`~envfit.advisor._renderer_options.RendererAdviseOptions`: a renderer's own
      terms (:func:`~envfit.advisor._renderer_advice.advise_renderer_map`): the renderer's
      model, asked through the predictor registry → the spp search → a
      :class:`~envfit.advisor._renderer_advice.RendererAdvice`.

    Parameters
    ----------
    envmap : EnvMap
        The map on its raw (linear) values.
    options : AdviseOptions or RendererAdviseOptions
        What to size, for which target, and how.

    Returns
    -------
    Advice or RendererAdvice
        The fit, the target and the rows sorted by cost, with timings, cache counts and notes;
        or the spp per strategy of the renderer's sampler.

    Raises
    ------
    envfit.base._errors.ParameterError
        Not an EnvMap, under 4 rows, constant on the scale (there is nothing to fit), or a
        relative target on a map whose mean shading value is not positive.
    envfit.base._errors.MemoryBudgetError
        A search or fit that cannot fit in memory, before any point is made
        (:func:`plan_advise_memory`).
    """
    from envfit.advisor._renderer_options import RendererAdviseOptions
    if isinstance(options, RendererAdviseOptions):
        from envfit.advisor._renderer_advice import advise_renderer_map
        return advise_renderer_map(envmap, options)
    if not isinstance(options, AdviseOptions):
        _check_envmap(envmap)
        raise ParameterError(f"options must be AdviseOptions or RendererAdviseOptions, got "
                             f"{type(options).__name__}")
    return _advise_rules(envmap, options)


def _advise_rules(envmap: EnvMap, opts: AdviseOptions) -> Advice:
    """:func:`advise_with` of envfit's own rules."""
    t_start = time.perf_counter()
    _check_envmap(envmap)
    original, rss0 = envmap, rss_bytes()
    envmap, plan, plan_notes = _prediction_map(envmap, opts)
    plan_advise_memory(envmap, pointsets=opts.pointsets, weights=opts.weights, nmin=opts.nmin,
                       nmax=opts.nmax, osw_nmax=opts.osw_nmax, fit_n=opts.fit_n,
                       check=opts.check, workers=opts.workers)
    check_lobe_resolved(opts.lobe(), envmap.height)      # the lobe's valid range on this map
    store = AdviseCache(opts.cache_dir, enabled=opts.cache)
    model = map_model(envmap, opts, store)
    wf = opts.lobe()
    t1 = time.perf_counter()
    rows = search_rules(wf, model, opts, store)
    t_search = time.perf_counter() - t1
    adv = _advice(envmap, opts, model, rows)
    setup = None
    if opts.renderer:
        adv.renderer, setup = advise_rule_rows(envmap, model.scaled,
                                               map_key(envmap, opts.scale), opts,
                                               model.target, model.mean_shading, store)
    t_check = 0.0
    if opts.check:
        t2 = time.perf_counter()
        adv.check = check_rows(adv, wf, model, opts)
        t_check = time.perf_counter() - t2
        if setup is not None:
            run_renderer_check(adv.renderer, setup, opts)
    adv.notes.extend(plan_notes + store.notes)
    _record_run(adv, store, model, {"search": t_search, "check": t_check}, t_start)
    if envmap is not original:
        adv.notes.append(_memory_note(adv, plan, rss0))
    return adv


def _record_run(adv: Advice, store: AdviseCache, model: MapModel, steps: dict,
                t_start: float) -> None:
    """The cache's counts and the seconds of each step (``steps``: search, check; the
    renderer section's, prefixed ``renderer_``) into ``adv``."""
    adv.cache = {"enabled": store.enabled, "folder": str(store.folder), "hits": store.hits,
                 "misses": store.misses, "writes": store.writes}
    adv.timings = {"fit": model.seconds_fit, "transfer": model.seconds_transfer, **steps,
                   **({f"renderer_{k}": v for k, v in adv.renderer.timings.items()}
                      if adv.renderer is not None else {}),
                   "total": time.perf_counter() - t_start}


def _memory_note(adv: Advice, plan, rss0: int) -> str:
    """The note of a downsampled run: the peak resident memory and seconds against the plan's."""
    return (f"memory and time: peak {format_bytes(peak_rss_bytes())} resident "
            f"(predicted {format_bytes(rss0 + plan.peak())}: "
            f"{format_bytes(rss0)} before the work + the plan's peak), "
            f"{adv.timings['total']:.0f} s (the plan: ~{plan.seconds():.0f} s, "
            f"its search an upper bound)")


def _prediction_map(envmap: EnvMap, opts: AdviseOptions):
    """The map the predictions use, its plan and notes: ``envmap`` itself when its plan fits
    (:func:`envfit.advisor._budget.prediction_height`), else its solid-angle block means at
    the planned height, with a note saying so and how much of the map's variance they keep.
    Raises :class:`~envfit.base._errors.MemoryBudgetError` (one line) when nothing fits."""
    h, plan = prediction_height(envmap, opts)
    if h == envmap.height:
        return envmap, plan, []
    small = envmap.resized(h, quiet=opts.quiet)
    return small, plan, [_downsample_note(envmap, small, plan, opts)]


def _downsample_note(envmap: EnvMap, small: EnvMap, plan, opts: AdviseOptions) -> str:
    """The note of a downsampled map: why, what the predictions keep (band limit, the degree
    a rule of ``nmax`` points resolves, :math:`\\sqrt{\\pi N}/2` for points
    :math:`\\sqrt{4\\pi/N}` apart), the variance kept and the plan's stages."""
    from envfit.maps import variance_kept
    h, need = small.height, lobe_rows(opts)
    top = PREDICTION_MAX_HEIGHT if need <= PREDICTION_MAX_HEIGHT else need
    why = (f"to fit the memory budget of {format_bytes(memory_budget_bytes())}"
           if h < min(envmap.height, top) else
           f"the glossy lobe needs at least {need} rows" if h > PREDICTION_MAX_HEIGHT else
           f"the predictions use at most {PREDICTION_MAX_HEIGHT} rows")
    l_res = int(np.sqrt(np.pi * opts.nmax) / 2)
    res = (f"above the l ~ {l_res} that rules of N <= {opts.nmax} points resolve"
           if l_res < h - 1 else
           f"below the l ~ {l_res} that rules of N <= {opts.nmax} points resolve: a smaller "
           f"--nmax or a larger memory budget would keep them")
    return (f"the predictions use the {envmap.width}x{envmap.height} map downsampled to "
            f"{small.width}x{small.height} ({why}; solid-angle block means, mean kept): "
            f"band limit l <= {h - 1}, (c) to l = {2 * h - 1}, {res}; the block means keep "
            f"{variance_kept(envmap, small):.1%} of the map's variance; --check measures on "
            f"the downsampled map; plan: " + "; ".join(plan.lines()))


def _advice(envmap: EnvMap, opts: AdviseOptions, model: MapModel,
            rows: list[AdviceRow]) -> Advice:
    """The :class:`Advice` of the map, its model and the sorted rows, with its recommendation."""
    fit = model.fit
    adv = Advice(
        map=envmap.name, map_size=[envmap.width, envmap.height], channels=envmap.channels,
        brdf=opts.brdf, shininess=opts.shininess, scale=opts.scale,
        scale_description=model.scale_description, target_rmse=model.target,
        target_relative=opts.target_relative, mean_shading=model.mean_shading, s=model.s,
        s_interval=fit.get("s_interval"), sigma=model.sigma,
        sigma_channels=model.sigma_channels, fit_source=fit["source"],
        fit_cached=model.fit_cached, fit_kernel=fit.get("kernel", "bandlimited"),
        fit_band_lmax=fit.get("band_lmax"), fit_samples=fit.get("samples"),
        band_lmax=model.band_lmax, mean_rms=model.mean_rms, rows=rows, recommendation="",
        settings=opts.settings(model.s_rounded),
        notes=list(envmap.notes) + list(fit.get("notes", [])),
        lookup_transfer=[float(x) for x in model.tau], spectral_lmax=model.spectral_lmax,
        map_power=[float(x) for x in np.mean(model.map_power, axis=0)],
        warnings=[r.warning for r in rows if r.warning])
    adv.recommendation = recommendation_text(adv)
    return adv

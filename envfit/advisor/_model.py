r"""The map's side of the advisor's prediction: the map on its scale, the absolute target, the
band-limited fit of s' and σ', the bilinear lookup's transfer τ_l and :math:`a_l(s')\tau_l`,
and the realised power per degree :math:`\hat P_{l,c}` of the map's bilinear interpolant to
:math:`L_\mathrm{tail} = 2H - 1` (:func:`spectral_lmax`) for prediction (c), with the fit, τ
and :math:`\hat P` cached (:mod:`envfit.advisor._cache`).

:math:`\hat P_{l,c} = \frac{1}{2l+1}\sum_m f_{lm,c}^2`
(:func:`envfit.shading._spectra.map_degree_power`) from the exact SH coefficients of the
interpolant, which is *not* band-limited: above H − 1 it holds the power of the bilinear
kernel's corners and of every sharp feature (a sun), which is what the estimators integrate.
It is computed once per map (≈ 1.1 s on a 1024×512 map: to l = 511 and to l = 1023) and
cached under the map's key and :math:`L_\mathrm{tail}`; τ is then :math:`\sum_c\hat
P_{l,c}/\sum_c\hat P^{pix}_{l,c}` for l ≤ H − 1 (:func:`envfit.shading._spectra.lookup_transfer`,
bit for bit :func:`envfit.shading._spectra.map_transfer`).

The fit is the likelihood of the kernel band-limited at the map's Nyquist degree H − 1 with
the samples at pixel centres (:func:`envfit.fit._smoothness.fit_smoothness`, ``kernel=
"bandlimited"``), or for a given s, σ' by the band-limited profiled likelihood
(:func:`envfit.fit._sigma.bandlimited_profiled_sigma`); σ' combines the channels'
(:func:`envfit.fit._sigma.combine_sigma`). Cache keys: the fit by the map's fingerprint, shape,
``up``, scale, s, ``"method": "likelihood"``, ``"kernel": "bandlimited"``, ``fit_n`` and seed;
τ by the map's key and the band limit. The same keys and values as before this module existed,
so cached answers stay bit-identical.

Example
-------
>>> import tempfile
>>> from envfit.advisor._cache import AdviseCache
>>> from envfit.advisor._options import AdviseOptions
>>> from envfit.data_gen._gp import gaussian_process_map
>>> env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp")
>>> opts = AdviseOptions(target_rmse=0.05, scale="linear", s=1.5, fit_n=200)
>>> m = map_model(env, opts, AdviseCache(tempfile.mkdtemp()))
>>> m.band_lmax, m.s, m.fit["source"], len(m.tau), m.sigma > 0, m.target
(15, 1.5, 'given', 16, True, 0.05)
>>> m.spectral_lmax, m.map_power.shape
(31, (1, 32))
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from envfit.advisor._cache import AdviseCache
from envfit.advisor._options import AdviseOptions
from envfit.advisor._prediction import mean_shading_value
from envfit.base import ParameterError
from envfit.base import s_value
from envfit.base import progress_bar
from envfit.base import array_fingerprint
from envfit.fit import bandlimited_profiled_sigma, combine_sigma
from envfit.maps import EnvMap
from envfit.maps import check_not_constant, fit_scale
from envfit.predict import PredictionContext
from envfit.shading import degree_weights, lookup_transfer, map_degree_power, pixel_degree_power

__all__ = ["MapModel", "map_model", "fit_smoothness", "spectral_lmax", "cached_map_power"]


def spectral_lmax(band_lmax: int) -> int:
    r""":math:`L_\mathrm{tail} = 2H - 1 = 2(\text{band\_lmax} + 1) - 1`: the highest degree of
    prediction (c), one octave above the map's band limit.

    Why there: the bilinear interpolant's power falls fast above H − 1 (on city.exr
    :math:`\hat P_{1023}/\hat P_{511} \approx 0.02`, about :math:`l^{-5.7}`) while a rule's
    :math:`e_l` grows about as l, so the octave [H, 2H) holds 4–18 % of a rule's mean squared
    error on city.exr and [2H, 4H) only 0.4–7 % (spherical Fibonacci, N = 64…16384); the
    next octave would cost :func:`envfit.shading._spectra.rule_error_power` 0.47 s instead of
    0.09 s at N = 4096 (and 0.025 s to H − 1) per evaluated N, and 4 s instead of 0.8 s of
    map analysis, against the first call's 60 s budget.

    >>> spectral_lmax(511)
    1023
    """
    return 2 * (int(band_lmax) + 1) - 1


def fit_smoothness(*args, **kwargs):
    """:func:`envfit.fit._smoothness.fit_smoothness`, imported on first use: numba and the
    interpolator load only when a fit is not cached (a cached ``envfit advise`` stays under 2 s)."""
    from envfit.fit import fit_smoothness as _fit_smoothness
    return _fit_smoothness(*args, **kwargs)


@dataclass(frozen=True)
class MapModel:
    """The map's numbers that every rule's prediction uses.

    Attributes
    ----------
    scaled : EnvMap
        The map on the options' scale (float64).
    scale_description : str
        The scale, in words.
    band_lmax : int
        The map's band limit H − 1.
    mean_rms : float
        :math:`(\\overline{m^2})^{1/2}`, the RMS over channels of the solid-angle mean.
    mean_shading : float
        :func:`~envfit.advisor._prediction.mean_shading_value` of the scaled map.
    target : float
        The absolute target RMSE (the relative one times ``mean_shading``).
    fit : dict
        The cached fit: s, s_interval, sigma_channels, source, kernel, band_lmax, samples, notes.
    fit_cached : bool
        Whether ``fit`` came from the cache.
    s, s_rounded, sigma : float
        The fitted s', s' rounded (:func:`~envfit.base._keys.s_value`) and σ'.
    sigma_channels : list of float
        σ' per channel.
    tau, dw : ndarray
        τ_l and :math:`a_l(s')\\tau_l`, l = 0…H − 1.
    seconds_fit, seconds_transfer : float
        Time of the fit step (a cache hit included) and of the τ and power step.
    spectral_lmax : int
        :math:`L_\\mathrm{tail} = 2H - 1`, the highest degree of prediction (c).
    map_power : ndarray
        (C, L_tail + 1) realised power per degree :math:`\\hat P_{l,c}` of the interpolant.
    """

    scaled: EnvMap
    scale_description: str
    band_lmax: int
    mean_rms: float
    mean_shading: float
    target: float
    fit: dict
    fit_cached: bool
    s: float
    s_rounded: float
    sigma: float
    sigma_channels: list
    tau: np.ndarray
    dw: np.ndarray
    seconds_fit: float
    seconds_transfer: float
    spectral_lmax: int = 0
    map_power: np.ndarray | None = None

    def context(self, *, band: bool = False) -> PredictionContext:
        r"""The :class:`envfit.predict.PredictionContext` of the map for
        :func:`envfit.predict.predict`: σ′ and s′ (rounded) for (b) and (b′), τ, the band limit,
        :math:`(\overline{m^2})^{1/2}` and :math:`\hat P_{l,c}` to
        :math:`L_\mathrm{tail} = 2H - 1` for (c) with its tail (``band``: to H − 1, validate's
        (c))."""
        P = self.map_power if not band else self.map_power[:, :self.band_lmax + 1]
        return PredictionContext(s=self.s_rounded, sigma=self.sigma,
                                 s_bandlimited=self.s_rounded, sigma_bandlimited=self.sigma,
                                 band_lmax=self.band_lmax, transfer=self.tau, map_power=P,
                                 mean_rms=self.mean_rms)


def absolute_target(opts: AdviseOptions, mean_shading: float) -> float:
    """The target RMSE: ``target_rmse``, or ``target_relative`` × the mean shading value."""
    if opts.target_relative is None:
        return float(opts.target_rmse)
    if not mean_shading > 0:
        raise ParameterError(f"the map's mean shading value on the {opts.scale} scale is "
                             f"{mean_shading:.3g}, not positive: give --target-rmse instead")
    return opts.target_relative * mean_shading


def map_key(envmap: EnvMap, scale: str) -> dict:
    """The cache key of the map on a scale: fingerprint, shape, ``up`` and scale."""
    return {"fingerprint": array_fingerprint(envmap.data), "shape": list(envmap.data.shape),
            "up": envmap.up, "scale": scale}


def _fresh_fit(envmap: EnvMap, scaled: EnvMap, opts: AdviseOptions) -> dict:
    """s' and σ' of the band-limited model, computed (the cached value's fields)."""
    if opts.s == "auto":
        res = fit_smoothness(envmap, method="likelihood", n=opts.fit_n, scale=opts.scale,
                             seed=opts.seed, kernel="bandlimited", quiet=opts.quiet)
        return {"s": float(res.s), "s_interval": [float(x) for x in res.s_interval],
                "sigma_channels": [float(x) for x in res.sigma], "source": "fit",
                "kernel": "bandlimited", "band_lmax": int(res.band_lmax),
                "samples": int(res.n), "notes": list(res.notes)}
    sig, used = bandlimited_profiled_sigma(scaled, float(opts.s), n=opts.fit_n, seed=opts.seed)
    return {"s": float(opts.s), "s_interval": None, "sigma_channels": sig.tolist(),
            "source": "given", "kernel": "bandlimited", "band_lmax": scaled.height - 1,
            "samples": int(used), "notes": []}


def cached_fit(envmap: EnvMap, scaled: EnvMap, opts: AdviseOptions,
               store: AdviseCache) -> tuple[dict, bool]:
    """The band-limited fit from the cache, or fitted and saved; (fit, whether cached)."""
    t0 = time.perf_counter()
    fit_key = {**map_key(envmap, opts.scale), "s": opts.s, "method": "likelihood",
               "kernel": "bandlimited", "n": opts.fit_n, "seed": opts.seed}
    fit = store.load("fit", fit_key)
    if fit is not None:
        return fit, True
    fit = _fresh_fit(envmap, scaled, opts)
    fit["seconds"] = time.perf_counter() - t0
    store.save("fit", fit_key, fit)
    return fit, False


def cached_map_power(envmap: EnvMap, scaled: EnvMap, scale: str, store: AdviseCache,
                     lmax: int, *, quiet: bool = True) -> np.ndarray:
    r""":math:`\hat P_{l,c}`, (C, lmax + 1), of the bilinear interpolant of ``scaled``
    (:func:`envfit.shading._spectra.map_degree_power`), from the cache (kind ``"power"``, the
    map's key and ``lmax``) or computed and saved.

    Degrees l ≤ H − 1 come from the analysis to H − 1 — bit for bit what ``envfit validate``'s
    :meth:`envfit.predict.PredictionContext.from_map` and
    :func:`envfit.shading._spectra.map_transfer` use (the Gauss–Legendre order of the analysis
    follows its lmax, so an analysis to 2H − 1 differs there by ~5e-12 relative) — and the
    tail l = H…lmax from the analysis to ``lmax``. A progress bar over the two analyses
    (seconds each on a 2048x1024 map) unless ``quiet``."""
    key = {**map_key(envmap, scale), "lmax": int(lmax)}
    pw = store.load("power", key)
    P = None if pw is None else np.asarray(pw.get("power", []), dtype=np.float64)
    if P is None or P.shape != (scaled.channels, int(lmax) + 1):
        h = scaled.height
        bar = progress_bar(2 if int(lmax) >= h else 1, desc="advise: map power", quiet=quiet,
                           unit="analysis")
        try:
            bar.set_postfix_str(f"to l = {h - 1}")
            P = map_degree_power(scaled, h - 1)
            bar.update(1)
            if int(lmax) >= h:
                bar.set_postfix_str(f"to l = {int(lmax)}")
                P = np.concatenate([P, map_degree_power(scaled, int(lmax))[:, h:]], axis=1)
                bar.update(1)
        finally:
            bar.close()
        store.save("power", key, {"power": [[float(x) for x in row] for row in P]})
    return P


def cached_transfer(envmap: EnvMap, scaled: EnvMap, scale: str, store: AdviseCache,
                    map_power: np.ndarray | None = None) -> np.ndarray:
    r"""τ_l, l = 0…H − 1, of the bilinear lookup of ``scaled``, from the cache or computed:
    :math:`\sum_c \hat P_{l,c} / \sum_c \hat P^{pix}_{l,c}` with ``map_power`` (its first
    H degrees; computed when None) over :func:`envfit.shading._spectra.pixel_degree_power`."""
    band_lmax = scaled.height - 1
    key = {**map_key(envmap, scale), "band_lmax": band_lmax}
    tr = store.load("transfer", key)
    if tr is None or len(tr.get("tau", [])) != band_lmax + 1:
        P = map_degree_power(scaled, band_lmax) if map_power is None else \
            np.asarray(map_power)[:, :band_lmax + 1]
        tr = {"tau": [float(x) for x in lookup_transfer(P, pixel_degree_power(scaled,
                                                                              band_lmax))]}
        store.save("transfer", key, tr)
    return np.asarray(tr["tau"], dtype=np.float64)


def map_model(envmap: EnvMap, opts: AdviseOptions, store: AdviseCache) -> MapModel:
    """The map on its scale, the target, the fit, τ and :math:`\\hat P` to
    :func:`spectral_lmax`: a :class:`MapModel`.

    Raises :class:`envfit.base._errors.ParameterError` for a map constant on the scale (in a
    channel, or σ' = 0: every rule is exact) and a relative target on a map whose mean
    shading value is not positive.
    """
    sc = fit_scale(opts.scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, opts.scale, envmap.name)
    band_lmax = scaled.height - 1
    mean_rms = float(np.sqrt(np.mean(scaled.mean() ** 2)))
    mean_shading = mean_shading_value(scaled)
    target = absolute_target(opts, mean_shading)
    t0 = time.perf_counter()
    fit, fit_cached = cached_fit(envmap, scaled, opts, store)
    t_fit = time.perf_counter() - t0
    s_rounded = s_value(float(fit["s"]))
    sigma_ch = [float(x) for x in fit["sigma_channels"]]
    sigma = combine_sigma(sigma_ch)
    if not sigma > 0:
        raise ParameterError("the map is constant on this scale (sigma = 0): every rule is exact")
    t0 = time.perf_counter()
    ltail = spectral_lmax(band_lmax)
    P = cached_map_power(envmap, scaled, opts.scale, store, ltail, quiet=opts.quiet)
    tau = cached_transfer(envmap, scaled, opts.scale, store, P)
    dw = degree_weights(s_rounded, band_lmax, tau)          # a_l(s') tau_l, l = 0..H-1
    return MapModel(scaled=scaled, scale_description=sc.describe(), band_lmax=band_lmax,
                    mean_rms=mean_rms, mean_shading=mean_shading, target=target, fit=fit,
                    fit_cached=fit_cached, s=float(fit["s"]), s_rounded=s_rounded, sigma=sigma,
                    sigma_channels=sigma_ch, tau=tau, dw=dw, seconds_fit=t_fit,
                    seconds_transfer=time.perf_counter() - t0, spectral_lmax=ltail,
                    map_power=P)

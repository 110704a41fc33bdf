r"""Estimate the Sobolev smoothness s of a map on the continuous range (1, 2), with an
uncertainty, by one of three explicit criteria (beyond the paper's Table 2 grid search):

``likelihood``
    Gaussian-process marginal likelihood of the samples under covariance
    :math:`\sigma^2 K^{(s)}_{gd}`, with :math:`\sigma^2` profiled out
    (:math:`\hat\sigma^2 = f^T K^{-1} f / N`):
    :math:`\ell(s) = -\tfrac12\,(N \log\hat\sigma^2 + \log\det K + N(1 + \log 2\pi))`,
    summed over channels. 95 % interval: the profile-likelihood interval
    :math:`2(\ell_{max} - \ell(s)) \le \chi^2_{1,0.95} = 3.84`.
``loo``
    Leave-one-out cross-validation in closed form (Rippa 1999: :math:`e_i = \alpha_i /
    (K^{-1})_{ii}`, no refits); score = RMS of the LOO residuals. Interval: bootstrap
    over the sample points of the argmin.
``holdout``
    The paper's criterion: RMSE of the reconstruction at held-out pixel centres. Interval:
    bootstrap over the held-out pixels.

The likelihood can use the kernel band-limited at the map's Nyquist degree H − 1 with the
samples at pixel centres (``kernel="bandlimited"``, ``envfit fit --kernel bandlimited``;
:mod:`envfit.kernels.bandlimited`): the exact model of a band-limited GP map, without the upward
bias of ŝ that the full kernel and bilinear lookups give on a finite-resolution map.

:math:`\hat\sigma` (per channel, on the named scale) is reported for every method at its
estimate: under the Gaussian-process reading, the expected squared error of a quadrature
rule is :math:`\sigma^2\,\mathrm{wce}^2`, which is how ``envfit validate`` and ``envfit
advise`` turn worst-case errors into predicted RMS errors.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np
from scipy import optimize

from envfit.kernels.bandlimited import (bandlimited_log_likelihood, map_band_limit, max_samples,
                          pixel_centre_samples)
from envfit.base.checks import check_int
from envfit.maps.envmap import EnvMap, check_sample_count
from envfit.base.errors import ParameterError
from envfit.kernels.interpolation import SobolevInterpolator
from envfit.base.resources import plan_memory
from envfit.maps.scales import check_not_constant, fit_scale
from envfit.fit.table2 import sample_directions

__all__ = ["METHODS", "KERNELS", "DEFAULT_METHOD", "DEFAULT_N", "FitResult", "fit_smoothness",
           "fit_smoothness_samples", "S_GRID", "SCORE_NAMES", "holdout_pixels",
           "bootstrap_indices", "bootstrap_argmin_interval", "plan_fit_memory"]

METHODS = ("likelihood", "loo", "holdout")
#: ``full``: K_gd (Eq. 14), samples by bilinear lookup; ``bandlimited``: K_gd truncated at the
#: map's Nyquist degree H − 1, samples at pixel centres (:mod:`envfit.kernels.bandlimited`)
KERNELS = ("full", "bandlimited")
DEFAULT_METHOD = "likelihood"
DEFAULT_N = 3000
#: the coarse grid the criterion is evaluated on before the continuous refinement
S_GRID = tuple(np.round(np.arange(1.05, 1.96, 0.075), 4))
CHI2_1_95 = 3.841458820694124
SCORE_NAMES = {"likelihood": "negative profiled log-likelihood per sample",
               "loo": "RMS leave-one-out residual", "holdout": "RMSE at held-out pixels"}


@dataclass
class FitResult:
    s: float
    s_interval: tuple[float, float]
    sigma: list[float]
    method: str
    scale: str
    n: int
    scale_description: str = ""
    curve: list[dict] = field(default_factory=list)
    score_name: str = ""
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    kernel: str = "full"
    band_lmax: int | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["s_interval"] = list(self.s_interval)
        return d


def _criterion(method: str, points, values, s, holdout_dirs=None, holdout_values=None,
               band_lmax: int | None = None):
    """(score to minimise, per-item squared errors for the bootstrap or None, sigma per channel)."""
    if band_lmax is not None:                 # likelihood only (checked by the caller)
        ll, sigma = bandlimited_log_likelihood(points, values, s, band_lmax)
        return -float(np.sum(ll)) / len(points), None, np.atleast_1d(sigma)
    interp = SobolevInterpolator(points, values, s)
    if method == "likelihood":
        ll, sigma = interp.log_likelihood_profiled()
        return -float(np.sum(ll)) / len(points), None, np.atleast_1d(sigma)
    if method == "loo":
        e = np.asarray(interp.loo_residuals()).reshape(len(points), -1)
        sq = np.sum(e * e, axis=1)
        return float(np.sqrt(np.mean(sq) / e.shape[1])), sq, None
    pred = np.asarray(interp(holdout_dirs)).reshape(holdout_values.shape)
    sq = np.sum((pred - holdout_values) ** 2, axis=1)
    return float(np.sqrt(np.mean(sq) / holdout_values.shape[1])), sq, None


def fit_smoothness_samples(points: np.ndarray, values: np.ndarray, *, method: str = DEFAULT_METHOD,
                           holdout_dirs=None, holdout_values=None, s_grid=S_GRID, seed: int = 0,
                           n_bootstrap: int = 400, band_lmax: int | None = None,
                           callback: Callable[[float], None] | None = None) -> dict:
    """Fit s from scattered samples ``values`` (N or N×C) at unit vectors ``points`` (N×3).

    Returns a dict with ``s``, ``s_interval``, ``sigma`` (per channel), ``curve`` and
    ``constant_channels`` (left out of the likelihood, σ̂ = 0; constant values in every
    channel raise :class:`~envfit.base.errors.ParameterError`: there is nothing to fit).
    Used by :func:`fit_smoothness`; also usable directly on sampled data (e.g. exact
    Gaussian-process samples in the tests). ``band_lmax`` (likelihood only): use the kernel
    band-limited at that degree (:mod:`envfit.kernels.bandlimited`) instead of K_gd.
    """
    if method not in METHODS:
        raise ParameterError(f"unknown fit method {method!r}; choose one of {', '.join(METHODS)}")
    if band_lmax is not None and method != "likelihood":
        raise ParameterError("the band-limited kernel is available for the likelihood method only")
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        values = values[:, None]
    varies = np.ptp(values, axis=0) > 0 if len(values) else np.zeros(values.shape[1], bool)
    if not np.any(varies):
        # sigma = 0: the likelihood is infinite at every s and the interval search meets NaN
        raise ParameterError(f"the {len(values)} sample values are constant"
                             f"{' in every channel' if values.shape[1] > 1 else ''}: "
                             "there is nothing to fit")
    if method == "likelihood" and not np.all(varies):
        # a constant channel has sigma = 0 and an infinite likelihood: fit on the others
        res = fit_smoothness_samples(points, values[:, varies], method=method,
                                     holdout_dirs=holdout_dirs, holdout_values=holdout_values,
                                     s_grid=s_grid, seed=seed, n_bootstrap=n_bootstrap,
                                     band_lmax=band_lmax, callback=callback)
        sigma = np.zeros(values.shape[1])
        sigma[varies] = res["sigma"]
        res["sigma"] = [float(x) for x in sigma]
        res["constant_channels"] = [int(c) for c in np.flatnonzero(~varies)]
        return res
    if method == "likelihood":
        # the GP is zero-mean; the map's mean is its l = 0 term, not part of its roughness
        values = values - values.mean(axis=0, keepdims=True)
    if method == "holdout":
        if holdout_dirs is None or holdout_values is None:
            raise ParameterError("holdout needs held-out directions and values")
        holdout_values = np.asarray(holdout_values, dtype=np.float64).reshape(len(holdout_dirs), -1)
    cache: dict[float, tuple] = {}

    def evaluate(s: float):
        s = float(np.clip(s, 1.0 + 1e-6, 2.0 - 1e-6))
        if s not in cache:
            cache[s] = _criterion(method, points, values, s, holdout_dirs, holdout_values,
                                  band_lmax)
            if callback:
                callback(s)
        return cache[s]

    grid = np.asarray(s_grid, dtype=float)
    scores = np.array([evaluate(s)[0] for s in grid])
    k = int(np.argmin(scores))
    lo = grid[max(k - 1, 0)] if k > 0 else 1.0 + 1e-6
    hi = grid[min(k + 1, len(grid) - 1)] if k < len(grid) - 1 else 2.0 - 1e-6
    opt = optimize.minimize_scalar(lambda s: evaluate(s)[0], bounds=(lo, hi), method="bounded",
                                   options={"xatol": 2e-3})
    s_hat = float(opt.x) if opt.fun <= scores[k] else float(grid[k])
    best = evaluate(s_hat)

    if method == "likelihood":
        n = len(points)
        # ℓ(s) = -n * score(s); interval where 2 (ℓmax - ℓ) <= 3.84
        def excess(s):
            return 2.0 * n * (evaluate(s)[0] - best[0]) - CHI2_1_95
        lo_s = _bracket_root(excess, s_hat, grid[grid < s_hat][::-1], 1.0 + 1e-6)
        hi_s = _bracket_root(excess, s_hat, grid[grid > s_hat], 2.0 - 1e-6)
        interval = (lo_s, hi_s)
    else:
        interval = _bootstrap_interval(grid, [evaluate(s)[1] for s in grid], seed=seed,
                                       n_bootstrap=n_bootstrap)
        interval = (min(interval[0], s_hat), max(interval[1], s_hat))
    # sigma: from the profiled likelihood at s_hat (computed if the method did not)
    if method == "likelihood":
        sigma = best[2]
    else:
        vals = values - values.mean(axis=0, keepdims=True)
        sigma = np.atleast_1d(SobolevInterpolator(points, vals, s_hat).log_likelihood_profiled()[1])
    curve = [{"s": float(s), "score": float(v[0])} for s, v in sorted(cache.items())]
    return {"s": s_hat, "s_interval": (float(interval[0]), float(interval[1])),
            "sigma": [float(x) for x in sigma], "curve": curve, "constant_channels": []}


def _bracket_root(f, inside: float, candidates, edge: float) -> float:
    """Where f changes sign going out from ``inside`` (f < 0): the first already-evaluated
    grid point with f > 0 brackets the root (no extra evaluations), then Brent's method;
    ``edge`` of (1, 2) if f stays negative all the way."""
    outer = next((float(c) for c in candidates if f(c) > 0), None)
    if outer is None:
        if f(edge) <= 0:
            return float(edge)
        outer = edge
    return float(optimize.brentq(f, min(inside, outer), max(inside, outer), xtol=2e-3))


def bootstrap_indices(m: int, *, seed: int, n_bootstrap: int) -> np.ndarray:
    """(n_bootstrap, m) item indices of the bootstrap resamples (seeded)."""
    return np.random.default_rng(seed).integers(0, m, size=(n_bootstrap, m))


def _bootstrap_interval(grid, sq_errors, *, seed: int, n_bootstrap: int) -> tuple[float, float]:
    """95 % percentile interval of the argmin of the resampled mean squared error."""
    E = np.stack(sq_errors)                       # (len(grid), items)
    idx = bootstrap_indices(E.shape[1], seed=seed, n_bootstrap=n_bootstrap)
    # mean over resampled items for every grid point: (n_bootstrap, len(grid))
    means = np.stack([E[:, i].mean(axis=1) for i in idx])
    return bootstrap_argmin_interval(grid, means)


def bootstrap_argmin_interval(grid, means: np.ndarray) -> tuple[float, float]:
    """95 % percentile interval of the per-resample argmin over ``grid`` of ``means``
    (n_bootstrap, len(grid)), each argmin refined by a parabola through its neighbours."""
    grid = np.asarray(grid, dtype=float)
    n_bootstrap = means.shape[0]
    k = np.argmin(means, axis=1)
    s_star = np.empty(n_bootstrap)
    for b in range(n_bootstrap):                  # parabolic refinement of each argmin
        j = int(np.clip(k[b], 1, len(grid) - 2))
        y0, y1, y2 = means[b, j - 1:j + 2]
        den = y0 - 2 * y1 + y2
        off = 0.5 * (y0 - y2) / den if den > 0 else 0.0
        s_star[b] = grid[j] + np.clip(off, -1, 1) * (grid[1] - grid[0])
    return float(np.percentile(s_star, 2.5)), float(np.percentile(s_star, 97.5))


def holdout_pixels(scaled: EnvMap, n_holdout: int, *, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(directions (m, 3), values (m, C)) of m = min(n_holdout, H W) distinct pixel centres
    drawn with probability proportional to solid angle (so their RMSE is a sphere average)."""
    rng = np.random.default_rng(seed)
    H, W, C = scaled.height, scaled.width, scaled.channels
    m = min(int(n_holdout), H * W)
    w = scaled.solid_angles().ravel()
    idx = rng.choice(H * W, size=m, replace=False, p=w / w.sum())
    return scaled.directions().reshape(-1, 3)[idx], scaled.data.reshape(-1, C)[idx]


def plan_fit_memory(n: int, width: int, height: int, channels: int, *,
                    method: str = DEFAULT_METHOD, n_holdout: int = 20000,
                    what: str = "the smoothness fit", n_name: str = "n") -> int:
    """The fit's memory guard (:func:`envfit.base.resources.plan_memory`), before any sample is
    made: the interpolator (N x N kernel matrix, O(N C) arrays) of ``n`` samples, the map on
    its scale and its pixel directions, and for ``holdout`` the held-out pixels and their
    predictions."""
    pixels = int(width) * int(height)
    c = int(channels)
    fixed = 8 * pixels * (c + 4)                         # scaled map, directions, solid angles
    if method == "holdout":
        m = min(int(n_holdout), pixels)
        fixed += 8 * m * (3 + 3 * c)
    return plan_memory(n, what, channels=c, fixed_bytes=fixed, n_name=n_name,
                       smallest=10)


def fit_smoothness(envmap: EnvMap, *, method: str = DEFAULT_METHOD, n: int = DEFAULT_N,
                   scale: str = "display", pointset: str = "sf", seed: int = 0,
                   n_holdout: int = 20000, s_grid=S_GRID, kernel: str = "full",
                   quiet: bool = True) -> FitResult:
    """Fit the Sobolev smoothness s of ``envmap`` (see the module docstring).

    The map is put on ``scale`` first (as in Table 2), then sampled at ``n`` directions
    (``pointset``; spherical Fibonacci by default). ``holdout`` compares the reconstruction
    with ``n_holdout`` random pixel centres (seeded).

    ``kernel="bandlimited"`` (likelihood only): the kernel truncated at the map's Nyquist
    degree H − 1 and the samples moved to their nearest pixel centres (repeats dropped), the
    exact model of a band-limited Gaussian-process map (:mod:`envfit.kernels.bandlimited`; it
    removes the upward bias of ŝ that the full kernel and bilinear lookups give).

    Checked before anything of size ``n`` is made: ``n`` an integer ≥ 10, the memory guard
    (:func:`plan_fit_memory`; :class:`~envfit.base.errors.MemoryBudgetError` naming the largest n
    that fits), ``n`` at most the map's pixel count (full kernel; an error, see
    :func:`~envfit.maps.envmap.check_sample_count`), and a map constant on ``scale`` (e.g. all
    zero) is refused (:func:`~envfit.maps.scales.check_not_constant`). A channel that is constant
    while others vary is left out of the likelihood (σ̂ = 0 for it, noted).
    """
    t0 = time.perf_counter()
    if method not in METHODS:
        raise ParameterError(f"unknown fit method {method!r}; choose one of {', '.join(METHODS)}")
    if kernel not in KERNELS:
        raise ParameterError(f"unknown kernel {kernel!r}; choose one of {', '.join(KERNELS)}")
    if kernel == "bandlimited" and method != "likelihood":
        raise ParameterError("the band-limited kernel is available for the likelihood method only")
    n = check_int(n, "the number of samples n", 10)
    C = envmap.channels
    notes = []
    band_lmax = None
    if kernel == "bandlimited":
        band_lmax = map_band_limit(envmap)
        cap = max_samples(band_lmax)
        if cap < 10:
            raise ParameterError(f"a {envmap.height}-row map is too small for the band-limited fit "
                                 "(it needs at least 5 rows: 10 samples, half the H² degrees of "
                                 "freedom)")
        if n > cap:
            notes.append(f"n = {n} capped at {cap}: a {envmap.height}-row map holds "
                         f"{envmap.height ** 2} degrees of freedom, and the band-limited fit "
                         "takes at most half of them")
            n = cap
    # before anything of size n: the memory guard, then n against the pixel count (the
    # band-limited cap above is stricter than the pixel count)
    plan_fit_memory(n, envmap.width, envmap.height, C, method=method, n_holdout=n_holdout)
    check_sample_count(n, envmap.width, envmap.height, name=envmap.name, what="n")
    sc = fit_scale(scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, scale, envmap.name)
    points = sample_directions(n, pointset=pointset, seed=seed, up=envmap.up)
    if kernel == "bandlimited":
        points, values = pixel_centre_samples(scaled, points)
        notes.append(f"band-limited kernel (L = {band_lmax}); {len(points)} samples at pixel "
                     f"centres ({n - len(points)} repeats dropped)")
        n = len(points)
    else:
        values = scaled.lookup(points).reshape(n, C)
    hd = hv = None
    if method == "holdout":
        hd, hv = holdout_pixels(scaled, n_holdout, seed=seed)
        notes.append(f"holdout: {len(hd)} pixel centres drawn with probability proportional to solid angle")
    from envfit.base.progress import progress_bar
    bar = progress_bar(len(s_grid) + 12, desc=f"fit ({method})", quiet=quiet, unit="s")
    try:
        res = fit_smoothness_samples(points, values, method=method, holdout_dirs=hd,
                                     holdout_values=hv, s_grid=s_grid, seed=seed,
                                     band_lmax=band_lmax, callback=lambda s: bar.update(1))
    finally:
        bar.close()
    if res.get("constant_channels"):
        notes.append(f"channel(s) {', '.join(map(str, res['constant_channels']))} constant on the "
                     f"{scale} scale at the samples: left out of the fit (sigma 0)")
    score_name = SCORE_NAMES[method]
    lo, hi = res["s_interval"]
    if lo <= 1.0 + 1e-3 or hi >= 2.0 - 1e-3:
        notes.append("the interval reaches the edge of (1, 2): the map may be rougher/smoother "
                     "than this kernel family can express")
    return FitResult(s=res["s"], s_interval=res["s_interval"], sigma=res["sigma"], method=method,
                     scale=scale, scale_description=sc.describe(), n=n, curve=res["curve"], score_name=score_name,
                     seconds=time.perf_counter() - t0, notes=notes, kernel=kernel,
                     band_lmax=band_lmax)

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
:mod:`envfit.sobolev._bandlimited`): the exact model of a band-limited GP map, without the upward
bias of ŝ that the full kernel and bilinear lookups give on a finite-resolution map.

The criterion at one s is :func:`envfit.fit._criterion.evaluate_criterion`; ŝ and its interval
come from the lattice search of :mod:`envfit.fit._search` (coarse grid, refinement lattice of
step 0.025, cubic spline), the same search and the same numbers as a map inside a library
(:func:`envfit.batch._library_fit.fit_smoothness_library`).

:math:`\hat\sigma` (per channel, on the named scale) is reported for every method at its
estimate (the profiled σ̂ of :func:`envfit.sobolev._likelihood.profiled_log_likelihood`,
computed at ŝ): under the Gaussian-process reading, the expected squared error of a quadrature
rule is :math:`\sigma^2\,\mathrm{wce}^2`, which is how ``envfit validate`` and ``envfit
advise`` turn worst-case errors into predicted RMS errors.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from envfit.sobolev import map_band_limit, max_samples, pixel_centre_samples
from envfit.base import check_int
from envfit.base import html_result
from envfit.maps import EnvMap, check_sample_count
from envfit.base import ParameterError
from envfit.defaults import FIT_METHODS
from envfit.base import plan_memory
from envfit.maps import check_not_constant, fit_scale
from envfit.fit._criterion import (N_BOOTSTRAP, bootstrap_indices, constant_columns,
                                   evaluate_criterion)
from envfit.fit._search import (CHI2_1_95, DEFAULT_REFINE, S_GRID, SmoothnessSearch,
                                bootstrap_argmin_interval, run_searches)
from envfit.fit._table2 import sample_directions

__all__ = ["METHODS", "KERNELS", "DEFAULT_METHOD", "DEFAULT_N", "FitResult", "SampleFit",
           "fit_smoothness", "fit_smoothness_samples", "S_GRID", "DEFAULT_REFINE", "SCORE_NAMES",
           "holdout_pixels", "bootstrap_indices", "bootstrap_argmin_interval", "plan_fit_memory"]

METHODS = FIT_METHODS                      # envfit.defaults
#: ``full``: K_gd (Eq. 14), samples by bilinear lookup; ``bandlimited``: K_gd truncated at the
#: map's Nyquist degree H − 1, samples at pixel centres (:mod:`envfit.sobolev._bandlimited`)
KERNELS = ("full", "bandlimited")
DEFAULT_METHOD = "likelihood"
DEFAULT_N = 3000
SCORE_NAMES = {"likelihood": "negative profiled log-likelihood per sample",
               "loo": "RMS leave-one-out residual", "holdout": "RMSE at held-out pixels"}


@dataclass
class FitResult:
    """The fit of one map (:func:`fit_smoothness`, or one map of a library)."""
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
        """JSON-ready fields (the interval as a list)."""
        d = asdict(self)
        d["s_interval"] = list(self.s_interval)
        return d

    def _repr_html_(self) -> str:
        """Jupyter: ŝ, its interval, σ̂ and how they were fitted (:func:`html_result`)."""
        band = "" if self.band_lmax is None else f", band-limited at l <= {self.band_lmax}"
        return html_result(f"FitResult: s = {self.s:.4g} ({self.method}, N = {self.n})", [
            ("s", self.s), ("95 % interval", self.s_interval), ("sigma per channel", self.sigma),
            ("scale", self.scale_description or self.scale), ("kernel", self.kernel + band),
            ("seconds", self.seconds), *(("note", n) for n in self.notes)])


@dataclass
class SampleFit:
    """The fit of scattered samples (:func:`fit_smoothness_samples`)."""
    s: float
    s_interval: tuple[float, float]
    #: σ̂ per channel at ŝ (0 for a constant channel)
    sigma: list[float]
    #: every evaluation of the criterion, ``{"s", "score"}`` in increasing s
    curve: list[dict] = field(default_factory=list)
    #: channels constant at the samples, left out of the likelihood (σ̂ = 0)
    constant_channels: list[int] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready fields (the interval as a list)."""
        d = asdict(self)
        d["s_interval"] = list(self.s_interval)
        return d


def _check_method(method: str, band_lmax) -> None:
    if method not in METHODS:
        raise ParameterError(f"unknown fit method {method!r}; choose one of {', '.join(METHODS)}")
    if band_lmax is not None and method != "likelihood":
        raise ParameterError("the band-limited kernel is available for the likelihood method only")


def _varying_values(values) -> tuple[np.ndarray, np.ndarray]:
    """(values as N×C float64, the constant columns); all constant: ParameterError (σ̂ = 0,
    the likelihood is infinite at every s: there is nothing to fit)."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        values = values[:, None]
    constant = constant_columns(values)
    if np.all(constant):
        raise ParameterError(f"the {len(values)} sample values are constant"
                             f"{' in every channel' if values.shape[1] > 1 else ''}: "
                             "there is nothing to fit")
    return values, constant


def fit_smoothness_samples(points: np.ndarray, values: np.ndarray, *, method: str = DEFAULT_METHOD,
                           holdout_dirs=None, holdout_values=None, s_grid=S_GRID,
                           refine: int = DEFAULT_REFINE, seed: int = 0,
                           n_bootstrap: int = N_BOOTSTRAP, band_lmax: int | None = None,
                           callback: Callable[[float], None] | None = None) -> SampleFit:
    """Fit s from scattered samples ``values`` (N or N×C) at unit vectors ``points`` (N×3).

    The lattice search of :mod:`envfit.fit._search` (``s_grid``, uniform, refined ``refine``
    times) over :func:`envfit.fit._criterion.evaluate_criterion`, then σ̂ at ŝ by one more
    factorisation. A channel constant at the samples is left out of the likelihood (σ̂ = 0,
    listed in ``constant_channels``); constant values in every channel raise
    :class:`~envfit.base._errors.ParameterError` (there is nothing to fit). Used by
    :func:`fit_smoothness`; also usable directly on sampled data (e.g. exact
    Gaussian-process samples in the tests). ``band_lmax`` (likelihood only): use the kernel
    band-limited at that degree (:mod:`envfit.sobolev._bandlimited`) instead of K_gd.
    ``callback(s)`` after each evaluation.
    """
    _check_method(method, band_lmax)
    values, constant = _varying_values(values)
    holdout = None
    if method == "holdout":
        if holdout_dirs is None or holdout_values is None:
            raise ParameterError("holdout needs held-out directions and values")
        holdout = [(holdout_dirs, np.asarray(holdout_values, dtype=np.float64)
                    .reshape(len(holdout_dirs), -1))]

    def evaluate(s: float, bootstrap: bool = False, criterion: str = method) -> dict:
        cell = evaluate_criterion(criterion, points, values, s, holdout=holdout,
                                  bootstrap=bootstrap, seed=seed, n_bootstrap=n_bootstrap,
                                  band_lmax=band_lmax)[0]
        if callback:
            callback(s)
        return cell

    search = SmoothnessSearch(method, len(points), s_grid, refine)
    res = run_searches([search], lambda wanted: [
        search.add(s, evaluate(s, search.needs_bootstrap(s))) for s in wanted[0]])[0]
    # σ̂ exactly at ŝ: one more factorisation (a library reads it off its lattice spline)
    if method == "likelihood":
        search.add(res.s, evaluate(res.s))
        sigma = search.ev[res.s]["sigma"]
    else:
        sigma = evaluate(res.s, criterion="likelihood")["sigma"]
    return SampleFit(s=res.s, s_interval=res.s_interval, sigma=[float(x) for x in sigma],
                     curve=search.curve(),
                     constant_channels=[int(c) for c in np.flatnonzero(constant)]
                     if method == "likelihood" else [])


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
    """The fit's memory guard (:func:`envfit.base._resources.plan_memory`), before any sample is
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
                   n_holdout: int = 20000, s_grid=S_GRID, refine: int = DEFAULT_REFINE,
                   kernel: str = "full", quiet: bool = True) -> FitResult:
    """Fit the Sobolev smoothness s of ``envmap`` (see the module docstring).

    The map is put on ``scale`` first (as in Table 2), then sampled at ``n`` directions
    (``pointset``; spherical Fibonacci by default). ``holdout`` compares the reconstruction
    with ``n_holdout`` random pixel centres (seeded). ``s_grid``, ``refine``: the search's
    coarse grid and lattice (:mod:`envfit.fit._search`).

    ``kernel="bandlimited"`` (likelihood only): the kernel truncated at the map's Nyquist
    degree H − 1 and the samples moved to their nearest pixel centres (repeats dropped), the
    exact model of a band-limited Gaussian-process map (:mod:`envfit.sobolev._bandlimited`; it
    removes the upward bias of ŝ that the full kernel and bilinear lookups give).

    Checked before anything of size ``n`` is made: ``n`` an integer ≥ 10, the memory guard
    (:func:`plan_fit_memory`; :class:`~envfit.base._errors.MemoryBudgetError` naming the largest n
    that fits), ``n`` at most the map's pixel count (full kernel; an error, see
    :func:`~envfit.maps._envmap.check_sample_count`), and a map constant on ``scale`` (e.g. all
    zero) is refused (:func:`~envfit.maps._scales.check_not_constant`). A channel that is constant
    while others vary is left out of the likelihood (σ̂ = 0 for it, noted).
    """
    t0 = time.perf_counter()
    _check_method(method, None)
    if kernel not in KERNELS:
        raise ParameterError(f"unknown kernel {kernel!r}; choose one of {', '.join(KERNELS)}")
    _check_method(method, 0 if kernel == "bandlimited" else None)
    n = check_int(n, "the number of samples n", 10)
    notes: list[str] = []
    band_lmax = map_band_limit(envmap) if kernel == "bandlimited" else None
    if band_lmax is not None:
        n = _band_limited_n(envmap, n, band_lmax, notes)
    # before anything of size n: the memory guard, then n against the pixel count (the
    # band-limited cap above is stricter than the pixel count)
    plan_fit_memory(n, envmap.width, envmap.height, envmap.channels, method=method,
                    n_holdout=n_holdout)
    check_sample_count(n, envmap.width, envmap.height, name=envmap.name, what="n")
    sc = fit_scale(scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, scale, envmap.name)
    points, values = _map_samples(scaled, n, pointset, seed, band_lmax, notes)
    hd = hv = None
    if method == "holdout":
        hd, hv = holdout_pixels(scaled, n_holdout, seed=seed)
        notes.append(f"holdout: {len(hd)} pixel centres drawn with probability proportional to solid angle")
    from envfit.base import progress_bar
    bar = progress_bar(len(s_grid) + 12, desc=f"fit ({method})", quiet=quiet, unit="s")
    try:
        res = fit_smoothness_samples(points, values, method=method, holdout_dirs=hd,
                                     holdout_values=hv, s_grid=s_grid, refine=refine, seed=seed,
                                     band_lmax=band_lmax, callback=lambda s: bar.update(1))
    finally:
        bar.close()
    notes.extend(fit_notes(res.s_interval, res.constant_channels, scale))
    return FitResult(s=res.s, s_interval=res.s_interval, sigma=res.sigma, method=method,
                     scale=scale, scale_description=sc.describe(), n=len(points),
                     curve=res.curve, score_name=SCORE_NAMES[method],
                     seconds=time.perf_counter() - t0, notes=notes, kernel=kernel,
                     band_lmax=band_lmax)


def _band_limited_n(envmap: EnvMap, n: int, band_lmax: int, notes: list[str]) -> int:
    """``n`` capped at the band-limited fit's largest sample count (noted)."""
    cap = max_samples(band_lmax)
    if cap < 10:
        raise ParameterError(f"a {envmap.height}-row map is too small for the band-limited fit "
                             "(it needs at least 5 rows: 10 samples, half the H² degrees of "
                             "freedom)")
    if n > cap:
        notes.append(f"n = {n} capped at {cap}: a {envmap.height}-row map holds "
                     f"{envmap.height ** 2} degrees of freedom, and the band-limited fit "
                     "takes at most half of them")
        return cap
    return n


def _map_samples(scaled: EnvMap, n: int, pointset: str, seed: int, band_lmax: int | None,
                 notes: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(points, values) of the map on its scale: bilinear lookups at the ``n`` directions, or
    for the band-limited kernel the directions' pixel centres (repeats dropped, noted)."""
    points = sample_directions(n, pointset=pointset, seed=seed, up=scaled.up)
    if band_lmax is None:
        return points, scaled.lookup(points).reshape(n, scaled.channels)
    points, values = pixel_centre_samples(scaled, points)
    notes.append(f"band-limited kernel (L = {band_lmax}); {len(points)} samples at pixel "
                 f"centres ({n - len(points)} repeats dropped)")
    return points, values


def fit_notes(interval: tuple[float, float], constant_channels, scale: str) -> list[str]:
    """The notes a fit's outcome calls for: constant channels left out, an interval at the
    edge of (1, 2)."""
    notes = []
    if constant_channels:
        notes.append(f"channel(s) {', '.join(map(str, constant_channels))} constant on the "
                     f"{scale} scale at the samples: left out of the fit (sigma 0)")
    if interval[0] <= 1.0 + 1e-3 or interval[1] >= 2.0 - 1e-3:
        notes.append("the interval reaches the edge of (1, 2): the map may be rougher/smoother "
                     "than this kernel family can express")
    return notes

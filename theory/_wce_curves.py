r"""Generic tools for worst-case-error curves E(N): power-law slopes, log grids, inversion.

Used by the figure data of :mod:`envfit.theory._figures` (Fig. 4's slopes, Fig. 5's QMC
equivalents), but independent of any figure:

* :func:`fit_convergence_slope` — least-squares exponent k of :math:`E \approx e^b N^k`;
* :func:`log_grid` — distinct integers on a logarithmic grid of N;
* :func:`qmc_wce_curve` — E(N) of the QMC rule of Sec. 8 / Table 1 (spherical Fibonacci,
  equal weights, morphed for the weight function) on such a grid;
* :func:`invert_wce_curve` — the smallest N reaching each of many targets, from a tabulated
  curve; :func:`extrapolate_wce_curve` — beyond the grid, from the fitted power law.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from envfit.theory._weight_function import WeightFunction
from envfit.theory._errors import TheoryParameterError, check_smoothness
from envfit.theory._quadrature import worst_case_error
from envfit.theory._truncation import morphed_spherical_fibonacci
from envfit.theory._weights import equal_weights

__all__ = ["fit_convergence_slope", "log_grid", "qmc_wce_curve", "invert_wce_curve",
           "extrapolate_wce_curve"]

Progress = Callable[[str], None]

def _check_int(v, what: str, lo: int) -> int:
    try:
        k = int(v)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"{what} must be an integer, got {v!r}") from None
    if k != v or k < lo:
        raise TheoryParameterError(f"{what} must be an integer >= {lo}, got {v!r}")
    return k


def fit_convergence_slope(ns, wce, nmin: float = 64, nmax: float | None = None):
    r"""Least-squares slope of :math:`\log E` against :math:`\log N` over nmin ≤ N ≤ nmax.

    Returns ``(slope, intercept, (n_lo, n_hi))`` with :math:`E \approx e^{b} N^{k}`; if fewer
    than two N lie in the range, all N are used (the range actually used is returned).

    >>> ns = np.array([16, 64, 256, 1024]); e = 3.0 * ns ** -0.75
    >>> round(fit_convergence_slope(ns, e)[0], 12)
    -0.75
    """
    ns = np.asarray(ns, dtype=np.float64)
    e = np.asarray(wce, dtype=np.float64)
    if ns.shape != e.shape or ns.ndim != 1:
        raise TheoryParameterError("ns and wce must be 1-D arrays of the same length")
    hi = np.inf if nmax is None else float(nmax)
    m = (ns >= nmin) & (ns <= hi) & (e > 0) & np.isfinite(e)
    if m.sum() < 2:
        m = (e > 0) & np.isfinite(e)
    if m.sum() < 2:
        return float("nan"), float("nan"), (float("nan"), float("nan"))
    k, b = np.polyfit(np.log(ns[m]), np.log(e[m]), 1)
    return float(k), float(b), (float(ns[m].min()), float(ns[m].max()))


def log_grid(nmax: int, per_octave: int = 8, nmin: int = 1) -> np.ndarray:
    """Distinct integers round(nmin·2^(k/per_octave)) from nmin up to nmax (inclusive).

    >>> log_grid(16, 2).tolist()
    [1, 2, 3, 4, 6, 8, 11, 16]
    """
    nmin = _check_int(nmin, "nmin", 1)
    nmax = _check_int(nmax, "nmax", nmin)
    per_octave = _check_int(per_octave, "per_octave", 1)
    k = np.arange(int(math.ceil(per_octave * math.log2(nmax / nmin))) + 1)
    g = np.unique(np.round(nmin * 2.0 ** (k / per_octave)).astype(np.int64))
    g = g[g <= nmax]
    return g if g[-1] == nmax else np.append(g, nmax)


def qmc_wce_curve(weight: WeightFunction, s: float, nmax: int = 16384, *, per_octave: int = 8,
                  nmin: int = 1, progress: Progress | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""E(N) of spherical Fibonacci points morphed for ``weight``, equal weights, on a log grid.

    The QMC rule of Sec. 8 / Table 1 (:func:`envfit.theory._truncation.morphed_spherical_fibonacci`),
    at the N of :func:`log_grid`. Cost: the O(N²) closed form at every grid point, about
    :math:`N_{max}^2/(1 - 2^{-2/\mathrm{per\_octave}})` pairs in all (≈ 6.3 N_max² for 8
    per octave: ≈ 2 s for N_max = 8192 on 2 cores).
    """
    s = check_smoothness(s)
    ns = log_grid(nmax, per_octave, nmin)
    e = np.empty(ns.size)
    for i, n in enumerate(ns):
        if progress:
            progress(f"QMC curve {weight!r} N = {int(n)}")
        u = morphed_spherical_fibonacci(int(n), weight)
        e[i] = worst_case_error(u, equal_weights(int(n)), weight, s)
    return ns, e


def invert_wce_curve(ns, wce, targets) -> np.ndarray:
    r"""Smallest N with E(N) ≤ target, for many targets at once, from a tabulated curve.

    The curve is made non-increasing by its running minimum (so the first grid point
    below a target is the one that matters, as in a bisection on N); between the last grid
    point above the target and the first one at or below it, log N is interpolated
    linearly in log E, and the result rounded up. A target at or above E(ns[0]) gives
    ns[0]; a target below every tabulated E gives NaN (beyond the grid: see
    :func:`extrapolate_wce_curve`).

    >>> ns = np.array([1, 2, 4, 8]); e = 1.0 / ns
    >>> invert_wce_curve(ns, e, [2.0, 0.5, 0.3, 0.1]).tolist()
    [1.0, 2.0, 4.0, nan]
    """
    ns = np.asarray(ns, dtype=np.float64)
    e = np.asarray(wce, dtype=np.float64)
    t = np.atleast_1d(np.asarray(targets, dtype=np.float64))
    if ns.ndim != 1 or ns.shape != e.shape or ns.size < 1 or np.any(np.diff(ns) <= 0):
        raise TheoryParameterError("ns must be increasing and match wce in length")
    if np.any(~(e > 0)):
        raise TheoryParameterError("the tabulated errors must be positive")
    env = np.minimum.accumulate(e)
    # first index k with env[k] <= target: env is non-increasing, so search on -env
    k = np.searchsorted(-env, -t, side="left")
    out = np.full(t.shape, np.nan)
    first = k == 0
    out[first] = ns[0]
    mid = (k > 0) & (k < ns.size)
    km = k[mid]
    x0, x1 = np.log(ns[km - 1]), np.log(ns[km])
    y0, y1 = np.log(env[km - 1]), np.log(env[km])
    frac = (np.log(t[mid]) - y0) / (y1 - y0)
    out[mid] = np.minimum(np.ceil(np.exp(x0 + frac * (x1 - x0)) - 1e-9), ns[km])
    return out


def extrapolate_wce_curve(ns, wce, targets, octaves: float = 2.0, max_factor: float = 64.0):
    r"""N for targets below a tabulated curve, from the power law fitted to its top octaves.

    Fits :math:`\log E = b + k\log N` over :math:`N \ge N_{max}/2^{octaves}` and solves for
    N (rounded up). Returns ``(N, k)``; N is NaN for targets within the curve's range and
    beyond ``max_factor`` times the last tabulated N (no extrapolation over more than
    log2(max_factor) octaves).

    >>> ns = np.array([1, 2, 4, 8]); e = 1.0 / ns
    >>> n, k = extrapolate_wce_curve(ns, e, [0.5, 1 / 32, 1e-6])
    >>> n.tolist(), round(k, 12)
    ([nan, 32.0, nan], -1.0)
    """
    ns = np.asarray(ns, dtype=np.float64)
    e = np.asarray(wce, dtype=np.float64)
    t = np.atleast_1d(np.asarray(targets, dtype=np.float64))
    k, b, _ = fit_convergence_slope(ns, e, ns.max() / 2.0 ** octaves)
    out = np.full(t.shape, np.nan)
    below = t < np.minimum.accumulate(e)[-1]
    if below.any() and k < 0:
        out[below] = np.ceil(np.exp((np.log(t[below]) - b) / k) - 1e-9)
    out[out > max_factor * ns.max()] = np.nan
    return out, k


r"""The data behind Figs. 1–5 of the paper, and a BNOT check figure (arrays, no plotting, no I/O).

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 7–8.

* Figs. 1–3 (:func:`spectra_data`): for each point set of Sec. 7.1 (N = 256, one
  realization), weight function (diffuse, glossy n = 30) and weighting (equal 1/N, or the
  optimal sample weights, OSW), the zonal power :math:`d_l^2 = (b_l - c_{l,0})^2`
  (Eq. 43), the anisotropic power :math:`C_l^2 = 2\sum_{m\ge1}|c_{l,m}|^2` (Eqs. 44, 59)
  and the error spectrum :math:`e_l^2 = a_l(d_l^2 + C_l^2)` (Eq. 42 with the factor
  :math:`a_l` restored, docs/ERRATA.md). Fig. 2 (:func:`low_order_closeup`) is the first ten :math:`C_l^2`
  (l = 1…10; :math:`C_0^2 \equiv 0`) of the diffuse case.
* Fig. 4 (:func:`convergence_data`): the worst-case error (closed form Eq. 41) against N
  for powers of two, with least-squares slopes of log E against log N.
* Fig. 5 (:func:`truncation_figure_data`): the SH/HSH truncation errors E(L) (Eqs. 51–52)
  and the number of QMC points (spherical Fibonacci, equal weights, morphed) with the same
  worst-case error, obtained for all L at once by inverting a precomputed curve E(N) of
  the QMC rule on a fine logarithmic grid of N (:func:`invert_wce_curve`).
* BNOT check (:func:`bnot_figure_data`): radial power spectrum of BNOT against random
  points on the unit square, and the capacity constraint :math:`|V_i^w| = 1/N`.
* Claims (:func:`figure_claims`): each statement of the paper about these figures (or of
  the BNOT construction) as a :class:`Claim` — the numbers, an explicit test with its
  threshold, and the verdict — so that front ends only print them.

All quadrature points are *morphed* for the weight function by default (importance
sampling, Sec. 7.2: the square is lifted by the Lambert equal-area map and its height
coordinate passed through the inverse CDF of p, :meth:`envfit.theory.brdf.WeightFunction.morph`);
``morph=False`` lifts them uniformly instead. Points live in the local frame of the lobe
(axis +z); for the glossy lobe this is the mirror direction (Sec. 4.3).

Example
-------
>>> d = spectra_data(n=32, lmax=16, pointsets=("sf", "random"), brdfs=("diffuse",))
>>> r = d.get("diffuse", "equal", "sf")
>>> bool(np.allclose(r.e2, r.a * (r.d2 + r.C2)))
True
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterable

import numpy as np

from .bnot import BNOTDiagnostics, bnot_diagnostics, bnot_square, radial_power_spectrum
from .brdf import Diffuse, Glossy, WeightFunction
from .errors import TheoryParameterError, check_smoothness
from .pointsets import DETERMINISTIC_POINTSETS, POINTSETS, generate, random_square
from .quadrature import error_spectrum, worst_case_error
from .table1 import CASES, case_weight
from .truncation import morphed_spherical_fibonacci, truncation_error_curve
from .weights import equal_weights, optimal_weights

__all__ = ["POINTSET_ORDER", "POINTSET_LABELS", "BRDFS", "WEIGHTINGS", "PAPER_LMAX",
           "make_weight", "quadrature_rule", "SpectrumRecord", "SpectraData", "spectra_data",
           "LowOrderCloseup", "low_order_closeup", "fit_convergence_slope", "ConvergenceData",
           "convergence_data", "log_grid", "qmc_wce_curve", "invert_wce_curve",
           "extrapolate_wce_curve", "TruncationFigureData", "truncation_figure_data",
           "BNOTFigureData", "bnot_figure_data", "Claim", "anisotropic_dominance_claim",
           "osw_low_order_claim", "random_slope_claims", "structured_beat_random_claims",
           "caption_fig5a_claim", "bnot_capacity_claim", "bnot_blue_noise_claim", "figure_claims",
           "split_lmax", "SLOPE_TOLERANCE", "BEATS_RANDOM_NMIN", "CAPACITY_TOLERANCE",
           "BLUE_NOISE_FACTOR", "CAPTION_RTOL"]

#: the point sets of Sec. 7.1, in the paper's order
POINTSET_ORDER = ("sobol", "bnot", "lp", "sf", "random", "jitter")
POINTSET_LABELS = {"sobol": "Sobol", "bnot": "BNOT", "lp": "LP", "sf": "SF",
                   "random": "Random", "jitter": "SJ"}
BRDFS = ("diffuse", "glossy")
#: "equal": w_j = 1/N; "osw": optimal sample weights K^{-1} z (Sec. 7.1)
WEIGHTINGS = ("equal", "osw")
#: the highest SH degree of the paper's spectra
PAPER_LMAX = 170

Progress = Callable[[str], None]


def _check_names(names: Iterable[str], allowed, what: str) -> tuple[str, ...]:
    out = tuple(names)
    bad = [x for x in out if x not in allowed]
    if bad or not out:
        raise TheoryParameterError(f"{what} must be a non-empty subset of {list(allowed)}, got {list(out)}")
    return out


def _check_int(v, what: str, lo: int) -> int:
    try:
        k = int(v)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"{what} must be an integer, got {v!r}") from None
    if k != v or k < lo:
        raise TheoryParameterError(f"{what} must be an integer >= {lo}, got {v!r}")
    return k


def make_weight(brdf: str, shininess: float = 30.0) -> WeightFunction:
    """The weight function named ``brdf`` ("diffuse" or "glossy" with ``shininess``).

    >>> make_weight("glossy", 10)
    Glossy(shininess=10)
    """
    if brdf == "diffuse":
        return Diffuse()
    if brdf == "glossy":
        return Glossy(shininess)
    raise TheoryParameterError(f"brdf must be 'diffuse' or 'glossy', got {brdf!r}")


def quadrature_rule(pointset: str, n: int, weight: WeightFunction, s: float, weighting: str, *,
                    seed: int = 0, morph: bool = True) -> tuple[np.ndarray, np.ndarray]:
    r"""Points (N×3, local frame of the lobe) and weights of one quadrature rule of Sec. 7.

    The square points of ``pointset`` are lifted by the Lambert map and, if ``morph``, their
    heights importance-sampled for ``weight`` (Sec. 7.2). ``weighting`` "equal" gives
    :math:`w_j = 1/N`, "osw" the optimal weights :math:`K^{-1}z` (Eq. 41 minimised).

    >>> u, w = quadrature_rule("sf", 8, Diffuse(), 1.5, "equal")
    >>> u.shape, float(w.sum())
    ((8, 3), 1.0)
    """
    if pointset not in POINTSETS:
        raise TheoryParameterError(f"unknown point set {pointset!r}; choose one of {sorted(POINTSETS)}")
    pts = generate(pointset, n, seed=seed, morph=weight.morph if morph else None)
    if weighting == "equal":
        return pts, equal_weights(pts.shape[0])
    if weighting == "osw":
        return pts, optimal_weights(pts, weight, s)
    raise TheoryParameterError(f"weights must be 'equal' or 'osw', got {weighting!r}")


# ----------------------------------------------------------------------------- Figs. 1–3
@dataclass(frozen=True)
class SpectrumRecord:
    r"""Spectra of one quadrature rule, l = 0…lmax (Eqs. 42–47).

    ``d2`` = :math:`d_l^2`, ``C2`` = :math:`C_l^2` (≥ 0, :math:`C_0^2 = 0`), ``a`` =
    :math:`a_l`, ``e2`` = :math:`a_l(d_l^2 + C_l^2)`; ``wce`` is the closed form Eq. 41,
    ``wce_zonal``/``wce_anisotropic`` the sums of Eqs. 46–47 to lmax, and ``tail`` =
    :math:`E^2 - \sum_{l\le lmax} e_l^2` (what the truncated spectral sum misses).
    """

    brdf: str
    pointset: str
    weights: str
    n: int
    seed: int
    morphed: bool
    l: np.ndarray
    a: np.ndarray
    d2: np.ndarray
    C2: np.ndarray
    e2: np.ndarray
    wce: float
    wce_zonal: float
    wce_anisotropic: float
    tail: float


@dataclass(frozen=True)
class SpectraData:
    """Spectra of every (brdf, weights, pointset) rule at one N: the data of Figs. 1–3."""

    n: int
    s: float
    shininess: float
    lmax: int
    seed: int
    morphed: bool
    pointsets: tuple[str, ...]
    brdfs: tuple[str, ...]
    weightings: tuple[str, ...]
    records: dict = field(repr=False)

    def get(self, brdf: str, weights: str, pointset: str) -> SpectrumRecord:
        return self.records[(brdf, weights, pointset)]


def spectra_data(n: int = 256, s: float = 1.5, shininess: float = 30.0, lmax: int = PAPER_LMAX, *,
                 seed: int = 0, pointsets: Iterable[str] = POINTSET_ORDER,
                 brdfs: Iterable[str] = BRDFS, weightings: Iterable[str] = WEIGHTINGS,
                 morph: bool = True, progress: Progress | None = None) -> SpectraData:
    r"""Power and error spectra of the quadrature rules of Sec. 7 (Figs. 1–3).

    One realization per stochastic point set (``seed``), as in the paper. Uses
    :func:`envfit.theory.quadrature.error_spectrum` (ducc0 adjoint SH synthesis for
    :math:`c_{l,m}`, the Legendre recurrence for :math:`c_{l,0}`, the closed form Eq. 41
    for E). Cost at N = 256, lmax = 170: ≈ 0.05 s per rule plus the BNOT set (≈ 3 s).
    """
    s = check_smoothness(s)
    n = _check_int(n, "n", 1)
    lmax = _check_int(lmax, "lmax", 1)
    pointsets = _check_names(pointsets, POINTSET_ORDER, "pointsets")
    brdfs = _check_names(brdfs, BRDFS, "brdfs")
    weightings = _check_names(weightings, WEIGHTINGS, "weightings")
    records = {}
    for brdf in brdfs:
        wf = make_weight(brdf, shininess)
        for ps in pointsets:
            for wt in weightings:
                if progress:
                    progress(f"spectrum {brdf} {ps} {wt}")
                u, w = quadrature_rule(ps, n, wf, s, wt, seed=seed, morph=morph)
                sp = error_spectrum(u, w, wf, s, lmax)
                records[(brdf, wt, ps)] = SpectrumRecord(
                    brdf=brdf, pointset=ps, weights=wt, n=n, seed=seed, morphed=bool(morph),
                    l=sp.l, a=sp.a, d2=sp.d2, C2=sp.C2, e2=sp.e2, wce=sp.wce,
                    wce_zonal=sp.wce_zonal, wce_anisotropic=sp.wce_anisotropic, tail=sp.tail)
    return SpectraData(n=n, s=s, shininess=float(shininess), lmax=lmax, seed=seed,
                       morphed=bool(morph), pointsets=pointsets, brdfs=brdfs,
                       weightings=weightings, records=records)


@dataclass(frozen=True)
class LowOrderCloseup:
    """Fig. 2: the first ``count`` anisotropic powers, l = 1…count, equal vs OSW weights.

    ``C2_equal[ps]``, ``C2_osw[ps]`` : (count,) arrays; ``reduction[ps]`` =
    Σ C²(OSW) / Σ C²(equal) over these degrees.
    """

    brdf: str
    l: np.ndarray
    C2_equal: dict
    C2_osw: dict
    reduction: dict


def low_order_closeup(data: SpectraData, brdf: str = "diffuse", count: int = 10) -> LowOrderCloseup:
    r"""The first ``count`` :math:`C_l^2`, l = 1…count (:math:`C_0^2 \equiv 0`), of Figs. 1(b)–(c).

    >>> d = spectra_data(n=32, lmax=16, pointsets=("random",), brdfs=("diffuse",))
    >>> c = low_order_closeup(d, count=5)
    >>> c.l.tolist(), bool(c.reduction["random"] < 1)
    ([1, 2, 3, 4, 5], True)
    """
    count = _check_int(count, "count", 1)
    if count > data.lmax:
        raise TheoryParameterError(f"count = {count} exceeds the spectra's lmax = {data.lmax}")
    if "equal" not in data.weightings or "osw" not in data.weightings:
        raise TheoryParameterError("the close-up needs both equal and OSW spectra")
    sl = slice(1, count + 1)
    eq = {ps: data.get(brdf, "equal", ps).C2[sl].copy() for ps in data.pointsets}
    op = {ps: data.get(brdf, "osw", ps).C2[sl].copy() for ps in data.pointsets}
    red = {ps: float(op[ps].sum() / eq[ps].sum()) if eq[ps].sum() > 0 else float("nan")
           for ps in data.pointsets}
    return LowOrderCloseup(brdf=brdf, l=np.arange(1, count + 1), C2_equal=eq, C2_osw=op,
                           reduction=red)


# ----------------------------------------------------------------------------- Fig. 4
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


@dataclass(frozen=True)
class ConvergenceData:
    r"""Fig. 4: worst-case error against N.

    ``wce[(brdf, weights, pointset)]`` is an array over ``ns``; for stochastic point sets
    with ``realizations`` > 1 it is the root mean square over seeds seed, seed + 1, ….
    ``slopes`` holds the fitted exponents over ``fit_range``.
    """

    ns: np.ndarray
    s: float
    shininess: float
    seed: int
    morphed: bool
    realizations: int
    fit_range: tuple[float, float]
    pointsets: tuple[str, ...]
    brdfs: tuple[str, ...]
    weightings: tuple[str, ...]
    wce: dict = field(repr=False)
    slopes: dict = field(repr=False)

    def beats_random(self, brdf: str, weights: str = "equal", nmin: int = 256) -> dict:
        r"""For each structured set: ``{"all": bool, "ratio_max": float}`` — whether its E is
        below the random set's at every N ≥ nmin, and the largest ratio E/E_random there."""
        if "random" not in self.pointsets:
            raise TheoryParameterError("the comparison needs the random point set")
        m = self.ns >= nmin
        if not m.any():
            raise TheoryParameterError(f"no N >= {nmin} in the data (largest N = {int(self.ns.max())})")
        ref = self.wce[(brdf, weights, "random")][m]
        out = {}
        for ps in self.pointsets:
            if ps == "random":
                continue
            r = self.wce[(brdf, weights, ps)][m] / ref
            out[ps] = {"all": bool(np.all(r < 1.0)), "ratio_max": float(r.max())}
        return out


def convergence_data(nmax: int = 2048, s: float = 1.5, shininess: float = 30.0, *,
                     nmin: int = 16, seed: int = 0, pointsets: Iterable[str] = POINTSET_ORDER,
                     brdfs: Iterable[str] = BRDFS, weightings: Iterable[str] = WEIGHTINGS,
                     morph: bool = True, realizations: int = 1, fit_nmin: int = 64,
                     progress: Progress | None = None) -> ConvergenceData:
    r"""Worst-case error (Eq. 41) for N = nmin, 2·nmin, …, ≤ nmax (powers of two) (Fig. 4).

    The paper's Fig. 4 uses one realization per point set and N up to 2048 (its Random
    curves are shifted by a factor 0.5 / 0.45 for readability; these are the raw values).
    Slopes: :func:`fit_convergence_slope` over ``fit_nmin`` ≤ N ≤ nmax. With seed 0 and
    one realization, random points converge like :math:`N^{-0.56}` (equal weights) and
    :math:`N^{-0.76}` (OSW) in both cases, the structured sets like :math:`N^{-0.72}` to
    :math:`N^{-0.83}` (the optimal rate for s = 1.5 is :math:`N^{-s/2} = N^{-0.75}`).
    Cost: O(N²) per rule, plus an N³/3 Cholesky for OSW and the BNOT sets (≈ 30 s for all
    powers of two to 2048, cached per (N, seed) in the process).
    """
    s = check_smoothness(s)
    nmin = _check_int(nmin, "nmin", 1)
    nmax = _check_int(nmax, "nmax", nmin)
    realizations = _check_int(realizations, "realizations", 1)
    pointsets = _check_names(pointsets, POINTSET_ORDER, "pointsets")
    brdfs = _check_names(brdfs, BRDFS, "brdfs")
    weightings = _check_names(weightings, WEIGHTINGS, "weightings")
    ns = nmin * 2 ** np.arange(int(math.floor(math.log2(nmax / nmin))) + 1)
    wce, slopes = {}, {}
    fit = (float("nan"), float("nan"))
    for brdf in brdfs:
        wf = make_weight(brdf, shininess)
        for ps in pointsets:
            reps = 1 if ps in DETERMINISTIC_POINTSETS else realizations
            for wt in weightings:
                if progress:
                    progress(f"wce {brdf} {ps} {wt}")
                e2 = np.zeros(ns.size)
                for r in range(reps):
                    for i, n in enumerate(ns):
                        u, w = quadrature_rule(ps, int(n), wf, s, wt, seed=seed + r, morph=morph)
                        e2[i] += worst_case_error(u, w, wf, s) ** 2
                e = np.sqrt(e2 / reps)
                wce[(brdf, wt, ps)] = e
                k, _, fit = fit_convergence_slope(ns, e, fit_nmin, nmax)
                slopes[(brdf, wt, ps)] = k
    return ConvergenceData(ns=ns, s=s, shininess=float(shininess), seed=seed, morphed=bool(morph),
                           realizations=realizations, fit_range=fit, pointsets=pointsets,
                           brdfs=brdfs, weightings=weightings, wce=wce, slopes=slopes)


# ----------------------------------------------------------------------------- Fig. 5
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

    The QMC rule of Sec. 8 / Table 1 (:func:`envfit.theory.truncation.morphed_spherical_fibonacci`),
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


@dataclass(frozen=True)
class TruncationFigureData:
    r"""Fig. 5: E(L), L = 0…Lmax, for "diffuse-sh", "glossy-sh", "glossy-hsh", and the
    equivalent numbers of QMC points.

    ``qmc_points[case]`` : float array (NaN beyond the tabulated QMC curve);
    ``qmc_points_extrapolated[case]`` : the power-law extrapolation for those L, up to 64
    times the tabulated range (NaN elsewhere); ``qmc_curve[brdf]`` = (ns, E(N)) of morphed
    SF points with equal weights;
    ``qmc_slope[brdf]`` the exponent used to extrapolate.
    """

    s: float
    shininess: float
    L: np.ndarray
    wce: dict
    qmc_points: dict
    qmc_points_extrapolated: dict
    qmc_curve: dict
    qmc_slope: dict
    morphed: bool = True


def truncation_figure_data(s: float = 1.5, shininess: float = 30.0, Lmax: int = 20, *,
                           qmc_nmax: int = 16384, per_octave: int = 8,
                           progress: Progress | None = None) -> TruncationFigureData:
    r"""The data of Fig. 5: truncation errors and QMC equivalents for every L.

    E(L) from :func:`envfit.theory.truncation.truncation_error_curve` (Eq. 52 summed from L + 1,
    HSH through Eq. 31); QMC equivalents by :func:`invert_wce_curve` on
    :func:`qmc_wce_curve` (one curve per weight function, shared by glossy SH and HSH).
    """
    s = check_smoothness(s)
    Lmax = _check_int(Lmax, "Lmax", 1)
    curves, slopes = {}, {}
    wce, qn, qx = {}, {}, {}
    for case, brdf, basis in CASES:
        wf, _ = case_weight(case, shininess)
        if brdf not in curves:
            curves[brdf] = qmc_wce_curve(wf, s, qmc_nmax, per_octave=per_octave, progress=progress)
        E = truncation_error_curve(wf, s, Lmax, basis)
        ns, eq = curves[brdf]
        wce[case] = E
        with np.errstate(divide="ignore"):
            qn[case] = invert_wce_curve(ns, eq, np.maximum(E, np.finfo(float).tiny))
            qx[case], slopes[brdf] = extrapolate_wce_curve(ns, eq, np.maximum(E, np.finfo(float).tiny))
    return TruncationFigureData(s=s, shininess=float(shininess), L=np.arange(Lmax + 1), wce=wce,
                                qmc_points=qn, qmc_points_extrapolated=qx, qmc_curve=curves,
                                qmc_slope=slopes)


# ----------------------------------------------------------------------------- BNOT check
@dataclass(frozen=True)
class BNOTFigureData:
    r"""BNOT vs random points on the unit square (torus).

    ``radius``, ``power_bnot``, ``power_random`` : radially averaged periodograms
    (:func:`envfit.theory.bnot.radial_power_spectrum`; E P = 1 for random points);
    ``low_band`` : |k| below which the mean power is compared (:math:`\sqrt N/2`);
    ``low_power_bnot``/``low_power_random`` : those means;
    ``diagnostics_bnot``/``diagnostics_random`` : capacity weights and cell areas
    (:func:`envfit.theory.bnot.bnot_diagnostics`), centroid residual, minimum distance.
    """

    n: int
    seed: int
    bnot_points: np.ndarray
    random_points: np.ndarray
    radius: np.ndarray
    power_bnot: np.ndarray
    power_random: np.ndarray
    low_band: float
    low_power_bnot: float
    low_power_random: float
    diagnostics_bnot: BNOTDiagnostics
    diagnostics_random: BNOTDiagnostics


def bnot_figure_data(n: int = 256, seed: int = 0, kmax: int | None = None) -> BNOTFigureData:
    r"""Radial power spectra of BNOT and random points and the capacity check.

    Blue noise: the power is ≪ 1 at low frequencies (|k| below ≈ √N) where random points
    have P ≈ 1. Capacity: the power cells of the BNOT sites with their capacity weights
    have area 1/N (to the solver's 1e-10; printed as the max relative area error), and the
    sites are (near) the centroids of their cells, unlike random sites.

    >>> d = bnot_figure_data(64, seed=1)
    >>> bool(d.low_power_bnot < 0.5 * d.low_power_random)
    True
    """
    n = _check_int(n, "n", 2)
    b = bnot_square(n, seed=seed)
    r = random_square(n, seed=seed)
    kmax = int(np.ceil(3.0 * np.sqrt(n))) if kmax is None else _check_int(kmax, "kmax", 1)
    rb, pb = radial_power_spectrum(b, kmax=kmax)
    rr, pr = radial_power_spectrum(r, kmax=kmax)
    if rb.shape != rr.shape or not np.allclose(rb, rr):    # same annuli, same lattice
        raise RuntimeError("radial bins differ between the two point sets")  # pragma: no cover
    band = 0.5 * math.sqrt(n)
    m = rb < band
    if not m.any():
        m = rb <= rb.min()
    return BNOTFigureData(n=n, seed=seed, bnot_points=b, random_points=r, radius=rb,
                          power_bnot=pb, power_random=pr, low_band=band,
                          low_power_bnot=float(pb[m].mean()), low_power_random=float(pr[m].mean()),
                          diagnostics_bnot=bnot_diagnostics(b), diagnostics_random=bnot_diagnostics(r))


# ----------------------------------------------------------------------------- claims
#: tolerance on a fitted convergence exponent (Fig. 4 claims): |k - k_paper| <= 0.1
SLOPE_TOLERANCE = 0.1
#: the smallest N of the "structured sets beat random" comparison (Fig. 4)
BEATS_RANDOM_NMIN = 256
#: a BNOT set meets its capacity constraint when every cell area is 1/N to this relative error
CAPACITY_TOLERANCE = 1e-4
#: blue noise: the mean low-band power of BNOT must be below this fraction of random's
BLUE_NOISE_FACTOR = 0.5
#: relative tolerance of the comparison with the Fig. 5(a) caption's E(3) = 4.4e-3
CAPTION_RTOL = 0.1


@dataclass(frozen=True)
class Claim:
    r"""One claim of the paper about Figs. 1–5, checked against computed numbers.

    Attributes
    ----------
    id : str
        Stable identifier, ``"<figure>.<what>[.<brdf>]"``, e.g. ``"fig4.random-slope-osw.diffuse"``.
    text : str
        The claim in words, with where the paper makes it.
    values : dict
        The numbers the verdict is computed from.
    test : str
        The explicit test applied to ``values``, e.g. ``"|slope + 0.75| <= 0.1"``.
    threshold : float
        The number that test compares with.
    holds : bool
        The verdict: whether the test passes.
    """

    id: str
    text: str
    values: dict
    test: str
    threshold: float
    holds: bool


def anisotropic_dominance_claim(data: SpectraData, brdf: str = "diffuse",
                                weights: str = "equal") -> Claim:
    r"""Sec. 5.2 / Fig. 1: the worst-case error of QMC rules is dominated by its anisotropic part.

    Test: :math:`E_Z / E_A < 1` (both summed to the spectra's lmax) for every point set;
    an :math:`E_A = 0` gives NaN, which fails.

    >>> d = spectra_data(n=32, lmax=16, pointsets=("sf",), brdfs=("diffuse",), weightings=("equal",))
    >>> anisotropic_dominance_claim(d).holds
    True
    """
    ratio = {}
    for ps in data.pointsets:
        r = data.get(brdf, weights, ps)
        ratio[ps] = r.wce_zonal / r.wce_anisotropic if r.wce_anisotropic > 0 else float("nan")
    return Claim(id=f"fig1.anisotropic-dominates.{brdf}",
                 text=f"Sec. 5.2, Fig. 1: the anisotropic part E_A dominates E ({brdf}, {weights} weights)",
                 values={"zonal_over_anisotropic": ratio, "lmax": data.lmax, "weights": weights},
                 test="E_Z / E_A < 1 for every point set", threshold=1.0,
                 holds=all(v < 1.0 for v in ratio.values()))


def osw_low_order_claim(closeup: LowOrderCloseup) -> Claim:
    r"""Fig. 2: the optimal sample weights reduce the low-order anisotropic power.

    Test: :math:`\sum_l C_l^2(\mathrm{OSW}) / \sum_l C_l^2(\mathrm{equal}) < 1` over the
    close-up's degrees, for every point set (:attr:`LowOrderCloseup.reduction`).

    >>> d = spectra_data(n=32, lmax=16, pointsets=("random",), brdfs=("diffuse",))
    >>> osw_low_order_claim(low_order_closeup(d, count=5)).holds
    True
    """
    eq = {ps: float(v.sum()) for ps, v in closeup.C2_equal.items()}
    op = {ps: float(v.sum()) for ps, v in closeup.C2_osw.items()}
    lo, hi = int(closeup.l[0]), int(closeup.l[-1])
    return Claim(id=f"fig2.osw-reduce-low-order.{closeup.brdf}",
                 text=f"Fig. 2: OSW reduce the anisotropic power C_l^2, l = {lo}..{hi} ({closeup.brdf})",
                 values={"sum_equal": eq, "sum_osw": op, "ratio": dict(closeup.reduction)},
                 test=f"sum_(l={lo}..{hi}) C_l^2 (OSW) / same (equal) < 1 for every point set",
                 threshold=1.0, holds=all(v < 1.0 for v in closeup.reduction.values()))


def random_slope_claims(data: ConvergenceData, tol: float = SLOPE_TOLERANCE) -> list[Claim]:
    r"""Sec. 7.2: random points converge like :math:`N^{-0.5}` with equal weights and like
    :math:`N^{-0.75}` with OSW — one claim per (weighting, brdf) present.

    Test: :math:`|k - k_\mathrm{paper}| \le` ``tol`` for the fitted slope k
    (:attr:`ConvergenceData.slopes`, fitted over :attr:`ConvergenceData.fit_range`).

    >>> c = convergence_data(64, pointsets=("random",), brdfs=("diffuse",), weightings=("equal",))
    >>> [(x.id, x.threshold) for x in random_slope_claims(c)]
    [('fig4.random-slope-equal.diffuse', 0.1)]
    """
    if "random" not in data.pointsets:
        return []
    expected = {"equal": -0.5, "osw": -0.75}
    out = []
    for wt in data.weightings:
        for b in data.brdfs:
            k, k0 = data.slopes[(b, wt, "random")], expected[wt]
            out.append(Claim(
                id=f"fig4.random-slope-{wt}.{b}",
                text=f"Sec. 7.2: random points with {wt} weights converge like N^{k0:g} ({b})",
                values={"slope": k, "expected": k0, "fit_range": tuple(data.fit_range)},
                test=f"|slope - ({k0:g})| <= {tol:g}", threshold=float(tol),
                holds=bool(abs(k - k0) <= tol)))
    return out


def structured_beat_random_claims(data: ConvergenceData,
                                  nmin: int = BEATS_RANDOM_NMIN) -> list[Claim]:
    r"""Fig. 4: with equal weights every structured set beats random points for N ≥ ``nmin``.

    One claim per brdf; ``values["per_pointset"][ps]`` is
    :meth:`ConvergenceData.beats_random` (``{"all", "ratio_max"}``). Test: E(set)/E(random)
    < 1 at every N ≥ nmin for every structured set. Empty when the data have no N ≥ nmin,
    no random set or no equal weights.
    """
    if data.ns.max() < nmin or "random" not in data.pointsets or "equal" not in data.weightings:
        return []
    out = []
    for b in data.brdfs:
        per = data.beats_random(b, "equal", nmin)
        out.append(Claim(
            id=f"fig4.structured-beat-random.{b}",
            text=f"Fig. 4: structured sets beat random at equal weights for every N >= {nmin} ({b})",
            values={"nmin": int(nmin), "per_pointset": per},
            test=f"E(set) / E(random) < 1 at every N >= {nmin}, for every structured set",
            threshold=1.0, holds=all(v["all"] for v in per.values())))
    return out


def caption_fig5a_claim(data: TruncationFigureData, rtol: float = CAPTION_RTOL) -> Claim | None:
    r"""Fig. 5(a) caption: diffuse SH truncated at L = 3 has E ≈ 4.4e-3 (≈ 930 QMC points).

    Test: :math:`|E(3)/4.4\times10^{-3} - 1| \le` ``rtol``. It fails with the paper's own
    formulas: :math:`b_3 = 0` for the diffuse lobe, so E(3) = E(2) (docs/ERRATA.md).
    None when the data stop before L = 3.

    >>> c = caption_fig5a_claim(truncation_figure_data(Lmax=4, qmc_nmax=64))
    >>> c.holds, c.values["b3_zero"]
    (False, True)
    """
    from .table1 import PAPER_FIG5A_CAPTION as cap
    E = data.wce[cap["case"]]
    L = int(cap["L"])
    if E.size <= L:
        return None
    q = data.qmc_points[cap["case"]][L]
    return Claim(id="fig5a.caption-E3",
                 text=f"Fig. 5(a) caption: L = {L} -> E = {cap['wce']:g}, ≈ {cap['qmc_points']} points",
                 values={"paper_wce": cap["wce"], "paper_qmc_points": cap["qmc_points"],
                         "wce_L3": float(E[L]), "wce_L2": float(E[L - 1]),
                         "b3_zero": bool(E[L] == E[L - 1]),
                         "qmc_points_L3": int(q) if math.isfinite(q) else None},
                 test=f"|E(3) / {cap['wce']:g} - 1| <= {rtol:g}", threshold=float(rtol),
                 holds=bool(abs(E[L] / cap["wce"] - 1.0) <= rtol))


def bnot_capacity_claim(data: BNOTFigureData, tol: float = CAPACITY_TOLERANCE) -> Claim:
    r"""BNOT (de Goes et al.): every power cell has the capacity 1/N.

    Test: max relative cell-area error ≤ ``tol``.

    >>> bnot_capacity_claim(bnot_figure_data(32)).holds
    True
    """
    err = data.diagnostics_bnot.max_relative_area_error
    return Claim(id="bnot.capacity", text="BNOT: every cell has area 1/N (capacity constraint)",
                 values={"max_relative_area_error": err, "n": data.n},
                 test=f"max_i |N |V_i| - 1| <= {tol:g}", threshold=float(tol),
                 holds=bool(err <= tol))


def bnot_blue_noise_claim(data: BNOTFigureData, factor: float = BLUE_NOISE_FACTOR) -> Claim:
    r"""BNOT is blue noise: little power at low frequencies, where random points have P ≈ 1.

    Test: mean power for :math:`|k| < \sqrt N/2` of BNOT < ``factor`` × that of random points.

    >>> bnot_blue_noise_claim(bnot_figure_data(32)).holds
    True
    """
    return Claim(id="bnot.blue-noise", text="BNOT: blue noise (low power at low frequencies)",
                 values={"low_band": data.low_band, "low_power_bnot": data.low_power_bnot,
                         "low_power_random": data.low_power_random},
                 test=f"mean P(|k| < sqrt(N)/2): BNOT < {factor:g} x random",
                 threshold=float(factor),
                 holds=bool(data.low_power_bnot < factor * data.low_power_random))


def figure_claims(spectra: SpectraData | None = None, convergence: ConvergenceData | None = None,
                  truncation: TruncationFigureData | None = None,
                  bnot: BNOTFigureData | None = None) -> list[Claim]:
    r"""Every claim that the given figure data can check, in figure order.

    Figs. 1–2 from ``spectra`` (diffuse; Fig. 2 needs both weightings and lmax ≥ 10),
    Fig. 4 from ``convergence``, Fig. 5(a) from ``truncation``, BNOT from ``bnot``; data
    left as None contribute nothing.

    >>> d = spectra_data(n=32, lmax=16, pointsets=("sf", "random"), brdfs=("diffuse",))
    >>> [c.id for c in figure_claims(spectra=d)]
    ['fig1.anisotropic-dominates.diffuse', 'fig2.osw-reduce-low-order.diffuse']
    """
    out: list[Claim] = []
    if spectra is not None and "diffuse" in spectra.brdfs:
        if "equal" in spectra.weightings:
            out.append(anisotropic_dominance_claim(spectra, "diffuse", "equal"))
        if "osw" in spectra.weightings and "equal" in spectra.weightings and spectra.lmax >= 10:
            out.append(osw_low_order_claim(low_order_closeup(spectra, "diffuse", 10)))
    if convergence is not None:
        out += random_slope_claims(convergence) + structured_beat_random_claims(convergence)
    if truncation is not None:
        c = caption_fig5a_claim(truncation)
        out += [c] if c is not None else []
    if bnot is not None:
        out += [bnot_capacity_claim(bnot), bnot_blue_noise_claim(bnot)]
    return out


def split_lmax(n: int, floor: int = PAPER_LMAX, cap: int = 2048) -> int:
    r"""Degree to which a spectrum of an N-point rule is summed when none is asked for.

    :math:`\min(cap, \max(floor, \lceil 16\sqrt N\rceil))`. The truncated spectral sum
    misses a tail that is ≈ √N/lmax of E² for equal weights
    (:math:`C_l^2 \to \frac{2l+1}{4\pi}\sum_j w_j^2`); 16√N leaves ≈ 3–30 % of E²
    (reported) at ≈ 1 s for N = 10⁴ (ducc0 adjoint synthesis ≈ 1–2 s at degree 2048).

    >>> split_lmax(100), split_lmax(256), split_lmax(10**6)
    (170, 256, 2048)
    """
    n = _check_int(n, "n", 1)
    return int(min(cap, max(floor, math.ceil(16.0 * math.sqrt(n)))))

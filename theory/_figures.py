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
  the QMC rule on a fine logarithmic grid of N
  (:func:`envfit.theory._wce_curves.invert_wce_curve`).
* BNOT check (:func:`bnot_figure_data`): radial power spectrum of BNOT against random
  points on the unit square, and the capacity constraint :math:`|V_i^w| = 1/N`.

The paper's statements about these figures are checked in :mod:`envfit.theory._claims`; the
generic E(N) curve tools (slopes, log grids, inversion) are in :mod:`envfit.theory._wce_curves`.

All quadrature points are *morphed* for the weight function by default (importance
sampling, Sec. 7.2: the square is lifted by the Lambert equal-area map and its height
coordinate passed through the inverse CDF of p, :meth:`envfit.theory._weight_function.WeightFunction.morph`);
``morph=False`` lifts them uniformly instead. Points live in the local frame of the lobe
(axis +z); for the glossy lobe this is the mirror direction (Sec. 4.3).

Examples
--------
>>> d = spectra_data(n=32, lmax=16, pointsets=("sf", "random"), brdfs=("diffuse",))
>>> r = d.get("diffuse", "equal", "sf")
>>> bool(np.allclose(r.e2, r.a * (r.d2 + r.C2)))
True
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from envfit.theory._bnot import (BNOTDiagnostics, bnot_diagnostics, bnot_square,
                                 radial_power_spectrum)
from envfit.theory._brdf import BRDFS, PAPER_SHININESS, Diffuse, Glossy, WeightFunction
from envfit.theory._errors import TheoryParameterError, check_smoothness
from envfit.theory._pointsets import DETERMINISTIC_POINTSETS, POINTSETS, generate, random_square
from envfit.theory._quadrature import error_spectrum, worst_case_error
from envfit.theory._table1 import CASES, case_weight
from envfit.theory._truncation import truncation_error_curve
from envfit.theory._wce_curves import (Progress, _check_int, extrapolate_wce_curve,
                                       fit_convergence_slope, invert_wce_curve, qmc_wce_curve)
from envfit.theory._weights import WEIGHTINGS, equal_weights, optimal_weights

__all__ = ["POINTSET_ORDER", "POINTSET_LABELS", "BRDFS", "WEIGHTINGS", "PAPER_LMAX",
           "make_weight", "quadrature_rule", "SpectrumRecord", "SpectraData", "spectra_data",
           "LowOrderCloseup", "low_order_closeup", "ConvergenceData", "convergence_data",
           "TruncationFigureData", "truncation_figure_data", "BNOTFigureData", "bnot_figure_data",
           "split_lmax"]

#: the point sets of Sec. 7.1, in the paper's order
POINTSET_ORDER = ("sobol", "bnot", "lp", "sf", "random", "jitter")
POINTSET_LABELS = {"sobol": "Sobol", "bnot": "BNOT", "lp": "LP", "sf": "SF",
                   "random": "Random", "jitter": "SJ"}
# BRDFS (theory.brdf) and WEIGHTINGS ("equal": w_j = 1/N; "osw": optimal sample weights
# K^{-1} z, Sec. 7.1; theory.weights) are imported above and re-exported
#: the highest SH degree of the paper's spectra
PAPER_LMAX = 170


def _check_names(names: Iterable[str], allowed, what: str) -> tuple[str, ...]:
    out = tuple(names)
    bad = [x for x in out if x not in allowed]
    if bad or not out:
        raise TheoryParameterError(f"{what} must be a non-empty subset of {list(allowed)}, got {list(out)}")
    return out


def make_weight(brdf: str, shininess: float = PAPER_SHININESS) -> WeightFunction:
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


def spectra_data(n: int = 256, s: float = 1.5, shininess: float = PAPER_SHININESS,
                 lmax: int = PAPER_LMAX, *,
                 seed: int = 0, pointsets: Iterable[str] = POINTSET_ORDER,
                 brdfs: Iterable[str] = BRDFS, weightings: Iterable[str] = WEIGHTINGS,
                 morph: bool = True, progress: Progress | None = None) -> SpectraData:
    r"""Power and error spectra of the quadrature rules of Sec. 7 (Figs. 1–3).

    One realization per stochastic point set (``seed``), as in the paper. Uses
    :func:`envfit.theory._quadrature.error_spectrum` (ducc0 adjoint SH synthesis for
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


def convergence_data(nmax: int = 2048, s: float = 1.5, shininess: float = PAPER_SHININESS, *,
                     nmin: int = 16, seed: int = 0, pointsets: Iterable[str] = POINTSET_ORDER,
                     brdfs: Iterable[str] = BRDFS, weightings: Iterable[str] = WEIGHTINGS,
                     morph: bool = True, realizations: int = 1, fit_nmin: int = 64,
                     progress: Progress | None = None) -> ConvergenceData:
    r"""Worst-case error (Eq. 41) for N = nmin, 2·nmin, …, ≤ nmax (powers of two) (Fig. 4).

    The paper's Fig. 4 uses one realization per point set and N up to 2048 (its Random
    curves are shifted by a factor 0.5 / 0.45 for readability; these are the raw values).
    Slopes: :func:`envfit.theory._wce_curves.fit_convergence_slope` over ``fit_nmin`` ≤ N ≤
    nmax. With seed 0 and one realization, random points converge like :math:`N^{-0.56}`
    (equal weights) and :math:`N^{-0.76}` (OSW) in both cases, the structured sets like
    :math:`N^{-0.72}` to :math:`N^{-0.83}` (the optimal rate for s = 1.5 is
    :math:`N^{-s/2} = N^{-0.75}`).
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


def truncation_figure_data(s: float = 1.5, shininess: float = PAPER_SHININESS, Lmax: int = 20, *,
                           qmc_nmax: int = 16384, per_octave: int = 8,
                           progress: Progress | None = None) -> TruncationFigureData:
    r"""The data of Fig. 5: truncation errors and QMC equivalents for every L.

    E(L) from :func:`envfit.theory._truncation.truncation_error_curve` (Eq. 52 summed from L + 1,
    HSH through Eq. 31); QMC equivalents by :func:`envfit.theory._wce_curves.invert_wce_curve`
    on :func:`envfit.theory._wce_curves.qmc_wce_curve` (one curve per weight function, shared
    by glossy SH and HSH).
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
    (:func:`envfit.theory._bnot.radial_power_spectrum`; E P = 1 for random points);
    ``low_band`` : |k| below which the mean power is compared (:math:`\sqrt N/2`);
    ``low_power_bnot``/``low_power_random`` : those means;
    ``diagnostics_bnot``/``diagnostics_random`` : capacity weights and cell areas
    (:func:`envfit.theory._bnot.bnot_diagnostics`), centroid residual, minimum distance.
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

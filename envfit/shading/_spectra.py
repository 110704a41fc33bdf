r"""Spectra behind predictions (b') and (c) of ``envfit validate``: per-degree error power of
a rule, a map's realised power per degree, and the bilinear lookup's transfer.

Notation (Eqs. 42–45, 59 of the paper): a rule with points :math:`u_j` and weights
:math:`w_j` estimating :math:`\int f(u)\,p(u\cdot a)\,du` has, on the real spherical
harmonics of degree l, the squared error :math:`e_l` (:func:`rule_error_power`); a field
of covariance :math:`\sigma^2\sum_l a_l^{(s)}\frac{2l+1}{4\pi}P_l` has the expected squared
error :math:`\sigma^2\sum_l a_l e_l` (the worst-case error squared, Eq. 42, when summed
to infinity). Three things make that exact for what a lat-long map is:

* it holds no degree above H − 1 (:func:`bandlimited_worst_case_errors`);
* the estimators see its *bilinear interpolant*, whose power at degree l is the pixel
  field's times a transfer :math:`\tau_l \le 1` (:func:`lookup_transfer`: 1 at low
  degrees, about 0.8 at half the Nyquist degree, 0.25 at the Nyquist degree);
* one map is one realisation: its power per degree scatters about the expectation
  (:func:`model_scatter`).

A map's realised spectrum (:func:`map_degree_power`) in place of the model gives prediction
(c) (:func:`spectral_rmse`), the exact mean over random rotations on that map.
"""
from __future__ import annotations

import math

import ducc0
import numpy as np

from envfit.theory import anisotropic_power_spectrum, zonal_sums
from envfit.theory import sobolev_coefficients

from envfit.maps import EnvMap
from envfit.base import ParameterError
from envfit.base import check_memory
from envfit.shading._bilinear_sh import bilinear_sh_coefficients

__all__ = ["rule_error_power", "bandlimited_worst_case_error", "bandlimited_worst_case_errors",
           "map_degree_power", "pixel_degree_power", "lookup_transfer", "map_transfer",
           "degree_weights", "band_e2", "sh_truncation_curve_transfer", "spectral_rmse",
           "model_scatter", "low_degree_power_ratio", "sh_analysis_cost", "rule_power_cost", "rows_within"]

#: seconds per (ring node x degree²) of the bilinear interpolant's Legendre analysis
#: (``ducc0.sht.leg2alm``), measured on a 2048x1024 map (19.6 s to l = 2047, 3.3 s to
#: l = 1023, 3 channels; a loaded 2-core machine)
_SEC_PER_LEG_OP = 1.7e-10
#: seconds per degree³ of a rule's adjoint SH synthesis and per (point x degree) of its
#: Legendre sums (:func:`rule_error_power`; 1.7 s at N = 4096, 12 s at l = 4095; 9 s and
#: 36 s at N = 65536)
_SEC_PER_L3, _SEC_PER_NL = 1.75e-10, 6e-8
#: bytes per degree² of :func:`rule_error_power` (ducc0's adjoint synthesis grid, the packed
#: coefficients, their power and degree index): 243 MB at l = 2047, 972 MB at l = 4095
_RULE_BYTES_PER_L2 = 58


def power_by_degree(alm: np.ndarray, lmax: int) -> np.ndarray:
    """(C, lmax+1) power per degree of complex m-major (healpy-layout) coefficients of a real map."""
    power = np.abs(alm) ** 2
    m = np.repeat(np.arange(lmax + 1), np.arange(lmax + 1, 0, -1))     # m of each packed entry
    l = np.concatenate([np.arange(mm, lmax + 1) for mm in range(lmax + 1)])
    power = power * np.where(m == 0, 1.0, 2.0)[None, :]
    out = np.stack([np.bincount(l, weights=row, minlength=lmax + 1) for row in power])
    return out / (2.0 * np.arange(lmax + 1) + 1.0)[None, :]


def bandlimited_worst_case_error(points, weights, brdf, s: float, lmax: int) -> float:
    r"""The worst-case error restricted to degrees l ≤ lmax (Eq. 42 summed to lmax):

    .. math:: E_{\le L}^2 = a_0 d_0^2 + \sum_{l=1}^{L} a_l (d_l^2 + C_l^2)

    (:func:`envfit.theory._sh.zonal_sums` for :math:`c_{l,0}`, :func:`envfit.theory._sh.anisotropic_power_spectrum`
    for :math:`C_l^2`; the same sum as ``envfit.theory._quadrature.error_spectrum(...).partial``).
    Under the GP reading it is the expected error for a field whose covariance has no
    degree above L — a lat-long map of H rows holds degrees up to H − 1 (the
    Gaussian-process maps of :mod:`envfit.data_gen._gp` are band-limited exactly there), so
    σ·E_{≤H−1} is prediction (b') of the report.

    >>> from envfit.theory._brdf import Diffuse
    >>> u = np.array([[0.0, 0.0, 1.0]]); bandlimited_worst_case_error(u, [1.0], Diffuse(), 1.5, 0)
    0.0
    """
    return bandlimited_worst_case_errors(points, weights, brdf, [s], lmax)[0]


def rule_error_power(points, weights, brdf, lmax: int) -> np.ndarray:
    r"""Per-degree error power of a quadrature rule, l = 0…lmax: the bracket of Eq. 42,

    .. math:: e_l = (b_l - c_{l,0})^2 + C_l^2 = \sum_{m=-l}^{l} |c_{l,m} - b_l\,\delta_{m0}|^2,

    the squared error of the rule on the 2l+1 real spherical harmonics of degree l (b_l the
    BRDF's zonal coefficients, :math:`c_{l,m}` the rule's, Eqs. 44–45 and 59;
    :func:`envfit.theory._sh.zonal_sums`, :func:`envfit.theory._sh.anisotropic_power_spectrum`). Weighted by
    a_l it is the error spectrum, :math:`E^2 = \sum_l a_l e_l` (:math:`C_0^2 = 0`); weighted
    by a map's realised power per degree it is that map's mean squared error over random
    rotations (:func:`spectral_rmse`).

    >>> from envfit.theory._brdf import Diffuse
    >>> u = np.array([[0.0, 0.0, 1.0]]); e = rule_error_power(u, [1.0], Diffuse(), 2)
    >>> float(e[0]) < 1e-30                       # one point, weight 1: constants are exact
    True
    """
    lmax = int(lmax)
    b = brdf.sh_coefficients(lmax)
    c0 = zonal_sums(points, weights, lmax)
    C2 = anisotropic_power_spectrum(points, weights, lmax)
    C2[0] = 0.0
    return (b - c0) ** 2 + C2


def bandlimited_worst_case_errors(points, weights, brdf, s_values, lmax: int, *,
                                  power: np.ndarray | None = None,
                                  transfer: np.ndarray | None = None) -> list[float]:
    """:func:`bandlimited_worst_case_error` for several s at once: the error power of the
    rule (:func:`rule_error_power`) does not depend on s and is computed once (or passed).
    ``transfer`` (τ_l, l = 0…lmax, :func:`lookup_transfer`) weights degree l by τ_l: the
    expected error on the bilinear interpolant of a band-limited field.

    >>> from envfit.theory._brdf import Glossy
    >>> u = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]); w = [0.5, 0.5]
    >>> e = bandlimited_worst_case_errors(u, w, Glossy(30.0), [1.2, 1.8], 20)
    >>> bool(np.isclose(e[1], bandlimited_worst_case_error(u, w, Glossy(30.0), 1.8, 20)))
    True
    """
    lmax = int(lmax)
    if power is None:
        power = rule_error_power(points, weights, brdf, lmax)
    power = np.asarray(power, dtype=np.float64)[:lmax + 1]
    if transfer is not None:
        power = power * np.asarray(transfer, dtype=np.float64)[:lmax + 1]
    out = []
    for s in s_values:
        e2 = sobolev_coefficients(float(s), lmax) * power
        out.append(math.sqrt(max(math.fsum(e2[::-1]), 0.0)))
    return out


def sh_analysis_cost(height: int, channels: int, lmax: int) -> tuple[int, float]:
    r"""Predicted (peak bytes, seconds) of :func:`map_degree_power` to degree ``lmax`` on a
    2H x H map of C channels: the bilinear interpolant's exact SH analysis
    (:func:`envfit.shading._ground_truth.bilinear_sh_coefficients`).

    Bytes: the rows' DFT (8 H W C), their Fourier coefficients and the pole-extended copy
    (2 x 16 H (l+1) C), one channel's Legendre integrands on the (H + 1) q Gauss nodes (three
    complex temporaries, 48 (H + 1) q (l + 1)), the coefficients (8 C (l+1)(l+2)) and their
    power by degree (~16 (l+1)^2); q = :func:`envfit.shading._patches.gauss_legendre_order`.
    Measured on a 2048x1024 map: 1.18 GB to l = 2047 (predicted 1.26 GB). Seconds:
    :data:`_SEC_PER_LEG_OP` x C (H + 1) q (l + 1)^2.

    >>> b, t = sh_analysis_cost(4096, 3, 8191)  # an 8K map to 2H - 1: the 19.9 GB of issue 22
    >>> round(b / 1e9), round(t / 60)
    (20, 21)
    """
    from envfit.shading._patches import gauss_legendre_order
    h, c, L1 = int(height), max(1, int(channels)), int(lmax) + 1
    q = gauss_legendre_order((L1 + 1) * (np.pi / h) / 2.0)
    w = 2 * h
    analysis = 8 * h * w * c + 32 * h * L1 * c + 48 * (h + 1) * q * L1 + 8 * c * L1 * (L1 + 1)
    power = 8 * c * L1 * (L1 + 1) + 12 * c * L1 * L1 // 2 + 16 * L1 * L1
    return int(max(analysis, power)), float(_SEC_PER_LEG_OP * c * (h + 1) * q * L1 * L1)


def rule_power_cost(n: int, lmax: int) -> tuple[int, float]:
    """Predicted (peak bytes, seconds) of one :func:`rule_error_power` of N points to degree
    ``lmax`` (the constants above: measured at N = 4096 and 65536, l = 511…4095).

    >>> b, t = rule_power_cost(4096, 4095)
    >>> round(b / 1e9, 2), round(t)
    (0.97, 13)
    """
    L1, n = int(lmax) + 1, int(n)
    return (int(_RULE_BYTES_PER_L2 * L1 * L1 + 8 * 24 * n),
            float(_SEC_PER_L3 * L1 ** 3 + _SEC_PER_NL * n * L1))


def map_degree_power(scaled: EnvMap, lmax: int) -> np.ndarray:
    r"""The map's realised power per degree, (C, lmax+1):
    :math:`\hat P_{l,c} = \frac{1}{2l+1}\sum_{m=-l}^{l} f_{lm,c}^2`, from the exact SH
    coefficients of the map's bilinear interpolant
    (:func:`envfit.shading._ground_truth.bilinear_sh_coefficients`; l = 0 holds the squared mean times 4π).
    Under the GP model, :math:`E[\hat P_l] = \sigma^2 a_l` for l ≥ 1.

    >>> from envfit.maps._envmap import EnvMap
    >>> p = map_degree_power(EnvMap(np.full((8, 16, 1), 2.0)), 3)
    >>> bool(np.isclose(p[0, 0], 4.0 * 4 * np.pi)) and bool(np.all(p[0, 1:] < 1e-20))
    True
    """
    lmax = int(lmax)
    need, secs = sh_analysis_cost(scaled.height, scaled.channels, lmax)
    check_memory(need, f"the SH power of a {scaled.width}x{scaled.height} map to degree {lmax} "
                       f"(~{secs:.0f} s)",
                 hint=f"downsample the map to at most {rows_within(scaled.channels, lmax)} "
                      f"rows (--max-height)")
    return power_by_degree(bilinear_sh_coefficients(scaled, lmax), lmax)


def rows_within(channels: int, lmax: int) -> int:
    """The most rows (a power of 2, at least 1) whose SH analysis to min(lmax, 2H - 1) fits
    the memory budget (:func:`sh_analysis_cost`)."""
    from envfit.base import memory_budget_bytes
    budget, h = memory_budget_bytes(), 1
    while h < 2 ** 16 and sh_analysis_cost(2 * h, channels, min(lmax, 4 * h - 1))[0] <= budget:
        h *= 2
    return h


def pixel_degree_power(scaled: EnvMap, lmax: int | None = None, *, nthreads: int = 1) -> np.ndarray:
    r"""Power per degree (C, lmax+1) of the function band-limited to lmax ≤ H − 1 that takes
    the pixel values at the pixel centres: ``ducc0.sht.analysis_2d`` on the equiangular
    ("F1") grid, exact for a map band-limited there (as the GP maps of :mod:`envfit.data_gen._gp`).
    Default lmax = H − 1. Needs W = 2H.

    >>> from envfit.maps._envmap import EnvMap
    >>> p = pixel_degree_power(EnvMap(np.full((8, 16, 1), 2.0)))
    >>> bool(np.isclose(p[0, 0], 4.0 * 4 * np.pi)) and bool(np.all(p[0, 1:] < 1e-20))
    True
    """
    H, W = scaled.height, scaled.width
    L = H - 1 if lmax is None else int(lmax)
    if W != 2 * H or not (0 <= L <= H - 1):
        raise ParameterError(f"pixel analysis needs a 2H x H map and lmax <= H - 1; got "
                             f"{W}x{H}, lmax = {L}")
    data = np.asarray(scaled.data, dtype=np.float64)
    out = []
    for c in range(scaled.channels):
        alm = ducc0.sht.analysis_2d(map=np.ascontiguousarray(data[None, :, :, c]), spin=0, lmax=L,
                                    geometry="F1", phi0=np.pi / W, nthreads=int(nthreads))
        out.append(alm[0])
    return power_by_degree(np.stack(out), L)


def lookup_transfer(bilinear_power, pixel_power) -> np.ndarray:
    r"""The bilinear lookup's transfer per degree, :math:`\tau_l = \sum_c \hat P^{bil}_{l,c} /
    \sum_c \hat P^{pix}_{l,c}`, l = 0…L: the power of the map's bilinear interpolant
    (:func:`map_degree_power`) over the power of its pixel values (:func:`pixel_degree_power`).

    The interpolant is smoother than the field it interpolates between pixel centres, so
    τ falls from 1 at low degrees to about 0.25 at the Nyquist degree; it hardly depends on
    the content (the ratio of two powers of one realisation), so a band-limited model of
    the pixel values times τ is a model of what the estimators integrate. Degrees with no
    pixel power get τ = 1.

    >>> lookup_transfer([[4.0, 1.0, 0.5]], [[4.0, 1.0, 1.0]]).tolist()
    [1.0, 1.0, 0.5]
    """
    b = np.atleast_2d(np.asarray(bilinear_power, dtype=np.float64))
    p = np.atleast_2d(np.asarray(pixel_power, dtype=np.float64))
    k = min(b.shape[1], p.shape[1])
    num, den = b[:, :k].sum(axis=0), p[:, :k].sum(axis=0)
    tiny = 1e-300 + 1e-14 * float(np.max(den, initial=0.0))
    return np.where(den > tiny, num / np.where(den > tiny, den, 1.0), 1.0)


def spectral_rmse(error_power, map_power) -> float:
    r"""Prediction (c): the RMSE of a rule on *this* map over uniformly random rotations,

    .. math:: \mathrm{RMSE}^2 = \frac1C\sum_c\sum_{l} \hat P_{l,c}\, e_l ,

    exact in expectation over Haar-random rotations (uniform axes with a uniform twist, as
    measured) for any map whose bilinear interpolant holds no degree above lmax: the error
    on :math:`\sum_{lm} f_{lm} Y_{lm}\circ R` averaged over R is, by Schur orthogonality of
    the Wigner D-matrices, :math:`\sum_l \frac{1}{2l+1}\sum_m f_{lm}^2 \sum_{m'}
    |\varepsilon_{lm'}|^2` with :math:`\sum_{m'}|\varepsilon_{lm'}|^2 = e_l`
    (:func:`rule_error_power`). It uses the map's realised spectrum and no model (neither s
    nor σ): it checks the measurement and the error spectra themselves, and separates "the
    map is not the model" from "the machinery is wrong".

    >>> spectral_rmse([0.0, 2.0], [[5.0, 0.5], [7.0, 1.5]])
    1.4142135623730951
    """
    e = np.asarray(error_power, dtype=np.float64)
    P = np.atleast_2d(np.asarray(map_power, dtype=np.float64))
    k = min(e.size, P.shape[1])
    return float(math.sqrt(max(float(np.mean(P[:, :k] @ e[:k])), 0.0)))


def model_scatter(error_power, s: float, sigma_channels, mean_error: float = 0.0, *,
                  transfer: np.ndarray | None = None) -> float:
    r"""Relative standard deviation of one map's RMSE about σ·E under the GP model.

    One map is one realisation: its power in degree l is
    :math:`\sigma_c^2 a_l\,\chi^2_{2l+1}/(2l+1)` per channel, so its mean squared error
    over all rotations, :math:`\frac1C\sum_{c,l} \hat P_{l,c} e_l` (:func:`spectral_rmse`),
    scatters about its expectation with variance
    :math:`\frac{1}{C^2}\sum_{c,l\ge1} 2 (\sigma_c^2 a_l e_l)^2/(2l+1)`. Returned: half
    its square root over the expected mean squared error (the delta method for the root),
    i.e. the spread expected between a map's measured RMSE and prediction (b′) that no
    better model could remove. Large when the error sits in a few low degrees (random
    points with equal weights), small for rules that integrate low degrees well.

    >>> round(model_scatter([0.0, 1.0, 0.0], 1.5, [1.0]), 6)    # all error in l = 1: χ²₃
    0.408248
    """
    e = np.asarray(error_power, dtype=np.float64)
    lmax = e.size - 1
    if transfer is not None:                      # the expected power is τ_l σ² a_l
        e = e * np.asarray(transfer, dtype=np.float64)[:lmax + 1]
    a = sobolev_coefficients(float(s), lmax)
    sig2 = np.asarray(sigma_channels, dtype=np.float64).ravel() ** 2
    S = sig2[:, None] * (a * e)[None, :]                               # (C, L+1)
    S[:, 0] = 0.0                                                      # the mean: not random
    C = sig2.size
    mse = float(S.sum() / C) + float(mean_error) ** 2
    if mse <= 0:
        return 0.0
    var = float(np.sum(2.0 * S ** 2 / (2.0 * np.arange(lmax + 1) + 1.0)[None, :])) / C ** 2
    return 0.5 * math.sqrt(var) / mse


def low_degree_power_ratio(scaled: EnvMap, sigma_channels, s: float, lmax: int = 8) -> dict:
    r"""The map's realised power per degree against the model's, l = 1…lmax.

    :math:`\rho_l = \frac1C\sum_c \hat P_{l,c} / (\hat\sigma_c^2 a_l^{(s)})`, with
    :math:`\hat P_{l,c} = \frac{1}{2l+1}\sum_m |f_{lm,c}|^2` from the exact SH coefficients of
    the scaled map's bilinear interpolant (:func:`envfit.shading._ground_truth.bilinear_sh_coefficients`).
    Under the GP model :math:`E[\hat P_l] = \sigma^2 a_l`, with relative scatter
    :math:`\sqrt{2/((2l+1)C)}` for one map: the few modes at low l make one map's errors
    for rules that err mostly there (random points with equal weights, the diffuse lobe)
    depart from σ·wce by that much. Returns ``{str(l): ρ_l}``.
    """
    sig2 = np.asarray(sigma_channels, dtype=np.float64) ** 2
    if not np.all(sig2 > 0):
        return {}
    P = map_degree_power(scaled, lmax)                                 # (C, lmax+1)
    a = sobolev_coefficients(s, lmax)
    return {str(l): float(np.mean(P[:, l] / (sig2 * a[l]))) for l in range(1, lmax + 1)}


def map_transfer(scaled: EnvMap) -> np.ndarray:
    r"""τ_l, l = 0…H − 1, of the map's bilinear lookup (:func:`envfit.shading._spectra.lookup_transfer`):
    the power of its bilinear interpolant (:func:`envfit.shading._spectra.map_degree_power`) over that
    of its pixel values (:func:`envfit.shading._spectra.pixel_degree_power`), summed over channels —
    the same τ as ``envfit validate``'s. ≈ 0.7 s on a 1024×512 map.

    >>> tau = map_transfer(EnvMap(np.full((8, 16, 2), 3.0)))   # a constant: nothing to damp
    >>> tau.shape, bool(np.allclose(tau, 1.0))
    ((8,), True)
    """
    L = scaled.height - 1
    return lookup_transfer(map_degree_power(scaled, L), pixel_degree_power(scaled, L))


def degree_weights(s: float, band_lmax: int, transfer=None) -> np.ndarray:
    r""":math:`a_l(s)\,\tau_l`, l = 0…``band_lmax``: what weights a rule's error power
    :math:`e_l` in :math:`E'^2` (``transfer`` None: τ = 1, the band-limited wce of Eq. 42).

    >>> from envfit.theory._sobolev import sobolev_coefficients
    >>> bool(np.array_equal(degree_weights(1.5, 3, [1, 1, 0.5, 0.25]),
    ...                     sobolev_coefficients(1.5, 3) * [1, 1, 0.5, 0.25]))
    True
    """
    a = sobolev_coefficients(float(s), int(band_lmax))
    if transfer is None:
        return a
    tau = np.asarray(transfer, dtype=np.float64)
    if tau.shape != a.shape:
        raise ParameterError(f"transfer has {tau.size} degrees, expected {a.size}")
    return a * tau


def band_e2(power, weights_l: np.ndarray) -> float:
    r""":math:`E'^2 = \sum_l w_l e_l` (``weights_l`` from :func:`degree_weights`), the correctly
    rounded sum (``math.fsum``): the same bits whatever the order, so a cached power gives
    exactly a fresh one's E'².

    >>> band_e2([1.0, 2.0], np.array([0.5, 0.25]))
    1.0
    """
    p = np.asarray(power, dtype=np.float64)
    return max(math.fsum(p * weights_l), 0.0)


def sh_truncation_curve_transfer(wf, s: float, Lmax: int, band_lmax: int,
                                 transfer=None) -> np.ndarray:
    r"""E'(L), L = 0…Lmax, of SH truncation on a map of band limit H − 1 = ``band_lmax`` read
    by bilinear lookups: :math:`E'^2(L) = \sum_{l=L+1}^{H-1} a_l\tau_l b_l^2` (Eq. 52 summed
    to the band limit, degree l weighted by τ_l). With ``transfer`` None it is
    ``envfit.theory._truncation.truncation_error_curve(wf, s, Lmax, "sh", lmax=band_lmax)`` (the same sums, the same
    order).

    >>> from envfit.theory._brdf import Diffuse
    >>> from envfit.theory._truncation import truncation_error_curve
    >>> bool(np.array_equal(sh_truncation_curve_transfer(Diffuse(), 1.5, 5, 40),
    ...                     truncation_error_curve(Diffuse(), 1.5, 5, "sh", lmax=40)))
    True
    """
    Lmax, band_lmax = int(Lmax), int(band_lmax)
    if band_lmax <= Lmax:
        raise ParameterError(f"band limit {band_lmax} must exceed Lmax = {Lmax}")
    a = degree_weights(s, band_lmax, transfer)
    b = wf.sh_coefficients(band_lmax)
    terms = a * b * b
    tail = np.cumsum(terms[::-1])[::-1]                      # tail[k] = sum_{l >= k}
    return np.sqrt(np.append(tail[1:], 0.0)[:Lmax + 1])

r"""Worst-case error of quadrature rules for shading integrals, in space and in frequency.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 5.1–5.2 and 6.1 (with the
errata's corrections, docs/ERRATA.md).

The normalised shading integral :math:`I_f = \frac{1}{2\pi r_s}\int f p\,dS` (Eq. 17) is
approximated by :math:`\sum_j w_j f(u_j)` (Eq. 34). For f in the Sobolev space
:math:`H^s(S^2)` with the generalized distance kernel
:math:`K(u,v) = C - |u-v|^{2s-2}`, :math:`C = 2^{2s-1}/s` (Eq. 14), the worst-case error is

.. math::
    E^2 = \sum_{i,j} w_i w_j K(u_i,u_j) - 2\sum_j w_j z_j + E_0^2                      \quad (41)

    z_j = \frac{1}{2\pi r_s}\int K(u_j,u)p(u)\,dS = \sum_l a_l b_l Y_{l,0}(u_j)
    \qquad E_0^2 = \sum_l a_l b_l^2                                                       \quad (57)

    E^2 = a_0 d_0^2 + \sum_{l\ge1} a_l (d_l^2 + C_l^2), \quad d_l = b_l - c_{l,0},
    \quad C_l^2 = S_l - c_{l,0}^2                                                        \quad (42)

Points are unit vectors in the local frame of the integral (BRDF axis = +z).

Numerics of the closed form
---------------------------
The constant C cancels exactly: with :math:`D_{ij} = |u_i-u_j|^{2s-2}`,
:math:`\zeta_j = C - z_j` and :math:`\bar\zeta = C - E_0^2`,

.. math:: E^2 = C\Big(\sum_j w_j - 1\Big)^2 + 2\sum_j w_j\zeta_j - \bar\zeta - \sum_{i,j} w_i w_j D_{ij},

three O(1) terms cancelling to :math:`E^2` (≈2e-8 for N = 10⁵). All sums are float64;
the pair sum runs over the upper triangle of cache-sized tiles (memory O(N + tile²))
and the band totals are added with ``math.fsum``; z_j is the Legendre series of the
embedding truncated where its tail bound is below 1e-15. Measured against the spectral
form Eq. 42 plus its explicitly computed tail (N = 64…3000), the absolute error of
:math:`E^2` is ≈1e-15, so the relative error of E is about :math:`10^{-15}/(2E^2)`:
≈5e-10 at E = 1e-3, ≈5e-8 at E = 1e-4 (allow 10× more for N = 10⁵).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.fft import dct

from envfit.theory._weight_function import WeightFunction
from envfit.theory._errors import TheoryParameterError, check_degree, check_smoothness
from envfit.theory._sh import (anisotropic_power_spectrum, check_points_weights, legendre_series,
                               zonal_sums)
from envfit.theory._sobolev import kernel_constant, kernel_series, sobolev_coefficients

__all__ = ["kernel_mean_embedding", "initial_error", "worst_case_error",
           "worst_case_error_squared", "error_spectrum", "ErrorSpectrum",
           "embedding_coefficients", "weighted_energy_sum"]

#: bound on the neglected tail sum_{l>L} |a_l b_l Y_l0(z)| of the embedding series
EMBEDDING_TOL = 1e-15
#: highest degree of the embedding series (reached only by weight functions with a jump
#: at the horizon; the achieved tail bound is then reported by a warning)
EMBEDDING_LMAX_CAP = 32768
#: evaluations of the kernel mean embedding (:func:`worst_case_error`'s ``embedding``)
EMBEDDING_METHODS = ("auto", "series", "chebyshev")
#: side of the square tiles of the pair sum (256² float64 = 512 KiB, cache resident)
TILE = 256


def _check_brdf(brdf) -> WeightFunction:
    if not isinstance(brdf, WeightFunction):
        raise TheoryParameterError(f"brdf must be a envfit.theory._brdf.WeightFunction, got {type(brdf).__name__}")
    return brdf


def embedding_coefficients(brdf: WeightFunction, s: float, tol: float = EMBEDDING_TOL) -> np.ndarray:
    r"""Legendre coefficients :math:`g_l = a_l b_l\sqrt{(2l+1)/4\pi}` of the embedding z(t), l = 0…L.

    L is the smallest power of two (≥ 64) with :math:`2\sum_{L<l\le 2L}|g_l| \le` ``tol``
    (at most 32768; a RuntimeWarning reports an achieved bound above 1000·tol),
    an estimate of :math:`\sum_{l>L}|g_l|` (a bound of the truncation error for any
    t, since :math:`|P_l| \le 1`) valid when :math:`|g_l|` decays at least like
    :math:`l^{-2}` (it decays like :math:`l^{-2s-1}` or faster for bounded p).
    """
    s = check_smoothness(s)
    _check_brdf(brdf)
    key = ("embedding", s, float(tol))
    cache = brdf._cache()
    if key in cache:
        return cache[key]
    L = 64
    while True:
        top = 2 * L
        a = sobolev_coefficients(s, top)
        b = brdf.sh_coefficients(top)
        l = np.arange(top + 1)
        g = a * b * np.sqrt((2 * l + 1) / (4 * np.pi))
        tail = 2.0 * np.abs(g[L + 1:]).sum()
        if tail <= tol or top >= EMBEDDING_LMAX_CAP:
            if tail > tol:
                L = top                          # keep every computed term
            if tail > 1e3 * tol:
                warnings.warn(f"kernel mean embedding of {brdf!r} (s = {s:g}): series tail "
                              f"≈ {tail:.1e} > tol = {tol:.0e} at lmax = {top}", RuntimeWarning,
                              stacklevel=2)
            g = g[:L + 1].copy()
            g.setflags(write=False)
            cache[key] = g
            return g
        L *= 2


def _embedding_chebyshev(brdf: WeightFunction, s: float, tol: float):
    """Piecewise Chebyshev interpolants of z(t) − g_0 on [−1, 0] and [0, 1] (cached)."""
    key = ("embedding_cheb", check_smoothness(s), float(tol))
    cache = brdf._cache()
    if key in cache:
        return cache[key]
    g = embedding_coefficients(brdf, s, tol).copy()
    g[0] = 0.0
    pieces = []
    for lo, hi in ((-1.0, 0.0), (0.0, 1.0)):
        deg = 64
        while True:
            # Chebyshev coefficients from values at the n first-kind points by a DCT-II
            # (accurate to rounding; numpy's chebinterpolate loses ~1e-14 here)
            n = deg + 1
            x = np.cos(np.pi * (np.arange(n) + 0.5) / n)
            c = dct(legendre_series(g, lo + (hi - lo) * 0.5 * (x + 1.0)), type=2) / n
            c[0] *= 0.5
            scale = max(np.abs(c).max(), 1e-300)
            # stop when the trailing coefficients are below tol or at the rounding floor
            if np.abs(c[(3 * deg) // 4:]).max() <= max(tol, 8 * np.finfo(float).eps * scale) \
                    or deg >= 2048:
                break
            deg *= 2
        # drop the negligible trailing coefficients
        keep = np.nonzero(np.abs(c) > 1e-18 * scale)[0]
        c = c[: (keep[-1] + 1) if keep.size else 1]
        pieces.append((lo, hi, c))
    cache[key] = pieces
    return pieces


def _embedding_minus_mean(t: np.ndarray, brdf: WeightFunction, s: float, tol: float,
                          method: str = "auto") -> np.ndarray:
    r""":math:`z(t) - g_0 = \sum_{l\ge1} g_l P_l(t)` (g_0 = C/2 exactly)."""
    if method not in EMBEDDING_METHODS:
        raise TheoryParameterError(f"embedding method must be one of {', '.join(EMBEDDING_METHODS)}, "
                                   f"got {method!r}")
    g = embedding_coefficients(brdf, s, tol)
    if method == "auto":
        # the direct sum is a Python-level recurrence over degrees: only for short series
        method = "series" if (g.size <= 512 and t.size * g.size <= 4 * 2 ** 20) else "chebyshev"
    if method == "series":
        g1 = g.copy()
        g1[0] = 0.0
        return legendre_series(g1, t)
    out = np.empty_like(t)
    for lo, hi, c in _embedding_chebyshev(brdf, s, tol):
        m = (t < 0.0) if lo < 0.0 else (t >= 0.0)
        x = (2.0 * t[m] - (lo + hi)) / (hi - lo)
        out[m] = np.polynomial.chebyshev.chebval(x, c)
    return out


def kernel_mean_embedding(points, brdf: WeightFunction, s: float, *, tol: float = EMBEDDING_TOL,
                          method: str = "auto") -> np.ndarray:
    r"""Kernel mean embedding of the normalised weight, :math:`z_j`, at each point.

    .. math:: z_j = \frac{1}{2\pi r_s}\int_{S^2} K(u_j,u)p(u)\,dS(u)
              = \sum_{l\ge0} a_l b_l \sqrt{\frac{2l+1}{4\pi}} P_l(u_j\cdot z)

    (the second term of Eq. 41 is :math:`2\sum_j w_j z_j`; Eq. 56). The Legendre series
    is truncated where the bound on its tail is below ``tol`` (see
    :func:`embedding_coefficients`); for large N it is evaluated through piecewise
    Chebyshev interpolants on [−1, 0] and [0, 1] (z is smooth on each; the pieces
    are refined until their trailing Chebyshev coefficients are below tol or the rounding
    floor; agreement with the direct sum ≈ 1e-15), O(N·deg) with deg ≈ 64–256 (at
    most 2048) instead of O(N·L). ``method`` = "series" forces the direct Clenshaw sum.

    >>> from envfit.theory._brdf import Diffuse
    >>> z = kernel_mean_embedding(np.array([[0.0, 0.0, 1.0]]), Diffuse(), 1.5)
    >>> z.shape
    (1,)
    """
    s = check_smoothness(s)
    _check_brdf(brdf)
    pts = check_points_weights(points, allow_empty=True)
    t = np.clip(pts[:, 2].copy(), -1.0, 1.0)
    g0 = embedding_coefficients(brdf, s, tol)[0]
    return g0 + _embedding_minus_mean(t, brdf, s, tol, method)


def initial_error(brdf: WeightFunction, s: float, *, tol: float = EMBEDDING_TOL) -> float:
    r"""Squared worst-case error with no samples, :math:`E_0^2 = \sum_l a_l b_l^2` (Eq. 57).

    Equal to :math:`\frac{1}{4\pi^2 r_s^2}\iint K(u,v)p(u)p(v)\,dS\,dS`; the series is
    summed (``math.fsum``) to the degree chosen by :func:`embedding_coefficients`; its
    terms :math:`a_l b_l^2` decay faster than the embedding's :math:`a_l b_l\sqrt{2l+1}`.

    >>> from envfit.theory._brdf import Diffuse
    >>> round(initial_error(Diffuse(), 1.5), 6) > kernel_constant(1.5) / 2
    True
    """
    s = check_smoothness(s)
    _check_brdf(brdf)
    return kernel_constant(s) - _mean_energy(brdf, s, tol)


def _mean_energy(brdf: WeightFunction, s: float, tol: float) -> float:
    r""":math:`\bar\zeta = \frac{1}{4\pi^2r_s^2}\iint |u-v|^{2s-2}pp = C/2 - \sum_{l\ge1}a_l b_l^2`."""
    g = embedding_coefficients(brdf, s, tol)
    L = g.size - 1
    a = sobolev_coefficients(s, L)
    b = brdf.sh_coefficients(L)
    return 0.5 * kernel_constant(s) - math.fsum((a[1:] * b[1:] ** 2)[::-1])


def _energy_row_band(P4a, P4bT, w, i0: int, tile: int, alpha: float) -> float:
    """Row band i0…i0+tile of the upper-triangular tiling of the weighted energy sum."""
    n = w.size
    i1 = min(n, i0 + tile)
    bi = i1 - i0
    wi = w[i0:i1]
    buf = np.empty((tile, tile))
    parts = []
    for j0 in range(i0, n, tile):
        j1 = min(n, j0 + tile)
        G = buf[:bi, :j1 - j0]
        # |u_i - u_j|^2 = 2 - 2 u_i.u_j as one K = 4 product [-2u_i, 2].[u_j, 1] (Eq. 10);
        # einsum without BLAS: a K = 4 product is memory-bound and BLAS threading of
        # such small products is slower than this single loop
        np.einsum("ik,kj->ij", P4a[i0:i1], P4bT[:, j0:j1], out=G, optimize=False)
        np.maximum(G, 0.0, out=G)
        if j0 == i0:
            G[np.arange(bi), np.arange(bi)] = 0.0
        if alpha == 0.5:
            np.sqrt(G, out=G)
        elif alpha == 0.25:
            np.sqrt(G, out=G)
            np.sqrt(G, out=G)
        else:
            np.power(G, alpha, out=G)
        v = float(wi @ (G @ w[j0:j1]))
        parts.append(v if j0 == i0 else 2.0 * v)
    return math.fsum(parts)


def weighted_energy_sum(points, weights, s: float, *, tile: int = TILE, workers: int = 1) -> float:
    r""":math:`\sum_{i,j} w_i w_j |u_i - u_j|^{2s-2}` over the upper triangle of tile × tile blocks.

    Each tile holds :math:`|u_i-u_j|^2 = 2 - 2u_i\cdot u_j` (Eq. 10), clipped at 0, with
    the diagonal set to exactly 0; it is raised to the power s − 1 in place and reduced
    with :math:`w_I^T D\, w_J` (BLAS gemv); off-diagonal tiles count twice. Tiles stay in
    cache (tile = 256: 512 KiB); memory is O(N + tile²), time O(N²): ≈ 5–6 ns per pair for
    s = 1.5 (N = 10⁴ in ≈ 0.3 s, N = 10⁵ in ≈ 30 s on one core; a general s uses
    ``np.power`` and is ≈ 3× slower). Band totals are added with ``math.fsum``.
    ``workers`` > 1 runs row bands in threads (numpy releases the GIL in these loops; it
    only helps on an otherwise idle machine).
    """
    s = check_smoothness(s)
    pts, w = check_points_weights(points, weights, allow_empty=True)
    n = pts.shape[0]
    if n == 0:
        return 0.0
    tile = int(max(16, tile))
    P4a = np.concatenate([-2.0 * pts, np.full((n, 1), 2.0)], axis=1)
    P4bT = np.ascontiguousarray(np.concatenate([pts, np.ones((n, 1))], axis=1).T)
    starts = range(0, n, tile)
    alpha = s - 1.0
    if workers is None or int(workers) <= 1:
        bands = [_energy_row_band(P4a, P4bT, w, i0, tile, alpha) for i0 in starts]
    else:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(int(workers)) as ex:
            bands = list(ex.map(lambda i0: _energy_row_band(P4a, P4bT, w, i0, tile, alpha), starts))
    return math.fsum(bands)


def worst_case_error_squared(points, weights, brdf: WeightFunction, s: float, *,
                             tol: float = EMBEDDING_TOL, tile: int = TILE, workers: int = 1,
                             embedding: str = "auto") -> float:
    r"""Squared worst-case error :math:`E^2` by the closed form Eq. 41 (may be ≈ −1e-15 from rounding).

    .. math:: E^2 = C\Big(\sum_j w_j - 1\Big)^2 + 2\sum_j w_j\zeta_j - \bar\zeta
              - \sum_{i,j} w_i w_j |u_i-u_j|^{2s-2},
              \qquad \zeta_j = C - z_j,\ \bar\zeta = C - E_0^2

    (Eq. 41 with the constant C cancelled exactly; see the module docstring for the
    accuracy). Parameters as :func:`worst_case_error`.
    """
    s = check_smoothness(s)
    _check_brdf(brdf)
    pts, w = check_points_weights(points, weights, allow_empty=True)
    C = kernel_constant(s)
    zbar = _mean_energy(brdf, s, tol)
    if pts.shape[0] == 0:
        return C - zbar
    g0 = embedding_coefficients(brdf, s, tol)[0]
    zeta = (C - g0) - _embedding_minus_mean(np.clip(pts[:, 2], -1.0, 1.0), brdf, s, tol,
                                            embedding)
    sw = math.fsum(w)
    cross = 2.0 * math.fsum(w * zeta)
    pair = weighted_energy_sum(pts, w, s, tile=tile, workers=workers)
    return C * (sw - 1.0) ** 2 + math.fsum([cross, -zbar, -pair])


def worst_case_error(points, weights, brdf: WeightFunction, s: float, *,
                     tol: float = EMBEDDING_TOL, tile: int = TILE, workers: int = 1,
                     embedding: str = "auto") -> float:
    r"""Worst-case error E of the quadrature rule (points, weights) for :math:`p\,f`, f ∈ H^s (Eq. 41).

    .. math:: E^2 = \sum_{i,j} w_i w_j K(u_i,u_j) - 2\sum_j w_j z_j + E_0^2

    O(N²) time, bounded memory. Absolute accuracy of :math:`E^2` ≈ 1e-14 (see the module
    docstring): relative error of E ≈ 1e-8 at E = 1e-3. A tiny negative :math:`E^2` from
    rounding is returned as 0. The one implementation of Eq. 41 (validation and the advisor
    call it per rule).

    Parameters
    ----------
    points, weights : (N, 3) unit vectors in the integral's local frame (axis = +z), (N,).
    brdf : the weight function p.
    s : Sobolev smoothness, 1 < s < 2.
    tol : tail bound of the embedding series (:func:`embedding_coefficients`).
    tile, workers : tiling and threads of the pair sum (:func:`weighted_energy_sum`).
    embedding : how the kernel mean embedding :math:`z_j` (Eq. 56) is evaluated —
        ``"series"`` the direct Legendre (Clenshaw) sum, O(N·L); ``"chebyshev"`` its
        cached piecewise Chebyshev interpolant (:func:`kernel_mean_embedding`), O(N·deg),
        agreeing with the series to ≈1e-15; ``"auto"`` (default) the series only when it
        is short (L ≤ 511 and N·L ≤ 4·2²⁰), else Chebyshev. Series of lobes with a kink or
        jump at the horizon are long (diffuse: L = 16 384 at s = 1.5, 32 768 at s = 1.1):
        the series costs 0.05–0.2 s per call for N ≤ 256, "auto" picks Chebyshev (~1 ms).
        E² from the three choices agrees to ≤ 1e-14 absolute (tests/test_theory_quadrature.py).

    >>> from envfit.theory._brdf import Diffuse
    >>> N = 500; j = np.arange(N); zp = 1 - (2 * j + 1) / (2 * N)
    >>> phi = 2 * np.pi * np.mod(j / ((1 + 5 ** 0.5) / 2), 1.0); z = np.sqrt(zp)
    >>> u = np.stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z], 1)
    >>> e = worst_case_error(u, np.full(N, 1 / N), Diffuse(), 1.5)
    >>> bool(0 < e < 0.01)
    True
    """
    e2 = worst_case_error_squared(points, weights, brdf, s, tol=tol, tile=tile, workers=workers,
                                  embedding=embedding)
    return math.sqrt(max(e2, 0.0))


@dataclass(frozen=True)
class ErrorSpectrum:
    r"""Spectral decomposition of the worst-case error (Eqs. 42–47), degrees l = 0…lmax.

    Attributes
    ----------
    l, a, b : degrees, Sobolev coefficients :math:`a_l`, weight coefficients :math:`b_l`.
    c0 : :math:`c_{l,0}` (Eq. 45).
    d2 : zonal power :math:`d_l^2 = (b_l - c_{l,0})^2` (Eq. 43).
    C2 : anisotropic power :math:`C_l^2 = S_l - c_{l,0}^2 = 2\sum_{m\ge1}|c_{l,m}|^2`
         (Eqs. 44, 59; computed from the m ≥ 1 coefficients, no cancellation).
    S : :math:`S_l = c_{l,0}^2 + C_l^2`.
    e2 : error spectrum :math:`e_l^2 = a_l(d_l^2 + C_l^2)` (Eq. 42 with the errata's a_l).
    wce_zonal, wce_anisotropic : :math:`E_Z` and :math:`E_A` (Eqs. 46–47) summed to lmax.
    wce : E from the closed form Eq. 41 (no truncation).
    partial : :math:`\sum_{l\le lmax} e_l^2`.
    tail : :math:`E^2 - \sum_{l\le lmax} e_l^2` (closed form minus partial sum).
    tail_diagonal : asymptotic estimate of the tail from the diagonal i = j of Eq. 44,
        :math:`\sum_j w_j^2 \sum_{l>lmax} a_l\frac{2l+1}{4\pi} = \sum_j w_j^2 (C - K_{lmax}(1))`,
        since :math:`C_l^2 \to \frac{2l+1}{4\pi}\sum_j w_j^2` (errata).
    """

    l: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c0: np.ndarray
    d2: np.ndarray
    C2: np.ndarray
    S: np.ndarray
    e2: np.ndarray
    wce_zonal: float
    wce_anisotropic: float
    wce: float
    partial: float
    tail: float
    tail_diagonal: float


def error_spectrum(points, weights, brdf: WeightFunction, s: float, lmax: int, *,
                   nthreads: int = 0, tol: float = EMBEDDING_TOL) -> ErrorSpectrum:
    r"""Power spectra and error spectrum of a quadrature rule up to degree lmax (Eqs. 42–47).

    :math:`c_{l,m}` come from ducc0's adjoint SH synthesis (see :mod:`envfit.theory._sh`), O(N +
    lmax² log lmax); ``wce`` is the closed form (Eq. 41) so that ``tail`` shows what the
    truncated spectral sum misses.

    >>> from envfit.theory._brdf import Glossy
    >>> rng = np.random.default_rng(0); N = 64
    >>> z = Glossy(30.0).morph(rng.uniform(size=N)); phi = rng.uniform(0, 2 * np.pi, N)
    >>> u = np.stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z], 1)
    >>> sp = error_spectrum(u, np.full(N, 1 / N), Glossy(30.0), 1.5, 64)
    >>> bool(abs(sp.partial + sp.tail - sp.wce ** 2) < 1e-12)
    True
    """
    s = check_smoothness(s)
    _check_brdf(brdf)
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    l = np.arange(lmax + 1)
    a = sobolev_coefficients(s, lmax)
    b = brdf.sh_coefficients(lmax)
    c0 = zonal_sums(pts, w, lmax)
    C2 = anisotropic_power_spectrum(pts, w, lmax, nthreads=nthreads)
    C2[0] = 0.0
    d2 = (b - c0) ** 2
    e2 = a * (d2 + C2)
    e2w = worst_case_error_squared(pts, w, brdf, s, tol=tol)
    partial = math.fsum(e2[::-1])
    k_at_1 = float(kernel_series(s, np.array(1.0), lmax))
    tail_diag = float(w @ w) * (kernel_constant(s) - k_at_1)
    return ErrorSpectrum(l=l, a=a, b=b, c0=c0, d2=d2, C2=C2, S=c0 ** 2 + C2, e2=e2,
                         wce_zonal=math.sqrt(math.fsum(a * d2)),
                         wce_anisotropic=math.sqrt(math.fsum(a * C2)),
                         wce=math.sqrt(max(e2w, 0.0)), partial=partial,
                         tail=e2w - partial, tail_diagonal=tail_diag)

r"""Worst-case error of Fourier (SH / HSH) truncation of the shading integral.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 5.3, 6.2 and 8 (with the
errata's corrections, docs/ERRATA.md).

Truncating the expansion of the weight function at degree L (Eq. 35) replaces p by p'
(Eq. 48). The worst-case error over f ∈ H^s is (Eqs. 51, 66)

.. math::
    E^2 = \sum_{l\ge0} a_l\,(b_l - b'_l)^2
        = \frac{1}{4\pi^2 r_s^2}\iint K(u,v)\,[p-p'](u)\,[p-p'](v)\,dS\,dS.

* SH truncation: :math:`b'_l = b_l` for l ≤ L, 0 beyond, so
  :math:`E^2 = \sum_{l=L+1}^{\infty} a_l b_l^2` (Eq. 52, errata: the sum starts at L + 1).
* HSH truncation: p' is the HSH expansion truncated at L, zero on the lower hemisphere;
  its SH coefficients are :math:`b'_l = \sum_{l'\le L}\tilde b_{l'}M_{ll'}` (Eq. 31), non-zero
  for every l. The difference is computed without cancellation as
  :math:`b_l - b'_l = \sum_{l'>L}\tilde b_{l'}M_{ll'}` (the HSH series of p converges
  fast; :math:`\tilde b_{l'}` is negligible beyond ``brdf.hsh_degree()``).

Choice of the SH degree ``lmax`` of the l-sum: ``max(2048, 8·(Lmax + 1))`` (the paper
used 170). p − p' has a jump at the horizon (HSH: |b_l − b'_l| ~ J/l for odd l) or a kink
(SH of the diffuse lobe), so the terms :math:`a_l(b_l-b'_l)^2` decay like
:math:`l^{-2s-2}` or faster and the neglected part of :math:`E^2` is
≈ :math:`l_{max}^{-2s-1}` relative to its jump-driven terms. Measured for the glossy HSH
case (n = 30, s = 1.5, L ≤ 16): E with lmax = 2048 differs from lmax = 8192 by ≈ 1e-9
relative, and from the spatial double integral Eq. 66 by ≈ 1e-10 (SH: ≈ 1e-13); the
paper's lmax = 170 would be off by up to 2e-5 relative (7e-6 at L = 13).
"""
from __future__ import annotations

import functools
import math
from typing import Callable

import numpy as np
from scipy import special

from envfit.theory._weight_function import WeightFunction, hsh_to_sh_matrix
from envfit.theory._errors import TheoryParameterError, check_smoothness
from envfit.theory._quadrature import worst_case_error
from envfit.theory._sh import legendre_series
from envfit.theory._sobolev import kernel_constant, sobolev_coefficients
from envfit.theory._weights import equal_weights, optimal_weights

__all__ = ["truncation_error", "truncation_error_curve", "spatial_truncation_error",
           "smallest_degree", "equivalent_qmc_points", "azimuthal_mean_kernel",
           "morphed_spherical_fibonacci"]

_BASES = ("sh", "hsh")


def _check_basis(basis: str) -> str:
    b = str(basis).lower()
    if b not in _BASES:
        raise TheoryParameterError(f"basis must be 'sh' or 'hsh', got {basis!r}")
    return b


def _check_L(L, what="L") -> int:
    try:
        v = int(L)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"{what} must be an integer, got {L!r}") from None
    if v != L or v < 0:
        raise TheoryParameterError(f"{what} must be an integer >= 0, got {L!r}")
    return v


def _default_lmax(Lmax: int) -> int:
    return max(2048, 8 * (Lmax + 1))


def truncation_error_curve(brdf: WeightFunction, s: float, Lmax: int, basis: str = "sh", *,
                           lmax: int | None = None) -> np.ndarray:
    r"""Worst-case truncation errors E(L) for L = 0…Lmax (Eqs. 51–52, errata).

    Returns an array of length Lmax + 1. ``lmax`` is the highest SH degree of the sum of
    Eq. 51 (default ``max(1024, 8(Lmax+1))``, see the module docstring).

    >>> from envfit.theory._brdf import Diffuse
    >>> E = truncation_error_curve(Diffuse(), 1.5, 4)
    >>> bool(E[3] == E[2])          # b_3 = 0 (errata)
    True
    """
    s = check_smoothness(s)
    Lmax = _check_L(Lmax, "Lmax")
    basis = _check_basis(basis)
    lmax = _default_lmax(Lmax) if lmax is None else _check_L(lmax, "lmax")
    if lmax <= Lmax:
        raise TheoryParameterError(f"lmax = {lmax} must exceed Lmax = {Lmax}")
    a = sobolev_coefficients(s, lmax)
    if basis == "sh":
        b = brdf.sh_coefficients(lmax)
        terms = a * b * b
        # E^2(L) = sum_{l > L} a_l b_l^2, summed from the smallest terms up
        tail = np.cumsum(terms[::-1])[::-1]                      # tail[k] = sum_{l >= k}
        e2 = np.append(tail[1:], 0.0)[:Lmax + 1]
    else:
        Lh = max(Lmax, brdf.hsh_degree()) + 8
        bt = brdf.hsh_coefficients(Lh)
        T = hsh_to_sh_matrix(lmax, Lh) * bt[None, :]            # b~_l' M_ll'
        R = np.cumsum(T[:, ::-1], axis=1)[:, ::-1]              # R[:, k] = sum_{l' >= k}
        delta = np.concatenate([R[:, 1:], np.zeros((lmax + 1, 1))], axis=1)[:, :Lmax + 1]
        e2 = a @ (delta * delta)
    return np.sqrt(e2)


def truncation_error(brdf: WeightFunction, s: float, L: int, *, basis: str = "sh",
                     lmax: int | None = None) -> float:
    r"""Worst-case error of truncating the SH or HSH expansion of p at degree L (Eqs. 51–52).

    >>> from envfit.theory._brdf import Diffuse
    >>> truncation_error(Diffuse(), 1.5, 1, basis="hsh")     # exact at L = 1 (errata)
    0.0
    """
    L = _check_L(L)
    return float(truncation_error_curve(brdf, s, L, basis, lmax=lmax)[L])


# ----------------------------------------------------------------------------------------
# spatial form (Eq. 66)

def azimuthal_mean_kernel(s: float, z1, z2) -> np.ndarray:
    r"""Azimuthal mean :math:`\bar k(z_1,z_2) = \frac{1}{2\pi}\int_0^{2\pi} K(u,v)\,d\phi` of Eq. 14.

    With :math:`|u-v|^2 = A - B\cos\phi`, :math:`A = 2 - 2z_1z_2`,
    :math:`B = 2\sqrt{(1-z_1^2)(1-z_2^2)}`, α = s − 1:

    .. math:: \bar k = C - (A+B)^\alpha\,{}_2F_1\!\left(-\alpha, \tfrac12; 1; \tfrac{2B}{A+B}\right),

    which for s = 3/2 is :math:`C - \frac{2}{\pi}\sqrt{A+B}\,E(m)`, m = 2B/(A+B), E the
    complete elliptic integral of the second kind. Legendre form:
    :math:`\bar k = \sum_l a_l\frac{2l+1}{4\pi}P_l(z_1)P_l(z_2)`.
    """
    s = check_smoothness(s)
    z1 = np.clip(np.asarray(z1, dtype=np.float64), -1.0, 1.0)
    z2 = np.clip(np.asarray(z2, dtype=np.float64), -1.0, 1.0)
    t1 = np.arccos(z1)
    t2 = np.arccos(z2)
    # A + B = 4 sin²((θ1+θ2)/2), A − B = 4 sin²((θ1−θ2)/2): no cancellation
    apb = 4.0 * np.sin(0.5 * (t1 + t2)) ** 2
    amb = 4.0 * np.sin(0.5 * (t1 - t2)) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(apb > 0.0, 1.0 - amb / apb, 0.0)
    m = np.clip(m, 0.0, 1.0)
    alpha = s - 1.0
    if alpha == 0.5:
        mean = (2.0 / np.pi) * np.sqrt(apb) * special.ellipe(m)
    else:
        mean = apb ** alpha * special.hyp2f1(-alpha, 0.5, 1.0, m)
    return kernel_constant(s) - mean


def _tanh_sinh(h: float = 1.0 / 32.0, tmax: float = 3.2):
    """Tanh-sinh rule on [−1, 1]: returns (1 + x, 1 − x, w), both distances accurate."""
    t = np.arange(-tmax, tmax + 0.5 * h, h)
    y = 0.5 * np.pi * np.sinh(t)
    one_plus = 2.0 / (1.0 + np.exp(-2.0 * y))
    one_minus = 2.0 / (1.0 + np.exp(2.0 * y))
    w = h * 0.5 * np.pi * np.cosh(t) / np.cosh(y) ** 2
    return one_plus, one_minus, w


def _map_nodes(a, b, rule):
    """Nodes and weights of the tanh-sinh rule on [a, b] (a, b broadcastable arrays)."""
    op, om, w = rule
    a = np.asarray(a, dtype=np.float64)[..., None]
    b = np.asarray(b, dtype=np.float64)[..., None]
    half = 0.5 * (b - a)
    x = np.where(op <= om, a + half * op, b - half * om)
    return x, half * w


def _residual(brdf: WeightFunction, L: int, basis: str):
    r"""q̂(z) = (p − p')(z)/r_s as a vectorised function on [−1, 1]."""
    r_s = brdf.r_s
    if basis == "sh":
        b = brdf.sh_coefficients(L)
        c = 2.0 * np.pi * b * np.sqrt((2 * np.arange(L + 1) + 1) / (4.0 * np.pi))

        def q(z):
            return brdf.p(z) / r_s - legendre_series(c, z)
    else:
        bt = brdf.hsh_coefficients(L)
        c = 2.0 * np.pi * bt * np.sqrt((2 * np.arange(L + 1) + 1) / (2.0 * np.pi))

        def q(z):
            z = np.asarray(z, dtype=np.float64)
            val = brdf.p(z) / r_s - legendre_series(c, 2.0 * np.clip(z, 0.0, 1.0) - 1.0)
            return np.where(z >= 0.0, val, 0.0)
    return q


def spatial_truncation_error(brdf: WeightFunction, s: float, L: int, *, basis: str = "sh",
                             h: float = 1.0 / 16.0) -> float:
    r"""E(L) from the spatial double integral Eq. 66, independently of the SH series.

    Using the zonal structure, :math:`dS = dz\,d\phi` and the azimuthal mean kernel
    (:func:`azimuthal_mean_kernel`, closed form with ₂F₁ / elliptic E):

    .. math:: E^2 = \int_{-1}^{1}\!\int_{-1}^{1}\hat q(z_1)\hat q(z_2)\,\bar k(z_1,z_2)\,dz_1dz_2,
              \qquad \hat q = (p - p')/r_s,

    with p' the SH expansion truncated at L on the whole sphere (Eq. 48) or the HSH one on
    the upper hemisphere (0 below). Both integrals use tanh-sinh rules (step h) on pieces
    split at the non-smooth points z = 0 (horizon) and z₂ = z₁ (kernel cusp), where the
    double-exponential rule keeps its fast convergence (h = 1/16 gives ≈1e-13 relative;
    ≈ 0.01 s for s = 1.5 with the elliptic form, ≈ 0.5 s with ₂F₁). For tests.
    """
    s = check_smoothness(s)
    L = _check_L(L)
    basis = _check_basis(basis)
    q = _residual(brdf, L, basis)
    rule = _tanh_sinh(h)
    outer = [(-1.0, 0.0), (0.0, 1.0)] if basis == "sh" else [(0.0, 1.0)]
    total = []
    for a0, b0 in outer:
        z1, w1 = _map_nodes(a0, b0, rule)              # (n1,)
        q1 = q(z1)
        # inner pieces split at -1, 0, z1, 1 (only the part where q̂ can be non-zero)
        lo_in = -1.0 if basis == "sh" else 0.0
        brk = np.sort(np.stack([np.full_like(z1, lo_in), np.zeros_like(z1), z1,
                                np.ones_like(z1)], axis=1), axis=1)
        inner = 0.0
        for k in range(3):
            z2, w2 = _map_nodes(brk[:, k], brk[:, k + 1], rule)   # (n1, n2)
            kb = azimuthal_mean_kernel(s, z1[:, None], z2)
            inner = inner + np.sum(w2 * q(z2) * kb, axis=1)
        total.append(float(np.sum(w1 * q1 * inner)))
    e2 = math.fsum(total)
    return math.sqrt(max(e2, 0.0))


# ----------------------------------------------------------------------------------------
# cut-offs and QMC equivalents (Sec. 8, Table 1)

def smallest_degree(brdf: WeightFunction, s: float, target: float, basis: str = "sh", *,
                    rtol: float = 0.0, Lmax: int = 512) -> int:
    r"""Smallest L with E(L) ≤ target·(1 + rtol) (Sec. 8, Table 1).

    ``rtol`` = 0 is the strict criterion. For s = 1.5 and E = 2.5e-3 it gives diffuse SH
    L = 6, glossy (n = 30) SH L = 14, glossy HSH L = 9, and for E = 1e-2 glossy SH 11,
    HSH 7. Table 1 prints 4 and 13 for the first two: E(4) = 2.66e-3 and E(13) = 2.56e-3
    exceed 2.5e-3 by 6 % and 2.4 %, i.e. the paper read its cut-offs off a log plot;
    ``rtol = 0.1`` reproduces all five published values. Raises TheoryParameterError if
    E(L) stays above the target up to ``Lmax``.

    >>> from envfit.theory._brdf import Glossy
    >>> smallest_degree(Glossy(30.0), 1.5, 1e-2, "hsh")
    7
    """
    target = float(target)
    if not (target > 0 and np.isfinite(target)):
        raise TheoryParameterError(f"target error must be > 0, got {target!r}")
    rtol = float(rtol)
    if not (rtol >= 0):
        raise TheoryParameterError(f"rtol must be >= 0, got {rtol!r}")
    L = 32
    while True:
        E = truncation_error_curve(brdf, s, L, basis)
        ok = np.nonzero(E <= target * (1.0 + rtol))[0]
        if ok.size:
            return int(ok[0])
        if L >= Lmax:
            raise TheoryParameterError(
                f"E(L) > {target:g} for all L ≤ {L} (E({L}) = {E[-1]:.3g})")
        L = min(2 * L, Lmax)


def morphed_spherical_fibonacci(n: int, brdf: WeightFunction | None = None) -> np.ndarray:
    r"""Spherical Fibonacci points on the upper hemisphere, optionally morphed for p (N×3).

    :math:`z'_j = 1 - (2j+1)/(2N)`, :math:`\phi_j = 2\pi\,\mathrm{frac}(j/\Phi)`, j = 0…N−1
    (docs/ERRATA.md, "Point sets"); with ``brdf`` the heights are importance-sampled,
    :math:`z_j = F^{-1}(z'_j)` (``brdf.morph``; Sec. 7.2). A local generator so that this
    module does not depend on ``envfit.theory._pointsets``.
    """
    n = _check_L(n, "n")
    if n < 1:
        raise TheoryParameterError("n must be >= 1")
    j = np.arange(n, dtype=np.float64)
    zp = 1.0 - (2.0 * j + 1.0) / (2.0 * n)
    golden = 0.5 * (1.0 + math.sqrt(5.0))
    phi = 2.0 * np.pi * np.mod(j / golden, 1.0)
    z = zp if brdf is None else brdf.morph(zp)
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def equivalent_qmc_points(target_error: float, brdf: WeightFunction, s: float,
                          pointset_fn: Callable[[int], np.ndarray] | None = None, *,
                          weights: str | Callable = "equal", nmin: int = 1,
                          nmax: int = 1 << 17, return_error: bool = False):
    r"""Number of QMC points whose worst-case error (Eq. 41) reaches ``target_error`` (Sec. 8).

    ``pointset_fn(n)`` returns n unit vectors in the local frame (BRDF axis +z). The
    default is the paper's choice for Fig. 5 / Table 1: spherical Fibonacci points with
    equal weights, *morphed* for p (:func:`morphed_spherical_fibonacci` with ``brdf``):
    equal weights 1/N only estimate the normalised integral of Eq. 17 when the points are
    distributed with density p/r_s, and Sec. 7.2 states that all QMC sets are morphed.
    ``weights`` is "equal", "optimal" (OSW) or a callable(points) → weights.

    Search: n doubles from ``nmin`` until E(n) ≤ target, then bisection between the last
    failing and the first passing n. E(n) of a deterministic sequence is not exactly
    monotone, so the result is a crossing, E(n) ≤ target < E(n − 1) (the smallest such n
    when E is monotone). Returns n (and E(n) if ``return_error``).

    For s = 1.5, E = 2.5e-3 (Table 1: ≈2000 diffuse, ≈1000 glossy): 1997 (diffuse) and
    1067 (glossy, n = 30); E = 4.4e-3 (Fig. 5(a) caption: ≈930): 947 (diffuse).
    """
    s = check_smoothness(s)
    target = float(target_error)
    if not (target > 0 and np.isfinite(target)):
        raise TheoryParameterError(f"target error must be > 0, got {target_error!r}")
    if pointset_fn is None:
        def pointset_fn(n):
            return morphed_spherical_fibonacci(n, brdf)
    wfn = _weight_rule(weights, brdf, s)

    @functools.lru_cache(maxsize=None)
    def err(n: int) -> float:
        pts = np.asarray(pointset_fn(n), dtype=np.float64)
        return worst_case_error(pts, wfn(pts), brdf, s)

    n = _first_crossing(err, target, max(1, _check_L(nmin, "nmin")), nmax)
    return (n, err(n)) if return_error else n


def _weight_rule(weights: str | Callable, brdf: WeightFunction, s: float) -> Callable:
    """The sample weights of :func:`equivalent_qmc_points` as a function of the points:
    ``"equal"`` (1/N), ``"optimal"`` (OSW for ``brdf`` and s) or the given callable."""
    if weights == "equal":
        return lambda pts: equal_weights(pts.shape[0])
    if weights == "optimal":
        return lambda pts: optimal_weights(pts, brdf, s)
    if callable(weights):
        return weights
    raise TheoryParameterError(f"weights must be 'equal', 'optimal' or a callable, got {weights!r}")


def _first_crossing(err: Callable[[int], float], target: float, nmin: int, nmax: int) -> int:
    """The n of :func:`equivalent_qmc_points`: n doubles from ``nmin`` until
    ``err(n) <= target`` (TheoryParameterError beyond ``nmax``), then bisection between the
    last failing and the first passing n: ``err(n) <= target < err(n - 1)``."""
    if err(nmin) <= target:
        return nmin
    lo, hi = nmin, 2 * nmin
    while err(hi) > target:
        lo, hi = hi, 2 * hi
        if hi > nmax:
            raise TheoryParameterError(f"the worst-case error is still {err(lo):.3g} > "
                                       f"{target:g} at n = {lo}; raise nmax")
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if err(mid) <= target:
            hi = mid
        else:
            lo = mid
    return hi

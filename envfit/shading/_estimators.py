r"""Estimators of the normalised shading integral (Eq. 17) on a lat-long map, and their RMSE.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Eqs. 34–35 and Sec. 9.2 (Figs. 7–8).

Every estimator sees the same function as the ground truth of :mod:`envfit.shading._ground_truth`: the
map's bilinear interpolant ``f = envmap.lookup`` (for the quadrature rules literally that
lookup; for the truncations the exact SH / HSH projections of that interpolant), so the
error of an estimator is its own error, not a resampling artefact.

* :func:`quadrature_estimates` — Eq. 34, :math:`\tilde I(a) = \sum_j w_j f(R_a u_j)`: one
  rule in the local frame of the integral (axis +z: e.g. a theory point set morphed for the
  BRDF with equal or optimal weights) rotated to each axis by the Duff et al. (2017) frame
  :func:`envfit.theory._pointsets.frame_from_axis`, optionally twisted by an independent uniform
  angle about each axis (``seed``) so that an RMSE over axes also averages over the
  pattern's orientation (Fig. 7).
* :func:`sh_truncation_estimates` / :func:`sh_truncation_curve` — Eq. 35 with SH:
  :math:`\tilde I_L(a) = \sum_{l\le L} b_l f^{(a)}_{l,0}`, where :math:`f^{(a)}_{l,0} =
  \sqrt{4\pi/(2l+1)}\sum_m f_{lm}Y_{lm}(a)` is the zonal coefficient of f in the frame of a
  (the rotation of the map's coefficients to the axis). That is the zonal convolution of
  :func:`envfit.shading._ground_truth.shading_integral` (``method="sh"``) with :math:`b_l` zeroed beyond L.
* :func:`hsh_truncation_estimates` / :func:`hsh_truncation_curve` — Eq. 35 with HSH on the
  hemisphere of a: :math:`\tilde I_L(a) = \sum_{l\le L}\tilde b_l\tilde f_{l,0}(a)`,
  :math:`\tilde f_{l,0}(a) = \int_{u\cdot a>0} f\,\tilde Y_{l,0}\,dS`,
  :math:`\tilde Y_{l,0}(u) = \sqrt{(2l+1)/(2\pi)}\,P_l(2u\cdot a-1)`.
  The projections are computed by the pixel-patch quadrature of
  :func:`envfit.shading._ground_truth.hemisphere_integrals` (all l ≤ L at once, Legendre recurrence in
  2z − 1), which clips the hemisphere exactly. The alternative — the SH path with the
  converted coefficients of ``truncated_hsh_as_sh`` (Eq. 31) — is *not* used: the truncated
  HSH weight jumps at the horizon (by :math:`\sum_l\tilde b_l\tilde Y_{l,0}(0)`), so its SH
  expansion decays only like :math:`l^{-3/2}` in :math:`\lambda_l`; measured on a 128×64
  sun-and-sky map (glossy n = 30, L = 2…10) the SH path is off by 2e-4, 5e-5, 3e-6 of the
  largest value at SH degree 63, 127, 255 — comparable to the truncation error itself at
  L ≈ 10–20 — while the clipped quadrature agrees with an independent fine quadrature to
  ~1e-9.
* :func:`rmse_over_axes` — root mean square error over axes (and channels).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> m = EnvMap(np.full((8, 16, 3), 0.5))
>>> axes = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
>>> pts = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]); w = np.array([0.5, 0.5])
>>> quadrature_estimates(m, axes, pts, w).round(12).tolist()
[[0.5, 0.5, 0.5], [0.5, 0.5, 0.5]]
>>> float(rmse_over_axes(sh_truncation_estimates(m, axes, "diffuse", 0), np.full((2, 3), 0.5)).total) < 1e-12
True
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.defaults import DEFAULT_SHININESS
from envfit.theory import frame_from_axis

from envfit.maps import EnvMap
from envfit.base import as_unit_vectors, check_int, check_ints
from envfit.base import ParameterError
from envfit.base import check_memory
from envfit.shading._bilinear_sh import bilinear_sh_coefficients, synthesize_convolution
from envfit.shading._ground_truth import (funk_hecke_factors, hsh_weight_coefficients,
                                          weight_function)
from envfit.shading._hemisphere import hemisphere_integrals
from envfit.shading._patches import axes_to_local

__all__ = ["quadrature_estimates", "sh_truncation_estimates", "sh_truncation_curve",
           "hsh_truncation_estimates", "hsh_truncation_curve", "hsh_projections",
           "rmse_over_axes", "RMSE", "LOOKUP_BLOCK"]

#: directions looked up per block in :func:`quadrature_estimates` (≈ 100 MB of temporaries)
LOOKUP_BLOCK = 1 << 21


def twisted_frames(axes: np.ndarray, seed=None) -> np.ndarray:
    """(M, 3, 3) orthonormal frames whose third column is each unit axis; with ``seed``, each
    frame gets an independent uniform random rotation (twist) about its axis, drawn in one go
    from ``numpy.random.default_rng(seed)`` so the result does not depend on blocking."""
    R = frame_from_axis(axes)
    if seed is not None:
        alpha = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, R.shape[0])
        ca, sa = np.cos(alpha), np.sin(alpha)
        t = R[:, :, 0] * ca[:, None] + R[:, :, 1] * sa[:, None]
        b = -R[:, :, 0] * sa[:, None] + R[:, :, 1] * ca[:, None]
        R = np.stack([t, b, R[:, :, 2]], axis=2)
    return R


def _degrees(Ls, name="L") -> np.ndarray:
    """A non-empty list of degrees ≥ 0 (:func:`envfit.base._checks.check_ints`) as int64."""
    arr = np.atleast_1d(np.asarray(Ls, dtype=object))
    if arr.ndim != 1 or arr.size == 0:
        raise ParameterError(f"{name} must be a non-empty list of degrees, got {Ls!r}")
    return np.asarray(check_ints(arr.tolist(), name, 0), dtype=np.int64)


# ----------------------------------------------------------------------------- quadrature

def quadrature_estimates(envmap: EnvMap, axes, local_points, weights, *, seed=None) -> np.ndarray:
    r"""Quadrature estimates :math:`\tilde I(a_m) = \sum_j w_j f(R_m u_j)` (Eq. 34) for M axes, (M, C).

    Parameters
    ----------
    envmap : the map; f = ``envmap.lookup`` (bilinear).
    axes : (M, 3) or (3,) world axes (normalised internally).
    local_points : (N, 3) directions in the local frame of the integral (axis = +z), e.g. a
        hemisphere point set morphed for the BRDF (normalised internally).
    weights : (N,) quadrature weights (1/N for an importance-sampled equal-weight rule; the
        estimate of the *normalised* integral of Eq. 17).
    seed : None — each axis uses :math:`R_m` = :func:`envfit.theory._pointsets.frame_from_axis`
        (Duff et al. 2017); otherwise :math:`R_m R_z(\alpha_m)` with
        :math:`\alpha_m` i.i.d. uniform on [0, 2π) from ``numpy.random.default_rng(seed)``,
        drawn once for all M axes (the same twist as
        :func:`envfit.theory._pointsets.rotate_to_axes` with that seed), so the result does not
        depend on the blocking.

    Work: M·N bilinear lookups in blocks of :data:`LOOKUP_BLOCK` directions.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.arange(8.0).reshape(2, 4), up="z")
    >>> quadrature_estimates(m, [0, 0, 1.0], [[0, 0, 1.0]], [1.0]).round(12).tolist()   # the up pole
    [[1.5]]
    """
    A = as_unit_vectors(axes, name="axes", allow_empty=True)
    P = as_unit_vectors(local_points, name="local_points")
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (P.shape[0],) or not np.all(np.isfinite(w)):
        raise ParameterError(f"weights must be {P.shape[0]} finite numbers, got shape {w.shape}")
    m_total, n = A.shape[0], P.shape[0]
    c = envmap.channels
    out = np.empty((m_total, c))
    R = twisted_frames(A, seed)                                  # (M, 3, 3), columns t, b, a
    mb = max(1, LOOKUP_BLOCK // n)
    check_memory(min(m_total, mb) * n * 8 * (3 + 2 * c) + 8 * n * 4,
                 f"a block of {min(m_total, mb)} axes x {n} points",
                 hint="use fewer points")
    for m0 in range(0, m_total, mb):
        m1 = min(m_total, m0 + mb)
        dirs = np.einsum("mij,nj->mni", R[m0:m1], P)             # (mb, N, 3)
        vals = envmap.lookup(dirs)                                # (mb, N, C)
        out[m0:m1] = np.einsum("mnc,n->mc", vals, w)
    return out


# ----------------------------------------------------------------------------- SH truncation

def sh_truncation_curve(envmap: EnvMap, axes, brdf="diffuse", Ls=(0, 1, 2), *,
                        shininess: float = DEFAULT_SHININESS, nthreads: int = 0) -> np.ndarray:
    r"""SH truncation estimates (Eq. 35) for several cut-off degrees, (len(Ls), M, C).

    :math:`\tilde I_L(a) = \sum_{l\le L} b_l f^{(a)}_{l,0} = \sum_{l\le L}\lambda_l\sum_m
    f_{lm}Y_{lm}(a)`, with :math:`f_{lm}` the exact SH coefficients of the map's bilinear
    interpolant (:func:`envfit.shading._ground_truth.bilinear_sh_coefficients`, computed once to max(Ls))
    and :math:`\lambda_l = \sqrt{4\pi/(2l+1)}\,b_l` (:func:`envfit.shading._ground_truth.funk_hecke_factors`).
    One ``ducc0.sht.synthesis_general`` per L (its cost grows with L², so the small degrees of
    a curve are cheap). ``L = 0`` gives the map's mean :math:`f_{00}/\sqrt{4\pi}`; L → ∞ the
    ground truth.
    """
    weight = weight_function(brdf, shininess)
    L = _degrees(Ls, "Ls")
    A = axes_to_local(as_unit_vectors(axes, name="axes", allow_empty=True), envmap.up)
    top = int(L.max())
    alm = bilinear_sh_coefficients(envmap, top, nthreads=nthreads)
    lam = funk_hecke_factors(weight, top)
    out = np.empty((L.size, A.shape[0], envmap.channels))
    for i, l in enumerate(L):
        out[i] = synthesize_convolution(alm, int(l), lam[:l + 1], A, nthreads=nthreads)
    return out


def sh_truncation_estimates(envmap: EnvMap, axes, brdf="diffuse", L: int = 2, *,
                            shininess: float = DEFAULT_SHININESS, nthreads: int = 0) -> np.ndarray:
    r"""SH truncation estimate (Eq. 35) :math:`\sum_{l\le L} b_l f^{(a)}_{l,0}` at each axis, (M, C).

    See :func:`sh_truncation_curve`.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 3.0))
    >>> sh_truncation_estimates(m, [0, 1.0, 0], "glossy", 4).round(9).tolist()
    [[3.0]]
    """
    return sh_truncation_curve(envmap, axes, brdf, [L], shininess=shininess,
                               nthreads=nthreads)[0]


# ----------------------------------------------------------------------------- HSH truncation

def _legendre_shifted(lmax: int):
    r"""Kernel generator of :math:`P_l(2z-1)`, l = 0…lmax (recurrence in place, O(1) buffers).

    The normalisation :math:`\sqrt{(2l+1)/2\pi}` of :math:`\tilde Y_{l,0}` is applied by the
    callers after the (linear) quadrature sums, which saves a pass over the node arrays.
    Each yielded array is only valid until the next one is requested.
    """
    def kernel(z):
        x = 2.0 * np.asarray(z, dtype=np.float64) - 1.0
        p_prev = np.ones_like(x)
        yield p_prev
        if lmax == 0:
            return
        p = x.copy()
        yield p
        nxt = np.empty_like(x)
        for l in range(1, lmax):
            np.multiply(x, p, out=nxt)
            nxt *= (2 * l + 1) / (l + 1)
            p_prev *= l / (l + 1)
            nxt -= p_prev
            p_prev, p, nxt = p, nxt, p_prev
            yield p
    return kernel


def _hsh_norms(lmax: int) -> np.ndarray:
    return np.sqrt((2 * np.arange(lmax + 1) + 1) / (2.0 * np.pi))


def hsh_projections(envmap: EnvMap, axes, lmax: int) -> np.ndarray:
    r"""Zonal HSH coefficients :math:`\tilde f_{l,0}(a) = \int_{u\cdot a>0} f\,\tilde Y_{l,0}\,dS`, l ≤ lmax, (M, lmax+1, C).

    f is the bilinear interpolant; :math:`\tilde Y_{l,0}(u) = \sqrt{(2l+1)/(2\pi)}\,
    P_l(2u\cdot a-1)` (orthonormal on the hemisphere of a). Pixel-patch Gauss–Legendre
    quadrature with the horizon clipped exactly (:func:`envfit.shading._ground_truth.hemisphere_integrals`,
    bandwidth lmax), all degrees at once by the Legendre recurrence in 2z − 1.
    """
    lmax = check_int(lmax, "lmax", 0)
    raw = hemisphere_integrals(envmap, as_unit_vectors(axes, name="axes", allow_empty=True), _legendre_shifted(lmax), lmax + 1,
                               degree=lmax)
    return raw * _hsh_norms(lmax)[None, :, None]


def hsh_truncation_curve(envmap: EnvMap, axes, brdf="diffuse", Ls=(0, 1, 2), *,
                         shininess: float = DEFAULT_SHININESS) -> np.ndarray:
    r"""HSH truncation estimates (Eq. 35, HSH) for several cut-off degrees, (len(Ls), M, C).

    :math:`\tilde I_L(a) = \sum_{l\le L}\tilde b_l\,\tilde f_{l,0}(a)` with
    :math:`\tilde b_l` = :func:`envfit.shading._ground_truth.hsh_weight_coefficients` (Eqs. 23/28, errata)
    and the projections of :func:`hsh_projections` computed once to max(Ls).
    For the diffuse lobe :math:`\tilde b_l = 0` for l ≥ 2, so every L ≥ 1 is exact.
    """
    weight = weight_function(brdf, shininess)
    L = _degrees(Ls, "Ls")
    top = int(L.max())
    proj = hsh_projections(envmap, axes, top)                  # (M, top+1, C)
    bt = hsh_weight_coefficients(weight, top)
    partial = np.cumsum(proj * bt[None, :, None], axis=1)       # (M, top+1, C)
    return np.moveaxis(partial[:, L, :], 1, 0).copy()


def hsh_truncation_estimates(envmap: EnvMap, axes, brdf="diffuse", L: int = 2, *,
                             shininess: float = DEFAULT_SHININESS) -> np.ndarray:
    r"""HSH truncation estimate :math:`\sum_{l\le L}\tilde b_l\tilde f_{l,0}(a)` at each axis, (M, C).

    Computed as one hemispherical quadrature with the single kernel
    :math:`p'_L(z)/(2\pi r_s) = \sum_{l\le L}\tilde b_l\tilde Y_{l,0}(z)` (Eq. 48 for HSH),
    which equals the sum of the projections.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> hsh_truncation_estimates(m, [0, 1.0, 0], "diffuse", 1).round(9).tolist()
    [[2.0]]
    """
    weight = weight_function(brdf, shininess)
    L = check_int(L, "L", 0)
    coef = hsh_weight_coefficients(weight, L) * _hsh_norms(L)
    basis = _legendre_shifted(L)

    def kernel(z):
        acc = np.zeros_like(z)
        for b, p in zip(coef, basis(z)):
            acc += b * p
        yield acc

    return hemisphere_integrals(envmap, as_unit_vectors(axes, name="axes", allow_empty=True), kernel, 1, degree=L)[:, 0, :]


# ----------------------------------------------------------------------------- errors

@dataclass(frozen=True)
class RMSE:
    """Root mean square errors over axes: ``total`` over axes and channels, ``per_channel``."""

    total: np.ndarray | float
    per_channel: np.ndarray


def rmse_over_axes(estimates, truth) -> RMSE:
    r"""RMSE over axes of estimates (…, M, C) against the truth (M, C).

    .. math:: \mathrm{RMSE} = \Big(\frac{1}{MC}\sum_{m,c}(\tilde I_{mc} - I_{mc})^2\Big)^{1/2},
              \qquad \mathrm{RMSE}_c = \Big(\frac1M\sum_m(\tilde I_{mc} - I_{mc})^2\Big)^{1/2}

    Leading axes of ``estimates`` (e.g. the L of a truncation curve) are kept: ``total``
    has the leading shape (a float when there is none), ``per_channel`` that shape + (C,).

    >>> r = rmse_over_axes(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([[1.0, 2.0], [3.0, 2.0]]))
    >>> float(r.total), r.per_channel.tolist()
    (1.0, [0.0, 1.4142135623730951])
    """
    e = np.asarray(estimates, dtype=np.float64)
    t = np.asarray(truth, dtype=np.float64)
    if t.ndim == 1:
        t = t[:, None]
        if e.ndim >= 1 and e.shape[-1] == t.shape[0]:
            e = e[..., None]
    if t.ndim != 2 or e.ndim < 2 or e.shape[-2:] != t.shape:
        raise ParameterError(f"estimates (..., M, C) and truth (M, C) disagree: "
                             f"{e.shape} vs {np.shape(truth)}")
    if t.shape[0] == 0:
        raise ParameterError("no axes to average over")
    d2 = (e - t) ** 2
    per = np.sqrt(d2.mean(axis=-2))
    tot = np.sqrt(d2.mean(axis=(-2, -1)))
    return RMSE(total=float(tot) if tot.ndim == 0 else tot, per_channel=per)

r"""Sobolev spaces on the sphere: the generalized distance kernel and its Legendre spectrum.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Sec. 3.2.

For 1 < s < 2 the generalized distance kernel (Brauchart et al. 2014) is

.. math::  K^{(s)}_{gd}(u, v) = \frac{2^{2s-1}}{s} - |u - v|^{2s-2}          \quad (14)

and its Legendre expansion :math:`K = \sum_l a_l \frac{2l+1}{4\pi} P_l(u\cdot v)` (Eq. 8) has

.. math::  a_0 = 4\pi \frac{2^{2s-2}}{s}, \qquad
           a_l = -4\pi \frac{2^{2s-2}}{s}
                 \frac{\Gamma(1-s+l)\,\Gamma(1+s)}{\Gamma(1+s+l)\,\Gamma(1-s)}, \ l\ge 1.
           \quad (15, 16)

:math:`a_l` decays like :math:`l^{-2s}`. Under the Gaussian-process reading used by
``data_gen`` and ``envfit fit``, a function whose SH coefficients are independent
:math:`f_{lm}\sim N(0, a_l)` has covariance :math:`K^{(s)}`.
"""
from __future__ import annotations

import numpy as np
from scipy import special

from envfit.theory._errors import check_smoothness

__all__ = ["sobolev_coefficients", "generalized_distance_kernel", "kernel_from_distance2",
           "kernel_constant", "kernel_series"]


def kernel_constant(s: float) -> float:
    r"""The constant term :math:`2^{2s-1}/s` of the generalized distance kernel (Eq. 14)."""
    s = check_smoothness(s)
    return 2.0 ** (2 * s - 1) / s


def sobolev_coefficients(s: float, lmax: int) -> np.ndarray:
    r"""Legendre coefficients :math:`a_l^{(s)}`, l = 0…lmax, of :math:`K^{(s)}_{gd}` (Eqs. 15–16).

    Computed with the Pochhammer symbol :math:`\Gamma(l+1-s)/\Gamma(l+1+s)` =
    ``poch(l+1+s, -2s)``, so it is stable for any lmax (a plain Gamma overflows
    before l = 170). For s = 1.5, :math:`a_0 = 16\pi/3` and
    :math:`a_l = 2\pi/((l-\frac12)(l+\frac12)(l+\frac32))`.

    >>> a = sobolev_coefficients(1.5, 3)
    >>> bool(np.isclose(a[0], 16 * np.pi / 3))
    True
    """
    s = check_smoothness(s)
    lmax = int(lmax)
    if lmax < 0:
        raise ValueError(f"lmax must be >= 0, got {lmax}")
    l = np.arange(lmax + 1, dtype=np.float64)
    c = 4.0 * np.pi * 2.0 ** (2 * s - 2) / s
    a = np.empty(lmax + 1)
    a[0] = c
    if lmax >= 1:
        # -Gamma(1+s)/Gamma(1-s) > 0 for 1 < s < 2
        pref = -c * special.gamma(1 + s) / special.gamma(1 - s)
        a[1:] = pref * special.poch(l[1:] + 1 + s, -2 * s)
    return a


def kernel_from_distance2(s: float, dist2):
    r""":math:`K^{(s)}_{gd}` as a function of the squared chordal distance :math:`|u-v|^2 = 2 - 2u\cdot v` (Eqs. 10, 14)."""
    s = check_smoothness(s)
    d2 = np.maximum(np.asarray(dist2, dtype=np.float64), 0.0)
    return 2.0 ** (2 * s - 1) / s - d2 ** (s - 1)


def generalized_distance_kernel(s: float, u, v) -> np.ndarray:
    r"""Kernel matrix :math:`K^{(s)}_{gd}(u_i, v_j)` (Eq. 14) for unit vectors u (…×3), v (…×3).

    Returns the broadcast of ``u[..., None, :]`` against ``v[None, ...]`` when both are 2-D
    (an M×N matrix); 1-D inputs give a scalar.
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    if u.ndim == 1 and v.ndim == 1:
        return kernel_from_distance2(s, np.sum((u - v) ** 2))
    u2 = np.atleast_2d(u)
    v2 = np.atleast_2d(v)
    # |u - v|^2 = 2 - 2 u.v for unit vectors (Eq. 10); BLAS for the dot products. Near
    # coincident pairs lose all relative precision that way (2 - 2u.v ~ 1e-16 instead of 0,
    # i.e. |u-v|^{2s-2} ~ 1e-8 at s = 1.5), so those entries are recomputed from differences.
    d2 = np.maximum(2.0 - 2.0 * (u2 @ v2.T), 0.0)
    close = np.nonzero(d2 < 1e-6)
    if close[0].size:
        d2[close] = np.sum((u2[close[0]] - v2[close[1]]) ** 2, axis=-1)
    return kernel_from_distance2(s, d2)


def kernel_series(s: float, t, lmax: int) -> np.ndarray:
    r"""Partial sum of Eq. 8, :math:`\sum_{l\le l_{max}} a_l \frac{2l+1}{4\pi} P_l(t)`, t = u·v.

    Converges to :func:`kernel_from_distance2` at ``2 - 2t`` as lmax grows (slowly near
    t = 1, where the kernel has a cusp). Uses the three-term Legendre recurrence.
    """
    t = np.asarray(t, dtype=np.float64)
    a = sobolev_coefficients(s, lmax)
    p_prev = np.ones_like(t)
    out = a[0] / (4 * np.pi) * p_prev
    if lmax == 0:
        return out
    p = t.copy()
    out = out + a[1] * 3 / (4 * np.pi) * p
    for l in range(1, lmax):
        p_next = ((2 * l + 1) * t * p - l * p_prev) / (l + 1)
        p_prev, p = p, p_next
        out = out + a[l + 1] * (2 * l + 3) / (4 * np.pi) * p
    return out

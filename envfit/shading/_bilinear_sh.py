r"""Exact SH coefficients of a map's bilinear interpolant and the zonal convolution at axes.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 4.2–4.3 (Eqs. 19–20).

The fast ground truth (``shading_integral(..., method="sh")``,
:mod:`envfit.shading._ground_truth`) and the SH truncation estimators: per row the Fourier
coefficients of the piecewise-linear interpolant in φ are the DFT times
:math:`\mathrm{sinc}^2(m\Delta\varphi/2)` (:func:`row_fourier`; any m, aliases included);
across rows they are linear in θ on each bilinear patch (:mod:`envfit.shading._patches`), so
the Legendre integrals are done by Gauss–Legendre per patch row (``ducc0.sht.leg2alm``;
:func:`bilinear_sh_coefficients`). Funk–Hecke then gives
:math:`I(a) = \sum_{l\le l_{max}} \lambda_l \sum_m f_{lm} Y_{lm}(a)`, synthesised at the axes
by ``ducc0.sht.synthesis_general`` (:func:`synthesize_convolution`).
"""
from __future__ import annotations

import numpy as np
import ducc0

from envfit.theory import gauss_legendre_01

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.base import check_memory
from envfit.maps import EnvMap
from envfit.shading._patches import gauss_legendre_order, local_angles, patch_rows

__all__ = ["DUCC_EPSILON", "row_fourier", "bilinear_sh_coefficients", "alm_l_index",
           "synthesize_convolution"]

#: accuracy requested from ducc0's NUFFT in synthesis_general (its double floor is ~2e-13)
DUCC_EPSILON = 1e-12


def row_fourier(data: np.ndarray, lmax: int) -> np.ndarray:
    r"""Fourier coefficients :math:`c_m`, m = 0…lmax, of each row's periodic piecewise-linear interpolant.

    Row values :math:`v_j` at :math:`\varphi_j = \varphi_0 + j\Delta`, Δ = 2π/W,
    :math:`\varphi_0 = \pi/W`; the interpolant is :math:`\sum_j v_j\Lambda((\varphi-\varphi_j)/\Delta)`
    with the hat Λ, so

    .. math:: c_m = \frac{1}{2\pi}\int_0^{2\pi} R(\varphi)e^{-im\varphi}d\varphi
              = \frac{1}{W}\,\mathrm{sinc}^2\!\Big(\frac{m}{W}\Big)\, e^{-im\varphi_0}\,
                \hat v_{m \bmod W}

    (``numpy.sinc``, :math:`\hat v` the DFT). Returns (H, lmax+1, C) complex.
    """
    h, w, c = data.shape
    vhat = np.fft.rfft(data, axis=1)                                  # (H, W//2+1, C)
    m = np.arange(lmax + 1)
    k = m % w
    conj = k > w // 2
    kk = np.where(conj, w - k, k)
    g = vhat[:, kk, :]
    g = np.where(conj[None, :, None], np.conj(g), g)
    fac = np.sinc(m / w) ** 2 / w * np.exp(-1j * m * np.pi / w)
    return g * fac[None, :, None]


def bilinear_sh_coefficients(envmap: EnvMap, lmax: int, *, nthreads: int = 0) -> np.ndarray:
    r"""SH coefficients :math:`f_{lm} = \int f\,Y^*_{lm}\,dS`, l ≤ lmax, of the map's bilinear interpolant.

    Exact up to Gauss–Legendre accuracy (~1e-10): per patch row the φ-Fourier coefficients
    are :math:`c_m(\theta) = (1-t)\,c_m^{(r)} + t\,c_m^{(r+1)}` (linear in θ, t the row
    fraction; the virtual rows beyond the poles have :math:`c_m^{(-1)} = (-1)^m c_m^{(0)}`),
    and :math:`f_{lm} = 2\pi\int_0^\pi c_m(\theta)\,\lambda_{lm}(\theta)\sin\theta\,d\theta`
    is summed over q Gauss nodes per patch row by ``ducc0.sht.leg2alm``, q from
    :func:`gauss_legendre_order` for degree lmax + 1 on a row of height π/H. lmax may
    exceed H − 1 (the interpolant is not band-limited).

    Returns complex (C, (lmax+1)(lmax+2)/2) in ducc0's m-major (healpy) layout, the map's
    *local* frame. Coefficients of a real map with m ≥ 0 only, as ``ducc0.sht.analysis_2d``.

    >>> m = EnvMap(np.ones((8, 16, 1)))
    >>> alm = bilinear_sh_coefficients(m, 4)
    >>> bool(abs(alm[0, 0] - np.sqrt(4 * np.pi)) < 1e-12 and np.abs(alm[0, 1:]).max() < 1e-12)
    True
    """
    lmax = check_int(lmax, "lmax", 0)
    data = np.asarray(envmap.data, dtype=np.float64)
    h, w, c = data.shape
    q = gauss_legendre_order((lmax + 2) * (np.pi / h) / 2.0)
    nring = (h + 1) * q
    check_memory(16 * (h * (lmax + 1) * c + 2 * nring * (lmax + 1)) + 8 * h * w * c,
                 f"the SH coefficients of a {w}x{h} map to degree {lmax}",
                 hint="use a smaller lmax")
    cm = row_fourier(data, lmax)                                      # (H, lmax+1, C)
    sign = np.where(np.arange(lmax + 1) % 2 == 0, 1.0, -1.0)[None, :, None]
    ext = np.concatenate([cm[:1] * sign, cm, cm[-1:] * sign], axis=0)  # rows −1 … H
    lo, hi = patch_rows(h)
    x, wq = gauss_legendre_01(q)
    theta = lo[:, None] + (hi - lo)[:, None] * x[None, :]             # (H+1, q)
    wt = (hi - lo)[:, None] * wq[None, :] * np.sin(theta) * 2.0 * np.pi
    # row fraction t of each node between rows s−1 and s (index s, s+1 in ext)
    t = theta * h / np.pi + 0.5 - np.arange(h + 1)[:, None]
    alm = np.empty((c, (lmax + 1) * (lmax + 2) // 2), dtype=np.complex128)
    for ch in range(c):
        top = ext[:-1, :, ch]                                          # (H+1, lmax+1)
        bot = ext[1:, :, ch]
        leg = (top[:, None, :] * (1.0 - t)[:, :, None] + bot[:, None, :] * t[:, :, None])
        leg *= wt[:, :, None]
        leg = leg.reshape(1, nring, lmax + 1)
        alm[ch] = ducc0.sht.leg2alm(leg=leg, lmax=lmax, theta=theta.ravel(), spin=0,
                                    nthreads=int(nthreads))[0]
    return alm


def alm_l_index(lmax: int) -> np.ndarray:
    """Degree l of each entry of ducc0's m-major alm array."""
    m = np.repeat(np.arange(lmax + 1), lmax + 1 - np.arange(lmax + 1))
    start = np.concatenate(([0], np.cumsum(lmax + 1 - np.arange(lmax))))
    return m + (np.arange(m.size) - start[m])


def synthesize_convolution(alm: np.ndarray, lmax: int, factors, axes_local, *,
                           nthreads: int = 0) -> np.ndarray:
    r""":math:`\sum_{l\le l_{max}} \lambda_l \sum_m f_{lm} Y_{lm}(a)` at local unit axes a, (M, C).

    ``alm``: (C, nalm) from :func:`bilinear_sh_coefficients` (its lmax ≥ ``lmax``);
    ``factors``: :math:`\lambda_l`, l = 0…lmax (zero them beyond L for a truncation).
    ``ducc0.sht.synthesis_general`` (NUFFT, accuracy :data:`DUCC_EPSILON`).
    """
    lmax = check_int(lmax, "lmax", 0)
    a = np.asarray(alm)
    have = int(round((np.sqrt(8 * a.shape[-1] + 1) - 3) / 2))
    if (have + 1) * (have + 2) // 2 != a.shape[-1] or have < lmax:
        raise ParameterError(f"alm must hold at least degree {lmax}, got {a.shape[-1]} entries")
    if have > lmax:
        keep = alm_l_index(have) <= lmax
        a = a[:, keep]
    lam = np.asarray(factors, dtype=np.float64)[:lmax + 1]
    scaled = a * lam[alm_l_index(lmax)][None, :]
    theta, phi = local_angles(np.asarray(axes_local, dtype=np.float64))
    loc = np.ascontiguousarray(np.stack([theta, phi], axis=1))
    out = np.empty((loc.shape[0], a.shape[0]))
    if loc.shape[0] == 0:
        return out
    for ch in range(a.shape[0]):
        if lmax == 0:
            out[:, ch] = scaled[ch, 0].real / np.sqrt(4 * np.pi)
            continue
        out[:, ch] = ducc0.sht.synthesis_general(
            alm=np.ascontiguousarray(scaled[ch:ch + 1]), spin=0, lmax=lmax, loc=loc,
            epsilon=DUCC_EPSILON, nthreads=int(nthreads))[0]
    return out

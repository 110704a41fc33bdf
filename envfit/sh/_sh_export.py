r"""Real spherical-harmonic coefficients of a map for engines: conversion, irradiance, windows.

Basis (the one this module exports, and says so in every output)
------------------------------------------------------------------
Orthonormal real SH, :math:`\int_{S^2} Y_{lm}^2\,d\omega = 1`, **without the Condon–Shortley
phase** — Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment
Maps" (SIGGRAPH 2001), Eq. 3 and Appendix; the form of three.js ``SphericalHarmonics3`` and
most engine code:

.. math:: Y_{l0} = Q_l^0(z),\quad Y_{l,m} = \sqrt2\,Q_l^m(z)\,\mathrm{Re}(x+iy)^m,\quad
          Y_{l,-m} = \sqrt2\,Q_l^m(z)\,\mathrm{Im}(x+iy)^m\quad(m>0),

:math:`Q_l^m(z) = \sqrt{\tfrac{2l+1}{4\pi}\tfrac{(l-m)!}{(l+m)!}}\,P_l^m(z)/\sin^m\theta`
(:math:`P_l^m` without the :math:`(-1)^m`), so :math:`Y_{1,-1} = 0.488603\,y`,
:math:`Y_{10} = 0.488603\,z`, :math:`Y_{11} = 0.488603\,x`. (x, y, z) are the axes of the
map's *world* frame: the renderer convention's (:mod:`envfit.maps._conventions`), e.g. +y up
for OpenEXR/Mitsuba 3, +z up for pbrt-v3/Blender. Ordering: flat index
:math:`l(l+1)+m`, m = −l…l. Sloan's "Stupid Spherical Harmonics (SH) Tricks" (GDC 2008) and
D3DX include the Condon–Shortley phase: multiply the entries with odd m by −1
(``condon_shortley=True``).

From the exact machinery
------------------------
:func:`envfit.shading._bilinear_sh.bilinear_sh_coefficients` gives the complex
:math:`a_{lm} = \int f\,Y^{c*}_{lm}` (ducc0/healpy convention, Condon–Shortley phase
included, m ≥ 0, the map's local frame) of the map's bilinear interpolant. For a real f

.. math:: r_{l0} = a_{l0},\qquad r_{l,m} = \sqrt2(-1)^m\,\mathrm{Re}\,a_{lm},\qquad
          r_{l,-m} = -\sqrt2(-1)^m\,\mathrm{Im}\,a_{lm}\quad(m > 0)

(:func:`complex_to_real`). The local frame goes to the world frame by the map's
``local_to_world`` matrix M: a reflection y → −y (:math:`a_{lm}\to\bar a_{lm}`) where det M
= −1, then the rotation :math:`R = M\,\mathrm{diag}(1,-1,1)` by ``ducc0.sht.rotate_alm``
(ZYZ Euler angles, :func:`world_alm`).

Irradiance (Ramamoorthi & Hanrahan 2001, Eqs. 7–9)
-------------------------------------------------
:math:`E_{lm} = \hat A_l L_{lm}` with the clamped cosine's :math:`\hat A_l`
(:func:`clamped_cosine_sh`), and the matrix-free quadratic form of their Eq. 13 for
l ≤ 2 with the constants :data:`RH_CONSTANTS` c1…c5 (:func:`rh_irradiance`).

Windows (ringing)
-----------------
:data:`WINDOWS`: per-degree factors :math:`w_l` applied to the coefficients of a cut-off L:
``none`` (1), ``hanning`` :math:`(1+\cos\frac{\pi l}{L+1})/2`, ``lanczos``
:math:`\mathrm{sinc}(\frac{l}{L+1})`, ``sloan`` :math:`1/(1+\lambda l^2(l+1)^2)`
(:func:`sloan_window`, λ from :func:`sloan_lambda`).

Example
-------
>>> from envfit.maps._envmap import EnvMap
>>> sh = sh_coefficients(EnvMap(np.full((8, 16, 3), 2.0)), 1)
>>> sh.coefficients.shape, round(float(sh.coefficients[0, 0]), 6)   # 2·√(4π)
((4, 3), 7.089815)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import ducc0
import numpy as np

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.maps import local_to_world
from envfit.shading import alm_l_index, bilinear_sh_coefficients

__all__ = ["NORMALISATION", "ORDERING", "WINDOWS", "RH_CONSTANTS", "SHCoefficients",
           "clamped_cosine_sh", "complex_to_real", "world_alm", "real_sh_basis", "sh_eval",
           "rh_irradiance", "window_weights", "sloan_window", "sloan_lambda",
           "shading_factors", "truncate_alm", "gl_synthesis", "pixel_synthesis",
           "channel_names",
           "sh_coefficients"]

NORMALISATION = ("orthonormal real SH (integral of Y_lm^2 over the sphere = 1), no "
                 "Condon-Shortley phase (Ramamoorthi & Hanrahan 2001): Y_1,-1 = 0.488603 y, "
                 "Y_1,0 = 0.488603 z, Y_1,1 = 0.488603 x in the convention's world axes")
ORDERING = "flat index l(l+1)+m, m = -l..l (0: l0 m0; 1..3: l1 m-1,0,1; 4..8: l2 m-2..2)"


# ---------------------------------------------------------------- clamped cosine
def clamped_cosine_sh(lmax: int) -> np.ndarray:
    r"""Ramamoorthi & Hanrahan's :math:`\hat A_l`, l = 0…lmax: the SH coefficients of the
    clamped cosine :math:`\max(\cos\theta, 0)` times :math:`\sqrt{4\pi/(2l+1)}` (Funk–Hecke).

    .. math:: \hat A_0 = \pi,\quad \hat A_1 = \frac{2\pi}{3},\quad \hat A_l = 0\ (l>1\ \text{odd}),
              \quad \hat A_l = \frac{2\pi(-1)^{l/2-1}}{(l+2)(l-1)}\,
              \frac{l!}{2^l\,((l/2)!)^2}\ (l\ \text{even})

    (R&H 2001, Eq. 8; :math:`l!/(2^l((l/2)!)^2) = \binom{l}{l/2}2^{-l}`, exact integers).

    >>> clamped_cosine_sh(4).round(6).tolist()                      # π, 2π/3, π/4, 0, −π/24
    [3.141593, 2.094395, 0.785398, 0.0, -0.1309]
    """
    lmax = check_int(lmax, "lmax", 0)
    out = np.zeros(lmax + 1)
    out[0] = math.pi
    if lmax >= 1:
        out[1] = 2.0 * math.pi / 3.0
    for l in range(2, lmax + 1, 2):
        sign = -1.0 if (l // 2 - 1) % 2 else 1.0
        out[l] = 2.0 * math.pi * sign / ((l + 2) * (l - 1)) * (math.comb(l, l // 2) / 2 ** l)
    return out


def _rh_constants() -> dict[str, float]:
    r"""c1…c5 of R&H 2001 Eq. 13 from :math:`\hat A_l` and the basis constants:
    c1 = Â₂ k₂₂, c2 = Â₁ k₁/2, c3 = 3 Â₂ k₂₀, c4 = Â₀ k₀₀, c5 = Â₂ k₂₀ with
    k₀₀ = 1/(2√π), k₁ = √(3/4π), k₂₀ = √(5/16π), k₂₂ = √(15/16π)."""
    a = clamped_cosine_sh(2)
    k00, k1 = 0.5 / math.sqrt(math.pi), math.sqrt(3.0 / (4.0 * math.pi))
    k20, k22 = math.sqrt(5.0 / (16.0 * math.pi)), math.sqrt(15.0 / (16.0 * math.pi))
    c = {"c1": a[2] * k22, "c2": a[1] * k1 / 2.0, "c3": 3.0 * a[2] * k20,
         "c4": a[0] * k00, "c5": a[2] * k20}
    return {k: float(v) for k, v in c.items()}


#: Ramamoorthi & Hanrahan 2001 Eq. 13's constants (published: 0.429043, 0.511664,
#: 0.743125, 0.886227, 0.247708), computed exactly
RH_CONSTANTS = _rh_constants()


def rh_irradiance(radiance9, dirs) -> np.ndarray:
    r"""Irradiance from the 9 radiance coefficients :math:`L_{lm}` (l ≤ 2, real basis of this
    module) by R&H 2001 Eq. 13, the matrix-free quadratic form

    .. math:: E(n) = c_1L_{22}(x^2-y^2) + c_3L_{20}z^2 + c_4L_{00} - c_5L_{20}
              + 2c_1(L_{2,-2}xy + L_{21}xz + L_{2,-1}yz) + 2c_2(L_{11}x + L_{1,-1}y + L_{10}z).

    ``radiance9``: (9, C) or (9,); ``dirs``: (..., 3) unit world directions. Returns (..., C).

    >>> L = np.zeros(9); L[0] = 2 * np.sqrt(np.pi)                   # constant radiance 1
    >>> round(float(rh_irradiance(L, [0.0, 0.0, 1.0])[0]), 9)        # E = π
    3.141592654
    """
    c = RH_CONSTANTS
    L = np.asarray(radiance9, dtype=np.float64)
    L = L[:, None] if L.ndim == 1 else L
    if L.shape[0] < 9:
        raise ParameterError(f"the R&H form needs 9 coefficients (lmax 2), got {L.shape[0]}")
    d = np.asarray(dirs, dtype=np.float64)
    x, y, z = (d[..., k][..., None] for k in range(3))
    return (c["c1"] * L[8] * (x * x - y * y) + c["c3"] * L[6] * z * z + c["c4"] * L[0]
            - c["c5"] * L[6] + 2 * c["c1"] * (L[4] * x * y + L[7] * x * z + L[5] * y * z)
            + 2 * c["c2"] * (L[3] * x + L[1] * y + L[2] * z))


# ---------------------------------------------------------------- conversion
def complex_to_real(alm, lmax: int) -> np.ndarray:
    r"""Real coefficients (C, (lmax+1)²), index l(l+1)+m, of complex m-major alm (C, nalm)
    of a real function: :math:`r_{l0} = a_{l0}`, :math:`r_{l,\pm m} = \sqrt2(-1)^m
    (\mathrm{Re}\,a_{lm}, -\mathrm{Im}\,a_{lm})` (module docstring).

    >>> a = np.zeros((1, 3), complex); a[0, 2] = 1 - 2j                # (l, m) = (1, 1)
    >>> complex_to_real(a, 1).round(6).tolist()
    [[0.0, -2.828427, 0.0, -1.414214]]
    """
    a = np.atleast_2d(np.asarray(alm))
    lmax = check_int(lmax, "lmax", 0)
    l = alm_l_index(lmax)
    m = np.repeat(np.arange(lmax + 1), lmax + 1 - np.arange(lmax + 1))
    out = np.zeros((a.shape[0], (lmax + 1) ** 2))
    s = np.sqrt(2.0) * np.where(m % 2 == 1, -1.0, 1.0)
    pos = m > 0
    out[:, l[~pos] * (l[~pos] + 1)] = a[:, ~pos].real
    out[:, l[pos] * (l[pos] + 1) + m[pos]] = s[pos] * a[:, pos].real
    out[:, l[pos] * (l[pos] + 1) - m[pos]] = -s[pos] * a[:, pos].imag
    return out


def _zyz(R: np.ndarray) -> tuple[float, float, float]:
    """(α, β, γ) with R = Rz(α) Ry(β) Rz(γ) for a rotation matrix R."""
    beta = float(np.arccos(np.clip(R[2, 2], -1.0, 1.0)))
    if abs(math.sin(beta)) > 1e-12:
        return float(np.arctan2(R[1, 2], R[0, 2])), beta, float(np.arctan2(R[2, 1], -R[2, 0]))
    if R[2, 2] > 0:
        return float(np.arctan2(R[1, 0], R[0, 0])), 0.0, 0.0
    return float(np.arctan2(-R[1, 0], -R[0, 0])), math.pi, 0.0


def world_alm(alm, lmax: int, up: str) -> np.ndarray:
    r"""The map's local-frame complex alm (C, nalm) in its world frame (``up``, see
    :func:`envfit.maps._latlong.local_to_world`): :math:`f_w(d) = f(M^Td)`.

    det M = −1: :math:`M = R\,P`, P = diag(1, −1, 1), whose action on a real function's alm
    is conjugation; R by ``ducc0.sht.rotate_alm(alm, lmax, γ, β, α)`` (active, ZYZ:
    R = Rz(α)Ry(β)Rz(γ)). Up ``"z"`` is the identity.
    """
    lmax = check_int(lmax, "lmax", 0)
    a = np.atleast_2d(np.asarray(alm, dtype=np.complex128))
    M = local_to_world(up)
    if np.linalg.det(M) < 0:
        a, M = np.conj(a), M @ np.diag([1.0, -1.0, 1.0])
    if np.allclose(M, np.eye(3)):
        return a.copy()
    al, be, ga = _zyz(M)
    return np.stack([ducc0.sht.rotate_alm(np.ascontiguousarray(x), lmax, ga, be, al)
                     for x in a])


def truncate_alm(alm, lmax: int) -> np.ndarray:
    """The entries l ≤ lmax of m-major alm (C, nalm) of a higher degree."""
    a = np.atleast_2d(np.asarray(alm))
    have = int(round((math.sqrt(8 * a.shape[-1] + 1) - 3) / 2))
    if have < lmax or (have + 1) * (have + 2) // 2 != a.shape[-1]:
        raise ParameterError(f"alm must hold at least degree {lmax}, got {a.shape[-1]} entries")
    return a if have == lmax else a[:, alm_l_index(have) <= lmax]


# ---------------------------------------------------------------- evaluation
def real_sh_basis(dirs, lmax: int) -> np.ndarray:
    r"""The real basis of this module at unit world directions, (..., (lmax+1)²).

    Normalised recurrences in z with :math:`(x+iy)^m` for the azimuth (no sinθ, no
    factorials; the same algorithm as the GLSL ``shEval`` of
    :mod:`envfit.sh._sh_format`): :math:`Q_0^0 = 1/\sqrt{4\pi}`,
    :math:`Q_m^m = Q_{m-1}^{m-1}\sqrt{(2m+1)/2m}`, :math:`Q_{m+1}^m = \sqrt{2m+3}\,z\,Q_m^m`,
    :math:`Q_l^m = a_{lm}(zQ_{l-1}^m - b_{lm}Q_{l-2}^m)`, :math:`a_{lm} = \sqrt{(4l^2-1)/(l^2-m^2)}`,
    :math:`b_{lm} = \sqrt{((l-1)^2-m^2)/(4(l-1)^2-1)}`. Independent of ducc0.

    >>> real_sh_basis([0.0, 0.0, 1.0], 1).round(6).tolist()
    [0.282095, 0.0, 0.488603, 0.0]
    """
    lmax = check_int(lmax, "lmax", 0)
    d = np.asarray(dirs, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    out = np.empty(d.shape[:-1] + ((lmax + 1) ** 2,))
    qmm = np.full(z.shape, 0.5 / math.sqrt(math.pi))
    re, im = np.ones(z.shape), np.zeros(z.shape)          # (x + iy)^m
    for m in range(lmax + 1):
        if m > 0:
            qmm = qmm * math.sqrt((2 * m + 1) / (2.0 * m))
            re, im = re * x - im * y, re * y + im * x
        q2, q1 = None, qmm
        for l in range(m, lmax + 1):
            if l == m + 1:
                q2, q1 = q1, math.sqrt(2 * m + 3) * z * qmm
            elif l > m + 1:
                a = math.sqrt((4 * l * l - 1) / (l * l - m * m))
                b = math.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
                q2, q1 = q1, a * (z * q1 - b * q2)
            if m == 0:
                out[..., l * (l + 1)] = q1
            else:
                out[..., l * (l + 1) + m] = math.sqrt(2.0) * q1 * re
                out[..., l * (l + 1) - m] = math.sqrt(2.0) * q1 * im
    return out


def sh_eval(coefficients, dirs, *, chunk: int = 32768) -> np.ndarray:
    r""":math:`\sum_{lm} c_{lm}Y_{lm}(d)` of real coefficients ((L+1)², K) at world directions
    (..., 3): the per-direction sum of :func:`real_sh_basis`, in chunks. Returns (..., K).

    >>> c = np.zeros((4, 1)); c[3] = 1.0                        # Y_11 = 0.488603 x
    >>> sh_eval(c, [1.0, 0.0, 0.0]).round(6).tolist()
    [0.488603]
    """
    c = np.asarray(coefficients, dtype=np.float64)
    c = c[:, None] if c.ndim == 1 else c
    L = int(round(math.sqrt(c.shape[0]))) - 1
    if (L + 1) ** 2 != c.shape[0]:
        raise ParameterError(f"{c.shape[0]} coefficients is not (L+1)^2 for any L")
    d = np.asarray(dirs, dtype=np.float64)
    flat = d.reshape(-1, 3)
    out = np.empty((flat.shape[0], c.shape[1]))
    chunk = max(1, min(int(chunk), (1 << 22) // c.shape[0]))      # ≤ 32 MB of basis values
    for i in range(0, flat.shape[0], chunk):
        out[i:i + chunk] = real_sh_basis(flat[i:i + chunk], L) @ c
    return out.reshape(d.shape[:-1] + (c.shape[1],))


# ---------------------------------------------------------------- windows
def _hanning(L: int) -> np.ndarray:
    l = np.arange(L + 1)
    return 0.5 * (1.0 + np.cos(np.pi * l / (L + 1)))


def _lanczos(L: int) -> np.ndarray:
    return np.sinc(np.arange(L + 1) / (L + 1))


def sloan_window(L: int, lam: float) -> np.ndarray:
    r"""Sloan's window :math:`w_l = 1/(1+\lambda\,l^2(l+1)^2)`, l = 0…L.

    Sloan, "Stupid Spherical Harmonics (SH) Tricks" (GDC 2008), section on windowing: the
    minimiser of :math:`\int(g-f)^2 + \lambda\int(\Delta g)^2` over g of degree ≤ L is
    :math:`g_{lm} = f_{lm}/(1+\lambda l^2(l+1)^2)` (:math:`\Delta Y_{lm} = -l(l+1)Y_{lm}`).
    Sloan, "Deringing Spherical Harmonics" (SIGGRAPH Asia 2017 Technical Briefs) chooses
    the windowing so that the reconstruction is non-negative, conservatively, by minimising
    a univariate polynomial; that paper's full text was not reachable here, so λ is chosen
    by the closest well-defined variant, :func:`sloan_lambda` (the smallest λ making the
    windowed signal ≥ 0 on a Gauss–Legendre grid).

    >>> sloan_window(2, 0.5).tolist()                         # 1, 1/(1+2), 1/(1+18)
    [1.0, 0.3333333333333333, 0.05263157894736842]
    """
    lam = float(lam)
    if not (math.isfinite(lam) and lam >= 0):
        raise ParameterError(f"the sloan window's lambda must be finite and >= 0, got {lam!r}")
    l = np.arange(int(L) + 1, dtype=np.float64)
    return 1.0 / (1.0 + lam * (l * (l + 1)) ** 2)


#: window name → w_l, l = 0…L, for a cut-off L (``sloan`` also takes λ)
WINDOWS = {"none": lambda L: np.ones(L + 1), "hanning": _hanning, "lanczos": _lanczos,
           "sloan": sloan_window}


def window_weights(name: str, L: int, lam: float | None = None) -> np.ndarray:
    """:math:`w_l`, l = 0…L, of window ``name`` (:data:`WINDOWS`); ``sloan`` needs ``lam``.

    >>> window_weights("hanning", 1).tolist(), window_weights("lanczos", 1).round(6).tolist()
    ([1.0, 0.5], [1.0, 0.63662])
    """
    L = check_int(L, "lmax", 0)
    if name not in WINDOWS:
        raise ParameterError(f"unknown window {name!r}; use one of {', '.join(WINDOWS)}")
    if name == "sloan":
        if lam is None:
            raise ParameterError("the sloan window needs its lambda (sloan_lambda)")
        return sloan_window(L, lam)
    return WINDOWS[name](L)


def shading_factors(lmax: int, irradiance: bool) -> np.ndarray:
    r"""Per-degree factors of the exported signal: :math:`\hat A_l` (irradiance) or 1 (radiance)."""
    return clamped_cosine_sh(lmax) if irradiance else np.ones(check_int(lmax, "lmax", 0) + 1)


# ---------------------------------------------------------------- synthesis, negativity
def gl_synthesis(alm, factors, lmax: int, nlat: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""The signal :math:`\sum_{l\le L} g_l\sum_m a_{lm}Y_{lm}` on a Gauss–Legendre grid
    (``ducc0.sht.synthesis_2d``, geometry "GL", nlat rings × 2 nlat), in the alm's frame.

    ``alm``: (C, nalm) complex m-major of degree ≥ lmax; ``factors``: :math:`g_l`, l ≤ lmax.
    nlat default max(256, 4(lmax+1)). Returns (values (C, nlat, 2 nlat), solid angle of a
    grid cell per ring (nlat,): the GL weight × 2π/nphi (``ducc0.misc.GL_weights``), summing
    to 4π over the grid).
    """
    lmax = check_int(lmax, "lmax", 0)
    n = max(256, 4 * (lmax + 1)) if nlat is None else check_int(nlat, "nlat", lmax + 1)
    a = truncate_alm(alm, lmax) * np.asarray(factors, dtype=np.float64)[alm_l_index(lmax)][None, :]
    vals = np.stack([ducc0.sht.synthesis_2d(alm=np.ascontiguousarray(x[None, :]), spin=0,
                                            lmax=lmax, geometry="GL", ntheta=n, nphi=2 * n)[0]
                     for x in a])
    return vals, ducc0.misc.GL_weights(n, 2 * n)


def pixel_synthesis(envmap: EnvMap, alm, factors, lmax: int,
                    height: int | None = None) -> np.ndarray:
    r"""The signal :math:`\sum_{l\le L} g_l\sum_m a_{lm}Y_{lm}` at the pixel centres of the
    map's lat-long grid (or of a ``height``-row one, same ``up``), (h, 2h, C):
    ``ducc0.sht.synthesis_2d`` on the equiangular grid (geometry "F1", φ₀ = π/W:
    :mod:`envfit.maps._latlong`'s local frame) from the local ``alm``."""
    lmax = check_int(lmax, "lmax", 0)
    a = truncate_alm(alm, lmax) * np.asarray(factors, dtype=np.float64)[alm_l_index(lmax)][None, :]
    h = envmap.height if height is None else check_int(height, "height", 1)
    return np.stack([ducc0.sht.synthesis_2d(alm=np.ascontiguousarray(x[None, :]), spin=0,
                                            lmax=lmax, geometry="F1", ntheta=h, nphi=2 * h,
                                            phi0=math.pi / (2 * h))[0] for x in a], axis=-1)


def negative_tolerance(alm, factors) -> float:
    """Values below −tol count as negative: 1e-9 of the largest channel mean of the signal
    (so rounding noise of a zero channel is not negativity)."""
    a0 = np.abs(np.atleast_2d(np.asarray(alm))[:, 0].real).max()
    return 1e-9 * max(float(a0 * abs(float(np.asarray(factors)[0]))) / math.sqrt(4 * math.pi),
                      1e-300)


def sloan_lambda(alm, factors, lmax: int, nlat: int | None = None) -> float:
    r"""λ of :func:`sloan_window` for this signal: the smallest λ ≥ 0 (to a factor 1 + 1e-3)
    for which :math:`\sum_l w_l(\lambda) g_l \sum_m a_{lm}Y_{lm}` is ≥ 0 in every channel at
    every node of :func:`gl_synthesis`'s grid; 0 if the unwindowed signal is.

    λ → ∞ leaves the mean (l = 0), so λ exists for a signal of non-negative mean; it is
    bracketed by doubling from :math:`10^{-3}/(L^2(L+1)^2)`, then bisected geometrically.
    A node grid cannot prove positivity between nodes; the dense check of
    :mod:`envfit.sh._ringing` measures what is left (none found on the maps tried).
    """
    lmax = check_int(lmax, "lmax", 0)
    g = np.asarray(factors, dtype=np.float64)[:lmax + 1]
    tol = negative_tolerance(alm, g)

    def negative(lam: float) -> bool:
        return bool(gl_synthesis(alm, g * sloan_window(lmax, lam), lmax, nlat)[0].min() < -tol)

    if lmax == 0 or not negative(0.0):
        return 0.0
    hi = 1e-3 / (lmax * (lmax + 1)) ** 2
    for _ in range(200):
        if not negative(hi):
            break
        hi *= 2.0
    else:
        raise ParameterError("no sloan window makes this signal non-negative (negative mean?)")
    lo = hi / 2.0
    while hi / lo > 1.0 + 1e-3:
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if not negative(mid) else (mid, hi)
    return hi


# ---------------------------------------------------------------- the export
def channel_names(c: int) -> tuple[str, ...]:
    """("R", "G", "B") for 3 channels, ("Y",) for 1 (luminance), else c0, c1, …"""
    return {3: ("R", "G", "B"), 1: ("Y",)}.get(c, tuple(f"c{k}" for k in range(c)))


@dataclass(frozen=True)
class SHCoefficients:
    r"""Real SH coefficients of a map for an engine (basis and ordering: module docstring).

    Attributes
    ----------
    lmax : the cut-off L
    coefficients : ((L+1)², C) the exported coefficients, world frame, index l(l+1)+m:
        :math:`w_l L_{lm}` (radiance) or :math:`w_l\hat A_l L_{lm}` (``irradiance``), in
        this module's basis (``condon_shortley`` flips odd m when written:
        :func:`envfit.sh._sh_format.signed_coefficients`)
    radiance : ((L+1)², C) the windowed radiance coefficients :math:`w_l L_{lm}` (the input
        of R&H's quadratic form, :func:`rh_irradiance`)
    irradiance : whether ``coefficients`` are the clamped-cosine convolution
    window, window_weights, window_lambda : the window, its :math:`w_l` and (sloan) its λ
    up : the world axis of the map's top row (the frame of x, y, z)
    channels : channel names ("R", "G", "B" or "Y")
    condon_shortley : odd-m signs flipped to Sloan's / D3DX's convention
    """

    lmax: int
    coefficients: np.ndarray
    radiance: np.ndarray
    irradiance: bool
    window: str
    window_weights: tuple
    window_lambda: float | None
    up: str
    channels: tuple
    condon_shortley: bool = False

    @property
    def degrees(self) -> np.ndarray:
        """l of each flat index."""
        return np.repeat(np.arange(self.lmax + 1), 2 * np.arange(self.lmax + 1) + 1)

    @property
    def orders(self) -> np.ndarray:
        """m of each flat index."""
        l = self.degrees
        return np.arange(l.size) - l * (l + 1)

    def evaluate(self, dirs) -> np.ndarray:
        """The exported signal at unit world directions (..., 3) → (..., C) (:func:`sh_eval`;
        the same function whatever ``condon_shortley``, which only changes the signs written)."""
        return sh_eval(self.coefficients, dirs)


def sh_coefficients(envmap: EnvMap, lmax: int, *, irradiance: bool = False,
                    window: str = "none", lam: float | None = None, alm=None,
                    condon_shortley: bool = False, nlat: int | None = None) -> SHCoefficients:
    r"""The map's real SH coefficients to degree ``lmax`` in its world frame.

    ``alm``: the map's local complex coefficients of degree ≥ lmax
    (:func:`~envfit.shading._bilinear_sh.bilinear_sh_coefficients`; computed if None).
    ``window="sloan"`` without ``lam``: λ from :func:`sloan_lambda` on the exported signal.

    >>> from envfit.maps._latlong import pixel_directions
    >>> d = pixel_directions(64, up="y")                        # L = 1 + x (world x)
    >>> sh = sh_coefficients(EnvMap((1.0 + d[..., :1]), up="y"), 1)
    >>> c = sh.coefficients[:, 0] / np.sqrt(4 * np.pi / np.array([1, 3, 3, 3]))
    >>> bool(np.allclose(c, [1.0, 0.0, 0.0, 1.0], atol=1e-3))  # Y_11 ∝ x: index 3
    True
    """
    lmax = check_int(lmax, "lmax", 0)
    a = bilinear_sh_coefficients(envmap, lmax) if alm is None else truncate_alm(alm, lmax)
    g = shading_factors(lmax, irradiance)
    if window == "sloan" and lam is None:
        lam = sloan_lambda(a, g, lmax, nlat)
    w = window_weights(window, lmax, lam)
    r0 = complex_to_real(world_alm(a, lmax, envmap.up), lmax).T           # ((L+1)², C)
    l = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    return SHCoefficients(lmax=lmax, coefficients=r0 * (w * g)[l][:, None],
                          radiance=r0 * w[l][:, None], irradiance=bool(irradiance),
                          window=window, window_weights=tuple(float(x) for x in w),
                          window_lambda=None if window != "sloan" else float(lam),
                          up=envmap.up, channels=channel_names(envmap.channels),
                          condon_shortley=bool(condon_shortley))

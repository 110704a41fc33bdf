r"""Bilinear patches of a lat-long map: the geometry both ground-truth methods share.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 4.3, 9.2.

In continuous pixel coordinates the map's bilinear interpolant (the function
:meth:`envfit.maps._envmap.EnvMap.lookup` evaluates) is bilinear in :math:`(\theta, \varphi)`
on each *patch* between four pixel centres: :math:`\theta \in [\theta_{s-1}, \theta_s]`,
:math:`\varphi \in [\varphi_j, \varphi_{j+1}]`, s = 0…H, j = 0…W−1, with the two polar caps
:math:`[0, \theta_0]` and :math:`[\theta_{H-1}, \pi]` interpolating across the pole (row −1
is row 0 at :math:`\varphi + \pi`, row H is row H−1 at :math:`\varphi + \pi`). Inside a
patch the integrand of the shading integral (Eq. 17) is smooth, so tensor Gauss–Legendre
rules (:func:`envfit.theory._brdf.gauss_legendre_01`, orders from
:func:`gauss_legendre_order`) converge spectrally.

Frames: axes are world directions; they are mapped to the map's local frame (z = up) by
``local_to_world(up).T`` (:func:`axes_to_local`), the frame of the lat-long
parametrisation and of ducc0's transforms (geometry "F1", ``phi0 = π/W``).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import special

from envfit.base import as_unit_vectors
from envfit.maps import local_to_world

__all__ = ["GL_TOL", "axes_to_local", "local_angles", "gauss_legendre_order",
           "patch_rows", "patch_corner_values", "bilinear_in_patch"]

#: target error of a Gauss–Legendre rule on one patch, relative to the patch's integral scale
GL_TOL = 1e-10


def axes_to_local(axes, up: str = "y") -> np.ndarray:
    """World axis directions (3,) or (M, 3) → unit vectors in the map's local frame, (M, 3).

    ``local = M_up^T world`` (:func:`envfit.maps._latlong.local_to_world`). Axes need not be unit
    length; zero, non-finite or mis-shaped input raises :class:`ParameterError`.

    >>> axes_to_local([0.0, 2.0, 0.0], "y").round(12).tolist()     # world +y = local up
    [[0.0, 0.0, 1.0]]
    """
    return as_unit_vectors(axes, name="axes", allow_empty=True) @ local_to_world(up)


def local_angles(a_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Colatitude θ ∈ [0, π] and longitude φ ∈ [0, 2π) of local directions (M, 3)."""
    theta = np.arctan2(np.hypot(a_local[:, 0], a_local[:, 1]), a_local[:, 2])
    phi = np.mod(np.arctan2(a_local[:, 1], a_local[:, 0]), 2.0 * np.pi)
    return theta, phi


def gauss_legendre_order(kappa: float, tol: float = GL_TOL) -> int:
    r"""Smallest q ≥ 2 whose q-point Gauss–Legendre rule integrates :math:`e^{i\kappa x}` on [−1, 1] to ``tol``.

    Uses the remainder :math:`E_q = \frac{2^{2q+1}(q!)^4}{(2q+1)((2q)!)^3}\kappa^{2q}`
    (Abramowitz & Stegun 25.4.30 with :math:`|f^{(2q)}| \le \kappa^{2q}`), monotone in κ.
    On an interval of length L a trig polynomial of degree D has κ = D L / 2.

    >>> gauss_legendre_order(0.0), gauss_legendre_order(np.pi / 2)
    (2, 7)
    """
    k = abs(float(kappa))
    if k == 0.0:
        return 2
    for q in range(2, 400):
        log_e = ((2 * q + 1) * math.log(2.0) + 4 * special.gammaln(q + 1)
                 - math.log(2 * q + 1) - 3 * special.gammaln(2 * q + 1) + 2 * q * math.log(k))
        if log_e <= math.log(tol):
            return q
    return 400


def patch_rows(height: int) -> tuple[np.ndarray, np.ndarray]:
    """θ-edges of the H+1 patch rows [0, θ_0], [θ_0, θ_1], …, [θ_{H−1}, π] → (lo, hi)."""
    theta_c = np.pi * (np.arange(height) + 0.5) / height
    edges = np.concatenate(([0.0], theta_c, [np.pi]))
    return edges[:-1], edges[1:]


def patch_corner_values(data: np.ndarray, s: np.ndarray, j: np.ndarray):
    """Values (T0, T1, B0, B1), each (P, C), at the four corners of patches (s, j).

    Top row s−1 and bottom row s; the virtual rows −1 and H are rows 0 and H−1 shifted by
    W/2 columns (across the pole), exactly as :func:`envfit.maps._latlong.bilinear_lookup`.
    """
    h, w, _ = data.shape
    j1 = (j + 1) % w
    r0 = s - 1
    vt = r0 < 0
    rt = np.where(vt, 0, r0)
    shift_t = np.where(vt, w // 2, 0)
    r1 = s
    vb = r1 > h - 1
    rb = np.where(vb, h - 1, r1)
    shift_b = np.where(vb, w // 2, 0)
    T0 = data[rt, (j + shift_t) % w]
    T1 = data[rt, (j1 + shift_t) % w]
    B0 = data[rb, (j + shift_b) % w]
    B1 = data[rb, (j1 + shift_b) % w]
    return T0, T1, B0, B1


def bilinear_in_patch(data, s, j, theta, phi):
    """Bilinear interpolant at (θ, φ) inside patch (s, j); s, j, θ, φ broadcast to (P, …)."""
    h, w, _ = data.shape
    T0, T1, B0, B1 = patch_corner_values(data, s, j)
    t = theta * (h / np.pi) - 0.5 - (s[:, None] - 1)                       # row fraction
    b = phi * (w / (2.0 * np.pi)) - 0.5 - j[:, None]                       # column fraction
    t = t[..., None]
    b = b[..., None]
    top = T0[:, None, :] + b * (T1 - T0)[:, None, :]
    bot = B0[:, None, :] + b * (B1 - B0)[:, None, :]
    return top + t * (bot - top)                                           # (P, n, C)


def horizon_breaks(theta_lo, theta_hi, p0, dphi, sa, ca, pa) -> np.ndarray:
    r"""φ offsets (P, 6) in [0, dφ], sorted, that split cells [θ_lo, θ_hi] × [p0, p0 + dφ]
    where the horizon of axes (sin θ_a, cos θ_a, φ_a) = (sa, ca, pa) crosses the cell's two
    rings: the roots of :math:`\sin\theta_a\sin\theta\cos(\varphi-\varphi_a) +
    \cos\theta_a\cos\theta = 0` at θ = θ_lo, θ_hi (absent roots give dφ), plus 0 and dφ.
    Between consecutive offsets the horizon's θ*(φ) stays inside the cell's θ-range or outside.
    """
    cand = []
    for te in (theta_lo, theta_hi):
        den = sa * np.sin(te)
        with np.errstate(divide="ignore", invalid="ignore"):
            kap = -ca * np.cos(te) / den
        ok = (den > 1e-300) & (np.abs(kap) <= 1.0)
        psi = np.arccos(np.clip(np.where(ok, kap, 0.0), -1.0, 1.0))
        for sg in (1.0, -1.0):
            rel = np.mod(pa + sg * psi - p0, 2.0 * np.pi)
            cand.append(np.where(ok & (rel > 0.0) & (rel < dphi), rel, dphi))
    zero = np.zeros(np.shape(p0))
    return np.sort(np.stack([zero] + cand + [np.full(np.shape(p0), dphi)], axis=1), axis=1)

r"""The variances :math:`V_i = \mathrm{Var}\,h_i` of the warped integrands by *pixel
quadrature in direction space*, and their exact means over all axes.

Per axis (:func:`_pixel_moments`): each pixel's cell integral of the bilinear interpolant
:math:`f` and of its square — exactly :math:`v^\top(M\otimes M)v` over its 3×3
neighbourhood (:func:`cell_square_average`, M the 1-D mass matrix) — times its solid angle,
lobe :math:`\rho_a` and map pdf at its centre; where the lobe is narrower than 8 pixels the
pixels are subdivided (:func:`_subdivision`, f looked up). With :math:`h_i = f\,
\mathrm{factor}_i` sampled with density :math:`p_i` (:mod:`._techniques`),

.. math:: V_i = Q[h_i^2 p_i]/Q[p_i] - (Q[h_i p_i]/Q[p_i])^2,

the variance under the normalised discrete measure — exact at a sun a few pixels wide, which a
grid in the square would sample with a handful of points.

Over all axes (:func:`exact_mean_variances`), in closed form: the means over uniform axes of
:math:`\rho_a(\omega)` and :math:`\rho_a(\omega)^2` at a fixed direction are :math:`1/4\pi`
and :math:`c_2` (:func:`_lobe_square_mean`), so BRDF and map sampling's mean variances are
:math:`\frac1{4\pi}\int f^2 - \overline{I^2}` and :math:`c_2\int f^2/p - \overline{I^2}` —
the calibration of the importance sample of axes (:mod:`._axis_mean`).

Reference: Marques, Bouville, Bouatouch, Eq. 17 (the shading integral :math:`I(a)`);
E. Veach, PhD thesis (1997), ch. 9 (MIS).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from envfit.maps import EnvMap
from envfit.maps import pixel_directions, pixel_solid_angles, rows_dot
from envfit.sampling import MapSampler
from envfit.sampling import brdf_pdf
from envfit.sampling import bilinear_cell_average
from envfit.predict.warped._axis_proposal import AXIS_POOL, _fibonacci_axes

__all__ = ["cell_square_average", "exact_mean_variances"]

#: a variance m2 - m1² at most this fraction of m2 is rounding (16 ulps), counted as 0
_ROUNDING = 16.0 * np.finfo(np.float64).eps

# the 1-D mass matrix of a cell [-1/2, 1/2] of a piecewise-linear interpolant of (a, b, c)
# at (-1, 0, 1): ∫ L² = 1/24 a² + 7/12 b² + 1/24 c² + 1/6 (ab + bc)
_MASS = np.array([[1 / 24, 1 / 12, 0.0], [1 / 12, 7 / 12, 1 / 12], [0.0, 1 / 12, 1 / 24]])


def _neighbours(y: np.ndarray) -> list[list[np.ndarray]]:
    """The 3×3 neighbourhood of every pixel (H, W, …), rows across the poles at φ + π."""
    w = y.shape[1]
    up = np.concatenate([np.roll(y[:1], w // 2, axis=1), y[:-1]], axis=0)
    down = np.concatenate([y[1:], np.roll(y[-1:], w // 2, axis=1)], axis=0)
    return [[np.roll(r, 1, axis=1), r, np.roll(r, -1, axis=1)] for r in (up, y, down)]


def cell_square_average(data: np.ndarray) -> np.ndarray:
    r"""Mean of the *square* of the bilinear interpolant over each pixel cell, (H, W, …).

    In pixel coordinates the interpolant is :math:`\sum v_{kl}\phi_k(x)\phi_l(y)` with hat
    functions, so over the cell :math:`[-\frac12,\frac12]^2` of a pixel
    :math:`\int L^2 = \sum_{ijkl} v_{ij}v_{kl}M_{ik}M_{jl}` over its 3×3 neighbourhood, M the
    1-D mass matrix (1/24, 7/12, 1/24 on the diagonal, 1/12 beside it); columns wrap and the
    rows beyond the poles are the edge rows at φ + π (as the lookup).

    >>> a = np.zeros((4, 8)); a[1, 2] = 1.0
    >>> round(float(cell_square_average(a).sum()), 12)            # ∫ hat² = (2/3)²
    0.444444444444
    """
    v = _neighbours(np.asarray(data, dtype=np.float64))
    out = np.zeros_like(v[1][1])
    for i in range(3):
        for k in range(3):
            if _MASS[i, k] == 0.0:
                continue
            for j in range(3):
                for m in range(3):
                    if _MASS[j, m] != 0.0:
                        out += _MASS[i, k] * _MASS[j, m] * v[i][j] * v[k][m]
    return out


def _cell_average(data: np.ndarray) -> np.ndarray:
    """Mean of the bilinear interpolant over each pixel cell, (H, W, C): the sampler's own
    :func:`envfit.sampling._map_sampler.bilinear_cell_average`, per channel."""
    d = np.asarray(data, dtype=np.float64)
    return np.stack([bilinear_cell_average(d[..., c]) for c in range(d.shape[-1])], axis=-1)


def _subdivision(envmap: EnvMap, weight) -> int:
    r"""Sub-nodes per pixel side so that a pixel is at most 1/8 of the lobe's angular width
    (glossy :math:`\sqrt{2/n}`, diffuse 1 rad), at most 16 and ~4M nodes."""
    width = min(1.0, math.sqrt(2.0 / weight.shininess)) if getattr(weight, "shininess", None) \
        else 1.0
    sub = math.ceil(8.0 * (math.pi / envmap.height) / width)
    cap = max(1, int(math.sqrt(4e6 / (envmap.height * envmap.width))))
    return int(max(1, min(sub, 16, cap)))


class _Pixels:
    """Direction-space quadrature nodes: directions (P, 3), ∫L and ∫L² per node cell (P, C),
    the map pdf (P,). One node per pixel with the cell-exact moments of the bilinear
    interpolant, or ``sub``² nodes per pixel (L looked up) where the lobe is narrow."""

    def __init__(self, envmap: EnvMap, sampler: MapSampler, sub: int = 1):
        h, w, c = envmap.data.shape
        if sub == 1:
            om = pixel_solid_angles(h, w).reshape(-1, 1)
            self.dirs = pixel_directions(h, w, up=envmap.up).reshape(-1, 3)
            self.first = _cell_average(envmap.data).reshape(-1, c) * om
            self.second = cell_square_average(envmap.data).reshape(-1, c) * om
            self.pdf = sampler.pixel_pdf.reshape(-1)
            self.area = om[:, 0]
            return
        hs, ws = h * sub, w * sub
        om = pixel_solid_angles(hs, ws).reshape(-1, 1)
        self.dirs = pixel_directions(hs, ws, up=envmap.up).reshape(-1, 3)
        L = envmap.lookup(self.dirs)
        self.first, self.second, self.area = L * om, L * L * om, om[:, 0]
        self.pdf = np.repeat(np.repeat(sampler.pixel_pdf, sub, axis=0), sub, axis=1).reshape(-1)


@dataclass(frozen=True)
class _Lobe:
    """The pixels in an axis' lobe (``on``) and, there, ρ_a, the map pdf and the moments."""
    on: np.ndarray
    rho: np.ndarray
    pdf: np.ndarray
    first: np.ndarray
    second: np.ndarray
    area: np.ndarray


def _pixel_lobe(px: _Pixels, weight, a) -> _Lobe:
    """The pixels in the lobe of axis a, gathered once for every technique's moments."""
    rho = brdf_pdf(weight, rows_dot(px.dirs, a))
    on = np.flatnonzero(rho > 0)
    return _Lobe(on, rho[on], px.pdf[on], px.first[on], px.second[on], px.area[on])


@dataclass(frozen=True)
class _Moments:
    """One axis's pixel-quadrature moments: ``variance`` (parts, C) and ``mean`` I (C,)."""
    variance: np.ndarray
    mean: np.ndarray


def _pixel_moments(px: _Pixels, technique, a, lobe: _Lobe | None = None) -> _Moments:
    r"""V (parts, C) and I (C,) of ``technique`` (:class:`._techniques.Technique`) at axis a
    by direction-space quadrature Q: with :math:`h_i = f\,\mathrm{factor}_i` sampled with
    density :math:`p_i`, :math:`V_i = Q[h_i^2p_i]/Q[p_i] - (Q[h_ip_i]/Q[p_i])^2` — the
    variance under the normalised discrete measure (never negative), free of the error
    :math:`\int h^2 - (\int h)^2` would take from a quadrature of :math:`\int p_i` off 1
    (a narrow lobe on a coarse map). ``lobe``: :func:`_pixel_lobe` of a, when known."""
    lb = _pixel_lobe(px, technique.weight, a) if lobe is None else lobe
    V, total = [], 0.0
    for i, part in enumerate(technique.terms(lb.rho, lb.pdf)):
        factor, p = part.factor, part.pdf
        q = float(p @ lb.area) if technique.is_lobe_part(i) else float(px.pdf @ px.area)
        fp = factor * p                           # einsum, not BLAS: see rows_dot
        m1 = np.einsum("i,ic->c", fp, lb.first) / q
        m2 = np.einsum("i,ic->c", fp * factor, lb.second) / q
        # m2 - m1² below the rounding of m2 is no variance (a constant integrand)
        V.append(np.where(m2 - m1 * m1 > _ROUNDING * m2, m2 - m1 * m1, 0.0))
        total = total + m1
    return _Moments(np.array(V), total)


def _lobe_square_mean(weight) -> float:
    r""":math:`c_2 = \frac1{4\pi}\int_{S^2}\rho_a(\omega)^2\,da = \frac12\int_0^1\rho(z)^2dz`,
    the mean over uniform axes of the squared lobe at a fixed direction (Gauss–Legendre)."""
    x, w = special.roots_legendre(400)
    z = 0.5 * (x + 1.0)
    return float(0.25 * np.sum(w * brdf_pdf(weight, z) ** 2))


def exact_mean_variances(envmap: EnvMap, px: _Pixels, weight) -> dict:
    r"""The mean over *all* axes of the one-sample variances of BRDF and map sampling, in
    closed form — no axis sampling:

    .. math:: \overline{V}_\mathrm{brdf} = \frac1{4\pi}\int f^2\,d\omega - \overline{I^2},
              \qquad
              \overline{V}_\mathrm{map} = c_2\int \frac{f^2}{p}\,d\omega - \overline{I^2},

    since the mean over axes of :math:`\rho_a(\omega)` is :math:`1/4\pi` and of
    :math:`\rho_a(\omega)^2` is :math:`c_2` (:func:`_lobe_square_mean`) at every direction;
    :math:`\int f^2` and :math:`\int f^2/p` by the pixels' cell-exact squares, and
    :math:`\overline{I^2}` over the :data:`._axis_proposal.AXIS_POOL` Fibonacci axes by the
    exact SH integrator (:func:`envfit.shading.shading_integral`, smooth in the axis).
    Means over channels."""
    from envfit.shading import shading_integral

    I = shading_integral(envmap, _fibonacci_axes(AXIS_POOL), weight)
    i2 = (I * I).mean(axis=0)
    second = px.second.sum(axis=0)
    over_p = (px.second / px.pdf[:, None]).sum(axis=0)
    return {"brdf": float(np.mean(second / (4.0 * np.pi) - i2)),
            "map": float(np.mean(_lobe_square_mean(weight) * over_p - i2))}

r"""Compiled (numba) forms of the principled BSDF for the microfacet model's hot loops, each
the same arithmetic as :class:`envfit.shading.microfacet.Principled` (``_principled``; the
renderer's source it follows is cited in the renderer's folder, ``_bsdf``), which the tests
compare it with, and :func:`two_lobe_kernels`, which picks a two-lobe BSDF's kernels:

* :func:`principled_eval_pdf` — f·cos θ_o and the sampling pdf at many light directions for
  one view (``Principled.eval`` and ``pdf``): the specular term F D(H) G₁(ω_i, H) G₁(ω_o, H)/
  (4 cos θ_i) (GGX, D zeroed where D cos θ_H ≤ 1e-20, F the blend of the dielectric
  Fresnel and the Schlick terms, only where F_d > 0 and ω_i·H, ω_o·H > 0) plus
  (1 − m) times the diffuse lobe (retro-reflection, fake subsurface, sheen); the pdf the
  mixture (1 − p_d) D G₁(ω_i, H)/(4 cos θ_i) + p_d cos θ_o/π;
* :func:`principled_sample` — ``Principled.sample`` (the lobe from a given ``sample1``: the
  diffuse one below p_d) and ``sample_square`` (the lobe from u_x, rescaled within it): a
  cosine-distributed direction by the concentric map, or the reflection about a GGX
  visible normal (``_vndf_kernels._normal``, the slope-space variant 0), dead where
  ω_i·n ≤ 0 or ω_o·n ≤ 0; then the weight f·cos/pdf and the pdf;
* :func:`principled_proxies` — the same at a map table's directions for many frames at
  once, reduced to each frame's emitter and BSDF sampling variances (as
  :func:`conductor_proxies`).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.predict.renderer._microfacet_kernels import _lambda, _local, _proxy_add, _proxy_out
from envfit.predict.renderer._plastic_kernels import (_dm, _finite, _fresnel, _half, _square,
                                                      compiled_plastic, plastic_eval_pdf,
                                                      plastic_proxies, plastic_sample)
from envfit.predict.renderer._vndf_kernels import _disk, _normal, _view_constants
from envfit.shading.microfacet import Principled

__all__ = ["compiled_principled", "principled_eval_pdf", "principled_sample",
           "principled_proxies", "two_lobe_kernels"]

#: consts' slots: α, η, roughness, base colour, metallic, spec_tint, sheen, flatness, p_d,
#: R₀(η)
_ALPHA, _ETA, _ROUGH, _BASE, _METAL, _TINT, _SHEEN, _FLAT, _PD, _R0 = range(10)


@numba.njit(cache=True, error_model="numpy")
def _w(c):  # pragma: no cover - numba
    """Schlick's weight (1 − c)⁵, 1 − c clamped to [0, 1]."""
    m = min(max(1.0 - c, 0.0), 1.0)
    return m * m * m * m * m


@numba.njit(cache=True, error_model="numpy")
def _fc_pdf(wi, lam_i, o, consts):  # pragma: no cover - numba
    """(f·cos, pdf) at the local light direction ``o`` for the local view ``wi`` (Λ(ω_i) =
    ``lam_i``)."""
    ix, iy, iz = wi[0], wi[1], wi[2]
    ox, oy, oz = o
    if not (iz > 0.0 and oz > 0.0):
        return 0.0, 0.0
    alpha, m = consts[_ALPHA], consts[_METAL]
    hx, hy, hz = _half(ix, iy, iz, ox, oy, oz)
    d = _dm(hx, hy, hz, alpha, 0)
    cih = ix * hx + iy * hy + iz * hz
    coh = ox * hx + oy * hy + oz * hz
    g1i = 0.0 if cih * iz <= 0.0 else 1.0 / (1.0 + lam_i)
    on = cih > 0.0 and coh > 0.0
    spec = 0.0
    fd = _fresnel(cih, consts[_ETA])
    if on and fd > 0.0:
        g1o = 0.0 if coh * oz <= 0.0 else 1.0 / (1.0 + _lambda(ox, oy, oz, alpha, 0))
        wc = _w(abs(cih))
        base, r0, t = consts[_BASE], consts[_R0], consts[_TINT]
        f = ((1.0 - m) * (1.0 - t) * fd + m * (wc * (1.0 - base) + base)
             + (1.0 - m) * t * (wc * (1.0 - r0) + r0))
        spec = _finite(f * d * (g1i * g1o) / (4.0 * iz))
    diff = 0.0
    if m < 1.0:
        fo, fi = _w(oz), _w(iz)
        rr = 2.0 * consts[_ROUGH] * coh * coh
        lobe = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1.0))
        flat = consts[_FLAT]
        if flat > 0.0:
            fss = (1.0 + (0.5 * rr - 1.0) * fo) * (1.0 + (0.5 * rr - 1.0) * fi)
            ss = 1.25 * (fss * (1.0 / (oz + iz) - 0.5) + 0.5)
            lobe = lobe + flat * (ss - lobe)
        diff = oz * consts[_BASE] / math.pi * lobe
        if consts[_SHEEN] > 0.0:
            diff = diff + consts[_SHEEN] * _w(abs(coh)) * oz
        diff = (1.0 - m) * diff
    q = _finite(d * g1i / (4.0 * iz)) if on else 0.0
    pd = consts[_PD]
    return spec + diff, (1.0 - pd) * q + pd * oz / math.pi


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _eval_pdf(wi, dirs, rows, consts, out):  # pragma: no cover - numba
    lam = _lambda(wi[0], wi[1], wi[2], consts[_ALPHA], 0)
    for p in numba.prange(dirs.shape[0]):
        out[p, 0], out[p, 1] = _fc_pdf(wi, lam, _local(dirs[p], rows), consts)


@numba.njit(cache=True, error_model="numpy")
def _direction(wi, vndf, u0, u1, diffuse, alpha):  # pragma: no cover - numba
    """ω_o of ``Principled.sample`` in the chosen lobe, and whether it is alive."""
    if diffuse:
        px, py = _disk(u0, u1, False)
        return px, py, math.sqrt(max(1.0 - (px * px + py * py), 0.0)), True
    mx, my, mz = _normal(wi, vndf, u0, u1, alpha, 0, 0)
    dot = wi[0] * mx + wi[1] * my + wi[2] * mz
    ox, oy, oz = 2.0 * dot * mx - wi[0], 2.0 * dot * my - wi[1], 2.0 * dot * mz - wi[2]
    alive = dot > 0.0 and ox * mx + oy * my + oz * mz > 0.0
    return ox, oy, oz, alive


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sample(wi, vndf, u, lobe, consts, wo, out):  # pragma: no cover - numba
    """``lobe`` = (square, sample1): the lobe from u_x (``sample_square``) or from sample1."""
    lam = _lambda(wi[0], wi[1], wi[2], consts[_ALPHA], 0)
    pd = consts[_PD]
    square = lobe[0] > 0.0
    for p in numba.prange(u.shape[0]):
        u0, s1 = u[p, 0], lobe[1]
        if square:
            u0, s1 = _square(u0, pd)
        ox, oy, oz, alive = _direction(wi, vndf, u0, u[p, 1], s1 < pd, consts[_ALPHA])
        weight, pdf = 0.0, 0.0
        if alive and wi[2] > 0.0 and math.isfinite(ox + oy + oz):
            fc, pdf = _fc_pdf(wi, lam, (ox, oy, oz), consts)
            weight = _finite(fc / pdf) if pdf > 0.0 else 0.0
        if weight <= 0.0:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = 0.0, 0.0, 1.0, weight, 0.0
        else:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = ox, oy, oz, weight, pdf


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _proxies(wis, frames, dirs, tab, consts, out):  # pragma: no cover - numba
    size = dirs.shape[0]
    for a in numba.prange(wis.shape[0]):
        wi = wis[a]
        lam = _lambda(wi[0], wi[1], wi[2], consts[_ALPHA], 0)
        acc = np.zeros(5)
        for p in range(size):
            fc, pb = _fc_pdf(wi, lam, _local(dirs[p], frames[a]), consts)
            _proxy_add(acc, tab[p], fc, pb)
        _proxy_out(acc, size, out[a])


def compiled_principled(bsdf) -> bool:
    """Whether the kernels repeat ``bsdf``: a :class:`Principled` (exactly that class)."""
    return type(bsdf) is Principled


def _constants(bsdf) -> np.ndarray:
    eta = bsdf.eta
    return np.array([bsdf.alpha, eta, bsdf.roughness, bsdf.base_color, bsdf.metallic,
                     bsdf.spec_tint, bsdf.sheen, bsdf.flatness,
                     float(bsdf.lobe_probability(np.array([1.0]))[0]),
                     ((eta - 1.0) / (eta + 1.0)) ** 2], dtype=np.float64)


def principled_eval_pdf(bsdf, wi, dirs, rows=None) -> tuple[np.ndarray, np.ndarray]:
    """(f·cos (P,), pdf (P,)) of the principled ``bsdf`` for the one view ``wi`` (3,) and light
    directions ``dirs`` (P, 3): local, or world with ``rows`` the local frame's axes as rows
    — ``Principled.eval`` and ``pdf``."""
    out = np.empty((2, len(dirs)))
    rows = np.eye(3) if rows is None else np.ascontiguousarray(rows, dtype=np.float64)
    _eval_pdf(np.ascontiguousarray(wi, dtype=np.float64),
              np.ascontiguousarray(dirs, dtype=np.float64), rows, _constants(bsdf), out.T)
    return out[0], out[1]


def principled_sample(bsdf, wi, u, u1=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω_o (P, 3), weight (P,), pdf (P,)) of the principled ``bsdf`` sampled for the one view
    ``wi`` (3,) at the points ``u`` (P, 2), local frame: ``Principled.sample_square(wi, u)``
    when ``u1`` is None, else ``Principled.sample(wi, u, u1=full(u1))``; where the weight is
    0, ω_o is the pole and the pdf 0."""
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    vndf = _view_constants(wi, float(bsdf.alpha), 0, 0) if wi[2] > 0 else np.zeros((4, 5))
    lobe = np.array([1.0, 0.0] if u1 is None else [0.0, float(u1)])
    wo, out = np.empty((len(u), 3)), np.empty((2, len(u)))
    _sample(wi, vndf, np.ascontiguousarray(u, dtype=np.float64), lobe, _constants(bsdf), wo,
            out)
    return wo, out[0], out[1]


def principled_proxies(bsdf, wis, frames, dirs, base, pdf) -> np.ndarray:
    """Per frame (v_e, v_b) (K, 2) of the principled ``bsdf`` on a map table, as
    :func:`plastic_proxies`."""
    tab = np.ascontiguousarray(np.column_stack([np.pi * base, pdf]), dtype=np.float64)
    out = np.zeros((len(wis), 2))
    _proxies(np.ascontiguousarray(wis, dtype=np.float64),
             np.ascontiguousarray(frames, dtype=np.float64),
             np.ascontiguousarray(dirs, dtype=np.float64), tab, _constants(bsdf), out)
    return out


def two_lobe_kernels(bsdf):
    """(eval_pdf, sample, proxies) compiled for a two-lobe ``bsdf`` (a rough plastic, a
    principled BSDF or an albedo-layered one), or None (numpy)."""
    from envfit.predict.renderer._layered_kernels import (compiled_layered, layered_eval_pdf,
                                                          layered_proxies, layered_sample)
    if compiled_layered(bsdf):
        return layered_eval_pdf, layered_sample, layered_proxies
    if compiled_plastic(bsdf):
        return plastic_eval_pdf, plastic_sample, plastic_proxies
    if compiled_principled(bsdf):
        return principled_eval_pdf, principled_sample, principled_proxies
    return None

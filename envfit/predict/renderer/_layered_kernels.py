r"""Compiled (numba) forms of the albedo-layered BSDF for the microfacet model's hot loops, the
same arithmetic as :class:`envfit.shading.microfacet.AlbedoLayered` (``_layered``; the
renderer's source it follows is cited in the renderer's folder, ``_bsdf``), which the tests
compare it with:

* :func:`layered_eval_pdf` — f·cos θ_o and the sampling pdf at many light directions for one
  view: s(μ) F(ω_i·H) D(H)/(4μ(1 + Λ_i + Λ_o)) + k_d(μ) cos θ_o/π (GGX, height-correlated,
  F the dielectric blend) and the mixture p_s D(H)/(4μ(1 + Λ_i)) + (1 − p_s) cos θ_o/π;
* :func:`layered_sample` — ``AlbedoLayered.sample`` (the lobe from a given number: the
  specular layer below p_s) and ``sample_square`` (from u_x, rescaled within its lobe): the
  reflection about a GGX visible normal of the ``hemisphere_concentric`` warp
  (``_vndf_kernels._normal``, variant 2) or a cosine-distributed direction by the concentric
  map, dead below the surface; then the weight f·cos/pdf and the pdf;
* :func:`layered_proxies` — the same at a map table's directions for many frames at once,
  reduced to each frame's emitter and BSDF sampling variances (as
  :func:`~._microfacet_kernels.conductor_proxies`).

The per-view constants (Λ_i, s(μ), k_d(μ), p_s(μ): the tables' lookups) are the BSDF's own,
computed in numpy (``AlbedoLayered.scale``, ``weights``); only the per-direction arithmetic
is compiled.
"""
from __future__ import annotations

import math
import weakref

import numba
import numpy as np

from envfit.predict.renderer._microfacet_kernels import _d, _lambda, _local, _proxy_add, _proxy_out
from envfit.predict.renderer._plastic_kernels import _finite, _fresnel, _half, _square
from envfit.predict.renderer._vndf_kernels import _disk, _normal, _view_constants
from envfit.shading.microfacet import AlbedoLayered
from envfit.shading.microfacet import VNDF_WARPS

__all__ = ["compiled_layered", "layered_eval_pdf", "layered_sample", "layered_proxies",
           "layered_views"]

#: consts' slots: α, η, f₀, F₀(η); a view's: Λ_i, s(μ), k_d(μ), p_s(μ)
_ALPHA, _ETA, _F0, _F0R = range(4)
_LAM, _SCALE, _KD, _PS = range(4)
_VARIANT = VNDF_WARPS.index("hemisphere_concentric")


@numba.njit(cache=True, error_model="numpy")
def _fc_pdf(wi, view, o, consts):  # pragma: no cover - numba
    """(f·cos, pdf) at the local light direction ``o`` for the local view ``wi``."""
    ix, iy, iz = wi[0], wi[1], wi[2]
    ox, oy, oz = o
    if not (iz > 0.0 and oz > 0.0):
        return 0.0, 0.0
    alpha = consts[_ALPHA]
    hx, hy, hz = _half(ix, iy, iz, ox, oy, oz)
    d = _d(hx, hy, hz, alpha, 0)
    cih = ix * hx + iy * hy + iz * hz
    f0, f0r = consts[_F0], consts[_F0R]
    s = min(max((_fresnel(cih, consts[_ETA]) - f0r) / (1.0 - f0r), 0.0), 1.0)
    f = f0 + (1.0 - f0) * s
    lam_i = view[_LAM]
    lam_o = _lambda(ox, oy, oz, alpha, 0)
    spec = _finite(view[_SCALE] * f * d / (4.0 * iz * (1.0 + lam_i + lam_o)))
    q = _finite(d / (4.0 * iz * (1.0 + lam_i)))
    ps = view[_PS]
    return spec + view[_KD] * oz / math.pi, ps * q + (1.0 - ps) * oz / math.pi


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _eval_pdf(wi, view, dirs, rows, consts, out):  # pragma: no cover - numba
    for p in numba.prange(dirs.shape[0]):
        out[p, 0], out[p, 1] = _fc_pdf(wi, view, _local(dirs[p], rows), consts)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sample(wi, vndf, view, u, lobe, consts, wo, out):  # pragma: no cover - numba
    """``lobe`` = (square, number): the lobe from u_x (``sample_square``) or the number."""
    ps = view[_PS]
    square = lobe[0] > 0.0
    for p in numba.prange(u.shape[0]):
        u0, s1 = u[p, 0], lobe[1]
        if square:
            u0, s1 = _square(u0, ps)
        if s1 < ps:
            mx, my, mz = _normal(wi, vndf, u0, u[p, 1], consts[_ALPHA], _VARIANT, 0)
            dot = wi[0] * mx + wi[1] * my + wi[2] * mz
            ox, oy, oz = 2.0 * dot * mx - wi[0], 2.0 * dot * my - wi[1], 2.0 * dot * mz - wi[2]
        else:
            px, py = _disk(u0, u[p, 1], False)
            ox, oy, oz = px, py, math.sqrt(max(1.0 - (px * px + py * py), 0.0))
        weight, pdf = 0.0, 0.0
        if wi[2] > 0.0 and oz > 0.0 and math.isfinite(ox + oy + oz):
            fc, pdf = _fc_pdf(wi, view, (ox, oy, oz), consts)
            weight = _finite(fc / pdf) if pdf > 0.0 else 0.0
        if weight <= 0.0:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = 0.0, 0.0, 1.0, weight, 0.0
        else:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = ox, oy, oz, weight, pdf


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _proxies(wis, views, frames, dirs, tab, consts, out):  # pragma: no cover - numba
    size = dirs.shape[0]
    for a in numba.prange(wis.shape[0]):
        acc = np.zeros(5)
        for p in range(size):
            fc, pb = _fc_pdf(wis[a], views[a], _local(dirs[p], frames[a]), consts)
            _proxy_add(acc, tab[p], fc, pb)
        _proxy_out(acc, size, out[a])


def compiled_layered(bsdf) -> bool:
    """Whether the kernels repeat ``bsdf``: an :class:`AlbedoLayered` (exactly that class)."""
    return type(bsdf) is AlbedoLayered


def _constants(bsdf) -> np.ndarray:
    eta = bsdf.eta
    return np.array([bsdf.alpha, eta, bsdf.f0, ((eta - 1.0) / (eta + 1.0)) ** 2])


def _views(bsdf, wis: np.ndarray) -> np.ndarray:
    """Per view (K, 4): Λ_i, s(μ), k_d(μ), p_s(μ) (0 where μ ≤ 0)."""
    wis = np.asarray(wis, dtype=np.float64).reshape(-1, 3)
    mu = np.clip(wis[:, 2], 0.0, 1.0)
    kd = bsdf.weights(mu)[1]
    out = np.column_stack([bsdf.distribution.lambda_(wis), bsdf.scale(mu), kd,
                           bsdf.lobe_probability(mu)])
    out[wis[:, 2] <= 0] = 0.0
    return np.ascontiguousarray(out)


#: per BSDF, the view row of each view :func:`layered_eval_pdf` and :func:`layered_sample`
#: were given (the microfacet model asks for one frame's view several times: each lobe,
#: each table); dropped with the BSDF
_VIEW_ROWS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_VIEW_ROWS_MAX = 4096


def _view_row(bsdf, wi: np.ndarray) -> np.ndarray:
    """:func:`_views` of the one view ``wi``, (4,), memoised per BSDF (and its parameters)
    and view: the same numbers, computed once."""
    try:
        rows = _VIEW_ROWS.setdefault(bsdf, {})
    except TypeError:                                   # not weakly referable: not memoised
        return _views(bsdf, wi)[0]
    key = (np.ascontiguousarray(wi, dtype=np.float64).tobytes(), _constants(bsdf).tobytes(),
           float(bsdf.base_color))
    row = rows.get(key)
    if row is None:
        if len(rows) >= _VIEW_ROWS_MAX:
            rows.clear()
        row = rows[key] = _views(bsdf, wi)[0]
    return row


def layered_views(bsdf, wis) -> np.ndarray:
    """The per-view constants (K, 4) of the views ``wis`` (K, 3) that :func:`layered_eval_pdf`
    and :func:`layered_sample` take as ``view`` (computed once for many calls)."""
    return _views(bsdf, wis)


def layered_eval_pdf(bsdf, wi, dirs, rows=None,
                     view=None) -> tuple[np.ndarray, np.ndarray]:
    """(f·cos (P,), pdf (P,)) of the layered ``bsdf`` for the one view ``wi`` (3,) and light
    directions ``dirs`` (P, 3): local, or world with ``rows`` the local frame's axes as rows
    — ``AlbedoLayered.eval`` and ``pdf``; ``view``: its row of :func:`layered_views`."""
    out = np.empty((2, len(dirs)))
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    rows = np.eye(3) if rows is None else np.ascontiguousarray(rows, dtype=np.float64)
    view = _view_row(bsdf, wi) if view is None else np.ascontiguousarray(view)
    _eval_pdf(wi, view, np.ascontiguousarray(dirs, dtype=np.float64), rows,
              _constants(bsdf), out.T)
    return out[0], out[1]


def layered_sample(bsdf, wi, u, u1=None,
                   view=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω_o (P, 3), weight (P,), pdf (P,)) of the layered ``bsdf`` sampled for the one view
    ``wi`` (3,) at the points ``u`` (P, 2), local frame: ``AlbedoLayered.sample_square(wi,
    u)`` when ``u1`` is None, else ``AlbedoLayered.sample(wi, u, u1=full(u1))``; where the
    weight is 0, ω_o is the pole and the pdf 0; ``view``: its row of :func:`layered_views`."""
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    vndf = (_view_constants(wi, float(bsdf.alpha), _VARIANT, 0) if wi[2] > 0
            else np.zeros((4, 5)))
    lobe = np.array([1.0, 0.0] if u1 is None else [0.0, float(u1)])
    wo, out = np.empty((len(u), 3)), np.empty((2, len(u)))
    view = _view_row(bsdf, wi) if view is None else np.ascontiguousarray(view)
    _sample(wi, vndf, view, np.ascontiguousarray(u, dtype=np.float64), lobe,
            _constants(bsdf), wo, out)
    return wo, out[0], out[1]


def layered_proxies(bsdf, wis, frames, dirs, base, pdf) -> np.ndarray:
    """Per frame (v_e, v_b) (K, 2) of the layered ``bsdf`` on a map table, as
    :func:`~._plastic_kernels.plastic_proxies`."""
    tab = np.ascontiguousarray(np.column_stack([np.pi * base, pdf]), dtype=np.float64)
    wis = np.ascontiguousarray(wis, dtype=np.float64)
    out = np.zeros((len(wis), 2))
    _proxies(wis, _views(bsdf, wis), np.ascontiguousarray(frames, dtype=np.float64),
             np.ascontiguousarray(dirs, dtype=np.float64), tab, _constants(bsdf), out)
    return out

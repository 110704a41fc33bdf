r"""Compiled (numba) forms of the rough plastic for the microfacet model's hot loops, each the
same arithmetic as :class:`envfit.shading.microfacet.RoughPlastic` (``_plastic``; the
renderer's source it follows is cited in the renderer's folder, ``_bsdf``), which the tests
compare it with:

* :func:`plastic_eval_pdf` — f·cos θ_o and the sampling pdf at many light directions for one
  view (``RoughPlastic.eval`` and ``pdf``): the specular term ρ_s F(ω_i·H) D(H) G_1(ω_i, H)
  G_1(ω_o, H)/(4 cos θ_i) (D zeroed where D cos θ_H ≤ 1e-20, separable Smith G of GGX or
  Beckmann's rational fit, the dielectric Fresnel of η) plus the diffuse term
  ρ_d/(1 − R_i')·cos θ_o/(πη²)·T(cos θ_i) T(cos θ_o) (T the rough transmittance table,
  linearly interpolated); the pdf the two lobes' mixture with the specular probability
  p_s = (1 − T_i)w / ((1 − T_i)w + T_i(1 − w)), the specular lobe's density by visible
  normals (D G_1(ω_i, H)/(4 cos θ_i)) or, ``sample_visible`` false, by D(m) cos θ_m
  (D cos θ_H/(4 ω_o·H));
* :func:`plastic_sample` — ``RoughPlastic.sample`` (the lobe from a given ``sample1``) and
  ``sample_square`` (the lobe from u_x, rescaled within its lobe): a normal by the plastic's
  visible-normal warp (``_vndf_kernels._normal``, the slope-space variant 0, as
  ``RoughPlastic.sample``) or the D(m) cos θ_m warp, reflected; or a
  cosine-distributed direction by the concentric map; then the weight f·cos/pdf and the pdf;
* :func:`plastic_proxies` — the same at a map table's directions for many frames at once,
  reduced to each frame's emitter and BSDF sampling variances (as :func:`conductor_proxies`).

The transmittance table T and the internal reflectance R_i are the BSDF's
(``rough_fresnel_tables``, computed in numpy when it is built); only the per-direction
arithmetic is compiled.

The renderer's source each step follows is cited in the renderer's folder
(``envfit/renderers/<name>/_bsdf.py``: eval, pdf, sample, the transmittance lookup, the
distribution's eval, G1, G, sample and pdf, the dielectric Fresnel, the cosine hemisphere by
the concentric disk).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.predict.renderer._microfacet_kernels import (_KINDS, _d, _lambda, _local,
                                                        _proxy_add, _proxy_out)
from envfit.predict.renderer._vndf_kernels import _disk, _normal, _view_constants
from envfit.shading.microfacet import RoughPlastic

__all__ = ["compiled_plastic", "plastic_eval_pdf", "plastic_sample", "plastic_proxies"]

_BIG = float(np.finfo(np.float64).max)


@numba.njit(cache=True, error_model="numpy")
def _finite(x):  # pragma: no cover - numba
    """``np.nan_to_num``: NaN → 0, ±inf → ± the largest float."""
    if math.isnan(x):
        return 0.0
    if math.isinf(x):
        return math.copysign(_BIG, x)
    return x


@numba.njit(cache=True, error_model="numpy")
def _lerp(table, x):  # pragma: no cover - numba
    """``_lerp_gather``: the table linearly interpolated at x clipped to [0, 1]."""
    n = table.shape[0]
    x = min(max(x, 0.0), 1.0) * (n - 1)
    i = min(int(x), n - 2)
    return table[i] + (x - i) * (table[i + 1] - table[i])


@numba.njit(cache=True, error_model="numpy")
def _view(ix, iy, iz, consts, table):  # pragma: no cover - numba
    """The per-view constants: (Λ(ω_i), T(cos θ_i), p_s) (``prob_specular``)."""
    t = _lerp(table, iz)
    w = consts[5]
    ps, pd = (1.0 - t) * w, t * (1.0 - w)
    return _lambda(ix, iy, iz, consts[0], int(consts[1])), t, ps / (ps + pd)


@numba.njit(cache=True, error_model="numpy")
def _fresnel(c, eta):  # pragma: no cover - numba
    """``fresnel_dielectric``'s reflectance F(cos θ_i, η) (the dielectric Fresnel)."""
    outside = c >= 0.0
    eta_it = eta if outside else 1.0 / eta
    eta_ti = 1.0 / eta if outside else eta
    ci = abs(c)
    if ci == 0.0:
        return 0.0 if eta == 1.0 else 1.0
    if eta == 1.0:
        return 0.0
    ct = math.sqrt(max(1.0 - (1.0 - c * c) * eta_ti * eta_ti, 0.0))
    a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
    a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    return 0.5 * (a_s * a_s + a_p * a_p)


@numba.njit(cache=True, error_model="numpy")
def _dm(mx, my, mz, alpha, kind):  # pragma: no cover - numba
    """``RoughPlastic._D``: D(m), zeroed where D cos θ_m ≤ 1e-20 (for a unit m that holds
    wherever cos θ_m ≤ 1e-20, where D itself may not be representable)."""
    if not mz > 1e-20:
        return 0.0
    d = _d(mx, my, mz, alpha, kind)
    return d if d * mz > 1e-20 else 0.0


@numba.njit(cache=True, error_model="numpy")
def _half(ix, iy, iz, ox, oy, oz):  # pragma: no cover - numba
    """The normalised half vector of two directions (0 where they cancel)."""
    hx, hy, hz = ix + ox, iy + oy, iz + oz
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    if n > 0.0:
        return hx / n, hy / n, hz / n
    return 0.0, 0.0, 0.0


@numba.njit(cache=True, error_model="numpy")
def _fc_pdf(wi, view, o, consts, table):  # pragma: no cover - numba
    """(f·cos, pdf) at the local light direction ``o`` for the local view ``wi`` and its
    ``view`` constants (:func:`_view`); ``consts`` = (α, kind, η, ρ_s, ρ_d/(1 − R_i')/(πη²),
    w, sample_visible)."""
    ix, iy, iz = wi[0], wi[1], wi[2]
    ox, oy, oz = o
    if not (iz > 0.0 and oz > 0.0):
        return 0.0, 0.0
    alpha, kind = consts[0], int(consts[1])
    hx, hy, hz = _half(ix, iy, iz, ox, oy, oz)
    d = _dm(hx, hy, hz, alpha, kind)
    dot_i = ix * hx + iy * hy + iz * hz
    dot_o = ox * hx + oy * hy + oz * hz
    g1i = 0.0 if dot_i * iz <= 0.0 else 1.0 / (1.0 + view[0])
    g1o = 0.0 if dot_o * oz <= 0.0 else 1.0 / (1.0 + _lambda(ox, oy, oz, alpha, kind))
    spec = _finite(consts[3] * _fresnel(dot_i, consts[2]) * d * (g1i * g1o) / (4.0 * iz))
    fc = spec + consts[4] * oz * view[1] * _lerp(table, oz)
    if consts[6] > 0.0:
        q = _finite(d * g1i / (4.0 * iz))
    else:
        q = _finite(d * hz / (4.0 * dot_o))
    ps = view[2]
    return fc, ps * q + (1.0 - ps) * oz / math.pi


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _eval_pdf(wi, dirs, rows, consts, table, out):  # pragma: no cover - numba
    view = _view(wi[0], wi[1], wi[2], consts, table)
    for p in numba.prange(dirs.shape[0]):
        out[p, 0], out[p, 1] = _fc_pdf(wi, view, _local(dirs[p], rows), consts, table)


@numba.njit(cache=True, error_model="numpy")
def _normal_all(u0, u1, alpha, kind):  # pragma: no cover - numba
    """``_normals_all``: m ~ D(m) cos θ_m (``sample_visible`` false)."""
    phi = 2.0 * math.pi * u1
    if kind == 1:
        cos_t = 1.0 / math.sqrt(1.0 - alpha * alpha * math.log(1.0 - u0))
    else:
        cos_t = 1.0 / math.sqrt(1.0 + alpha * alpha * u0 / (1.0 - u0))
    sin_t = math.sqrt(max(1.0 - cos_t * cos_t, 0.0))
    return math.cos(phi) * sin_t, math.sin(phi) * sin_t, cos_t


@numba.njit(cache=True, error_model="numpy")
def _direction(wi, vndf, u0, u1, spec, consts):  # pragma: no cover - numba
    """ω_o of ``RoughPlastic.sample`` in the chosen lobe: the reflection about a sampled
    normal (visible normals: ``vndf`` the rows of ``_view_constants``), or the cosine-weighted
    hemisphere by the concentric disk."""
    if not spec:
        px, py = _disk(u0, u1, False)
        return px, py, math.sqrt(max(1.0 - (px * px + py * py), 0.0))
    alpha, kind = consts[0], int(consts[1])
    if consts[6] > 0.0:
        mx, my, mz = _normal(wi, vndf, u0, u1, alpha, 0, kind)
    else:
        mx, my, mz = _normal_all(u0, u1, alpha, kind)
    dot = wi[0] * mx + wi[1] * my + wi[2] * mz
    return 2.0 * dot * mx - wi[0], 2.0 * dot * my - wi[1], 2.0 * dot * mz - wi[2]


@numba.njit(cache=True, error_model="numpy")
def _square(ux, ps):  # pragma: no cover - numba
    """``sample_square``'s lobe number (``sample1``: 0 specular, 1 diffuse) and u_x rescaled
    to [0, 1] within its lobe."""
    spec = ux < ps
    x = ux / ps if spec else (ux - ps) / (1.0 - ps)
    if math.isnan(x):
        x = 0.0
    return min(max(x, 0.0), 1.0), 0.0 if spec else 1.0


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sample(wi, vndf, u, lobe, consts, table, wo, out):  # pragma: no cover - numba
    """``lobe`` = (square, sample1): the lobe from u_x (``sample_square``) or from sample1."""
    view = _view(wi[0], wi[1], wi[2], consts, table)
    ps = view[2]
    square = lobe[0] > 0.0
    for p in numba.prange(u.shape[0]):
        u0, s1 = u[p, 0], lobe[1]
        if square:
            u0, s1 = _square(u0, ps)
        spec = wi[2] > 0.0 and s1 < ps
        o = _direction(wi, vndf, u0, u[p, 1], spec, consts)
        fc, pdf = _fc_pdf(wi, view, o, consts, table)
        weight = _finite(fc / pdf) if pdf > 0.0 else 0.0
        if weight <= 0.0:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = 0.0, 0.0, 1.0, weight, 0.0
        else:
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = o[0], o[1], o[2], weight, pdf


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _proxies(wis, frames, dirs, tab, consts, table, out):  # pragma: no cover - numba
    size = dirs.shape[0]
    for a in numba.prange(wis.shape[0]):
        wi = wis[a]
        view = _view(wi[0], wi[1], wi[2], consts, table)
        acc = np.zeros(5)
        for p in range(size):
            fc, pb = _fc_pdf(wi, view, _local(dirs[p], frames[a]), consts, table)
            _proxy_add(acc, tab[p], fc, pb)
        _proxy_out(acc, size, out[a])


def compiled_plastic(bsdf) -> bool:
    """Whether the kernels repeat ``bsdf``: a :class:`RoughPlastic` (exactly that class; GGX or
    Beckmann, any α, η, scalar reflectances, ``nonlinear``, ``sample_visible``)."""
    return (type(bsdf) is RoughPlastic and bsdf.distribution.kind in _KINDS
            and all(isinstance(v, float) for v in (bsdf.diffuse_reflectance,
                                                   bsdf.specular_reflectance, bsdf.eta)))


def _constants(bsdf) -> tuple[np.ndarray, np.ndarray]:
    """(consts of :func:`_fc_pdf`, the transmittance table) of ``bsdf``."""
    d, eta, rho = bsdf.distribution, bsdf.eta, bsdf.diffuse_reflectance
    ri = rho * bsdf.internal_reflectance if bsdf.nonlinear else bsdf.internal_reflectance
    diffuse = rho / (1.0 - ri) / math.pi / (eta * eta)          # eval's order of operations
    consts = np.array([d.alpha, _KINDS[d.kind], eta, bsdf.specular_reflectance, diffuse,
                       bsdf.specular_sampling_weight, bsdf.sample_visible], dtype=np.float64)
    return consts, np.ascontiguousarray(bsdf.transmittance_table, dtype=np.float64)


def plastic_eval_pdf(bsdf, wi, dirs, rows=None) -> tuple[np.ndarray, np.ndarray]:
    """(f·cos (P,), pdf (P,)) of the rough plastic ``bsdf`` for the one view ``wi`` (3,) and
    light directions ``dirs`` (P, 3): local, or world with ``rows`` the local frame's axes
    (t, b, n) as rows (local = ``dirs @ rows.T``) — ``RoughPlastic.eval`` and ``pdf``."""
    consts, table = _constants(bsdf)
    out = np.empty((2, len(dirs)))
    rows = np.eye(3) if rows is None else np.ascontiguousarray(rows, dtype=np.float64)
    _eval_pdf(np.ascontiguousarray(wi, dtype=np.float64),
              np.ascontiguousarray(dirs, dtype=np.float64), rows, consts, table, out.T)
    return out[0], out[1]


def plastic_sample(bsdf, wi, u, u1=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω_o (P, 3), weight f·cos/pdf (P,), pdf (P,)) of the rough plastic ``bsdf`` sampled
    for the one view ``wi`` (3,) at the points ``u`` (P, 2), local frame:
    ``RoughPlastic.sample_square(wi, u)`` (the lobe from u_x) when ``u1`` is None, else
    ``RoughPlastic.sample(wi, u, u1=full(u1))`` (the lobe from sample1 = ``u1``); where the
    weight is 0, ω_o is the pole and the pdf 0."""
    consts, table = _constants(bsdf)
    d = bsdf.distribution
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    vndf = np.zeros((4, 5))
    if wi[2] > 0 and bsdf.sample_visible:
        vndf = _view_constants(wi, float(d.alpha), 0, _KINDS[d.kind])
    lobe = np.array([1.0, 0.0] if u1 is None else [0.0, float(u1)])
    wo, out = np.empty((len(u), 3)), np.empty((2, len(u)))
    _sample(wi, vndf, np.ascontiguousarray(u, dtype=np.float64), lobe, consts, table, wo, out)
    return wo, out[0], out[1]


def plastic_proxies(bsdf, wis, frames, dirs, base, pdf) -> np.ndarray:
    r"""Per frame a: (v_e, v_b) (K, 2), the variances of emitter and BSDF sampling on a map
    table (``MicrofacetModel._proxies``) for the rough plastic ``bsdf``: with
    :math:`b = \pi\,` ``base`` (P, 3), :math:`f` its f·cos and :math:`p_b` its pdf at the
    table's world ``dirs`` (P, 3) in frame a (``frames`` (K, 3, 3), axes as rows; views
    ``wis`` (K, 3) local), :math:`v_e = \overline{|b|^2 f^2} - |\overline{b f}|^2` and
    :math:`v_b = \overline{|b|^2 p\, f^2/p_b} - |\overline{b f}|^2` (``pdf`` the map's),
    clipped at 0 (:func:`conductor_proxies`' definition)."""
    consts, table = _constants(bsdf)
    tab = np.ascontiguousarray(np.column_stack([np.pi * base, pdf]), dtype=np.float64)
    out = np.zeros((len(wis), 2))
    _proxies(np.ascontiguousarray(wis, dtype=np.float64),
             np.ascontiguousarray(frames, dtype=np.float64),
             np.ascontiguousarray(dirs, dtype=np.float64), tab, consts, table, out)
    return out

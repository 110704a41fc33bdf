r"""Visible-normal sampling of the microfacet distributions: a uniform point ``u`` of the unit
square → a microfacet normal m with density :math:`D_{\omega_i}(m)`
(:meth:`MicrofacetDistribution.visible_pdf`), by one of three warps (:data:`VNDF_WARPS`).

All three draw the same density; they differ in the map from ``u`` to m, so the same ``u``
gives different normals. Each is named by its GGX form; its Beckmann form is listed with it:

* ``slope_space`` — stretch ω_i, sample the α = 1 visible slopes in the frame of ω_i's
  azimuth, rotate and unstretch the slopes. GGX: Heitz 2018 in slope space from the
  **concentric** disk point (:func:`concentric_disk`, the branch-reduced form that picks the
  y branch on :math:`|x| < |y|`), p_y lerped with s = ½(1 + cos θ_i); the disk's x becomes the slope
  across the plane of incidence with the sign opposite to the hemisphere warps' T1 (the same
  u gives m mirrored across the plane of incidence). Beckmann: Jakob's numerical inversion of
  Heitz–d'Eon 2014 (initial guess, CDF normalisation, three plain Newton steps in the erf
  domain, u clamped to [1e-6, 1 − 1e-6]); stretched views within 4 float32 ε of the pole
  take azimuth 0.
* ``hemisphere_polar`` — GGX only: Heitz 2018 in the hemisphere configuration with basis
  T1 = z × ω_h, T2 = ω_h × T1 and a **polar** disk point (:func:`polar_disk`: r = √u₀,
  φ = 2πu₁); m_z ≥ 1e-6.
* ``hemisphere_concentric`` — GGX: as ``hemisphere_polar`` with the **concentric** disk point
  and m_z ≥ 0 (T1 = (1, 0, 0), T2 = (0, 1, 0) where the stretched view's :math:`x^2 + y^2 \le 10^{-7}`).
  Beckmann: the safeguarded reformulation of Jakob's routine (a closed-form start, up to
  three Newton/bisection steps, stop at |residual| ≤ 1e-6; polar slopes at normal
  incidence, stretched cos θ ≥ 0.99999), with the exact erf and erf⁻¹ (scipy).

Which renderer samples by which warp, read from which source, its folder says
(``envfit/renderers/<name>/_bsdf.py``).

References: Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018;
Heitz, d'Eon, "Importance Sampling Microfacet-Based BSDFs using the Distribution of Visible
Normals", EGSR 2014; Jakob, "An Improved Visible Normal Sampling Routine for the Beckmann
Distribution", 2014.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import erf, erfinv

from envfit.base import ParameterError

__all__ = ["concentric_disk", "polar_disk", "sample_visible_normals", "VNDF_WARPS"]

#: the visible-normal warps by name (module docstring)
VNDF_WARPS = ("slope_space", "hemisphere_polar", "hemisphere_concentric")
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_F32_EPS = float(np.finfo(np.float32).eps)


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """Shirley–Chiu concentric square → disk, the branch-reduced form (the y branch on
    :math:`|x| < |y|`; the classic form gives the same point, ties included).
    (K, 2) → (K, 2)."""
    x = 2.0 * u[:, 0] - 1.0
    y = 2.0 * u[:, 1] - 1.0
    q13 = np.abs(x) < np.abs(y)
    r = np.where(q13, y, x)
    rp = np.where(q13, x, y)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 0.25 * math.pi * rp / r
    phi = np.where(q13, 0.5 * math.pi - phi, phi)
    phi = np.where((x == 0) & (y == 0), 0.0, phi)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)


def polar_disk(u: np.ndarray) -> np.ndarray:
    """The polar square → disk map: r = √u₀, φ = 2πu₁. (K, 2) → (K, 2)."""
    r = np.sqrt(u[:, 0])
    t = 2.0 * math.pi * u[:, 1]
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.sqrt(np.einsum("ij,ij->i", v, v))[:, None]     # np.linalg.norm, faster


def _stretch(wi: np.ndarray, alpha: float) -> np.ndarray:
    return _normalize(np.stack([alpha * wi[:, 0], alpha * wi[:, 1], wi[:, 2]], axis=1))


def _ggx_slopes_11(cos_i: np.ndarray, u: np.ndarray) -> np.ndarray:
    """GGX's α = 1 visible slopes for incidence cos θ_i (Heitz 2018 in slope space)."""
    p = concentric_disk(u)
    s = 0.5 * (1.0 + cos_i)
    h = np.sqrt(np.maximum(1.0 - p[:, 0] ** 2, 0.0))
    py = h + s * (p[:, 1] - h)                        # dr::lerp(h, p.y, s)
    x = p[:, 0]
    z = np.sqrt(np.maximum(1.0 - x * x - py * py, 0.0))
    sin_i = np.sqrt(np.maximum(1.0 - cos_i ** 2, 0.0))
    norm = 1.0 / (sin_i * py + cos_i * z)
    return np.stack([(cos_i * py - sin_i * z) * norm, x * norm], axis=1)


def _beckmann_slopes_newton(cos_i: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Beckmann's α = 1 visible slopes: Jakob's inversion with three plain Newton steps."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tan_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0)) / cos_i
        cot_i = 1.0 / tan_i
        maxval = erf(cot_i)
        u = np.clip(u, 1e-6, 1.0 - 1e-6)
        x = maxval - (maxval + 1.0) * erf(np.sqrt(-np.log(u[:, 0])))
        tail = np.where(tan_i == 0.0, 0.0, _INV_SQRT_PI * tan_i * np.exp(-cot_i ** 2))
        ux = u[:, 0] * (1.0 + maxval + tail)
        for _ in range(3):
            slope = erfinv(x)
            value = 1.0 + x + _INV_SQRT_PI * tan_i * np.exp(-slope ** 2) - ux
            x = x - value / (1.0 - slope * tan_i)
    return np.stack([erfinv(x), erfinv(2.0 * u[:, 1] - 1.0)], axis=1)


def _slope_space(kind: str, alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The ``slope_space`` warp: stretch, the α = 1 slopes, rotate, unstretch."""
    wp = _stretch(wi, alpha)
    sin2 = 1.0 - wp[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        cs = np.clip(wp[:, :2] / np.sqrt(sin2)[:, None], -1.0, 1.0)
    small = np.abs(sin2) <= 4.0 * _F32_EPS
    cos_phi = np.where(small, 1.0, cs[:, 0])
    sin_phi = np.where(small, 0.0, cs[:, 1])
    eleven = _ggx_slopes_11 if kind == "ggx" else _beckmann_slopes_newton
    s = eleven(wp[:, 2], u)
    sx = (cos_phi * s[:, 0] - sin_phi * s[:, 1]) * alpha
    sy = (sin_phi * s[:, 0] + cos_phi * s[:, 1]) * alpha
    return _normalize(np.stack([-sx, -sy, np.ones_like(sx)], axis=1))


def _heitz2018(wh: np.ndarray, t1: np.ndarray, t2: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Heitz 2018 §4.2–4.3: warp the disk point and reproject onto the hemisphere (T1, T2, ω_h)."""
    h = np.sqrt(np.maximum(1.0 - p[:, 0] ** 2, 0.0))
    py = h + 0.5 * (1.0 + wh[:, 2]) * (p[:, 1] - h)
    pz = np.sqrt(np.maximum(1.0 - p[:, 0] ** 2 - py ** 2, 0.0))
    return p[:, :1] * t1 + py[:, None] * t2 + pz[:, None] * wh


def _hemisphere_polar(kind: str, alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The ``hemisphere_polar`` warp (GGX only)."""
    if kind != "ggx":
        raise ParameterError("the hemisphere_polar visible-normal warp is GGX's only (Heitz "
                             f"2018), got {kind!r}")
    wh = _stretch(wi, alpha)
    wh = np.where(wh[:, 2:] < 0, -wh, wh)
    normal = wh[:, 2] >= 0.99999
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = _normalize(np.stack([-wh[:, 1], wh[:, 0], np.zeros(len(wh))], axis=1))
    t1 = np.where(normal[:, None], np.array([1.0, 0.0, 0.0]), t1)
    t2 = np.cross(wh, t1)
    nh = _heitz2018(wh, t1, t2, polar_disk(u))
    return _normalize(np.stack([alpha * nh[:, 0], alpha * nh[:, 1],
                                np.maximum(nh[:, 2], 1e-6)], axis=1))


def _hemisphere_concentric_ggx(alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The ``hemisphere_concentric`` warp, GGX."""
    wh = _stretch(wi, alpha)
    lensq = wh[:, 0] ** 2 + wh[:, 1] ** 2
    ok = lensq > 1e-7
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.stack([-wh[:, 1], wh[:, 0], np.zeros(len(wh))], axis=1) / np.sqrt(lensq)[:, None]
    t1 = np.where(ok[:, None], t1, np.array([1.0, 0.0, 0.0]))
    t2 = np.where(ok[:, None], np.cross(wh, t1), np.array([0.0, 1.0, 0.0]))
    hh = _heitz2018(wh, t1, t2, concentric_disk(u))
    return _normalize(np.stack([alpha * hh[:, 0], alpha * hh[:, 1],
                                np.maximum(hh[:, 2], 0.0)], axis=1))


def _safeguarded_slope_x(tan_i, u0):
    """The safeguarded root search for Beckmann's x slope (exact erf/erf⁻¹)."""
    cot_i = 1.0 / tan_i
    erf_a, exp_a2 = erf(cot_i), np.exp(-cot_i * cot_i)
    k = tan_i * _INV_SQRT_PI
    y_approx = u0 * (1.0 + erf_a + k * (1.0 - erf_a * erf_a))
    y_exact = u0 * (1.0 + erf_a + k * exp_a2)
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.where(k > 0, (0.5 - np.sqrt(k * (k - y_approx + 1.0) + 0.25)) / k, y_approx - 1.0)
    inv = erfinv(b)
    begin_x, begin_y, end_x = -np.ones_like(b), -y_exact, erf_a
    cur_x, cur_y = b, 1.0 + b + k * np.exp(-inv * inv) - y_exact
    for _ in range(3):
        act = np.abs(cur_y) > 1e-6
        same = np.where(begin_y < 0, -1, 1) == np.where(cur_y < 0, -1, 1)
        begin_x = np.where(act & same, cur_x, begin_x)
        begin_y = np.where(act & same, cur_y, begin_y)
        end_x = np.where(act & ~same, cur_x, end_x)
        newton = cur_x - cur_y / (1.0 - inv * tan_i)
        inside = (newton >= begin_x) & (newton <= end_x)
        cur_x = np.where(act, np.where(inside, newton, 0.5 * (begin_x + end_x)), cur_x)
        inv = np.where(act, erfinv(cur_x), inv)
        cur_y = np.where(act, 1.0 + cur_x + k * np.exp(-inv * inv) - y_exact, cur_y)
    return inv


def _hemisphere_concentric_beckmann(alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The ``hemisphere_concentric`` warp, Beckmann: the safeguarded slopes (polar ones at
    normal incidence)."""
    wh = _stretch(wi, alpha)
    normal = wh[:, 2] >= 0.99999
    sin_i = np.sqrt(np.maximum(1.0 - wh[:, 2] ** 2, 0.0))
    safe_sin = np.where(normal, 1.0, sin_i)
    tan_i = np.where(normal, 1.0, safe_sin / wh[:, 2])
    cos_phi = np.where(normal, 1.0, wh[:, 0] / safe_sin)
    sin_phi = np.where(normal, 0.0, wh[:, 1] / safe_sin)
    with np.errstate(divide="ignore"):
        r = np.sqrt(-np.log(u[:, 0]))
    phi = 2.0 * math.pi * u[:, 1]
    sx = np.where(normal, r * np.cos(phi), _safeguarded_slope_x(tan_i, u[:, 0]))
    sy = np.where(normal, r * np.sin(phi), erfinv(2.0 * u[:, 1] - 1.0))
    rx = (cos_phi * sx - sin_phi * sy) * alpha
    ry = (sin_phi * sx + cos_phi * sy) * alpha
    return _normalize(np.stack([-rx, -ry, np.ones_like(rx)], axis=1))


def sample_visible_normals(warp: str, kind: str, alpha: float, wi, u) -> np.ndarray:
    r"""Microfacet normals m (K, 3) drawn from :math:`D_{\omega_i}` by the visible-normal
    ``warp``.

    Parameters
    ----------
    warp : a name of :data:`VNDF_WARPS` (module docstring)
    kind : "ggx" or "beckmann" (``hemisphere_polar``: "ggx" only)
    alpha : the roughness α (already checked by the caller's distribution)
    wi : (K, 3) unit view directions in the local frame, wi_z > 0
    u : (K, 2) points of the unit square

    Returns
    -------
    ndarray (K, 3): unit microfacet normals in the local frame.
    """
    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
    if warp == "slope_space":
        return _slope_space(kind, alpha, wi, u)
    if warp == "hemisphere_polar":
        return _hemisphere_polar(kind, alpha, wi, u)
    if warp == "hemisphere_concentric":
        if kind == "ggx":
            return _hemisphere_concentric_ggx(alpha, wi, u)
        return _hemisphere_concentric_beckmann(alpha, wi, u)
    raise ParameterError(f"visible-normal warp must be one of {VNDF_WARPS}, got {warp!r}")

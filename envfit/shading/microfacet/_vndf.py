r"""Visible-normal sampling of the microfacet distributions, step for step as each renderer does
it: a uniform point ``u`` of the unit square → a microfacet normal m with density
:math:`D_{\omega_i}(m)` (:meth:`MicrofacetDistribution.visible_pdf`).

All three draw the same density; they differ in the map from ``u`` to m, so the same ``u``
gives different normals:

* **Mitsuba 3** (``include/mitsuba/render/microfacet.h``: ``MicrofacetDistribution::sample``,
  ``sample_visible_11``): stretch ω_i, sample the α = 1 visible slopes in the frame of ω_i's
  azimuth, rotate and unstretch the slopes. GGX: Heitz 2018 in slope space from the
  **concentric** disk point (``warp::square_to_uniform_disk_concentric``), p_y lerped with
  s = ½(1 + cos θ_i); the disk's x becomes the slope across the plane of incidence
  with the sign opposite to pbrt's/Cycles' T1 (the same u gives m mirrored across the plane
  of incidence relative to Cycles). Beckmann: Jakob's
  numerical inversion of Heitz–d'Eon 2014 (initial guess, CDF normalisation, three plain
  Newton steps in the erf domain).
* **pbrt-v4** (``src/pbrt/util/scattering.h``: ``TrowbridgeReitzDistribution::Sample_wm``;
  GGX only): Heitz 2018 in the hemisphere configuration with basis T1 = z × ω_h, T2 = ω_h × T1
  and a **polar** disk point (``SampleUniformDiskPolar``: r = √u₀, φ = 2πu₁); m_z ≥ 1e-6.
* **Cycles** (``src/kernel/closure/bsdf_microfacet.h``: ``microfacet_ggx_sample_vndf``,
  ``microfacet_beckmann_sample_vndf``): GGX as pbrt but with the **concentric** disk point
  (``sample_uniform_disk``) and m_z ≥ 0; Beckmann: the OSL reformulation of Jakob's routine
  (a closed-form start, up to three safeguarded Newton/bisection steps, stop at |residual|
  ≤ 1e-6). Cycles evaluates erf and erf⁻¹ by fast approximations (``fast_erff``,
  ``fast_ierff``); this port uses the exact functions (scipy), so its Beckmann normals differ
  from Cycles' by those approximations' error.

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

__all__ = ["concentric_disk", "polar_disk", "sample_visible_normals", "VNDF_RENDERERS"]

VNDF_RENDERERS = ("mitsuba3", "pbrt4", "cycles")
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_F32_EPS = float(np.finfo(np.float32).eps)


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """Shirley–Chiu concentric square → disk (Mitsuba's branch-reduced form; Cycles'
    ``sample_uniform_disk`` gives the same point, ties included). (K, 2) → (K, 2)."""
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
    """pbrt-v4's ``SampleUniformDiskPolar``: r = √u₀, φ = 2πu₁. (K, 2) → (K, 2)."""
    r = np.sqrt(u[:, 0])
    t = 2.0 * math.pi * u[:, 1]
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.sqrt(np.einsum("ij,ij->i", v, v))[:, None]     # np.linalg.norm, faster


def _stretch(wi: np.ndarray, alpha: float) -> np.ndarray:
    return _normalize(np.stack([alpha * wi[:, 0], alpha * wi[:, 1], wi[:, 2]], axis=1))


def _mitsuba_ggx_11(cos_i: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``sample_visible_11``, GGX branch: α = 1 visible slopes for incidence cos θ_i."""
    p = concentric_disk(u)
    s = 0.5 * (1.0 + cos_i)
    h = np.sqrt(np.maximum(1.0 - p[:, 0] ** 2, 0.0))
    py = h + s * (p[:, 1] - h)                        # dr::lerp(h, p.y, s)
    x = p[:, 0]
    z = np.sqrt(np.maximum(1.0 - x * x - py * py, 0.0))
    sin_i = np.sqrt(np.maximum(1.0 - cos_i ** 2, 0.0))
    norm = 1.0 / (sin_i * py + cos_i * z)
    return np.stack([(cos_i * py - sin_i * z) * norm, x * norm], axis=1)


def _mitsuba_beckmann_11(cos_i: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``sample_visible_11``, Beckmann branch: Jakob's inversion with three Newton steps."""
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


def _sample_mitsuba(kind: str, alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``MicrofacetDistribution::sample`` with ``sample_visible`` (steps 1–4)."""
    wp = _stretch(wi, alpha)
    sin2 = 1.0 - wp[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        cs = np.clip(wp[:, :2] / np.sqrt(sin2)[:, None], -1.0, 1.0)
    small = np.abs(sin2) <= 4.0 * _F32_EPS
    cos_phi = np.where(small, 1.0, cs[:, 0])
    sin_phi = np.where(small, 0.0, cs[:, 1])
    eleven = _mitsuba_ggx_11 if kind == "ggx" else _mitsuba_beckmann_11
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


def _sample_pbrt(kind: str, alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``TrowbridgeReitzDistribution::Sample_wm`` (GGX only)."""
    if kind != "ggx":
        raise ParameterError("pbrt-v4 has no Beckmann distribution (TrowbridgeReitz only)")
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


def _sample_cycles_ggx(alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``microfacet_ggx_sample_vndf``."""
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


def _cycles_beckmann_slope_x(tan_i, u0):
    """``microfacet_beckmann_sample_vndf``'s root search for the x slope (exact erf/erf⁻¹)."""
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


def _sample_cycles_beckmann(alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``microfacet_beckmann_sample_vndf`` (steps 1–5; normal incidence by its special case)."""
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
    sx = np.where(normal, r * np.cos(phi), _cycles_beckmann_slope_x(tan_i, u[:, 0]))
    sy = np.where(normal, r * np.sin(phi), erfinv(2.0 * u[:, 1] - 1.0))
    rx = (cos_phi * sx - sin_phi * sy) * alpha
    ry = (sin_phi * sx + cos_phi * sy) * alpha
    return _normalize(np.stack([-rx, -ry, np.ones_like(rx)], axis=1))


def sample_visible_normals(renderer: str, kind: str, alpha: float, wi, u) -> np.ndarray:
    r"""Microfacet normals m (K, 3) drawn from :math:`D_{\omega_i}` as ``renderer`` draws them.

    Parameters
    ----------
    renderer : "mitsuba3", "pbrt4" or "cycles"
    kind : "ggx" or "beckmann" (pbrt-v4: "ggx" only)
    alpha : the roughness α (already checked by the caller's distribution)
    wi : (K, 3) unit view directions in the local frame, wi_z > 0
    u : (K, 2) points of the unit square

    Returns
    -------
    ndarray (K, 3): unit microfacet normals in the local frame.
    """
    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
    if renderer == "mitsuba3":
        return _sample_mitsuba(kind, alpha, wi, u)
    if renderer == "pbrt4":
        return _sample_pbrt(kind, alpha, wi, u)
    if renderer == "cycles":
        if kind == "ggx":
            return _sample_cycles_ggx(alpha, wi, u)
        return _sample_cycles_beckmann(alpha, wi, u)
    raise ParameterError(f"renderer must be one of {VNDF_RENDERERS}, got {renderer!r}")

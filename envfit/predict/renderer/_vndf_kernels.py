r"""Compiled (numba) BSDF sampling of a white rough conductor for one view: the conductor's
visible-normal warp (its ``vndf_variant``, a code of :data:`VNDF_VARIANTS`) step for step, then
the reflection, the weight f·cos/pdf and the pdf — the arithmetic of
:meth:`envfit.shading.microfacet.Conductor.sample` and
:func:`envfit.shading.microfacet.sample_visible_normals` (``_vndf``), which the tests compare
it with. Which renderer draws by which variant, read from which source, its folder says
(``envfit/renderers/<name>/__init__.py``, the record's microfacet conventions).

The variants (all draw the same density :math:`D_{\omega_i}(m)`; they differ in the map from
u to m):

* **0, slope space** — GGX: stretch ω_i, the α = 1 visible slopes (Heitz 2018 in slope space)
  from the *concentric* disk point, p_y lerped, the slopes rotated by the stretched view's
  azimuth, unstretched; Beckmann: Jakob's inversion (2014: initial guess, CDF normalisation,
  three plain Newton steps in the erf domain, u clamped to [1e-6, 1 − 1e-6]); separable G, the
  weight G1(ω_o, m) and the pdf's view masking G1(ω_i, m) (χ⁺);
* **1, hemisphere, polar disk** — GGX only: Heitz 2018 in the hemisphere configuration, basis
  T1 = z × ω_h, T2 = ω_h × T1, the *polar* disk point (r = √u₀, φ = 2πu₁), m_z ≥ 1e-6;
  height-correlated G, the weight G2/G1;
* **2, hemisphere, concentric disk** — GGX: as 1 with the *concentric* disk point and
  m_z ≥ 0; Beckmann: the safeguarded reformulation of Jakob's routine (a closed-form start, up
  to three Newton/bisection steps, stop at |residual| ≤ 1e-6; exact erf and erf⁻¹, as the
  numpy port), polar slopes at normal incidence; height-correlated G, the weight G2/G1.

erf⁻¹ is not in numba's ``math``: :func:`_erfinv` is Giles' double-precision approximation
for |y| < 0.9978 (a degree-22 polynomial in log(1 − y²), no erf: a quarter of the time of a
refined single-precision guess) and, in the tails, his single-precision approximation refined
by Newton steps on log ``math.erfc``: ``scipy.special.erfinv`` to 1e-14 relative on (−1, 1)
(to 1e-15 where |y| < 0.9978), checked in the tests.

References: Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018;
Jakob, "An Improved Visible Normal Sampling Routine for the Beckmann Distribution", 2014;
Giles, "Approximating the erfinv function", GPU Computing Gems Jade, 2011.
"""
from __future__ import annotations

import math
import weakref

import numba
import numpy as np

from envfit.predict.renderer._microfacet_kernels import _KINDS, _d, _lambda
from envfit.shading.microfacet import VNDF_WARPS

__all__ = ["conductor_sample", "compiled_sampling", "VNDF_VARIANTS"]

#: the visible-normal warps by their code (module docstring; the index of a conductor's
#: ``vndf_variant`` in :data:`envfit.shading.microfacet.VNDF_WARPS`)
VNDF_VARIANTS = VNDF_WARPS

_F32_EPS = float(np.finfo(np.float32).eps)
_BIG = float(np.finfo(np.float64).max)
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_TWO_OVER_SQRT_PI = 2.0 / math.sqrt(math.pi)


#: Giles' double-precision erf⁻¹ where w = −log(1 − y²) < 6.25 (|y| < 0.9978): erf⁻¹(y) =
#: y·Σ_k c_k (w − 3.125)^k, c_0 … c_22 (Giles 2011, the double-precision central branch)
_GILES_CENTRE = (1.6536545626831027356, 0.24015818242558961693, -0.0060336708714301490533,
                 -0.00074070253416626697512, 0.0001867342080340571352,
                 -1.3882523362786468719e-05, -1.3654692000834678645e-06,
                 4.2347877827932403518e-07, -2.9070369957882005086e-08,
                 -4.1126339803469836976e-09, 1.051212273321532285e-09,
                 -5.4154120542946279317e-11, -1.2975133253453532498e-11,
                 2.6335093153082322977e-12, -8.1519341976054721522e-14,
                 -4.0545662729752068639e-14, 6.6376381343583238325e-15,
                 2.0972767875968561637e-17, -1.333171662854620906e-16,
                 1.115787767802518096e-17, 1.2858480715256400167e-18,
                 -1.685059138182016589e-19, -3.6444120640178196996e-21)


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _giles_centre(w):  # pragma: no cover - numba
    """Σ_k c_k w^k of :data:`_GILES_CENTRE` by Estrin's scheme (four Horner chains in w⁴, the
    chain of k ≡ j mod 4 for j = 0…3, joined by w and w²): a quarter of Horner's dependent
    multiply-adds, the same sum to rounding."""
    c = _GILES_CENTRE
    w2 = w * w
    w4 = w2 * w2
    q0, q1, q2, q3 = c[20], c[21], c[22], c[19]
    for k in range(16, -1, -4):
        q0 = c[k] + q0 * w4
        q1 = c[k + 1] + q1 * w4
        q2 = c[k + 2] + q2 * w4
    for k in range(15, 2, -4):
        q3 = c[k] + q3 * w4
    return (q0 + w * q1) + w2 * (q2 + w * q3)


@numba.njit(cache=True, error_model="numpy")
def _erfinv(y):  # pragma: no cover - numba
    """erf⁻¹(y): ±inf at ±1, NaN outside [−1, 1] (as ``scipy.special.erfinv``)."""
    if not (-1.0 < y < 1.0):
        if y == 1.0 or y == -1.0:
            return math.copysign(np.inf, y)
        return np.nan
    w = -math.log((1.0 - y) * (1.0 + y))
    if w < 6.25:                                # |y| < 0.9978: Giles' double precision
        return y * _giles_centre(w - 3.125)
    a = abs(y)
    w = math.sqrt(w) - 3.0
    p = -0.000200214257
    for c in (0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773,
              -0.0076224613, 0.00943887047, 1.00167406, 2.83297682):
        p = c + p * w
    x = p * a
    for _ in range(8):                          # the tails: Newton on log erfc, nearly linear
        slope = _TWO_OVER_SQRT_PI * math.exp(-x * x)
        if slope == 0.0:
            break
        c = math.erfc(x)
        step = -(math.log(c) - math.log(1.0 - a)) * c / slope
        x -= step
        if abs(step) <= 1e-15 * x:
            break
    return math.copysign(x, y)


@numba.njit(cache=True, error_model="numpy")
def _slopes_normal(s0, s1, cph, sph, alpha):  # pragma: no cover - numba
    """α = 1 slopes (s0, s1) rotated by the view's azimuth (cos φ, sin φ), unstretched,
    turned into the unit normal (−s_x, −s_y, 1)/‖·‖ (the slope warps' last two steps)."""
    sx = (cph * s0 - sph * s1) * alpha
    sy = (sph * s0 + cph * s1) * alpha
    n = math.sqrt(sx * sx + sy * sy + 1.0)
    return -sx / n, -sy / n, 1.0 / n


@numba.njit(cache=True, error_model="numpy")
def _disk(u0, u1, polar):  # pragma: no cover - numba
    """The disk point of ``concentric_disk`` (Shirley–Chiu) or ``polar_disk`` (r = √u0,
    φ = 2πu1)."""
    if polar:
        r = math.sqrt(u0)
        t = 2.0 * math.pi * u1
        return r * math.cos(t), r * math.sin(t)
    x, y = 2.0 * u0 - 1.0, 2.0 * u1 - 1.0
    if x == 0.0 and y == 0.0:
        return 0.0, 0.0
    if abs(x) < abs(y):
        phi = 0.5 * math.pi - 0.25 * math.pi * x / y
        return y * math.cos(phi), y * math.sin(phi)
    phi = 0.25 * math.pi * y / x
    return x * math.cos(phi), x * math.sin(phi)


@numba.njit(cache=True, error_model="numpy")
def _ggx_normal(wi, wp, basis, u0, u1, alpha, variant):  # pragma: no cover - numba
    """One GGX visible normal m from (u0, u1) by ``variant`` (:data:`VNDF_VARIANTS`); ``wp``
    the stretched view, ``basis`` the per-view constants."""
    if variant == 0:
        cos_i = wp[2]
        px, py = _disk(u0, u1, False)
        h = math.sqrt(max(1.0 - px * px, 0.0))
        y = h + 0.5 * (1.0 + cos_i) * (py - h)
        z = math.sqrt(max(1.0 - px * px - y * y, 0.0))
        sin_i = math.sqrt(max(1.0 - cos_i * cos_i, 0.0))
        norm = 1.0 / (sin_i * y + cos_i * z)
        s0, s1 = (cos_i * y - sin_i * z) * norm, px * norm
        return _slopes_normal(s0, s1, basis[0, 0], basis[0, 1], alpha)
    px, py = _disk(u0, u1, variant == 1)
    h = math.sqrt(max(1.0 - px * px, 0.0))
    y = h + 0.5 * (1.0 + wp[2]) * (py - h)
    z = math.sqrt(max(1.0 - px * px - y * y, 0.0))
    nx = px * basis[0, 0] + y * basis[1, 0] + z * wp[0]
    ny = px * basis[0, 1] + y * basis[1, 1] + z * wp[1]
    nz = px * basis[0, 2] + y * basis[1, 2] + z * wp[2]
    mz = max(nz, 1e-6) if variant == 1 else max(nz, 0.0)
    mx, my = alpha * nx, alpha * ny
    n = math.sqrt(mx * mx + my * my + mz * mz)
    return mx / n, my / n, mz / n


@numba.njit(cache=True, error_model="numpy")
def _beckmann_y(u1, variant):  # pragma: no cover - numba
    """The α = 1 Beckmann slope y of variants 0 and 2 (not at normal incidence), erf⁻¹(2u1 − 1)
    (variant 0: u1 clamped to [1e-6, 1 − 1e-6], Jakob's inversion): the view does not enter
    (:func:`_y_slopes`)."""
    if variant == 0:
        u1 = min(max(u1, 1e-6), 1.0 - 1e-6)
    return _erfinv(2.0 * u1 - 1.0)


@numba.njit(cache=True, error_model="numpy")
def _beckmann_newton_x(consts, u0):  # pragma: no cover - numba
    """Variant 0's α = 1 Beckmann slope x: Jakob's inversion, ``consts`` = (tan θ_i,
    erf(cot θ_i), tail)."""
    tan_i, maxval, tail = consts[0], consts[1], consts[2]
    u0 = min(max(u0, 1e-6), 1.0 - 1e-6)
    x = maxval - (maxval + 1.0) * math.erf(math.sqrt(-math.log(u0)))
    ux = u0 * (1.0 + maxval + tail)
    for _ in range(3):
        slope = _erfinv(x)
        value = 1.0 + x + _INV_SQRT_PI * tan_i * math.exp(-slope * slope) - ux
        x = x - value / (1.0 - slope * tan_i)
    return _erfinv(x)


@numba.njit(cache=True, error_model="numpy")
def _beckmann_safeguarded_x(consts, u0):  # pragma: no cover - numba
    """Variant 2's α = 1 Beckmann slope x (safeguarded Newton/bisection); ``consts`` =
    (normal, tan θ_i, erf a, e^{−a²}, k)."""
    tan_i, erf_a, exp_a2, k = consts[1], consts[2], consts[3], consts[4]
    y_approx = u0 * (1.0 + erf_a + k * (1.0 - erf_a * erf_a))
    y_exact = u0 * (1.0 + erf_a + k * exp_a2)
    b = (0.5 - math.sqrt(k * (k - y_approx + 1.0) + 0.25)) / k if k > 0 else y_approx - 1.0
    inv = _erfinv(b)
    begin_x, begin_y, end_x = -1.0, -y_exact, erf_a
    cur_x, cur_y = b, 1.0 + b + k * math.exp(-inv * inv) - y_exact
    for _ in range(3):
        if not abs(cur_y) > 1e-6:
            break
        if (begin_y < 0) == (cur_y < 0):
            begin_x, begin_y = cur_x, cur_y
        else:
            end_x = cur_x
        newton = cur_x - cur_y / (1.0 - inv * tan_i)
        cur_x = newton if begin_x <= newton <= end_x else 0.5 * (begin_x + end_x)
        inv = _erfinv(cur_x)
        cur_y = 1.0 + cur_x + k * math.exp(-inv * inv) - y_exact
    return inv


@numba.njit(cache=True, error_model="numpy")
def _normal(wi, view, u0, u1, alpha, variant, kind):  # pragma: no cover - numba
    """One visible normal of GGX (:func:`_ggx_normal`) or Beckmann (variant 0 or 2);
    ``view`` the rows of :func:`_view_constants`."""
    if kind == 0:
        return _ggx_normal(wi, view[0], view[1:3], u0, u1, alpha, variant)
    polar = variant == 2 and view[3, 0] > 0.0
    return _beckmann_normal(view, u0, u1, 0.0 if polar else _beckmann_y(u1, variant), alpha,
                            variant)


@numba.njit(cache=True, error_model="numpy")
def _beckmann_normal(view, u0, u1, s1, alpha, variant):  # pragma: no cover - numba
    """One Beckmann visible normal (variant 0 or 2) given its slope y ``s1`` =
    :func:`_beckmann_y` (u1): the slope x from u0 and the view's constants ``view[3]``;
    variant 2 at normal incidence polar (r from u0, φ from u1; ``s1`` unused)."""
    consts = view[3]
    if variant == 0:
        s0 = _beckmann_newton_x(consts, u0)
    elif consts[0] > 0.0:                       # variant 2 at normal incidence
        r, phi = math.sqrt(-math.log(u0)), 2.0 * math.pi * u1
        s0, s1 = r * math.cos(phi), r * math.sin(phi)
    else:
        s0 = _beckmann_safeguarded_x(consts, u0)
    return _slopes_normal(s0, s1, view[1, 0], view[1, 1], alpha)


@numba.njit(cache=True, error_model="numpy")
def _g1(vx, vy, vz, mx, my, mz, alpha, kind):  # pragma: no cover - numba
    """Smith's G1 with χ⁺ (variant 0's masking): 0 where v sees the back of m."""
    if (vx * mx + vy * my + vz * mz) * vz <= 0.0:
        return 0.0
    return 1.0 / (1.0 + _lambda(vx, vy, vz, alpha, kind))


@numba.njit(cache=True, error_model="numpy")
def _reflect(wi, m, lam_i, alpha, variant, kind):  # pragma: no cover - numba
    """(ω_o, weight, pdf) of one sample of :func:`_sample` from its visible normal m: the
    reflection, the weight (variant 0: G1(ω_o, m); 1 and 2: G2/G1) and the pdf
    D·G1(ω_i)/(4 cos θ_i); the pole, 0 and 0 for a dead sample."""
    ix, iy, iz = wi[0], wi[1], wi[2]
    mx, my, mz = m
    dot = ix * mx + iy * my + iz * mz
    ox, oy, oz = 2.0 * dot * mx - ix, 2.0 * dot * my - iy, 2.0 * dot * mz - iz
    d = _d(mx, my, mz, alpha, kind)
    if variant == 0:
        w = _g1(ox, oy, oz, mx, my, mz, alpha, kind)
        gview = _g1(ix, iy, iz, mx, my, mz, alpha, kind)
    else:
        w = (1.0 + lam_i) / (1.0 + lam_i + _lambda(ox, oy, oz, alpha, kind))
        gview = 1.0 / (1.0 + lam_i)
    if not (oz > 0.0 and iz > 0.0 and d > 0.0 and w > 0.0):
        return 0.0, 0.0, 1.0, 0.0, 0.0
    q = d * gview / (4.0 * iz)
    if math.isnan(q):
        q = 0.0
    elif math.isinf(q):
        q = _BIG
    return ox, oy, oz, w, q


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sample(wi, view, u, ys, lobe, wo, out):  # pragma: no cover - numba
    """:func:`conductor_sample` at the points ``u`` for ``lobe`` = (α, variant, kind);
    Beckmann's slopes y ``ys`` given (:func:`_y_slopes`; empty: taken here)."""
    alpha, variant, kind = lobe
    lam_i = _lambda(wi[0], wi[1], wi[2], alpha, kind)
    given = kind == 1 and ys.shape[0] == u.shape[0]
    for p in numba.prange(u.shape[0]):
        if given:
            m = _beckmann_normal(view, u[p, 0], u[p, 1], ys[p], alpha, variant)
        else:
            m = _normal(wi, view, u[p, 0], u[p, 1], alpha, variant, kind)
        wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = _reflect(wi, m, lam_i, alpha,
                                                                      variant, kind)


@numba.njit(cache=True, error_model="numpy")
def _beckmann_factors(consts, c, variant):  # pragma: no cover - numba
    """Beckmann's α = 1 slopes on the grid ``c`` × ``c`` as products s0 = a0(u0)·b0(u1),
    s1 = a1(u0)·b1(u1) (2, m) each: the warps of :func:`_normal` are separable (variants
    0 and 2: slope x from u0, slope y from u1; variant 2 at normal incidence polar)."""
    m = c.shape[0]
    a, b = np.ones((2, m)), np.ones((2, m))
    for k in range(m):
        if variant == 0:
            a[0, k], b[1, k] = _beckmann_newton_x(consts, c[k]), _beckmann_y(c[k], 0)
        elif consts[0] > 0.0:
            r, phi = math.sqrt(-math.log(c[k])), 2.0 * math.pi * c[k]
            a[0, k], a[1, k], b[0, k], b[1, k] = r, r, math.cos(phi), math.sin(phi)
        else:
            a[0, k], b[1, k] = _beckmann_safeguarded_x(consts, c[k]), _beckmann_y(c[k], 2)
    return a, b


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _y_kernel(u, variant, out):  # pragma: no cover - numba
    for p in numba.prange(u.shape[0]):
        out[p] = _beckmann_y(u[p, 1], variant)


#: variant → (a token, the points' u1, their slopes y) of the last point set (:func:`_y_slopes`)
_Y_KEPT: dict = {}


def _y_slopes(u: np.ndarray, variant: int) -> np.ndarray:
    """Beckmann's slopes y (:func:`_beckmann_y`) at the points ``u``: independent of the view,
    so taken once for the many frames a model samples at one table — kept for the last point
    set of each variant while ``u`` lives, and reused where ``u``'s second column holds the
    same numbers (compared, a read of ``u``: about 1 % of the warp's time)."""
    kept = _Y_KEPT.get(variant)
    if kept is not None and len(kept[1]) == len(u) and np.array_equal(kept[1], u[:, 1]):
        return kept[2]
    ys = np.empty(len(u))
    _y_kernel(u, variant, ys)
    token = object()
    _Y_KEPT[variant] = (token, u[:, 1].copy(), ys)
    weakref.finalize(u, _forget_y, variant, token)
    return ys


def _forget_y(variant: int, token) -> None:
    """Drop the kept slopes y of ``variant`` if still those of ``token``'s point set."""
    kept = _Y_KEPT.get(variant)
    if kept is not None and kept[0] is token:
        del _Y_KEPT[variant]


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sample_grid(wi, view, a, b, alpha, variant, wo, out):  # pragma: no cover - numba
    """:func:`_sample` of Beckmann at the midpoints of a grid (u0 the slow index), its
    special functions once per row and column (:func:`_beckmann_factors`)."""
    lam_i = _lambda(wi[0], wi[1], wi[2], alpha, 1)
    m = a.shape[1]
    for i in numba.prange(m):
        for j in range(m):
            n = _slopes_normal(a[0, i] * b[0, j], a[1, i] * b[1, j], view[1, 0], view[1, 1],
                               alpha)
            p = i * m + j
            wo[p, 0], wo[p, 1], wo[p, 2], out[0, p], out[1, p] = _reflect(wi, n, lam_i, alpha,
                                                                          variant, 1)


def compiled_sampling(conductor) -> bool:
    """Whether :func:`conductor_sample` repeats ``conductor.sample``: white GGX or Beckmann,
    its weight's form the one its warp's code implies (variant 0 with separable G, the
    hemisphere variants with height-correlated G)."""
    return (getattr(conductor, "white", False) and conductor.distribution.kind in _KINDS
            and conductor.separable_g == (conductor.vndf_variant == 0))


def _beckmann_constants(wp, variant):
    """The per-view constants of the Beckmann warps: variant 0's (tan θ_i, erf(cot θ_i),
    tail); variant 2's (normal incidence, tan θ_i, erf a, e^{−a²}, tan θ_i/√π) with
    a = cot θ_i, and its
    (cos φ, sin φ) of the stretched view."""
    consts, azimuth = np.zeros(5), None
    with np.errstate(divide="ignore"):
        if variant == 0:
            cos_i = wp[2]
            tan_i = np.sqrt(max(1.0 - cos_i * cos_i, 0.0)) / cos_i
            cot_i = np.float64(1.0) / tan_i
            tail = 0.0 if tan_i == 0.0 else _INV_SQRT_PI * tan_i * math.exp(-cot_i ** 2)
            consts[:3] = tan_i, math.erf(cot_i), tail
            return consts, azimuth
        normal = wp[2] >= 0.99999
        sin_i = 1.0 if normal else math.sqrt(max(1.0 - wp[2] ** 2, 0.0))
        tan_i = 1.0 if normal else sin_i / wp[2]
        consts[:5] = (float(normal), tan_i, math.erf(1.0 / tan_i), math.exp(-1.0 / tan_i ** 2),
                      tan_i * _INV_SQRT_PI)
        azimuth = (1.0, 0.0) if normal else (wp[0] / sin_i, wp[1] / sin_i)
    return consts, azimuth


def _view_constants(wi, alpha, variant, kind):
    """The per-view rows of :func:`_sample` (4, 5): the stretched view; the warp's basis —
    variant 0's (cos φ, sin φ) of the stretched view's azimuth, the hemisphere variants' GGX
    (T1, T2), variant 2's Beckmann (cos φ, sin φ); the Beckmann constants."""
    view = np.zeros((4, 5))
    wp = np.array([alpha * wi[0], alpha * wi[1], wi[2]])
    wp /= np.linalg.norm(wp)
    basis = view[1:3, :3]
    if variant == 0:
        sin2 = 1.0 - wp[2] ** 2
        if abs(sin2) <= 4.0 * _F32_EPS:
            basis[0, :2] = 1.0, 0.0
        else:
            basis[0, :2] = np.clip(wp[:2] / np.sqrt(sin2), -1.0, 1.0)
    elif kind == 0:
        if variant == 1:
            wp = -wp if wp[2] < 0 else wp
            ok = wp[2] < 0.99999
        else:
            ok = wp[0] ** 2 + wp[1] ** 2 > 1e-7
        if ok:
            t1 = np.array([-wp[1], wp[0], 0.0]) / np.hypot(wp[0], wp[1])
            basis[0], basis[1] = t1, np.cross(wp, t1)
        else:
            basis[0] = 1.0, 0.0, 0.0
            basis[1] = np.cross(wp, basis[0]) if variant == 1 else (0.0, 1.0, 0.0)
    if kind == 1:
        view[3], azimuth = _beckmann_constants(wp, variant)
        if azimuth is not None:
            basis[0, :2] = azimuth
    view[0, :3] = wp
    return view


def conductor_sample(conductor, wi, u, level: int | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω_o (P, 3), weight f·cos/pdf (P,), pdf (P,)) of a white GGX or Beckmann ``conductor``
    sampled for the one view ``wi`` (3,) at the points ``u`` (P, 2), local frame; where the
    weight is 0, ω_o is the pole and the pdf 0 (``Conductor.sample`` leaves the reflected
    direction). ``level``: ``u`` is ``midpoints(level)``, where Beckmann's warp takes its
    special functions once per row and column (the same numbers, ≈ 2^level times fewer
    erf⁻¹)."""
    d = conductor.distribution
    variant, kind = conductor.vndf_variant, _KINDS[d.kind]
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    alpha = float(d.alpha)
    view = _view_constants(wi, alpha, variant, kind)
    wo, out = np.empty((len(u), 3)), np.empty((2, len(u)))
    if kind == 1 and level is not None:
        m = 1 << int(level)
        if len(u) != m * m:
            raise ValueError("u must be midpoints(level)")
        a, b = _beckmann_factors(view[3], (np.arange(m) + 0.5) / m, variant)
        _sample_grid(wi, view, a, b, alpha, variant, wo, out)
    else:
        u = np.ascontiguousarray(u, dtype=np.float64)
        polar = variant == 2 and view[3, 0] > 0.0
        ys = _y_slopes(u, variant) if kind == 1 and not polar else np.zeros(0)
        _sample(wi, view, u, ys, (alpha, variant, kind), wo, out)
    return wo, out[0], out[1]

r"""Ground truth of the normalised shading integral (Eq. 17) on a lat-long map, two ways.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 4.1–4.3, 9.2.

For an axis :math:`a` (a world unit vector: the normal for the diffuse lobe, the mirror
direction for the glossy one, Sec. 4.3) and a zonal weight function :math:`p` that vanishes
on the lower hemisphere :math:`u\cdot a < 0`,

.. math::  I(a) = \frac{1}{2\pi r_s}\int_{S^2} f(u)\,p(u\cdot a)\,dS(u),
           \qquad r_s = \int_0^1 p(z)\,dz                                    \quad (17, 18)

so :math:`I = 1` for :math:`f \equiv 1`. The integrand :math:`f` is *the map as the
estimators see it*: the bilinear interpolant of the pixel values
(:meth:`envfit.maps.envmap.EnvMap.lookup`, :func:`envfit.maps.latlong.bilinear_lookup`), not the
piecewise-constant pixel function nor the band-limited interpolant of the pixel centres.
Those three functions differ by :math:`O(h^2 f'')`, :math:`h = \pi/H` — relative
differences of 1e-3…1e-2 on a 64-row map, far above the 1e-4 at which the estimators'
errors are compared — so both methods below integrate the bilinear interpolant itself,
to ~1e-9.

Bilinear patches
----------------
In continuous pixel coordinates the interpolant is bilinear in :math:`(\theta, \varphi)`
on each *patch* between four pixel centres: :math:`\theta \in [\theta_{s-1}, \theta_s]`,
:math:`\varphi \in [\varphi_j, \varphi_{j+1}]`, s = 0…H, j = 0…W−1, with the two polar caps
:math:`[0, \theta_0]` and :math:`[\theta_{H-1}, \pi]` interpolating across the pole (row −1
is row 0 at :math:`\varphi + \pi`, row H is row H−1 at :math:`\varphi + \pi`). Inside a
patch the integrand :math:`f\,p(u\cdot a)\sin\theta` is smooth, so tensor Gauss–Legendre
rules converge spectrally; the only non-smooth set is the horizon :math:`u\cdot a = 0` (the
kink of the diffuse lobe, the jump :math:`e^{-n}` of the glossy one, the jump of the
hemispherical harmonics).

``method="pixels"`` (direct quadrature, the reference)
    :func:`hemisphere_integrals`: a q×q Gauss–Legendre rule on every patch (q from the
    bandwidth of p and the pixel size, :func:`gauss_legendre_order`: the rule integrates
    every trig polynomial of the patch's degree to 1e-10, so the lobe of a large shininess
    is resolved near the axis by a larger q instead of ad-hoc supersampling), evaluated
    for a block of axes at once (the dot products :math:`u\cdot a` are outer products of
    ring and meridian factors; the sum over nodes is one BLAS product per block). Patches
    that the horizon may cut (corner values of :math:`u\cdot a` within :math:`h^2/4` of 0,
    a rigorous bound) are masked out and integrated exactly over their part above the
    horizon: the φ-range is split where the horizon crosses the patch's rings, and for each
    Gauss node in φ the θ-range is clipped at the horizon's colatitude
    :math:`\theta^*(\varphi)` (closed form), so every piece is smooth. The cost is one
    kernel evaluation per node per axis: :math:`(H+1)W q^2` per axis.
``method="sh"`` (fast default)
    :func:`bilinear_sh_coefficients`: exact SH coefficients of the bilinear interpolant:
    per row the Fourier coefficients of the piecewise-linear interpolant in φ are the DFT
    times :math:`\mathrm{sinc}^2(m\Delta\varphi/2)` (any m, aliases included); across rows
    they are linear in θ on each patch, so the Legendre integrals are done by Gauss–Legendre
    per patch row (``ducc0.sht.leg2alm``). Then Funk–Hecke: :math:`I(a) = \sum_{l\le
    l_{max}} \lambda_l \sum_m f_{lm} Y_{lm}(a)` with
    :math:`\lambda_l = \sqrt{4\pi/(2l+1)}\,b_l = \int_0^1 p P_l\,dz / r_s`
    (:func:`funk_hecke_factors`, b_l from envfit.theory.brdf), synthesised at the axes by
    ``ducc0.sht.synthesis_general``. The only approximation is the truncation at
    :math:`l_{max}`: negligible for lobes smooth at the horizon (glossy n ≳ 20), but the
    diffuse kink gives :math:`b_l \approx (2/\pi) l^{-2}` (even l), :math:`\lambda_l \sim
    l^{-5/2}`, and the tail then depends on the map's content near the horizon of each axis;
    it falls like :math:`l_{max}^{-3}` (measured; see :func:`default_sh_lmax`).

Frames: axes are world directions; they are mapped to the map's local frame (z = up) by
``local_to_world(up).T``, the frame of the lat-long parametrisation and of ducc0's
transforms (geometry "F1", ``phi0 = π/W``).

Example
-------
>>> import numpy as np
>>> from envfit.maps.envmap import EnvMap
>>> m = EnvMap(np.full((16, 32, 1), 2.0))
>>> axes = np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
>>> bool(np.allclose(shading_integral(m, axes, "diffuse"), 2.0, atol=1e-9))
True
>>> bool(np.allclose(shading_integral(m, axes, "glossy", 30, method="pixels"), 2.0, atol=1e-9))
True
"""
from __future__ import annotations

import math
from typing import Callable, Iterable

import numpy as np
import ducc0
from scipy import special

from envfit.theory.brdf import Diffuse, Glossy, WeightFunction

from envfit.base.checks import check_int
from envfit.maps.envmap import EnvMap
from envfit.base.errors import ParameterError
from envfit.maps.latlong import local_to_world
from envfit.base.resources import check_memory

__all__ = ["shading_integral", "weight_function", "funk_hecke_factors",
           "hsh_weight_coefficients", "bilinear_sh_coefficients", "synthesize_convolution",
           "hemisphere_integrals", "axes_to_local", "gauss_legendre_order", "polynomial_degree",
           "default_sh_lmax", "METHODS"]

METHODS = ("sh", "pixels")

#: accuracy requested from ducc0's NUFFT in synthesis_general (its double floor is ~2e-13)
DUCC_EPSILON = 1e-12

#: target error of a Gauss–Legendre rule on one patch, relative to the patch's integral scale
GL_TOL = 1e-10

#: kernel evaluations per chunk in the pixel method: small enough (0.5 MB per array) that
#: the few elementwise passes over a chunk stay in cache — 2–3x faster than 32 MB chunks
BLOCK_ELEMENTS = 1 << 16


# ----------------------------------------------------------------------------- parameters

def weight_function(brdf="diffuse", shininess: float = 30.0) -> WeightFunction:
    """The :class:`envfit.theory.brdf.WeightFunction` named by ``brdf``.

    ``"diffuse"`` → :class:`~envfit.theory.brdf.Diffuse` (p = z); ``"glossy"`` →
    :class:`~envfit.theory.brdf.Glossy` (p = e^{n(z−1)}, n = ``shininess``); a WeightFunction is
    returned as is. Anything else raises :class:`ParameterError`.

    >>> weight_function("glossy", 10).shininess
    10.0
    """
    if isinstance(brdf, WeightFunction):
        return brdf
    if isinstance(brdf, str):
        name = brdf.strip().lower()
        if name == "diffuse":
            return Diffuse()
        if name == "glossy":
            try:
                return Glossy(shininess)
            except ValueError as exc:
                raise ParameterError(str(exc)) from None
    raise ParameterError(f"brdf must be 'diffuse', 'glossy' or a envfit.theory.brdf.WeightFunction, "
                         f"got {brdf!r}")


def axes_to_local(axes, up: str = "y") -> np.ndarray:
    """World axis directions (3,) or (M, 3) → unit vectors in the map's local frame, (M, 3).

    ``local = M_up^T world`` (:func:`envfit.maps.latlong.local_to_world`). Axes need not be unit
    length; zero, non-finite or mis-shaped input raises :class:`ParameterError`.

    >>> axes_to_local([0.0, 2.0, 0.0], "y").round(12).tolist()     # world +y = local up
    [[0.0, 0.0, 1.0]]
    """
    return unit_axes(axes) @ local_to_world(up)


def unit_axes(axes) -> np.ndarray:
    """Axes as an (M, 3) array of unit vectors; zero, non-finite or mis-shaped input raises
    :class:`ParameterError`."""
    a = np.asarray(axes, dtype=np.float64)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise ParameterError(f"axes must have shape (3,) or (M, 3), got {np.shape(axes)}")
    if not np.all(np.isfinite(a)):
        raise ParameterError("axes contain NaN or Inf")
    norm = np.linalg.norm(a, axis=1)
    if np.any(norm == 0.0):
        raise ParameterError("axes must be non-zero vectors")
    return a / norm[:, None]


def _local_angles(a_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    theta = np.arctan2(np.hypot(a_local[:, 0], a_local[:, 1]), a_local[:, 2])
    phi = np.mod(np.arctan2(a_local[:, 1], a_local[:, 0]), 2.0 * np.pi)
    return theta, phi


# ----------------------------------------------------------------------------- quadrature

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


def _gl01(q: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(int(q))
    return 0.5 * (x + 1.0), 0.5 * w


def polynomial_degree(weight: WeightFunction) -> int:
    r"""Bandwidth D of the lobe: p on [0, 1] is a polynomial of degree D in z to rounding.

    ``weight.resolution_degree()`` (envfit.theory.brdf). A polynomial of degree D in z = cos θ is a
    trig polynomial of degree D in θ and in φ about any axis, so D fixes the Gauss–Legendre
    orders of both methods. Diffuse: 1; Glossy n = 30: ≈ 35; n = 1000: ≈ 170.

    >>> polynomial_degree(Diffuse())
    1
    """
    try:
        return int(weight.resolution_degree())
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def funk_hecke_factors(weight: WeightFunction, lmax: int) -> np.ndarray:
    r"""Funk–Hecke factors :math:`\lambda_l = \sqrt{4\pi/(2l+1)}\,b_l = \int_0^1 p P_l\,dz \,/\, r_s`, l = 0…lmax.

    With them the shading integral of Eq. 17 is the zonal convolution
    :math:`I(a) = \sum_l \lambda_l \sum_m f_{lm} Y_{lm}(a)` (Eq. 19 rotated to the axis a);
    :math:`\lambda_0 = 1`. :math:`b_l` = ``weight.sh_coefficients(lmax)`` (Eq. 20, envfit.theory.brdf).

    >>> lam = funk_hecke_factors(Diffuse(), 2)
    >>> bool(np.allclose(lam, [1.0, 2.0 / 3.0, 0.25]))            # Ramamoorthi-Hanrahan A_l/π
    True
    """
    lmax = check_int(lmax, "lmax", 0)
    l = np.arange(lmax + 1)
    return np.asarray(weight.sh_coefficients(lmax), dtype=np.float64) * np.sqrt(
        4.0 * np.pi / (2 * l + 1))


def hsh_weight_coefficients(weight: WeightFunction, lmax: int) -> np.ndarray:
    r"""Normalised HSH coefficients :math:`\tilde b_l = \frac{1}{r_s}\sqrt{\frac{2l+1}{2\pi}}\int_0^1 p(z)P_l(2z-1)\,dz`.

    ``weight.hsh_coefficients(lmax)`` (Eqs. 23, 28–30 with the errata normalisation;
    :math:`\tilde b_0 = 1/\sqrt{2\pi}`; diffuse: zero for l ≥ 2).

    >>> bool(np.allclose(hsh_weight_coefficients(Diffuse(), 2),
    ...                  [1 / np.sqrt(2 * np.pi), 1 / np.sqrt(6 * np.pi), 0.0], atol=1e-15))
    True
    """
    lmax = check_int(lmax, "lmax", 0)
    return np.asarray(weight.hsh_coefficients(lmax), dtype=np.float64)


def default_sh_lmax(weight: WeightFunction, height: int) -> int:
    r"""Default truncation degree of ``method="sh"`` for a map of ``height`` rows.

    * Lobes smooth up to the horizon (glossy n ≳ 25): the smallest L beyond which every
      :math:`|\lambda_l| \le 10^{-11}` (searched up to 4(D + 16), D =
      :func:`polynomial_degree`); independent of the map (≈ 7.4√n for glossy: 41 at n = 30).
    * Otherwise (the diffuse kink, :math:`\lambda_l \sim l^{-5/2}`; glossy with small n,
      whose jump :math:`e^{-n}` at the horizon gives :math:`\lambda_l \sim e^{-n} n\,l^{-3/2}`):
      :math:`\max(H - 1, \min(2H - 1, 511))`. The residual tail falls like
      :math:`l_{max}^{-3}`; measured against ``method="pixels"`` on a sun-and-sky map it is
      5e-6 (H = 32), 8e-7 (H = 64) and 6e-8 (H = 512, lmax = 511) of the largest value
      (bench/bench_shading.py, tests/test_shading.py).

    >>> default_sh_lmax(Diffuse(), 32), default_sh_lmax(Glossy(30.0), 32)
    (63, 41)
    """
    h = check_int(height, "height", 1)
    D = polynomial_degree(weight)
    top = 4 * (D + 16)
    lam = np.abs(funk_hecke_factors(weight, top))
    big = np.nonzero(lam > 1e-11)[0]
    last = int(big[-1]) if big.size else 0
    if last < (3 * top) // 4:
        return last + 1
    return max(h - 1, min(2 * h - 1, 511))


# ----------------------------------------------------------------------------- SH method

def _patch_rows(height: int) -> tuple[np.ndarray, np.ndarray]:
    """θ-edges of the H+1 patch rows [0, θ_0], [θ_0, θ_1], …, [θ_{H−1}, π] → (lo, hi)."""
    theta_c = np.pi * (np.arange(height) + 0.5) / height
    edges = np.concatenate(([0.0], theta_c, [np.pi]))
    return edges[:-1], edges[1:]


def _row_fourier(data: np.ndarray, lmax: int) -> np.ndarray:
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
    cm = _row_fourier(data, lmax)                                      # (H, lmax+1, C)
    sign = np.where(np.arange(lmax + 1) % 2 == 0, 1.0, -1.0)[None, :, None]
    ext = np.concatenate([cm[:1] * sign, cm, cm[-1:] * sign], axis=0)  # rows −1 … H
    lo, hi = _patch_rows(h)
    x, wq = _gl01(q)
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


def _alm_l_index(lmax: int) -> np.ndarray:
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
        keep = _alm_l_index(have) <= lmax
        a = a[:, keep]
    lam = np.asarray(factors, dtype=np.float64)[:lmax + 1]
    scaled = a * lam[_alm_l_index(lmax)][None, :]
    theta, phi = _local_angles(np.asarray(axes_local, dtype=np.float64))
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


# ----------------------------------------------------------------------------- pixel method

def _patch_corner_values(data: np.ndarray, s: np.ndarray, j: np.ndarray):
    """Values (T0, T1, B0, B1), each (P, C), at the four corners of patches (s, j).

    Top row s−1 and bottom row s; the virtual rows −1 and H are rows 0 and H−1 shifted by
    W/2 columns (across the pole), exactly as :func:`envfit.maps.latlong.bilinear_lookup`.
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


def _bilinear_in_patch(data, s, j, theta, phi):
    """Bilinear interpolant at (θ, φ) inside patch (s, j); s, j, θ, φ broadcast to (P, …)."""
    h, w, _ = data.shape
    T0, T1, B0, B1 = _patch_corner_values(data, s, j)
    t = theta * (h / np.pi) - 0.5 - (s[:, None] - 1)                       # row fraction
    b = phi * (w / (2.0 * np.pi)) - 0.5 - j[:, None]                       # column fraction
    t = t[..., None]
    b = b[..., None]
    top = T0[:, None, :] + b * (T1 - T0)[:, None, :]
    bot = B0[:, None, :] + b * (B1 - B0)[:, None, :]
    return top + t * (bot - top)                                           # (P, n, C)


def _horizon_pieces(s, j, sa, ca, pa, lo, hi, w):
    """Split each flagged patch's φ-range where the horizon crosses its two rings.

    Returns (pair index, φ_lo, φ_hi) of the non-empty pieces that are (partly) above the
    horizon. Within a piece θ*(φ) stays inside the patch's θ-range or outside it.
    """
    dphi = 2.0 * np.pi / w
    p0 = 2.0 * np.pi * (j + 0.5) / w
    cand = []
    for te in (lo[s], hi[s]):
        st, ct = np.sin(te), np.cos(te)
        den = sa * st
        with np.errstate(divide="ignore", invalid="ignore"):
            kap = -ca * ct / den
        ok = (den > 1e-300) & (np.abs(kap) <= 1.0)
        psi = np.arccos(np.clip(np.where(ok, kap, 0.0), -1.0, 1.0))
        for sg in (1.0, -1.0):
            rel = np.mod(pa + sg * psi - p0, 2.0 * np.pi)
            cand.append(np.where(ok & (rel > 0.0) & (rel < dphi), rel, dphi))
    pts = np.sort(np.stack([np.zeros_like(p0)] + cand + [np.full_like(p0, dphi)], axis=1), axis=1)
    plo = p0[:, None] + pts[:, :-1]
    phi_ = p0[:, None] + pts[:, 1:]
    mid = 0.5 * (plo + phi_)
    A = sa[:, None] * np.cos(mid - pa[:, None])
    ztop = A * np.sin(lo[s])[:, None] + (ca * np.cos(lo[s]))[:, None]
    zbot = A * np.sin(hi[s])[:, None] + (ca * np.cos(hi[s]))[:, None]
    keep = (phi_ - plo > 0.0) & ((ztop > 0.0) | (zbot > 0.0))
    return np.nonzero(keep)[0], plo[keep], phi_[keep]


def hemisphere_integrals(envmap: EnvMap, axes, kernel: Callable[[np.ndarray], Iterable[np.ndarray]],
                         count: int, *, degree: int, horizon: bool = True,
                         axes_are_local: bool = False) -> np.ndarray:
    r""":math:`J_k(a) = \int_{u\cdot a > 0} f(u)\,g_k(u\cdot a)\,dS(u)` for k < ``count``, (M, count, C).

    f is the map's bilinear interpolant; ``kernel(z)`` yields the ``count`` arrays
    :math:`g_k(z)` (same shape as z, z ∈ [0, 1]); ``degree`` is their bandwidth D (trig
    degree in θ and φ, :func:`polynomial_degree` for a weight function, l for
    :math:`P_l(2z-1)`). The integral stops at the horizon even where g_k(0) ≠ 0.

    Rule (see the module doc): q×q Gauss–Legendre per bilinear patch, q =
    :func:`gauss_legendre_order` of (D + 2)·h/2; patches the horizon may cross are masked
    out and integrated piecewise with the horizon clipped exactly (q+1 nodes per piece and
    direction). ``horizon=False`` skips that refinement (for kernels that vanish at the
    horizon to rounding, e.g. glossy n ≥ 30: the masked error is bounded by
    :math:`\max_{z<2h}|g|\cdot 4\pi h`). Work per axis: (H+1)·W·q² kernel evaluations plus
    O(H q²) on the cut patches; blocked over axes (:data:`BLOCK_ELEMENTS`).
    """
    count = check_int(count, "count", 1)
    degree = check_int(degree, "degree", 0)
    data = np.asarray(envmap.data, dtype=np.float64)
    h, w, c = data.shape
    A = (np.asarray(axes, dtype=np.float64) if axes_are_local
         else axes_to_local(axes, envmap.up))
    m_total = A.shape[0]
    out = np.zeros((m_total, count, c))
    if m_total == 0:
        return out
    hh = np.pi / h
    dphi = 2.0 * np.pi / w
    q = gauss_legendre_order((degree + 2) * hh / 2.0)
    x, wq = _gl01(q)
    lo, hi = _patch_rows(h)
    th = (lo[:, None] + (hi - lo)[:, None] * x[None, :]).ravel()           # ((H+1) q,)
    wth = ((hi - lo)[:, None] * wq[None, :]).ravel() * np.sin(th)
    ph = (2.0 * np.pi * (np.arange(w) + 0.5)[:, None] / w + dphi * x[None, :]).ravel()
    wph = np.tile(dphi * wq, w)
    nth, nph = th.size, ph.size
    check_memory(8 * nth * nph * (c + 4), f"the {nph}x{nth} quadrature grid of a {w}x{h} map",
                 hint="use a smaller map (EnvMap.resized) or method='sh'")
    # f at the nodes, through the same lookup the estimators use
    st, ct = np.sin(th), np.cos(th)
    local = np.empty((nth, nph, 3))
    local[..., 0] = st[:, None] * np.cos(ph)[None, :]
    local[..., 1] = st[:, None] * np.sin(ph)[None, :]
    local[..., 2] = ct[:, None]
    F = envmap.lookup(local @ local_to_world(envmap.up).T)                 # (nth, nph, C)
    del local
    WF = F * (wth[:, None, None] * wph[None, :, None])
    del F
    cph, sph = np.cos(ph), np.sin(ph)
    # corners for the horizon flags: rings lo[0..H] ∪ {π}, meridians φ_j
    ring_e = np.concatenate((lo, [np.pi]))
    pj = 2.0 * np.pi * (np.arange(w) + 0.5) / w
    margin = hh * hh / 4.0 + 1e-12          # |z − bilinear(corners)| ≤ (Δθ² + Δφ²)/8 ≤ h²/4
    theta_a, phi_a = _local_angles(A)
    sa_all, ca_all = np.sin(theta_a), np.cos(theta_a)
    # block sizes: axes per block and patch rows per chunk
    mb = int(max(1, min(m_total, BLOCK_ELEMENTS // max(1, nph * q))))
    rows_per_chunk = int(max(1, BLOCK_ELEMENTS // max(1, mb * nph * q)))
    xf, wf = _gl01(q + 1)
    for m0 in range(0, m_total, mb):
        m1 = min(m_total, m0 + mb)
        a = A[m0:m1]
        nb = m1 - m0
        Qn = np.outer(cph, a[:, 0]) + np.outer(sph, a[:, 1])                 # (nph, nb)
        if horizon:
            Qc = np.outer(np.cos(pj), a[:, 0]) + np.outer(np.sin(pj), a[:, 1])   # (W, nb)
            Zc = np.sin(ring_e)[:, None, None] * Qc[None] + np.cos(ring_e)[:, None, None] * a[:, 2]
            Zc1 = np.roll(Zc, -1, axis=1)
            zmax = np.maximum(np.maximum(Zc[:-1], Zc[1:]), np.maximum(Zc1[:-1], Zc1[1:]))
            zmin = np.minimum(np.minimum(Zc[:-1], Zc[1:]), np.minimum(Zc1[:-1], Zc1[1:]))
            flag = (zmax > -margin) & (zmin < margin)                       # (H+1, W, nb)
            del Zc, Zc1, zmax, zmin
        # global rule, chunked over patch rows
        for s0 in range(0, h + 1, rows_per_chunk):
            s1 = min(h + 1, s0 + rows_per_chunk)
            sl = slice(s0 * q, s1 * q)
            Z = st[sl, None, None] * Qn[None] + ct[sl, None, None] * a[:, 2][None, None, :]
            pos = Z > 0.0
            if horizon:
                keep = ~flag[s0:s1]                                          # (ns, W, nb)
                pos = (pos.reshape(s1 - s0, q, w, q, nb)
                       & keep[:, None, :, None, :]).reshape(pos.shape)
            np.clip(Z, 0.0, 1.0, out=Z)
            wf_chunk = WF[sl].reshape(-1, c)                                # (n, C)
            buf = np.empty(Z.size)
            for k, g in enumerate(kernel(Z)):
                np.multiply(g.reshape(-1), pos.reshape(-1), out=buf)
                # (nb, n) @ (n, C): this operand order is the fast one in OpenBLAS
                out[m0:m1, k, :] += buf.reshape(-1, nb).T @ wf_chunk
            del Z, pos, buf
        if not horizon:
            continue
        # exact integration of the cut patches
        ss, jj, mm = np.nonzero(flag)
        del flag
        if ss.size == 0:
            continue
        pair, plo, phi_hi = _horizon_pieces(ss, jj, sa_all[m0:m1][mm], ca_all[m0:m1][mm],
                                            phi_a[m0:m1][mm], lo, hi, w)
        npc = pair.size
        step = int(max(1, BLOCK_ELEMENTS // (4 * (q + 1) ** 2)))
        for p0 in range(0, npc, step):
            p1 = min(npc, p0 + step)
            pr = pair[p0:p1]
            s_, j_, m_ = ss[pr], jj[pr], mm[pr]
            sa, ca, pa = sa_all[m0:m1][m_], ca_all[m0:m1][m_], phi_a[m0:m1][m_]
            L = (phi_hi[p0:p1] - plo[p0:p1])
            phn = plo[p0:p1, None] + L[:, None] * xf[None, :]                # (P, qf)
            wphn = L[:, None] * wf[None, :]
            Aph = sa[:, None] * np.cos(phn - pa[:, None])                    # (P, qf)
            t0, t1 = lo[s_][:, None], hi[s_][:, None]
            ztop = Aph * np.sin(t0) + ca[:, None] * np.cos(t0)
            zbot = Aph * np.sin(t1) + ca[:, None] * np.cos(t1)
            # the root of A sinθ + B cosθ in [0, π]
            neg = (-ca)[:, None] >= 0.0
            root = np.where(neg, np.arctan2(-ca[:, None], Aph), np.arctan2(ca[:, None], -Aph))
            root = np.clip(root, t0, t1)
            tlo = np.where(ztop >= 0.0, t0, np.where(zbot >= 0.0, root, t1))
            thi = np.where(zbot >= 0.0, t1, np.where(ztop >= 0.0, root, t0))
            thi = np.maximum(thi, tlo)
            thn = tlo[:, :, None] + (thi - tlo)[:, :, None] * xf[None, None, :]   # (P, qf, qf)
            wn = (wphn[:, :, None] * (thi - tlo)[:, :, None] * wf[None, None, :]
                  * np.sin(thn))
            phb = np.broadcast_to(phn[:, :, None], thn.shape)
            z = Aph[:, :, None] * np.sin(thn) + ca[:, None, None] * np.cos(thn)
            z = np.clip(z, 0.0, 1.0)
            P = s_.size
            fv = _bilinear_in_patch(data, s_, j_, thn.reshape(P, -1), phb.reshape(P, -1))
            fw = fv * wn.reshape(P, -1)[:, :, None]                            # (P, n, C)
            for k, g in enumerate(kernel(z.reshape(P, -1))):
                contrib = np.einsum("pnc,pn->pc", fw, g)
                for ch in range(c):
                    out[m0:m1, k, ch] += np.bincount(m_, weights=contrib[:, ch], minlength=nb)
    return out


# ----------------------------------------------------------------------------- front end

def _horizon_negligible(weight: WeightFunction, height: int) -> bool:
    """True if p on the band z ∈ [0, 2h] is below 1e-13 of max p (glossy n ≳ 30)."""
    hh = np.pi / height
    zb = np.linspace(0.0, min(1.0, 2.0 * hh), 65)
    band = float(np.max(np.abs(weight.p(zb))))
    pmax = float(np.max(np.abs(weight.p(np.linspace(0.0, 1.0, 1025)))))
    return band <= 1e-13 * pmax


def shading_integral(envmap: EnvMap, axes, brdf="diffuse", shininess: float = 30.0, *,
                     method: str = "sh", lmax: int | None = None,
                     nthreads: int = 0) -> np.ndarray:
    r"""Normalised shading integral (Eq. 17) of the map's bilinear interpolant about each axis, (M, C).

    .. math:: I(a) = \frac{1}{2\pi r_s}\int_{u\cdot a>0} f(u)\,p(u\cdot a)\,dS(u)

    Parameters
    ----------
    envmap : the map (f = ``envmap.lookup``, its bilinear interpolant).
    axes : (M, 3) or (3,) world directions (normalised internally): the normal (diffuse)
        or the mirror direction (glossy; the hemisphere is the one about the axis, Sec. 4.3).
    brdf : "diffuse", "glossy" (with ``shininess`` n) or a :class:`envfit.theory.brdf.WeightFunction`.
    method : "sh" (default, fast: exact SH coefficients of the bilinear interpolant, zonal
        convolution, truncated at ``lmax``; default :func:`default_sh_lmax`) or "pixels"
        (direct Gauss–Legendre quadrature over the bilinear patches with the horizon
        clipped exactly; the reference, ~1e-9 relative, O(M·H·W) work).
    lmax : SH truncation degree (``method="sh"`` only).

    Returns float64 (M, C).

    >>> from envfit.maps.envmap import EnvMap
    >>> m = EnvMap(np.ones((8, 16, 3)))
    >>> shading_integral(m, [0.0, 0.0, 1.0], "glossy", 100).round(9).tolist()
    [[1.0, 1.0, 1.0]]
    """
    weight = weight_function(brdf, shininess)
    if method not in METHODS:
        raise ParameterError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    A = axes_to_local(axes, envmap.up)
    h = envmap.height
    if method == "sh":
        L = default_sh_lmax(weight, h) if lmax is None else check_int(lmax, "lmax", 0)
        lam = funk_hecke_factors(weight, L)
        alm = bilinear_sh_coefficients(envmap, L, nthreads=nthreads)
        return synthesize_convolution(alm, L, lam, A, nthreads=nthreads)
    if lmax is not None:
        raise ParameterError("lmax applies to method='sh' only")
    norm = 1.0 / (2.0 * np.pi * float(weight.r_s))

    def kernel(z):
        yield norm * np.asarray(weight.p(z), dtype=np.float64)

    res = hemisphere_integrals(envmap, A, kernel, 1, degree=polynomial_degree(weight),
                               horizon=not _horizon_negligible(weight, h),
                               axes_are_local=True)
    return res[:, 0, :]

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
(:meth:`envfit.maps._envmap.EnvMap.lookup`, :func:`envfit.maps._latlong.bilinear_lookup`), not the
piecewise-constant pixel function nor the band-limited interpolant of the pixel centres.
Those three functions differ by :math:`O(h^2 f'')`, :math:`h = \pi/H` — relative
differences of 1e-3…1e-2 on a 64-row map, far above the 1e-4 at which the estimators'
errors are compared — so both methods below integrate the bilinear interpolant itself,
to ~1e-9, patch by patch (:mod:`envfit.shading._patches`).

``method="pixels"`` (direct quadrature, the reference)
    :func:`envfit.shading._hemisphere.hemisphere_integrals`: a q×q Gauss–Legendre rule on
    every bilinear patch, the patches the horizon may cut integrated exactly over their
    part above it; :math:`(H+1)W q^2` kernel evaluations per axis.
``method="sh"`` (fast default)
    :func:`envfit.shading._bilinear_sh.bilinear_sh_coefficients`: exact SH coefficients of
    the bilinear interpolant; then Funk–Hecke: :math:`I(a) = \sum_{l\le l_{max}} \lambda_l
    \sum_m f_{lm} Y_{lm}(a)` with :math:`\lambda_l = \sqrt{4\pi/(2l+1)}\,b_l = \int_0^1 p
    P_l\,dz / r_s` (:func:`funk_hecke_factors`, b_l from envfit.theory._brdf), synthesised
    at the axes (:func:`envfit.shading._bilinear_sh.synthesize_convolution`). The only
    approximation is the truncation at :math:`l_{max}`: negligible for lobes smooth at the
    horizon (glossy n ≳ 20), but the diffuse kink gives :math:`b_l \approx (2/\pi) l^{-2}`
    (even l), :math:`\lambda_l \sim l^{-5/2}`, and the tail then depends on the map's
    content near the horizon of each axis; it falls like :math:`l_{max}^{-3}` (measured;
    see :func:`default_sh_lmax`).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> m = EnvMap(np.full((16, 32, 1), 2.0))
>>> axes = np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
>>> bool(np.allclose(shading_integral(m, axes, "diffuse"), 2.0, atol=1e-9))
True
>>> bool(np.allclose(shading_integral(m, axes, "glossy", 30, method="pixels"), 2.0, atol=1e-9))
True
"""
from __future__ import annotations

import numpy as np

from envfit.defaults import DEFAULT_SHININESS
from envfit.theory import Diffuse, Glossy, WeightFunction

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.maps import EnvMap
# the two methods and the patch geometry this front end dispatches to
from envfit.shading._bilinear_sh import bilinear_sh_coefficients, synthesize_convolution
from envfit.shading._hemisphere import hemisphere_integrals
from envfit.shading._patches import axes_to_local

__all__ = ["shading_integral", "weight_function", "funk_hecke_factors",
           "hsh_weight_coefficients", "polynomial_degree", "default_sh_lmax", "METHODS"]

METHODS = ("sh", "pixels")


# ----------------------------------------------------------------------------- parameters

def weight_function(brdf="diffuse", shininess: float = DEFAULT_SHININESS) -> WeightFunction:
    """The :class:`envfit.theory._brdf.WeightFunction` named by ``brdf``.

    ``"diffuse"`` → :class:`~envfit.theory._brdf.Diffuse` (p = z); ``"glossy"`` →
    :class:`~envfit.theory._brdf.Glossy` (p = e^{n(z−1)}, n = ``shininess``); a WeightFunction is
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
    raise ParameterError(f"brdf must be 'diffuse', 'glossy' or a envfit.theory._brdf.WeightFunction, "
                         f"got {brdf!r}")


def polynomial_degree(weight: WeightFunction) -> int:
    r"""Bandwidth D of the lobe: p on [0, 1] is a polynomial of degree D in z to rounding.

    ``weight.resolution_degree()`` (envfit.theory._brdf). A polynomial of degree D in z = cos θ is a
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
    :math:`\lambda_0 = 1`. :math:`b_l` = ``weight.sh_coefficients(lmax)`` (Eq. 20, envfit.theory._brdf).

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


# ----------------------------------------------------------------------------- front end

def _horizon_negligible(weight: WeightFunction, height: int) -> bool:
    """True if p on the band z ∈ [0, 2h] is below 1e-13 of max p (glossy n ≳ 30)."""
    hh = np.pi / height
    zb = np.linspace(0.0, min(1.0, 2.0 * hh), 65)
    band = float(np.max(np.abs(weight.p(zb))))
    pmax = float(np.max(np.abs(weight.p(np.linspace(0.0, 1.0, 1025)))))
    return band <= 1e-13 * pmax


def _check_sh_memory(envmap: EnvMap, lmax: int, axes: int) -> None:
    """The SH ground truth's memory guard, before the analysis: the interpolant's SH
    coefficients to ``lmax`` (:func:`envfit.shading._spectra.sh_analysis_cost`) and the
    synthesis at ``axes`` axes; one line naming the rows that fit."""
    from envfit.base import check_memory
    from envfit.shading._spectra import rows_within, sh_analysis_cost
    need, secs = sh_analysis_cost(envmap.height, envmap.channels, lmax)
    check_memory(need + 16 * (int(axes) + lmax * lmax) * envmap.channels,
                 f"the SH ground truth of a {envmap.width}x{envmap.height} map to degree "
                 f"{lmax} (~{secs:.0f} s)",
                 hint=f"downsample the map to at most {rows_within(envmap.channels, lmax)} "
                      f"rows (--max-height)")


def shading_integral(envmap: EnvMap, axes, brdf="diffuse", shininess: float = DEFAULT_SHININESS, *,
                     method: str = "sh", lmax: int | None = None,
                     nthreads: int = 0) -> np.ndarray:
    r"""Normalised shading integral (Eq. 17) of the map's bilinear interpolant about each axis, (M, C).

    .. math:: I(a) = \frac{1}{2\pi r_s}\int_{u\cdot a>0} f(u)\,p(u\cdot a)\,dS(u)

    Parameters
    ----------
    envmap : the map (f = ``envmap.lookup``, its bilinear interpolant).
    axes : (M, 3) or (3,) world directions (normalised internally): the normal (diffuse)
        or the mirror direction (glossy; the hemisphere is the one about the axis, Sec. 4.3).
    brdf : "diffuse", "glossy" (with ``shininess`` n) or a :class:`envfit.theory._brdf.WeightFunction`.
    method : "sh" (default, fast: exact SH coefficients of the bilinear interpolant, zonal
        convolution, truncated at ``lmax``; default :func:`default_sh_lmax`) or "pixels"
        (direct Gauss–Legendre quadrature over the bilinear patches with the horizon
        clipped exactly; the reference, ~1e-9 relative, O(M·H·W) work).
    lmax : SH truncation degree (``method="sh"`` only).

    Returns float64 (M, C).

    >>> from envfit.maps._envmap import EnvMap
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
        _check_sh_memory(envmap, L, A.shape[0])
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

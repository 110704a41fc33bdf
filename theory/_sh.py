r"""Real-space ↔ spherical-harmonic utilities for quadrature rules on the sphere.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 3.1, 5.2 and 6.1.

Conventions
-----------
* Orthonormal complex SH :math:`Y_{l,m}(\theta,\phi) = N_{l,m} P_l^m(\cos\theta) e^{im\phi}`
  (Eqs. 1–2, Condon–Shortley phase, as ``scipy.special.sph_harm_y``), so that
  :math:`Y_{l,0} = \sqrt{(2l+1)/4\pi}\, P_l(\cos\theta)` (Eq. 60).
* Points are unit vectors (N×3) in the *local frame of the integral*: the axis of the
  zonal weight function (BRDF) is +z, :math:`\cos\theta = u\cdot z`.
* The spectral coefficients of a quadrature rule are (Eq. 54)

  .. math:: c_{l,m} = \sum_{j=1}^N w_j Y_{l,m}(u_j),

  and for real weights :math:`c_{l,-m} = (-1)^m c_{l,m}^*`, so the degree-l power is
  :math:`S_l = \sum_{m=-l}^{l}|c_{l,m}|^2 = c_{l,0}^2 + C_l^2` with the anisotropic power
  :math:`C_l^2 = 2\sum_{m=1}^{l}|c_{l,m}|^2` (Eq. 59). By the addition theorem (Eq. 3)
  :math:`S_l = \frac{2l+1}{4\pi}\sum_{i,j} w_i w_j P_l(u_i\cdot u_j)` (Eq. 44).

The fast path uses ``ducc0.sht.adjoint_synthesis_general`` (a NUFFT-based adjoint SH
synthesis on arbitrary points, O(lmax² log lmax + N)). ducc0 returns, for m ≥ 0 in the
healpy packing, :math:`\sum_j w_j Y^*_{l,m}(u_j)` — the complex conjugate of Eq. 54 with
no factor 2 for m > 0 (checked against ``scipy.special.sph_harm_y`` in the tests).
"""
from __future__ import annotations

import numpy as np

from envfit.theory._errors import TheoryParameterError, check_degree

__all__ = ["legendre_p", "legendre_series", "legendre_moments", "points_to_angles", "zonal_sums",
           "point_set_sh_coefficients", "anisotropic_power_spectrum",
           "point_set_power_spectrum", "check_points_weights"]

#: accuracy requested from ducc0's NUFFT (its double-precision floor is 2e-13)
DUCC_EPSILON = 2.5e-13


def check_points_weights(points, weights=None, *, allow_empty: bool = False):
    """Validate a quadrature rule: ``points`` (N×3 unit vectors), ``weights`` (N,), as float64.

    Raises :class:`~envfit.theory._errors.TheoryParameterError` for wrong shapes, non-finite values,
    or vectors whose norm differs from 1 by more than 1e-6.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise TheoryParameterError(f"points must be an N×3 array of unit vectors, got shape {pts.shape}")
    if pts.shape[0] == 0 and not allow_empty:
        raise TheoryParameterError("the point set is empty")
    if not np.all(np.isfinite(pts)):
        raise TheoryParameterError("points contain non-finite values")
    if pts.shape[0]:
        nrm = np.einsum("ij,ij->i", pts, pts)
        if np.max(np.abs(nrm - 1.0)) > 2e-6:
            raise TheoryParameterError("points must be unit vectors (|u| = 1 to within 1e-6)")
    if weights is None:
        return pts
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (pts.shape[0],):
        raise TheoryParameterError(f"weights must have shape ({pts.shape[0]},), got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise TheoryParameterError("weights contain non-finite values")
    return pts, w


def legendre_p(lmax: int, t) -> np.ndarray:
    r"""Legendre polynomials :math:`P_0(t) … P_{lmax}(t)`, shape ``(lmax+1,) + t.shape``.

    Bonnet's recurrence :math:`(l+1)P_{l+1} = (2l+1)tP_l - lP_{l-1}` (stable for −1 ≤ t ≤ 1).

    >>> legendre_p(2, [0.5]).ravel().round(4).tolist()
    [1.0, 0.5, -0.125]
    """
    lmax = check_degree(lmax)
    t = np.asarray(t, dtype=np.float64)
    out = np.empty((lmax + 1,) + t.shape)
    out[0] = 1.0
    if lmax >= 1:
        out[1] = t
    for l in range(1, lmax):
        out[l + 1] = ((2 * l + 1) * t * out[l] - l * out[l - 1]) / (l + 1)
    return out


def legendre_series(coeffs, t) -> np.ndarray:
    r"""Evaluate :math:`\sum_{l=0}^{L} c_l P_l(t)` by Clenshaw's recurrence, O(L·size(t)).

    Memory is three arrays the size of ``t``. Backward recurrence
    :math:`\beta_l = c_l + \frac{2l+1}{l+1} t \beta_{l+1} - \frac{l+1}{l+2}\beta_{l+2}`,
    result :math:`\beta_0`.

    >>> float(legendre_series([0.0, 0.0, 1.0], 0.5))
    -0.125
    """
    c = np.asarray(coeffs, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    L = c.size - 1
    if L < 0:
        return np.zeros_like(t)
    b1 = np.zeros_like(t)   # beta_{l+1}
    b2 = np.zeros_like(t)   # beta_{l+2}
    tmp = np.empty_like(t)
    for l in range(L, -1, -1):
        # beta_l = c_l + alpha_l t beta_{l+1} - gamma_{l+1} beta_{l+2}
        np.multiply(t, b1, out=tmp)
        tmp *= (2 * l + 1) / (l + 1)
        b2 *= -(l + 1) / (l + 2)
        tmp += b2
        tmp += c[l]
        b1, b2, tmp = tmp, b1, b2
    return b1


def points_to_angles(points) -> tuple[np.ndarray, np.ndarray]:
    r"""Colatitude θ ∈ [0, π] and longitude φ ∈ [0, 2π) of unit vectors (accurate near poles)."""
    p = np.asarray(points, dtype=np.float64)
    theta = np.arctan2(np.hypot(p[:, 0], p[:, 1]), p[:, 2])
    phi = np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * np.pi)
    return theta, phi


def legendre_moments(x, fw, lmax: int) -> np.ndarray:
    r""":math:`\sum_k fw_k P_l(x_k)` for l = 0…lmax by the Legendre recurrence (memory O(len(x)))."""
    out = np.empty(lmax + 1)
    p_prev = np.ones_like(x)
    out[0] = fw.sum()
    if lmax == 0:
        return out
    p = x.copy()
    out[1] = fw @ p
    tmp = np.empty_like(x)
    for l in range(1, lmax):
        np.multiply(x, p, out=tmp)
        tmp *= (2 * l + 1) / (l + 1)
        p_prev *= -l / (l + 1)
        tmp += p_prev
        p_prev, p, tmp = p, tmp, p_prev
        out[l + 1] = fw @ p
    return out


def zonal_sums(points, weights, lmax: int) -> np.ndarray:
    r"""Zonal coefficients :math:`c_{l,0} = \sqrt{\frac{2l+1}{4\pi}}\sum_j w_j P_l(u_j\cdot z)`, l = 0…lmax (Eq. 45).

    O(N·lmax) by the Legendre recurrence, memory O(N).

    >>> pts = np.array([[0.0, 0.0, 1.0]])
    >>> bool(np.isclose(zonal_sums(pts, [1.0], 1)[1], np.sqrt(3 / (4 * np.pi))))
    True
    """
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    out = legendre_moments(pts[:, 2].copy(), w, lmax)
    l = np.arange(lmax + 1)
    return np.sqrt((2 * l + 1) / (4 * np.pi)) * out


def _ducc_adjoint(points, weights, lmax: int, nthreads: int) -> np.ndarray:
    """ducc0 adjoint synthesis: packed (healpy order, m-major) Σ_j w_j Y*_lm(u_j), m ≥ 0."""
    import ducc0  # local import: only the fast spectrum path needs it

    theta, phi = points_to_angles(points)
    loc = np.ascontiguousarray(np.stack([theta, phi], axis=1))
    alm = ducc0.sht.adjoint_synthesis_general(
        map=np.ascontiguousarray(weights, dtype=np.float64)[None, :], spin=0, lmax=lmax,
        loc=loc, epsilon=DUCC_EPSILON, nthreads=int(nthreads))
    return alm[0]


def _packed_l_index(lmax: int) -> np.ndarray:
    """Degree l of each entry of a healpy-packed alm array (m-major, l = m…lmax)."""
    m = np.repeat(np.arange(lmax + 1), np.arange(lmax + 1, 0, -1))
    start = m * (2 * lmax + 1 - m) // 2
    return np.arange(m.size) - start


def point_set_sh_coefficients(points, weights, lmax: int, *, nthreads: int = 0) -> np.ndarray:
    r"""All :math:`c_{l,m} = \sum_j w_j Y_{l,m}(u_j)` for 0 ≤ m ≤ l ≤ lmax (Eq. 54).

    Returns a complex ``(lmax+1, lmax+1)`` array ``c[l, m]`` (zero where m > l); negative
    orders follow from :math:`c_{l,-m} = (-1)^m c^*_{l,m}`. Uses ducc0 (accuracy ≈ 1e-13
    relative to :math:`(\sum_l S_l)^{1/2}`).
    """
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    alm = _ducc_adjoint(pts, w, lmax, nthreads)
    out = np.zeros((lmax + 1, lmax + 1), dtype=np.complex128)
    lidx = _packed_l_index(lmax)
    midx = np.repeat(np.arange(lmax + 1), np.arange(lmax + 1, 0, -1))
    out[lidx, midx] = np.conj(alm)
    return out


def anisotropic_power_spectrum(points, weights, lmax: int, *, nthreads: int = 0) -> np.ndarray:
    r"""Anisotropic power :math:`C_l^2 = 2\sum_{m=1}^{l}|c_{l,m}|^2`, l = 0…lmax (Eq. 59).

    Computed directly from the m ≥ 1 coefficients (ducc0 adjoint synthesis), so it has no
    cancellation even where :math:`C_l^2 \ll c_{l,0}^2` (e.g. optimal weights at low l);
    :math:`C_0^2 = 0`.
    """
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    alm = _ducc_adjoint(pts, w, lmax, nthreads)
    power = alm.real ** 2 + alm.imag ** 2
    m0 = lmax + 1                       # entries 0…lmax are the m = 0 column
    lidx = _packed_l_index(lmax)[m0:]
    return 2.0 * np.bincount(lidx, weights=power[m0:], minlength=lmax + 1)


def point_set_power_spectrum(points, weights, lmax: int, *, nthreads: int = 0):
    r"""Zonal sums and total power of a quadrature rule, l = 0…lmax.

    Returns ``(c_l0, S_l)`` with :math:`c_{l,0}` from Eq. 45 and
    :math:`S_l = \sum_{m=-l}^{l}|c_{l,m}|^2 = c_{l,0}^2 + C_l^2` (Eqs. 44, 54, 59).
    Cost O(N·lmax + lmax² log lmax) (ducc0), versus O(N²·lmax) for the Legendre pair sum
    of Eq. 44.

    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(50, 3)); u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> c0, S = point_set_power_spectrum(u, np.full(50, 1 / 50), 4)
    >>> bool(np.isclose(S[0], 1 / (4 * np.pi)))
    True
    """
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    c0 = zonal_sums(pts, w, lmax)
    C2 = anisotropic_power_spectrum(pts, w, lmax, nthreads=nthreads)
    return c0, c0 ** 2 + C2


def _power_spectrum_legendre_pairs(points, weights, lmax: int, block: int = 512):
    r"""Reference O(N²·lmax) implementation of Eq. 44 (for tests only).

    :math:`S_l = \frac{2l+1}{4\pi}\sum_{i,j} w_i w_j P_l(u_i\cdot u_j)`, returns ``(c_l0, S_l)``.
    """
    pts, w = check_points_weights(points, weights)
    lmax = check_degree(lmax)
    n = pts.shape[0]
    S = np.zeros(lmax + 1)
    for i0 in range(0, n, block):
        g = np.clip(pts[i0:i0 + block] @ pts.T, -1.0, 1.0)
        P = legendre_p(lmax, g)                       # (lmax+1, bi, n)
        S += np.einsum("lij,i,j->l", P, w[i0:i0 + block], w)
    l = np.arange(lmax + 1)
    return zonal_sums(pts, w, lmax), (2 * l + 1) / (4 * np.pi) * S


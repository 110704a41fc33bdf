r"""Thin wrapper around ``ducc0.sht`` for lat-long maps in the local frame (real SH coefficients).

The grid (docs/HELPERS.md, "Lat-long convention"): an H×W map, W = 2H, pixel (i, j) centred at

.. math::  \theta_i = \pi (i + \tfrac12)/H, \qquad \varphi_j = 2\pi (j + \tfrac12)/W,

local direction :math:`d = (\sin\theta\cos\varphi, \sin\theta\sin\varphi, \cos\theta)`.
This is exactly ducc0's geometry ``"F1"`` (Fejér's first rule rings) with ``phi0 = π/W``.

Real spherical harmonics (orthonormal on the sphere, no Condon–Shortley phase), stored at
the flat index :math:`l^2 + l + m`, :math:`-l \le m \le l`:

.. math::
   Y_{l,0} = Y_l^0, \qquad
   Y_{l,m} = \sqrt2\,(-1)^m\,\mathrm{Re}\,Y_l^m, \qquad
   Y_{l,-m} = \sqrt2\,(-1)^m\,\mathrm{Im}\,Y_l^m \quad (m > 0),

with :math:`Y_l^m` the complex orthonormal harmonics *with* the Condon–Shortley phase
(``scipy.special.sph_harm_y``). So :math:`Y_{l,m} \propto P_l^m(\cos\theta)\cos m\varphi`
and :math:`Y_{l,-m} \propto P_l^m(\cos\theta)\sin m\varphi` with positive constants.

ducc0 stores the complex coefficients :math:`a_{lm}` of a *real* map for m ≥ 0 only
(healpy order: index :math:`m(2L+1-m)/2 + l`) and synthesises
:math:`f = \sum_l [a_{l0} Y_l^0 + \sum_{m>0} 2\,\mathrm{Re}(a_{lm} Y_l^m)]`.
Matching both expansions gives, for m > 0,

.. math::  a_{l0} = c_{l,0}, \qquad a_{lm} = (-1)^m\,(c_{l,m} - i\,c_{l,-m})/\sqrt2 ,

so independent real coefficients :math:`c_{l,\pm m} \sim N(0, a_l)` correspond to complex
:math:`a_{lm}` whose real and imaginary parts each have variance :math:`a_l/2`
(and a real :math:`a_{l0}` of variance :math:`a_l`). The test suite checks this mapping
against ``scipy.special.sph_harm_y``.

Example
-------
>>> import numpy as np
>>> c = np.zeros(real_coefficient_count(2)); c[real_index(1, 0)] = 1.0
>>> f = synthesize(c, 4)
>>> theta, phi = grid_angles(4)
>>> bool(np.allclose(f[:, 0], np.sqrt(3 / (4 * np.pi)) * np.cos(theta)))
True
"""
from __future__ import annotations

import numpy as np
import ducc0

from envfit.data_gen._errors import SyntheticMapError

__all__ = ["grid_angles", "grid_directions", "real_coefficient_count", "real_index",
           "complex_alm_count", "real_to_complex_alm", "complex_to_real_alm",
           "synthesize", "analyze"]


def _check_height(height) -> int:
    try:
        h = int(height)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"map height must be an integer, got {height!r}") from None
    if h != height or h < 1:
        raise SyntheticMapError(f"map height must be a positive integer, got {height!r}")
    return h


def _check_lmax(lmax) -> int:
    try:
        L = int(lmax)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"lmax must be an integer >= 0, got {lmax!r}") from None
    if L != lmax or L < 0:
        raise SyntheticMapError(f"lmax must be an integer >= 0, got {lmax!r}")
    return L


def grid_angles(height: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Pixel-centre angles of an H×2H lat-long map: θ_i = π(i+½)/H (H,), φ_j = 2π(j+½)/W (W,)."""
    h = _check_height(height)
    w = 2 * h
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2.0 * np.pi * (np.arange(w) + 0.5) / w
    return theta, phi


def grid_directions(height: int) -> np.ndarray:
    r"""Local unit vectors of the pixel centres, shape (H, 2H, 3): (sinθ cosφ, sinθ sinφ, cosθ)."""
    theta, phi = grid_angles(height)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    out = np.empty((theta.size, phi.size, 3))
    out[..., 0] = st * np.cos(phi)[None, :]
    out[..., 1] = st * np.sin(phi)[None, :]
    out[..., 2] = ct
    return out


def real_coefficient_count(lmax: int) -> int:
    """Number of real SH coefficients up to degree lmax: (lmax + 1)²."""
    L = _check_lmax(lmax)
    return (L + 1) ** 2


def real_index(l, m):
    """Flat index l² + l + m of the real coefficient (l, m), −l ≤ m ≤ l (works on arrays)."""
    out = np.asarray(l) * (np.asarray(l) + 1) + np.asarray(m)
    return int(out) if out.ndim == 0 else out


def complex_alm_count(lmax: int) -> int:
    """Number of complex m ≥ 0 coefficients in ducc0/healpy storage: (L+1)(L+2)/2."""
    L = _check_lmax(lmax)
    return (L + 1) * (L + 2) // 2


def _healpy_lm(L: int) -> tuple[np.ndarray, np.ndarray]:
    """(l, m) of each entry of the healpy-ordered alm array (m-major, then l = m…L)."""
    m = np.repeat(np.arange(L + 1), L + 1 - np.arange(L + 1))
    start = np.concatenate(([0], np.cumsum(L + 1 - np.arange(L))))  # index of (l=m, m)
    l = m + (np.arange(m.size) - start[m])
    return l, m


def real_to_complex_alm(coeffs, lmax: int) -> np.ndarray:
    r"""Real coefficients (…, (L+1)²) → ducc0 complex alm (…, (L+1)(L+2)/2), see module doc.

    :math:`a_{l0} = c_{l,0}`, :math:`a_{lm} = (-1)^m (c_{l,m} - i c_{l,-m})/\sqrt2` for m > 0.
    """
    L = _check_lmax(lmax)
    c = np.asarray(coeffs, dtype=np.float64)
    if c.shape[-1] != (L + 1) ** 2:
        raise SyntheticMapError(
            f"expected {(L + 1) ** 2} real coefficients for lmax = {L}, got {c.shape[-1]}")
    l, m = _healpy_lm(L)
    pos = l * l + l + m
    neg = l * l + l - m
    sign = np.where(m % 2 == 0, 1.0, -1.0)
    scale = np.where(m == 0, 1.0, sign / np.sqrt(2.0))
    alm = scale * (c[..., pos] - 1j * np.where(m == 0, 0.0, 1.0) * c[..., neg])
    return alm.astype(np.complex128)


def complex_to_real_alm(alm, lmax: int) -> np.ndarray:
    r"""Inverse of :func:`real_to_complex_alm` (the imaginary part of :math:`a_{l0}` is dropped)."""
    L = _check_lmax(lmax)
    a = np.asarray(alm, dtype=np.complex128)
    if a.shape[-1] != (L + 1) * (L + 2) // 2:
        raise SyntheticMapError(
            f"expected {(L + 1) * (L + 2) // 2} complex coefficients for lmax = {L}, "
            f"got {a.shape[-1]}")
    l, m = _healpy_lm(L)
    out = np.zeros(a.shape[:-1] + ((L + 1) ** 2,))
    sign = np.where(m % 2 == 0, 1.0, -1.0)
    zero = m == 0
    out[..., (l * l + l)[zero]] = a[..., zero].real
    nz = ~zero
    out[..., (l * l + l + m)[nz]] = np.sqrt(2.0) * sign[nz] * a[..., nz].real
    out[..., (l * l + l - m)[nz]] = -np.sqrt(2.0) * sign[nz] * a[..., nz].imag
    return out


def synthesize(coeffs, height: int, *, lmax: int | None = None, nthreads: int = 1) -> np.ndarray:
    r"""Evaluate :math:`f = \sum_{l\le L}\sum_m c_{lm} Y_{lm}` exactly at the pixel centres.

    ``coeffs``: real coefficients, shape ((L+1)²,) or (K, (L+1)²) for K maps. Returns
    (H, 2H) or (K, H, 2H) float64. L may exceed the grid's Nyquist degree H − 1: the map then
    holds exact point values of the band-limited function (which aliases on analysis).
    """
    h = _check_height(height)
    c = np.asarray(coeffs, dtype=np.float64)
    if lmax is None:
        L = int(round(np.sqrt(c.shape[-1]))) - 1
    else:
        L = _check_lmax(lmax)
    alm = real_to_complex_alm(c, L)
    batch = alm.reshape(-1, alm.shape[-1])
    w = 2 * h
    out = np.empty((batch.shape[0], h, w))
    for k in range(batch.shape[0]):
        ducc0.sht.synthesis_2d(alm=batch[k:k + 1], spin=0, lmax=L, geometry="F1",
                               map=out[k:k + 1], phi0=np.pi / w, nthreads=int(nthreads))
    return out.reshape(c.shape[:-1] + (h, w))


def analyze(map2d, lmax: int | None = None, *, nthreads: int = 1) -> np.ndarray:
    r"""Real SH coefficients (…, (L+1)²) of an H×2H map (or K×H×2H) on the F1 grid (ducc0).

    Exact for maps band-limited to L ≤ H − 1 (the default L); ducc0 refuses L ≥ H.
    """
    f = np.asarray(map2d, dtype=np.float64)
    if f.ndim not in (2, 3) or f.shape[-1] != 2 * f.shape[-2]:
        raise SyntheticMapError(f"expected an H×2H map (or K×H×2H), got shape {f.shape}")
    h, w = f.shape[-2:]
    L = h - 1 if lmax is None else _check_lmax(lmax)
    if L > h - 1:
        raise SyntheticMapError(
            f"analysis on an {h}-row F1 grid is exact only up to lmax = {h - 1}, got {L}")
    batch = np.ascontiguousarray(f.reshape(-1, h, w))
    out = np.empty((batch.shape[0], (L + 1) ** 2))
    for k in range(batch.shape[0]):
        alm = ducc0.sht.analysis_2d(map=batch[k:k + 1], spin=0, lmax=L, geometry="F1",
                                    phi0=np.pi / w, nthreads=int(nthreads))
        out[k] = complex_to_real_alm(alm[0], L)
    return out.reshape(f.shape[:-2] + ((L + 1) ** 2,))

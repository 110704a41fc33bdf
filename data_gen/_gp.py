r"""Gaussian-process environment maps of known Sobolev smoothness (Sec. 3.2, Eqs. 8, 14–16).

The zero-mean Gaussian process with covariance the generalized distance kernel

.. math::  K^{(s)}_{gd}(u, v) = \frac{2^{2s-1}}{s} - |u-v|^{2s-2}
           = \sum_{l\ge0} a_l^{(s)} \sum_{m=-l}^{l} Y_{lm}(u) Y_{lm}(v)     \quad (8, 11, 14)

is, by the addition theorem, the random field :math:`f = \sum_{lm} f_{lm} Y_{lm}` whose
real orthonormal SH coefficients are independent, :math:`f_{lm} \sim N(0, a_l^{(s)})`.
Its pointwise variance is :math:`K(u,u) = 2^{2s-1}/s` and its angular power spectrum is
:math:`C_l = a_l^{(s)} \sim l^{-2s}`: this is the "integrand of smoothness s" that the
paper's worst-case errors are about, and the ground truth for ``envfit fit``.

Two samplers:

* ``method="sht"`` (default, any size): draw the real coefficients up to ``lmax`` and
  synthesise them exactly at the pixel centres with ``ducc0.sht.synthesis_2d`` (geometry
  ``"F1"``, ``phi0 = π/W``; see :mod:`envfit.data_gen._sht` for the real/complex convention). The
  default band limit is the grid's Nyquist degree ``lmax = H − 1``: an H×2H equal-angle grid
  determines a function band-limited to degree ≤ H − 1 uniquely (2H samples on every great
  circle through the poles, 2H samples per ring, |m| ≤ H − 1 < W/2), so the map *is* the
  band-limited field—analysis recovers its coefficients exactly and its discrete spectrum is
  the continuous one, with no aliasing. The price is the missing tail
  :math:`\sum_{l\ge H}(2l+1)a_l/(4\pi) = O(H^{2-2s})` of the variance (large for s near 1;
  compare :func:`expected_variance` with and without ``lmax``). ``lmax > H − 1`` is allowed:
  the map then holds exact point values of a wider-band field, which alias on analysis.
* ``method="exact"`` (small maps): the process itself, not band-limited, sampled at the
  pixel centres as :math:`L z` with :math:`L L^T = K + \epsilon I` the Cholesky factor of
  the kernel matrix, z standard normal. ε = 0 unless the factorisation fails (nearly
  coincident points, s close to 2); it is then raised from 1e-12 to 1e-6 times the diagonal
  :math:`2^{2s-1}/s` until it succeeds—an added white noise of relative variance ≤ 1e-6.

The written map is ``offset + scale * f``: the process itself is zero-mean; ``offset``
(scalar or one value per channel) only makes the stored map positive. Channels are
independent samples drawn in order from one ``numpy.random.default_rng(seed)``.

Example
-------
>>> f = gaussian_process_map(1.5, 32, seed=1, channels=3, offset=4.0)
>>> f.shape, f.dtype
((32, 64, 3), dtype('float64'))
>>> round(expected_variance(1.5), 6)     # K(u, u) = 2^(2s-1)/s = 8/3
2.666667
"""
from __future__ import annotations

import numpy as np

from envfit.theory import cholesky
from envfit.theory import check_smoothness
from envfit.theory import generalized_distance_kernel, kernel_constant, sobolev_coefficients

from envfit.data_gen import _sht as sht
from envfit.data_gen._errors import SyntheticMapError

__all__ = ["gaussian_process_map", "gaussian_process_values", "expected_variance",
           "expected_power_spectrum", "EXACT_MAX_POINTS"]

#: Largest number of points the exact (Cholesky) sampler accepts: an N×N float64 kernel
#: matrix, N = 4608 (an H = 48 map), is 170 MB and factorises in about a second.
EXACT_MAX_POINTS = 4608

#: Largest band limit of the SHT sampler: (L+1)² real coefficients per channel (0.5 GB at
#: 8191, plus about as much transient memory), for maps up to H = 8192.
SHT_MAX_LMAX = 8191

_JITTERS = (0.0, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)


def expected_power_spectrum(s0: float, lmax: int) -> np.ndarray:
    r"""Expected angular power spectrum :math:`E[C_l] = a_l^{(s_0)}`, l = 0…lmax (Eqs. 15–16).

    :math:`C_l = \frac{1}{2l+1}\sum_m f_{lm}^2` for real orthonormal coefficients.

    >>> bool(np.isclose(expected_power_spectrum(1.5, 1)[1], 2 * np.pi / (0.5 * 1.5 * 2.5)))
    True
    """
    return sobolev_coefficients(s0, lmax)


def expected_variance(s0: float, lmax: int | None = None) -> float:
    r"""Pointwise variance :math:`\sum_{l\le l_{max}} (2l+1)\,a_l^{(s_0)}/(4\pi)` of the field.

    This is the variance of every pixel of a map band-limited at ``lmax`` (the field is
    isotropic). ``lmax=None`` gives the full process, :math:`K(u,u) = 2^{2s-1}/s` (Eq. 14).
    For s = 1.5 the sum telescopes to :math:`8/3 - \frac12(\frac{1}{L+1/2} + \frac{1}{L+3/2})`.

    >>> round(expected_variance(1.5, 0), 6)    # a_0/(4π) = 4/3
    1.333333
    """
    if lmax is None:
        return float(kernel_constant(s0))
    a = sobolev_coefficients(s0, lmax)
    l = np.arange(a.size)
    return float(np.sum((2 * l + 1) * a) / (4.0 * np.pi))


def _check_channels(channels) -> int:
    try:
        c = int(channels)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"channels must be a positive integer, got {channels!r}") from None
    if c != channels or c < 1:
        raise SyntheticMapError(f"channels must be a positive integer, got {channels!r}")
    return c


def _affine(offset, scale, channels: int) -> tuple[np.ndarray, np.ndarray]:
    out = []
    for name, v in (("offset", offset), ("scale", scale)):
        a = np.asarray(v, dtype=np.float64)
        if a.ndim > 1 or (a.ndim == 1 and a.size not in (1, channels)):
            raise SyntheticMapError(
                f"{name} must be a scalar or one value per channel ({channels}), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise SyntheticMapError(f"{name} must be finite, got {v!r}")
        out.append(np.broadcast_to(a.reshape(-1) if a.ndim else a, (channels,)).copy())
    return out[0], out[1]


def _unit_vectors(directions) -> np.ndarray:
    u = np.asarray(directions, dtype=np.float64)
    if u.ndim != 2 or u.shape[1] != 3 or u.shape[0] < 1:
        raise SyntheticMapError(f"directions must have shape (N, 3), N >= 1, got {u.shape}")
    if not np.all(np.isfinite(u)):
        raise SyntheticMapError("directions contain non-finite values")
    norm = np.linalg.norm(u, axis=1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise SyntheticMapError(
            f"directions must be unit vectors (|u| = 1 within 1e-6); worst |u| = "
            f"{norm[np.argmax(np.abs(norm - 1.0))]:.9g}")
    return u / norm[:, None]


def _kernel_cholesky(s0: float, u: np.ndarray) -> tuple[np.ndarray, float]:
    r"""Lower Cholesky factor of :math:`K^{(s_0)}_{gd}(u_i, u_j) + \epsilon I` and the ε used.

    ε is 0 when the plain factorisation succeeds, else the first of 1e-12…1e-6 times the
    diagonal :math:`2^{2s-1}/s` that makes it succeed.
    """
    n = u.shape[0]
    if n > EXACT_MAX_POINTS:
        raise SyntheticMapError(
            f"the exact Gaussian-process sampler factorises an N×N kernel matrix; N = {n} "
            f"exceeds the limit {EXACT_MAX_POINTS} (an H = 48 map). Use method='sht' for "
            f"larger maps")
    K = generalized_distance_kernel(s0, u, u)
    return _cholesky_with_jitter(0.5 * (K + K.T), kernel_constant(s0))


def _cholesky_with_jitter(K: np.ndarray, diag: float) -> tuple[np.ndarray, float]:
    """Lower Cholesky factor of K + εI, ε = the first of 0, 1e-12…1e-6 × diag that works."""
    n = K.shape[0]
    for rel in _JITTERS:
        try:
            A = K if rel == 0.0 else K + (rel * diag) * np.eye(n)
            return cholesky(A), rel * diag
        except np.linalg.LinAlgError:
            continue
    raise SyntheticMapError(
        f"the kernel matrix of {n} points is not numerically positive definite even with a "
        f"jitter of {_JITTERS[-1]:g}×diagonal (duplicate directions?)")


def gaussian_process_values(s0: float, directions, *, seed, channels: int = 1,
                            offset=0.0, scale=1.0) -> np.ndarray:
    r"""Exact sample of the GP with covariance :math:`K^{(s_0)}_{gd}` at arbitrary unit vectors.

    Returns ``offset + scale * f`` of shape (N, channels), with :math:`f = L z`,
    :math:`L L^T = K(u_i, u_j)` (+ a tiny jitter only if needed, see module doc) and z
    standard normal of shape (N, channels). Not band-limited. N ≤ :data:`EXACT_MAX_POINTS`.
    Any frame works (the kernel is rotation invariant); ``data_gen`` uses the local one.

    >>> u = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    >>> gaussian_process_values(1.5, u, seed=0, channels=2).shape
    (2, 2)
    """
    s0 = check_smoothness(s0)
    c = _check_channels(channels)
    off, sc = _affine(offset, scale, c)
    u = _unit_vectors(directions)
    L, _ = _kernel_cholesky(s0, u)
    z = np.random.default_rng(seed).standard_normal((u.shape[0], c))
    return off + sc * (L @ z)


def gaussian_process_map(s0: float, height: int, *, seed, channels: int = 1, offset=0.0,
                         scale=1.0, lmax: int | None = None, method: str = "sht",
                         nthreads: int = 1) -> np.ndarray:
    r"""H×2H×C lat-long map sampled from the GP with covariance :math:`K^{(s_0)}_{gd}`.

    ``method="sht"``: real coefficients :math:`f_{lm} \sim N(0, a_l^{(s_0)})` independent
    for l ≤ ``lmax`` (default H − 1, the grid's Nyquist degree; see the module doc),
    synthesised exactly at the pixel centres with ducc0. ``method="exact"``: the
    non-band-limited process at the pixel centres by Cholesky (2H² ≤
    :data:`EXACT_MAX_POINTS`, i.e. H ≤ 48; ``lmax`` must be None). Returns
    ``offset + scale * f`` (float64); the process f itself is zero-mean.

    Parameters
    ----------
    s0 : smoothness, 1 < s0 < 2 (else ``envfit.theory._errors.TheoryParameterError``, a ValueError).
    height : H (rows); the width is 2H.
    seed : anything ``numpy.random.default_rng`` accepts.
    channels : independent samples, stacked on the last axis.
    offset, scale : scalars or one value per channel.
    nthreads : ducc0 threads (results do not depend on it).

    >>> f = gaussian_process_map(1.5, 16, seed=3)
    >>> f.shape
    (16, 32, 1)
    """
    s0 = check_smoothness(s0)
    h = sht._check_height(height)
    c = _check_channels(channels)
    off, sc = _affine(offset, scale, c)
    if method == "exact":
        if lmax is not None:
            raise SyntheticMapError(
                "method='exact' samples the full (not band-limited) process: lmax must be None")
        u = sht.grid_directions(h).reshape(-1, 3)
        vals = gaussian_process_values(s0, u, seed=seed, channels=c, offset=off, scale=sc)
        return vals.reshape(h, 2 * h, c)
    if method != "sht":
        raise SyntheticMapError(f"method must be 'sht' or 'exact', got {method!r}")
    L = h - 1 if lmax is None else sht._check_lmax(lmax)
    if L > SHT_MAX_LMAX:
        raise SyntheticMapError(f"lmax = {L} exceeds the limit {SHT_MAX_LMAX}")
    a = sobolev_coefficients(s0, L)
    l_of = np.repeat(np.arange(L + 1), 2 * np.arange(L + 1) + 1)   # degree of flat index
    sd = np.sqrt(a)[l_of]
    rng = np.random.default_rng(seed)
    out = np.empty((h, 2 * h, c))
    for k in range(c):
        coeffs = sd * rng.standard_normal(sd.size)
        out[..., k] = off[k] + sc[k] * sht.synthesize(coeffs, h, lmax=L, nthreads=nthreads)
    return out

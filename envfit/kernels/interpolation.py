r"""Kernel interpolation of scattered samples on the sphere with the generalized distance kernel.

Marques, Bouville, Bouatouch, Sec. 9.1 / Table 2: an environment map is sampled at N unit
vectors :math:`p_j` and reconstructed with the reproducing kernel of the Sobolev space
:math:`H^s(S^2)`,

.. math::  K^{(s)}_{gd}(u, v) = \frac{2^{2s-1}}{s} - |u - v|^{2s-2}, \qquad 1 < s < 2
           \quad (14)

.. math::  \tilde f(u) = \sum_{j=1}^N \alpha_j K(u, p_j), \qquad K\alpha = f

(:math:`K_{ij} = K(p_i, p_j)`, symmetric positive definite for distinct nodes). The
interpolant is the minimum-norm element of :math:`H^s` through the data and, under the
Gaussian-process reading (``envfit.theory.sobolev``), the posterior mean for the prior
covariance :math:`\sigma^2 K`.

Numerics
--------
* **Factorisation.** float64 Cholesky, *in place*: the matrix is written straight into a
  Fortran-ordered buffer (lower triangle only) by a parallel numba kernel and factorised by
  :func:`envfit.theory.cholesky.cholesky_inplace` (LAPACK ``dpotrf`` on 2048-column panels,
  BLAS-3 updates in tiles that stay clear of OpenBLAS's threaded-``dsyrk`` crash on
  AVX-512 CPUs at N >= 16 000; same speed as one ``dpotrf``): one N x N allocation, 3.2 GB at N = 20000
  (``scipy.linalg.cho_factor`` on a C-ordered matrix would copy it). The condition
  number grows like :math:`N^s` (~5e8 at s = 1.9, N = 20000), so there is no float32
  shortcut. A memory guard (:func:`envfit.base.resources.check_memory`) runs before the
  allocation and names the largest N that fits.
* **Distances** are formed from coordinate differences, ``|u - v|^2 = sum (u_k - v_k)^2``,
  which keeps full relative accuracy next to the cusp of the kernel; the Gram form
  ``2 - 2 u.v`` (a rank-3 "BLAS" product, memory bound anyway) loses it there.
* **Evaluation** :math:`\tilde f(q) = c_s \sum_j \alpha_j - \sum_j \alpha_j |q - p_j|^{2s-2}`,
  two methods:

  ``"direct"`` (exact)
      a fused numba loop (distance, power, accumulation; no temporaries) with a
      vectorised float64 power (``envfit.kernels._kernels.fast_pow``, ~1e-15 relative; ``sqrt``
      for s = 1.5). M N power evaluations.
  ``"nearfar"`` (fast summation)
      the kernel's power part :math:`g(t) = (2 - 2t)^{s-1}`, ``t = q.p``, is replaced
      outside a cap of chordal radius :math:`\delta` by a polynomial :math:`P_L(t)`
      (Chebyshev interpolation on :math:`[-1, 1 - \delta^2/2]` truncated at 1e-15;
      L ~ 20-25/delta), which by the addition theorem is a spherical-harmonic convolution:
      :math:`\sum_j \alpha_j P_L(q\cdot p_j) = \sum_{lm} w_l Y_{lm}(q) \sum_j \alpha_j
      Y^*_{lm}(p_j)` (two ducc0 NUFFT-based SH transforms, accuracy 3e-13). Pairs closer
      than :math:`\delta` get the exact correction :math:`g - P_L` (3-D cell list,
      ~8 neighbours per query). Cost O(C (L^2 log L + M + N)) for the transforms plus
      ~8 M C near pairs, instead of M N C; error
      ~1e-12 :math:`\sum_j |\alpha_j K(q, p_j)|` (vs ~1e-15 for direct), which is far
      below the interpolation error (the RMSE against a map is unchanged to 6+ digits).

  ``"auto"`` (default) picks ``"nearfar"`` when M N >= 5e7 and N >= 500.
* **Threads.** numba kernels, BLAS/LAPACK calls and ducc0 transforms alternate and never
  overlap; each uses all cores (``numba.get_num_threads()``; BLAS via its own pool, limit it
  with ``threadpoolctl`` if the caller runs several interpolators in parallel).
* **Leave-one-out residuals** (Rippa 1999) :math:`e_i = \alpha_i / (K^{-1})_{ii}` need the
  diagonal of :math:`K^{-1} = L^{-T} L^{-1}`: :math:`(K^{-1})_{ii} = \|L^{-1} e_i\|^2`,
  computed in column blocks by BLAS ``dtrsm`` on the trailing triangle (no copy of L,
  N x 512 workspace). Cost N^3/3 flops, the same as the Cholesky factorisation itself
  (~45 s at N = 20000 on 2 cores); computed once and cached.
* **Profiled likelihood** :math:`\ell = -\tfrac12(N\log\hat\sigma^2 + \log\det K +
  N(1+\log 2\pi))`, :math:`\hat\sigma^2 = f^T K^{-1} f / N` per channel, log det from the
  Cholesky diagonal: O(N C) once the factor exists.

Example
-------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> p = rng.normal(size=(200, 3))
>>> f = p[:, 2] ** 2                      # any samples
>>> it = SobolevInterpolator(p, f, 1.5)
>>> bool(np.allclose(it(p), f, atol=1e-9))  # interpolates the data
True
"""
from __future__ import annotations

import ctypes
import functools
import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
import scipy.fft
from scipy import special
from scipy.linalg import cython_blas, lapack
from scipy.spatial import cKDTree

from envfit.theory.cholesky import cholesky_inplace
from envfit.theory.errors import TheoryParameterError, check_smoothness
from envfit.theory.sobolev import kernel_constant

from envfit.kernels import _kernels
from envfit.base.errors import DuplicatePointsError, ParameterError
from envfit.base.resources import (MEMORY_FRACTION, available_memory_bytes, check_memory, format_bytes,
                                   interpolator_nbytes, largest_feasible_n)

__all__ = ["SobolevInterpolator", "ProfiledLikelihood", "as_unit_vectors",
           "FarFieldExpansion",
           "far_field_expansion", "DUPLICATE_DISTANCE", "EVAL_METHODS"]

#: two nodes closer than this (chordal distance) are duplicates
DUPLICATE_DISTANCE = 1e-12
#: a Cholesky pivot p with p^2 < this * c_s means coincident nodes (rounding-level pivot)
_SINGULAR_PIVOT = 64 * np.finfo(np.float64).eps
EVAL_METHODS = ("auto", "direct", "nearfar")
#: bytes of temporaries one evaluation block may use
_BLOCK_BYTES = 64 * 2**20
#: ducc0 NUFFT SH transforms: requested accuracy (2e-13 is ducc0's float64 floor)
_SHT_EPSILON = 3e-13
#: near/far split: target mean number of nodes within delta of a query
_NEAR_NEIGHBOURS = 8.0
_DELTA_MIN, _DELTA_MAX = 0.02, 0.6
#: "auto" uses near/far above this many kernel entries (and N >= _AUTO_MIN_N)
_AUTO_MIN_ENTRIES = 5e7
_AUTO_MIN_N = 500


# ----------------------------------------------------------------------------- helpers

def _check_s(s) -> float:
    try:
        return check_smoothness(s)
    except TheoryParameterError as exc:
        raise ParameterError(str(exc)) from None


def as_unit_vectors(points, *, name: str = "points") -> np.ndarray:
    """``points`` (..., 3) as a C-contiguous float64 (M, 3) array of unit vectors.

    Rejects (with :class:`~envfit.base.errors.ParameterError`, never a numpy warning) a wrong
    shape, NaN/Inf entries and zero vectors. Vectors are rescaled by their largest
    component before the norm is taken, so huge or tiny finite vectors do not overflow.

    >>> as_unit_vectors([[0, 0, 2.0], [3.0, 4.0, 0]])
    array([[0. , 0. , 1. ],
           [0.6, 0.8, 0. ]])
    """
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array of 3-vectors") from None
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ParameterError(f"{name} must have shape (..., 3), got {p.shape}")
    p = p.reshape(-1, 3)
    if p.shape[0] == 0:
        raise ParameterError(f"{name} is empty")
    finite = np.isfinite(p).all(axis=1)
    if not finite.all():
        i = int(np.argmin(finite))
        raise ParameterError(f"{name}[{i}] = {p[i].tolist()} is not finite")
    big = np.abs(p).max(axis=1)
    if not (big > 0).all():
        i = int(np.argmin(big > 0))
        raise ParameterError(f"{name}[{i}] is the zero vector, which has no direction")
    # vectors that are unit to rounding are kept bit for bit (so normalising is idempotent
    # and a query equal to a node gives d = 0 exactly: at s near 1 the kernel's cusp turns a
    # 1e-16 displacement into a 1e-3 kernel change); elementwise ops only, so a row's
    # result never depends on the other rows
    with np.errstate(over="ignore", under="ignore"):
        n2 = p[:, 0] * p[:, 0] + p[:, 1] * p[:, 1] + p[:, 2] * p[:, 2]
    keep = np.abs(n2 - 1.0) <= 8 * np.finfo(np.float64).eps
    if keep.all():
        return np.ascontiguousarray(p)
    q = p / big[:, None]
    q /= np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2])[:, None]
    q[keep] = p[keep]
    return np.ascontiguousarray(q)


def _as_values(values, n: int, *, name: str = "values") -> tuple[np.ndarray, bool]:
    """(N, C) float64 Fortran-ordered copy of ``values`` and whether the input was 1-D."""
    try:
        v = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a numeric array") from None
    vector = v.ndim == 1
    if vector:
        v = v[:, None]
    if v.ndim != 2 or v.shape[0] != n:
        raise ParameterError(f"{name} must have shape ({n},) or ({n}, C), got {np.shape(values)}")
    if v.shape[1] == 0:
        raise ParameterError(f"{name} has no channels")
    if not np.isfinite(v).all():
        raise ParameterError(f"{name} contain NaN or Inf")
    return np.array(v, dtype=np.float64, order="F"), vector


def _closest_pair(points: np.ndarray) -> tuple[int, int, float]:
    """Indices (i < j) and chordal distance of the closest pair of nodes (kd-tree, O(N log N))."""
    if points.shape[0] < 2:
        return 0, 0, math.inf
    dist, idx = cKDTree(points).query(points, k=2)
    i = int(np.argmin(dist[:, 1]))
    # with exact duplicates the query may list the point itself second: take the other one
    j = int(idx[i, 1]) if int(idx[i, 1]) != i else int(idx[i, 0])
    return min(i, j), max(i, j), float(dist[i, 1])


def _to_theta_phi(p: np.ndarray) -> np.ndarray:
    """(M, 2) colatitude, longitude in [0, 2 pi) of unit vectors (accurate at the poles)."""
    loc = np.empty((p.shape[0], 2))
    loc[:, 0] = np.arctan2(np.hypot(p[:, 0], p[:, 1]), p[:, 2])
    phi = np.arctan2(p[:, 1], p[:, 0])
    loc[:, 1] = np.where(phi < 0, phi + 2 * np.pi, phi)
    return loc


def _nthreads() -> int:
    return max(1, int(numba.get_num_threads()))


# ------------------------------------------------------------------ BLAS dtrsm by pointer

@functools.lru_cache(maxsize=None)
def _dtrsm():
    """scipy's BLAS ``dtrsm`` as a ctypes function (sub-matrices are passed by pointer and
    leading dimension, so the trailing triangle of the factor is never copied)."""
    capsule = cython_blas.__pyx_capi__["dtrsm"]
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype = ctypes.c_char_p
    get_name.argtypes = [ctypes.py_object]
    get_ptr = ctypes.pythonapi.PyCapsule_GetPointer
    get_ptr.restype = ctypes.c_void_p
    get_ptr.argtypes = [ctypes.py_object, ctypes.c_char_p]
    addr = get_ptr(capsule, get_name(capsule))
    c_int_p = ctypes.POINTER(ctypes.c_int)
    proto = ctypes.CFUNCTYPE(None, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p,
                             ctypes.c_char_p, c_int_p, c_int_p,
                             ctypes.POINTER(ctypes.c_double), ctypes.c_void_p, c_int_p,
                             ctypes.c_void_p, c_int_p)
    return proto(addr)


def _inverse_diagonal_from_cholesky(factor: np.ndarray, block: int = 512) -> np.ndarray:
    r"""``diag(K^-1)`` from the lower Cholesky factor L (Fortran-ordered, K = L L^T).

    :math:`(K^{-1})_{ii} = \|L^{-1} e_i\|^2` and, L being lower triangular, the columns
    ``i0:i1`` of :math:`L^{-1}` vanish above row i0 and equal
    :math:`L[i0:, i0:]^{-1} E`: one ``dtrsm`` per block on the trailing triangle.
    Flops :math:`\sum (N - i_0)^2 b \approx N^3/3`; workspace N x b.
    """
    n = factor.shape[0]
    if n == 0:
        return np.zeros(0)
    if not (factor.flags.f_contiguous and factor.dtype == np.float64):
        raise ValueError("factor must be a Fortran-ordered float64 array")
    block = max(1, min(block, n))
    dtrsm = _dtrsm()
    out = np.empty(n)
    work = np.empty(n * block)  # Fortran (rows, cols) buffer, reused
    one = ctypes.c_double(1.0)
    lda = ctypes.c_int(n)
    side, uplo, trans, diag = b"L", b"L", b"N", b"N"
    base = factor.ctypes.data
    for i0 in range(0, n, block):
        i1 = min(n, i0 + block)
        rows, cols = n - i0, i1 - i0
        x = work[: rows * cols].reshape(cols, rows).T  # Fortran view, ld = rows
        x[...] = 0.0
        x[np.arange(cols), np.arange(cols)] = 1.0
        dtrsm(side, uplo, trans, diag, ctypes.byref(ctypes.c_int(rows)),
              ctypes.byref(ctypes.c_int(cols)), ctypes.byref(one),
              ctypes.c_void_p(base + 8 * (i0 + i0 * n)), ctypes.byref(lda),
              ctypes.c_void_p(x.ctypes.data), ctypes.byref(ctypes.c_int(rows)))
        out[i0:i1] = np.einsum("ij,ij->j", x, x)
    return out


# ------------------------------------------------------------------ near/far expansion

@dataclass(frozen=True)
class FarFieldExpansion:
    r"""Polynomial far field of :math:`g(t) = (2 - 2t)^a`, a = s - 1, for ``"nearfar"``.

    ``lmax`` = L, the degree of :math:`P_L \approx g` on :math:`[-1, 1 - \delta^2/2]`;
    ``sh_weights[l]`` = :math:`w_l = 4\pi g_l/(2l+1)`, :math:`P_L = \sum_l g_l P_l`, so that
    :math:`P_L(u\cdot v) = \sum_{l,m} w_l Y_{lm}(u) Y^*_{lm}(v)`; ``near_cheb``: Chebyshev
    coefficients of :math:`S(d^2) = P_L(1 - d^2/2)` on :math:`d^2 \in [0, \delta^2]`;
    ``far_error``: max :math:`|P_L - g|` on the far interval (checked on a fine grid).
    """
    s: float
    delta: float
    lmax: int
    sh_weights: np.ndarray
    near_cheb: np.ndarray
    far_error: float


def _chebyshev_coefficients(values: np.ndarray) -> np.ndarray:
    """Coefficients of the Chebyshev interpolant through values at x_k = cos(pi (k+1/2)/n)."""
    n = values.shape[0]
    c = scipy.fft.dct(values, type=2) / n
    c[0] /= 2
    return c


@functools.lru_cache(maxsize=32)
def far_field_expansion(s: float, delta: float, rtol: float = 1e-15) -> FarFieldExpansion:
    r"""The near/far split of the kernel for smoothness s and near radius ``delta``.

    1. Chebyshev interpolation of :math:`g(t) = (2-2t)^{s-1}` on :math:`[-1, t_0]`,
       :math:`t_0 = 1 - \delta^2/2`, evaluated as :math:`(d^2)^{s-1}` with
       :math:`d^2 = \delta^2 + (4 - \delta^2)\sin^2(\theta_k/2)` (no cancellation);
       truncated after the last coefficient above ``rtol * 4^(s-1)``: degree L.
    2. Legendre coefficients of :math:`P_L` on [-1, 1] by interpolation at the L + 1
       Gauss-Legendre nodes.
    3. :math:`S(d^2) = P_L(1 - d^2/2)` re-expanded on the near interval (degree ~20).

    >>> ff = far_field_expansion(1.5, 0.1)
    >>> ff.lmax > 100 and ff.far_error < 1e-13
    True
    """
    s = _check_s(s)
    a = s - 1.0
    delta = float(delta)
    if not (0.0 < delta < 2.0):
        raise ParameterError(f"near radius delta must be in (0, 2), got {delta}")
    d2min = delta * delta
    t0 = 1.0 - d2min / 2.0
    gmax = 4.0 ** a
    n = 1024
    while True:
        theta = np.pi * (np.arange(n) + 0.5) / n
        # t = ((t0 + 1) x + t0 - 1) / 2, x = cos(theta): 2 - 2t = d2min + (4 - d2min) sin^2(theta/2)
        d2 = d2min + (4.0 - d2min) * np.sin(theta / 2) ** 2
        c = _chebyshev_coefficients(d2 ** a)
        big = np.nonzero(np.abs(c) > rtol * gmax)[0]
        lmax = int(big[-1]) if big.size else 0
        if lmax < 0.6 * n or n >= 2**16:
            break
        n *= 4
    c = c[: lmax + 1]

    def poly(t):  # P_L(t) through the mapped Chebyshev variable
        x = (2.0 * t - (t0 - 1.0)) / (t0 + 1.0)
        return np.polynomial.chebyshev.chebval(x, c)

    # Legendre coefficients g_l of P_L: interpolation at the L + 1 Gauss-Legendre nodes
    # (a well-conditioned square solve; the quadrature form sum_i w_i P_L(u_i) P_l(u_i)
    # is mathematically the same but scipy's weights near +-1 carry ~1e-11 relative errors,
    # which show up as 1e-10 errors of the series at t = -1)
    u, _ = special.roots_legendre(lmax + 1)
    vander = np.polynomial.legendre.legvander(u, lmax)
    g = np.linalg.solve(vander, poly(u))
    # P_L(u.v) = sum_l g_l P_l(u.v) = sum_lm [4 pi g_l / (2l+1)] Y_lm(u) Y*_lm(v)
    weights = 4.0 * np.pi * g / (2.0 * np.arange(lmax + 1) + 1.0)
    # near-zone representation of P_L
    m = 64
    y = np.cos(np.pi * (np.arange(m) + 0.5) / m)
    d2n = d2min * (1.0 + y) / 2.0
    cn = _chebyshev_coefficients(poly(1.0 - d2n / 2.0))
    keep = np.nonzero(np.abs(cn) > 1e-14 * gmax)[0]
    cn = cn[: (int(keep[-1]) + 3 if keep.size else 1)].copy()
    # check the far-field error on a fine grid in d2 (geometric near the cut)
    d2c = np.concatenate([d2min * np.geomspace(1.0, 4.0 / d2min, 4001), np.linspace(d2min, 4.0, 4001)])
    err = float(np.max(np.abs(poly(1.0 - d2c / 2.0) - d2c ** a)))
    return FarFieldExpansion(s=s, delta=delta, lmax=lmax, sh_weights=weights,
                             near_cheb=np.ascontiguousarray(cn), far_error=err)


def _near_radius(n: int) -> float:
    """delta with about :data:`_NEAR_NEIGHBOURS` of N uniformly spread nodes within it
    (cap area fraction delta^2/4), rounded to 2 significant digits so that the cached
    expansion is reused across nearby N."""
    d = math.sqrt(4.0 * _NEAR_NEIGHBOURS / max(n, 1))
    d = min(max(d, _DELTA_MIN), _DELTA_MAX)
    return float(f"{d:.2g}")


@dataclass
class _CellList:
    """Nodes sorted by the cell of a uniform grid of side h >= delta over [-1, 1]^3."""
    h: float
    ngrid: int
    order: np.ndarray
    cell_start: np.ndarray
    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray

    @classmethod
    def build(cls, points: np.ndarray, delta: float) -> "_CellList":
        ngrid = max(1, int(math.floor(2.0 / delta)))
        h = 2.0 / ngrid  # >= delta
        idx = np.minimum(((points + 1.0) / h).astype(np.int64), ngrid - 1)
        lin = (idx[:, 0] * ngrid + idx[:, 1]) * ngrid + idx[:, 2]
        order = np.argsort(lin, kind="stable")
        counts = np.bincount(lin, minlength=ngrid**3)
        start = np.zeros(ngrid**3 + 1, dtype=np.int64)
        np.cumsum(counts, out=start[1:])
        sp = points[order]
        return cls(h=h, ngrid=ngrid, order=order, cell_start=start,
                   px=np.ascontiguousarray(sp[:, 0]), py=np.ascontiguousarray(sp[:, 1]),
                   pz=np.ascontiguousarray(sp[:, 2]))


# ------------------------------------------------------------------ the interpolator

class ProfiledLikelihood(NamedTuple):
    """Gaussian-process log-likelihood with the scale profiled out, per channel."""
    loglik: np.ndarray | float
    #: :math:`\hat\sigma = (f^T K^{-1} f / N)^{1/2}`
    sigma: np.ndarray | float


class SobolevInterpolator:
    r"""Interpolate values at unit vectors with the generalized distance kernel (Eq. 14).

    Parameters
    ----------
    points : (N, 3) array
        Node directions (normalised here; NaN/Inf or zero vectors are rejected).
    values : (N,) or (N, C) array
        Samples (one column per channel or per map; one factorisation serves them all).
    s : float
        Sobolev smoothness, 1 < s < 2.
    check_duplicates : bool
        Look for nodes closer than :data:`DUPLICATE_DISTANCE` before factorising
        (kd-tree, O(N log N)). A failed factorisation is always reported as
        :class:`~envfit.base.errors.DuplicatePointsError` with the closest pair.

    Attributes
    ----------
    points (N, 3), s, n, nchannels, kernel_constant (:math:`c_s = 2^{2s-1}/s`),
    coefficients (:math:`\alpha`, N x C), cholesky (``(L, True)``, the in-place factor as
    :func:`scipy.linalg.cho_solve` expects it), log_det (:math:`\log\det K`).

    Raises
    ------
    ParameterError, DuplicatePointsError, MemoryBudgetError

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> p = rng.normal(size=(300, 3)); f = np.c_[p[:, 0], p[:, 1] ** 2]
    >>> it = SobolevInterpolator(p, f, 1.7)
    >>> it.coefficients.shape, it([0.0, 0.0, 1.0]).shape
    ((300, 2), (2,))
    """

    def __init__(self, points, values, s, *, check_duplicates: bool = True):
        self.s = _check_s(s)
        pts = as_unit_vectors(points)
        n = pts.shape[0]
        vals, self._vector = _as_values(values, n)
        self.n = n
        self.nchannels = vals.shape[1]
        self.kernel_constant = kernel_constant(self.s)
        self._a = self.s - 1.0
        self._kind = _kernels.power_kind(self._a)
        budget = available_memory_bytes() * MEMORY_FRACTION
        check_memory(interpolator_nbytes(n, self.nchannels),
                     f"interpolating {n} samples (the {n}x{n} float64 kernel matrix "
                     f"alone is {format_bytes(8.0 * n * n)})",
                     hint=f"the largest N that fits is {largest_feasible_n(budget, self.nchannels)}")
        if check_duplicates and n > 1:
            i, j, d = _closest_pair(pts)
            if d < DUPLICATE_DISTANCE:
                raise DuplicatePointsError(
                    f"points {i} and {j} coincide (distance {d:.1e} < {DUPLICATE_DISTANCE:g}): "
                    f"the kernel matrix is singular; remove or merge duplicate samples")
        self.points = pts
        self._px = np.ascontiguousarray(pts[:, 0])
        self._py = np.ascontiguousarray(pts[:, 1])
        self._pz = np.ascontiguousarray(pts[:, 2])
        self._values = vals
        #: wall-clock seconds of the construction steps ("matrix", "cholesky", "solve")
        self.timings = {}
        self._factor = self._factorize()
        self.log_det = float(2.0 * np.sum(np.log(np.diagonal(self._factor))))
        t = time.perf_counter()
        self._alpha = self._solve_matrix(vals)
        self.timings["solve"] = time.perf_counter() - t
        self._kinv_diag = None
        self._cells = {}

    @classmethod
    def from_coefficients(cls, points, coefficients, s) -> "SobolevInterpolator":
        r"""An evaluation-only interpolant :math:`\sum_j \alpha_j K(\cdot, p_j)` from known
        coefficients :math:`\alpha` (N,) or (N, C), without building or factorising K.

        Used where the factorisation happened elsewhere (e.g. one factorisation solved for
        a whole library of maps, :mod:`envfit.batch.library`): evaluation needs only the nodes and
        :math:`\alpha` (O(N C) memory), so a worker can evaluate without the N x N factor.
        :meth:`evaluate` gives bit-for-bit what the fitted interpolator gives for the same
        :math:`\alpha`; :meth:`solve`, :meth:`loo_residuals` and
        :meth:`log_likelihood_profiled` raise :class:`~envfit.base.errors.ParameterError`.

        >>> import numpy as np
        >>> p = np.random.default_rng(2).normal(size=(50, 3))
        >>> full = SobolevInterpolator(p, p[:, 2], 1.5)
        >>> light = SobolevInterpolator.from_coefficients(p, full.coefficients[:, 0], 1.5)
        >>> bool(np.array_equal(light(p[:5]), full(p[:5])))
        True
        """
        self = cls.__new__(cls)
        self.s = _check_s(s)
        pts = as_unit_vectors(points)
        n = pts.shape[0]
        alpha, self._vector = _as_values(coefficients, n, name="coefficients")
        self.n = n
        self.nchannels = alpha.shape[1]
        self.kernel_constant = kernel_constant(self.s)
        self._a = self.s - 1.0
        self._kind = _kernels.power_kind(self._a)
        self.points = pts
        self._px = np.ascontiguousarray(pts[:, 0])
        self._py = np.ascontiguousarray(pts[:, 1])
        self._pz = np.ascontiguousarray(pts[:, 2])
        self._values = None
        self.timings = {}
        self._factor = None
        self.log_det = float("nan")
        self._alpha = alpha
        self._kinv_diag = None
        self._cells = {}
        return self

    # -- construction ------------------------------------------------------------
    def _factorize(self) -> np.ndarray:
        n = self.n
        # the only N x N allocation: Fortran order, lower triangle written by the kernel
        t0 = time.perf_counter()
        # zeros (calloc: pages are zeroed lazily, no extra pass) so the unused upper triangle
        # holds no garbage: cho_solve(check_finite=True) on .cholesky must not see NaNs
        buf = np.zeros((n, n), dtype=np.float64, order="F")
        _kernels.fill_kernel_matrix(self._px, self._py, self._pz, self._a, self._kind,
                                    self.kernel_constant, buf)
        t1 = time.perf_counter()
        info = cholesky_inplace(buf)
        c = buf
        self.timings["matrix"] = t1 - t0
        self.timings["cholesky"] = time.perf_counter() - t1
        if info < 0:  # pragma: no cover - argument error
            raise RuntimeError(f"dpotrf argument {-info} is invalid")
        if info == 0:
            # coincident nodes can also slip through with a pivot at rounding level
            pivot = float(np.min(np.diagonal(c)))
            if pivot * pivot >= _SINGULAR_PIVOT * self.kernel_constant:
                return c
        i, j, d = _closest_pair(self.points)
        where = f"dpotrf failed at column {info}" if info > 0 else "a pivot at rounding level"
        raise DuplicatePointsError(
            f"the {n}x{n} kernel matrix is numerically singular ({where}); closest nodes: "
            f"points {i} and {j} at distance {d:.1e}: remove or merge (near-)duplicate samples")

    # -- linear algebra ------------------------------------------------------------
    @property
    def cholesky(self) -> tuple[np.ndarray, bool]:
        """``(L, True)``: lower Cholesky factor of K (Fortran order, factorised in place).

        Only the lower triangle is meaningful (the strict upper one was never written).
        Usable directly with :func:`scipy.linalg.cho_solve`.
        """
        self._require_factor()
        return self._factor, True

    @property
    def coefficients(self) -> np.ndarray:
        r""":math:`\alpha = K^{-1} f`, shape (N, C)."""
        return self._alpha

    def _require_factor(self) -> None:
        if self._factor is None:
            raise ParameterError("this interpolant was built from coefficients alone "
                                 "(from_coefficients): it has no factorisation to solve with")

    def _solve_matrix(self, vals: np.ndarray) -> np.ndarray:
        self._require_factor()
        x, info = lapack.dpotrs(self._factor, vals, lower=1)
        if info != 0:  # pragma: no cover
            raise RuntimeError(f"dpotrs failed (info={info})")
        return x

    def solve(self, new_values) -> np.ndarray:
        r""":math:`K^{-1} f` for new samples at the same nodes (same factorisation).

        ``new_values`` (N,) or (N, C); the result has the same shape. Cost: two triangular
        solves, O(N^2 C).
        """
        vals, vector = _as_values(new_values, self.n, name="new_values")
        x = self._solve_matrix(vals)
        return x[:, 0] if vector else x

    def _coefficients_for(self, values):
        if values is None:
            self._require_factor()
            return self._values, self._alpha, self._vector
        vals, vector = _as_values(values, self.n)
        return vals, self._solve_matrix(vals), vector

    def inverse_diagonal(self) -> np.ndarray:
        r""":math:`\mathrm{diag}(K^{-1})` (N,), computed once (N^3/3 flops, see module doc)."""
        self._require_factor()
        if self._kinv_diag is None:
            block = int(min(512, max(64, _BLOCK_BYTES // (8 * max(self.n, 1)))))
            self._kinv_diag = _inverse_diagonal_from_cholesky(self._factor, block=block)
        return self._kinv_diag

    def loo_residuals(self, values=None) -> np.ndarray:
        r"""Leave-one-out residuals :math:`e_i = f_i - \tilde f^{(-i)}(p_i) = \alpha_i / (K^{-1})_{ii}`.

        Rippa's closed form: no refits. ``values`` default to the fitted ones; shape (N,) or
        (N, C) like them.
        """
        _, alpha, vector = self._coefficients_for(values)
        e = alpha / self.inverse_diagonal()[:, None]
        return e[:, 0] if vector else e

    def log_likelihood_profiled(self, values=None) -> ProfiledLikelihood:
        r"""GP marginal log-likelihood of the samples with the scale profiled out, per channel.

        Model :math:`f \sim N(0, \sigma^2 K)`; the maximising
        :math:`\hat\sigma^2 = f^T K^{-1} f / N` gives
        :math:`\ell = -\tfrac12 (N \log\hat\sigma^2 + \log\det K + N (1 + \log 2\pi))`.
        Returns ``(loglik, sigma)`` (:math:`\hat\sigma`), arrays of shape (C,) or scalars for
        1-D values.
        """
        vals, alpha, vector = self._coefficients_for(values)
        n = self.n
        quad = np.einsum("ij,ij->j", vals, alpha)
        with np.errstate(divide="ignore"):
            sigma2 = quad / n
            ll = -0.5 * (n * np.log(sigma2) + self.log_det + n * (1.0 + math.log(2.0 * math.pi)))
        sigma = np.sqrt(sigma2)
        if vector:
            return ProfiledLikelihood(float(ll[0]), float(sigma[0]))
        return ProfiledLikelihood(ll, sigma)

    # -- evaluation ----------------------------------------------------------------
    def __call__(self, query) -> np.ndarray:
        """Interpolant at ``query`` (..., 3) directions: shape (...,) or (..., C) like ``values``."""
        return self.evaluate(query)

    def evaluate(self, query, coefficients=None, *, method: str = "auto") -> np.ndarray:
        r""":math:`\sum_j \alpha_j K(q, p_j)` at query directions (..., 3).

        ``coefficients`` (N,) or (N, C) default to the fitted :attr:`coefficients`; the
        output is (...,) or (..., C) accordingly. ``method``: ``"direct"``, ``"nearfar"``
        or ``"auto"`` (see the module docstring).
        """
        if method not in EVAL_METHODS:
            raise ParameterError(f"unknown evaluation method {method!r}; choose one of "
                                 f"{', '.join(EVAL_METHODS)}")
        qshape = np.shape(query)[:-1] if np.ndim(query) >= 1 else ()
        q = as_unit_vectors(query, name="query")
        if coefficients is None:
            alpha, vector = self._alpha, self._vector
        else:
            alpha, vector = _as_values(coefficients, self.n, name="coefficients")
        m = q.shape[0]
        if method == "auto":
            method = ("nearfar" if (m * self.n >= _AUTO_MIN_ENTRIES and self.n >= _AUTO_MIN_N)
                      else "direct")
        if method == "direct":
            out = self._power_sums_direct(q, alpha)
        else:
            out = self._power_sums_nearfar(q, alpha)
        # f(q) = c sum_j alpha_j - sum_j alpha_j |q - p_j|^(2s-2)
        np.subtract(self.kernel_constant * alpha.sum(axis=0), out, out=out)
        if vector:
            return out[:, 0].reshape(qshape)
        return out.reshape(qshape + (alpha.shape[1],))

    def _power_sums_direct(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        m, nc = q.shape[0], alpha.shape[1]
        out = np.empty((m, nc))
        a, kind = self._a, self._kind
        if nc == 1:
            _kernels.power_sums_1(q, self._px, self._py, self._pz,
                                  np.ascontiguousarray(alpha[:, 0]), a, kind, out[:, 0])
        elif nc == 3:
            w = [np.ascontiguousarray(alpha[:, c]) for c in range(3)]
            _kernels.power_sums_3(q, self._px, self._py, self._pz, w[0], w[1], w[2], a, kind, out)
        else:  # many right-hand sides: power block (bounded memory) then BLAS
            rows = max(1, _BLOCK_BYTES // (8 * self.n))
            block = np.empty((min(rows, m), self.n))
            for i0 in range(0, m, rows):
                i1 = min(m, i0 + rows)
                blk = block[: i1 - i0]
                _kernels.power_block(q[i0:i1], self._px, self._py, self._pz, a, kind, blk)
                np.matmul(blk, alpha, out=out[i0:i1])
        return out

    def _cell_list(self, delta: float) -> _CellList:
        cl = self._cells.get(delta)
        if cl is None:
            cl = self._cells[delta] = _CellList.build(self.points, delta)
        return cl

    def _power_sums_nearfar(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        import ducc0  # heavy import, only here

        m, nc = q.shape[0], alpha.shape[1]
        delta = _near_radius(self.n)
        ff = far_field_expansion(self.s, delta)
        cells = self._cell_list(delta)
        nthreads = _nthreads()
        lmax = ff.lmax
        # far field: alm = w_l sum_j alpha_j Y*_lm(p_j)
        node_loc = _to_theta_phi(self.points)
        l_of_index = np.concatenate([np.arange(mm, lmax + 1) for mm in range(lmax + 1)])
        weights = ff.sh_weights[l_of_index]
        alms = []
        for c in range(nc):  # ducc0: one scalar (spin-0) map per call
            alm = ducc0.sht.adjoint_synthesis_general(
                lmax=lmax, spin=0, map=np.ascontiguousarray(alpha[:, c])[None, :], loc=node_loc,
                epsilon=_SHT_EPSILON, nthreads=nthreads)
            alm *= weights
            alms.append(alm)
        sw = np.ascontiguousarray(alpha[cells.order])
        out = np.empty((m, nc))
        near = np.empty((min(m, 2**18), nc))
        for i0 in range(0, m, 2**18):  # bounded temporaries: loc (4 MB) and near (2 MB * C)
            i1 = min(m, i0 + 2**18)
            qb = q[i0:i1]
            qloc = _to_theta_phi(qb)
            nb = near[: i1 - i0]
            _kernels.near_field_correction(qb, cells.h, cells.ngrid, cells.cell_start, cells.px,
                                           cells.py, cells.pz, sw, delta * delta, self._a,
                                           self._kind, ff.near_cheb, nb)
            for c in range(nc):
                far = ducc0.sht.synthesis_general(alm=alms[c], spin=0, lmax=lmax, loc=qloc,
                                                  epsilon=_SHT_EPSILON, nthreads=nthreads)
                np.add(far[0], nb[:, c], out=out[i0:i1, c])
        return out

    def __repr__(self) -> str:
        return (f"SobolevInterpolator(n={self.n}, channels={self.nchannels}, s={self.s:g}, "
                f"log_det={self.log_det:.6g})")

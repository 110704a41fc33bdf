r"""Quadrature weights: equal weights and the optimal sample weights (OSW).

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Sec. 7.1, after Marques et al.
(2018), "Optimal sample weights for hemispherical integral quadratures".

The squared worst-case error (Eq. 41) is the quadratic form
:math:`E^2(w) = w^T K w - 2 w^T z + E_0^2` with :math:`K_{ij} = K^{(s)}_{gd}(u_i, u_j)`
(Eq. 14, positive definite for distinct points) and z the kernel mean embedding of the
weight function (:func:`envfit.theory._quadrature.kernel_mean_embedding`). Its minimiser over w is

.. math:: w^\star = K^{-1} z, \qquad E^2(w^\star) = E_0^2 - z^T K^{-1} z,

and the gradient :math:`\nabla_w E^2 = 2(Kw - z)` vanishes there.
"""
from __future__ import annotations

import numpy as np

from envfit.theory._weight_function import WeightFunction
from envfit.theory._cholesky import cho_factor, cho_solve
from envfit.theory._errors import TheoryParameterError, check_smoothness
from envfit.theory._quadrature import kernel_mean_embedding
from envfit.theory._sh import check_points_weights
from envfit.theory._sobolev import kernel_constant

__all__ = ["equal_weights", "optimal_weights", "kernel_matrix", "WEIGHTINGS"]

#: the weightings of a quadrature rule (Sec. 7.1): "equal" (w_j = 1/N, :func:`equal_weights`)
#: and "osw" (optimal sample weights K^{-1} z, :func:`optimal_weights`)
WEIGHTINGS = ("equal", "osw")

#: refuse kernel matrices larger than this (bytes); N = 20 000 is 3.2 GB
MAX_MATRIX_BYTES = 4 * 2 ** 30


def equal_weights(n: int) -> np.ndarray:
    """Equal QMC weights 1/n (Sec. 7.1), for points importance-sampled from p (morphed).

    >>> equal_weights(4).tolist()
    [0.25, 0.25, 0.25, 0.25]
    """
    try:
        n_i = int(n)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"n must be a positive integer, got {n!r}") from None
    if n_i != n or n_i < 1:
        raise TheoryParameterError(f"n must be a positive integer, got {n!r}")
    return np.full(n_i, 1.0 / n_i)


def kernel_matrix(points, s: float, *, max_bytes: int = MAX_MATRIX_BYTES) -> np.ndarray:
    r"""Gram matrix :math:`K_{ij} = 2^{2s-1}/s - |u_i-u_j|^{2s-2}` (Eq. 14), Fortran order, float64.

    Built in place from one BLAS Gram product (:math:`|u-v|^2 = 2 - 2u\cdot v`, Eq. 10),
    with an exactly zero distance on the diagonal.
    """
    s = check_smoothness(s)
    pts = check_points_weights(points)
    n = pts.shape[0]
    if 8 * n * n > max_bytes:
        raise TheoryParameterError(
            f"the {n}×{n} kernel matrix needs {8 * n * n / 2**30:.1f} GiB > "
            f"max_bytes = {max_bytes / 2**30:.1f} GiB; use fewer points")
    K = np.empty((n, n), order="F")
    np.matmul(pts, pts.T, out=K)              # symmetric: C/F order are the same values
    K *= -2.0
    K += 2.0
    np.maximum(K, 0.0, out=K)
    K[np.arange(n), np.arange(n)] = 0.0
    if s == 1.5:
        np.sqrt(K, out=K)
    else:
        np.power(K, s - 1.0, out=K)
    np.subtract(kernel_constant(s), K, out=K)
    return K


def optimal_weights(points, brdf: WeightFunction, s: float, *,
                    max_bytes: int = MAX_MATRIX_BYTES) -> np.ndarray:
    r"""Optimal sample weights :math:`w = K^{-1}z` minimising the worst-case error (Eq. 41).

    float64 Cholesky (:func:`envfit.theory._cholesky.cho_factor`, in place: LAPACK on panels, safe
    from OpenBLAS's threaded-``dsyrk`` crash at large N). The condition number of K grows like :math:`N^{s}` (errata: ≈5e8 at
    s = 1.9, N = 20 000), so float32 is not safe; float64 leaves ≈1e-7 relative accuracy
    on w in the worst case, and the worst-case error is first-order insensitive to w
    errors at the optimum. Raises TheoryParameterError when K is not numerically positive
    definite (duplicate or nearly coincident points).

    >>> from envfit.theory._brdf import Diffuse
    >>> rng = np.random.default_rng(1)
    >>> u = rng.normal(size=(50, 3)); u[:, 2] = np.abs(u[:, 2])
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> w = optimal_weights(u, Diffuse(), 1.5)
    >>> bool(abs(w.sum() - 1) < 0.1)
    True
    """
    s = check_smoothness(s)
    pts = check_points_weights(points)
    z = kernel_mean_embedding(pts, brdf, s)
    K = kernel_matrix(pts, s, max_bytes=max_bytes)
    n = K.shape[0]
    k_diag = kernel_constant(s)
    msg = ("the kernel matrix is not numerically positive definite: the point set has "
           "duplicate or nearly coincident points")
    try:  # kernel_matrix is Fortran-ordered: factorised in place
        cf = cho_factor(K, overwrite_a=True)
    except np.linalg.LinAlgError:
        raise TheoryParameterError(msg) from None
    # a duplicate point can survive the factorisation with a rounding-level pivot
    piv = np.abs(np.diagonal(cf[0]))
    if piv.min() ** 2 <= 64.0 * n * np.finfo(float).eps * k_diag:
        raise TheoryParameterError(msg)
    return cho_solve(cf, z)

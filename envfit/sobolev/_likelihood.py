r"""The Gaussian-process log-likelihood with the scale profiled out, implemented once.

Model :math:`f_c \sim N(0, \sigma_c^2 K)` for each channel c of the samples (N × C),
with K any positive-definite kernel matrix (the paper's :math:`K^{(s)}_{gd}`,
:class:`envfit.sobolev._interpolation.SobolevInterpolator`, or the band-limited
:math:`K^{(s)}_L`, :func:`envfit.sobolev._bandlimited.bandlimited_log_likelihood`). The
maximising scale and the log-likelihood there are

.. math:: \hat\sigma_c^2 = \frac{f_c^T K^{-1} f_c}{N}, \qquad
          \ell_c = -\tfrac12\,\bigl(N\log\hat\sigma_c^2 + \log\det K + N(1 + \log 2\pi)\bigr).

Both need only the solve :math:`\alpha = K^{-1} f` and :math:`\log\det K`, which the
caller's factorisation provides; :func:`profiled_log_likelihood` turns them into
:class:`ProfiledLikelihood`. A channel with :math:`f_c^T K^{-1} f_c = 0` (a constant
channel after centring) has :math:`\hat\sigma_c = 0` and :math:`\ell_c = +\infty`.

Example
-------
>>> import numpy as np
>>> K = np.array([[2.0, 0.5], [0.5, 1.0]]); f = np.array([1.0, -1.0])
>>> r = profiled_log_likelihood(f, np.linalg.solve(K, f), float(np.linalg.slogdet(K)[1]))
>>> from scipy.stats import multivariate_normal
>>> bool(np.isclose(r.loglik, multivariate_normal(cov=r.sigma ** 2 * K).logpdf(f)))
True
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["ProfiledLikelihood", "profiled_log_likelihood"]

_LOG_2PI = math.log(2.0 * math.pi)


class ProfiledLikelihood(NamedTuple):
    """Gaussian-process log-likelihood with the scale profiled out, per channel."""
    loglik: np.ndarray | float
    #: :math:`\hat\sigma = (f^T K^{-1} f / N)^{1/2}`
    sigma: np.ndarray | float


def profiled_log_likelihood(values, alpha, log_det: float) -> ProfiledLikelihood:
    r""":math:`(\ell_c, \hat\sigma_c)` per channel from the samples, their solve and
    :math:`\log\det K` (module docstring).

    Parameters
    ----------
    values : (N,) or (N, C) array
        The samples f, used as given (centre them first: the model is zero-mean).
    alpha : array of the shape of ``values``
        :math:`K^{-1} f`.
    log_det : float
        :math:`\log\det K`.

    Returns
    -------
    ProfiledLikelihood
        ``(loglik, sigma)``: arrays of shape (C,), or floats for 1-D ``values``.
    """
    vals = np.asarray(values, dtype=np.float64)
    vector = vals.ndim == 1
    vals = vals.reshape(len(vals), -1)
    alpha = np.asarray(alpha, dtype=np.float64).reshape(vals.shape)
    n = vals.shape[0]
    # fᵀK⁻¹f ≥ 0 for a positive-definite K; a rounding-negative value is a zero
    sigma2 = np.maximum(np.einsum("ij,ij->j", vals, alpha) / n, 0.0)
    with np.errstate(divide="ignore"):
        ll = -0.5 * (n * np.log(sigma2) + float(log_det) + n * (1.0 + _LOG_2PI))
    sigma = np.sqrt(sigma2)
    if vector:
        return ProfiledLikelihood(float(ll[0]), float(sigma[0]))
    return ProfiledLikelihood(ll, sigma)

r"""Image error metrics between a reference map and a reconstruction (same shape).

Compare on an explicit value scale (:mod:`envfit.maps._scales`): the paper's Table 2 RMSE is on a
display-referred [0, 1] image. Arrays are ``H x W x C`` (or ``H x W``); all functions
return Python floats computed in float64.

Example
-------
>>> import numpy as np
>>> a = np.zeros((2, 4, 3)); b = np.full((2, 4, 3), 0.1)
>>> round(rmse(a, b), 12), round(psnr(a, b, data_range=1.0), 6)
(0.1, 20.0)
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

__all__ = ["rmse", "rmse_solid_angle", "psnr", "ssim"]


def _pair(a, b) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ParameterError(f"images must have the same shape; got {a.shape} and {b.shape}")
    if a.size == 0:
        raise ParameterError("images are empty")
    return a, b


def rmse(a, b) -> float:
    r"""Root mean squared error over all pixels and channels (the paper's Table 2 RMSE):

    .. math::  \mathrm{RMSE} = \Big(\frac{1}{N C}\sum_{p=1}^{N}\sum_{c=1}^{C}
               (a_{pc} - b_{pc})^2\Big)^{1/2}.

    Every pixel counts equally (as in an image comparison), regardless of its solid angle.

    >>> bool(rmse(np.array([0.0, 0.0]), np.array([3.0, 4.0])) == np.sqrt(12.5))
    True
    """
    a, b = _pair(a, b)
    return float(np.sqrt(np.mean((a - b) ** 2)))


def rmse_solid_angle(a, b, solid_angles) -> float:
    r"""Solid-angle weighted RMSE, the discrete :math:`L^2(S^2)` error normalised by 4π:

    .. math::  \Big(\frac{\sum_{ij} \Omega_{ij} \frac1C\sum_c (a_{ijc}-b_{ijc})^2}
               {\sum_{ij}\Omega_{ij}}\Big)^{1/2},

    ``solid_angles`` of shape ``(H, W)`` (e.g. :meth:`EnvMap.solid_angles`).

    >>> from envfit.maps._latlong import pixel_solid_angles
    >>> a = np.zeros((2, 4, 1)); b = np.ones((2, 4, 1))
    >>> round(rmse_solid_angle(a, b, pixel_solid_angles(2)), 12)
    1.0
    """
    a, b = _pair(a, b)
    w = np.asarray(solid_angles, dtype=np.float64)
    if a.ndim == 2:
        a, b = a[..., None], b[..., None]
    if w.shape != a.shape[:2]:
        raise ParameterError(f"solid_angles must have shape {a.shape[:2]}, got {w.shape}")
    sq = np.mean((a - b) ** 2, axis=-1)
    return float(np.sqrt(np.sum(w * sq) / np.sum(w)))


def psnr(a, b, data_range: float) -> float:
    r"""Peak signal-to-noise ratio in dB (``skimage.metrics.peak_signal_noise_ratio``):

    .. math::  \mathrm{PSNR} = 10 \log_{10}\frac{R^2}{\mathrm{RMSE}(a, b)^2},

    ``R = data_range`` (1 for display-referred images); ``a`` is the reference. Identical
    images give ``inf``.

    >>> round(psnr(np.zeros((2, 4)), np.full((2, 4), 0.01), data_range=1.0), 9)
    40.0
    """
    from skimage.metrics import peak_signal_noise_ratio

    a, b = _pair(a, b)
    if not (np.isfinite(data_range) and data_range > 0):
        raise ParameterError(f"data_range must be positive, got {data_range!r}")
    if np.array_equal(a, b):
        return float("inf")
    return float(peak_signal_noise_ratio(a, b, data_range=float(data_range)))


def ssim(a, b, data_range: float) -> float:
    r"""Mean structural similarity (``skimage.metrics.structural_similarity``, channel_axis=-1):

    .. math::  \mathrm{SSIM}(x, y) = \frac{(2\mu_x\mu_y + C_1)(2\sigma_{xy} + C_2)}
               {(\mu_x^2+\mu_y^2+C_1)(\sigma_x^2+\sigma_y^2+C_2)},\quad
               C_1 = (0.01R)^2,\ C_2 = (0.03R)^2,

    with local statistics over 7x7 windows (skimage defaults), averaged over the image and
    the channels; ``R = data_range``. 1 for identical images. Images need H, W ≥ 7.

    >>> x = np.random.default_rng(0).random((8, 16, 3))
    >>> ssim(x, x, data_range=1.0)
    1.0
    """
    from skimage.metrics import structural_similarity

    a, b = _pair(a, b)
    if not (np.isfinite(data_range) and data_range > 0):
        raise ParameterError(f"data_range must be positive, got {data_range!r}")
    if a.ndim == 2:
        a, b = a[..., None], b[..., None]
    if min(a.shape[:2]) < 7:
        raise ParameterError(f"SSIM needs images of at least 7x7 pixels, got {a.shape[:2]}")
    return float(structural_similarity(a, b, data_range=float(data_range), channel_axis=-1))

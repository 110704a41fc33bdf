r"""The importance sample of axes behind a warped spectrum's mean over uniform axes.

``count`` axes are drawn systematically from the :data:`AXIS_POOL` spherical Fibonacci axes
(in a serpentine order, so that systematic sampling stratifies the sphere) with probability

.. math:: \pi_a = \tfrac13\,\tfrac1P + \tfrac13\,\frac{m_a}{\sum m}
                  + \tfrac13\,\frac{m'_a}{\sum m'},

m and m′ proxies of BRDF and map sampling's second moments of the luminance at axis a (an
8×8-pixel-block quadrature, :func:`envfit.sampling.proxy_second_moments`), each weighted by
:math:`1/(P\,\pi_a\,\mathrm{count})`: unbiased for the pool mean, and the few axes whose lobe
holds a sun are not missed. The proxies depend on the map, sampler and lobe only; a
:class:`._spectrum_inputs.SpectrumInputs` computes them once for all techniques.

Reference: Marques, Bouville, Bouatouch, Sec. 7 (spherical Fibonacci points).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.maps import EnvMap
from envfit.sampling import MapSampler, proxy_second_moments
from envfit.sampling import normalised_moments
from envfit.theory import spherical_fibonacci_sphere

__all__ = ["AXIS_POOL", "proposal_axes"]

#: spherical Fibonacci axes the importance sample of axes is drawn from
AXIS_POOL = 2048


def _fibonacci_axes(m: int) -> np.ndarray:
    """The m spherical Fibonacci axes of :func:`envfit.theory.spherical_fibonacci_sphere`
    in a *serpentine* order: √(m/2) bands of z, φ ascending in even bands and descending in
    odd ones, so that neighbours in the order are neighbours on the sphere and systematic
    sampling along it stratifies the sphere."""
    pts = spherical_fibonacci_sphere(m)
    phi = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2.0 * np.pi)
    bands = max(1, round(math.sqrt(m / 2.0)))
    band = np.minimum((0.5 * (1.0 - pts[:, 2]) * bands).astype(int), bands - 1)
    return pts[np.lexsort((np.where(band % 2 == 0, phi, -phi), band))]


def _pool_moments(envmap: EnvMap, sampler: MapSampler, weight):
    """The proxies (m, m′) of :func:`envfit.sampling.proxy_second_moments` at the pool."""
    return proxy_second_moments(envmap, sampler, weight, _fibonacci_axes(AXIS_POOL))


def _systematic(moments, count: int):
    """(axes (count, 3), weights (count,)) drawn from the pool with the proxies ``moments``
    (module docstring)."""
    pool = _fibonacci_axes(AXIS_POOL)
    pi = (np.full(AXIS_POOL, 1.0 / AXIS_POOL) + sum(normalised_moments(moments))) / 3.0
    cdf = np.cumsum(pi)
    cdf /= cdf[-1]
    idx = np.minimum(np.searchsorted(cdf, (np.arange(count) + 0.5) / count), AXIS_POOL - 1)
    wts = 1.0 / (AXIS_POOL * pi[idx] * count)
    return pool[idx], wts / wts.sum()


def proposal_axes(envmap: EnvMap, sampler: MapSampler, weight, count: int):
    r"""``count`` axes and their weights for the mean over uniform axes (weights sum to 1).

    Systematic sampling of the :data:`AXIS_POOL` spherical Fibonacci axes with probability
    :math:`\pi_a = \frac13\frac1P + \frac13\frac{m_a}{\sum m} + \frac13\frac{m'_a}{\sum m'}`
    (m, m′ the BRDF- and map-sampling second moments of the luminance, block quadrature);
    weight :math:`1/(P\pi_a\,\mathrm{count})`. Unbiased for the pool mean; the weights are at
    most 3/count.

    >>> from envfit.maps import EnvMap
    >>> m = EnvMap(np.ones((8, 16, 1)))
    >>> from envfit.shading import weight_function
    >>> A, wts = proposal_axes(m, MapSampler(m), weight_function("diffuse", 30.0), 16)
    >>> A.shape, round(float(wts.sum()), 9)
    ((16, 3), 1.0)
    """
    return _systematic(_pool_moments(envmap, sampler, weight), count)

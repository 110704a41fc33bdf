r"""Importance sampling of a lat-long map (:class:`MapSampler`): pdf ∝ luminance × solid angle.

A piecewise-constant 2-D distribution over the pixels, pdf per solid angle constant inside
each pixel, sampled by the marginal (rows) / conditional (columns) inverse CDF and uniformly
in :math:`(\cos\theta, \phi)` inside the pixel; the image infinite light of pbrt-v4 (Pharr,
Jakob, Humphreys, *Physically Based Rendering*, 4th ed., §12.5 "Image Infinite Lights", with
``PiecewiseConstant2D``, §A.5) and Mitsuba 3's ``envmap`` emitter
(``src/emitters/envmap.cpp``: luminance × sin θ warp), on envfit's lat-long geometry (exact
pixel solid angles). The luminance is smoothed as the bilinear interpolant sees it and
floored at :data:`DEFAULT_FLOOR` of its mean (a defensive mixture). The estimators that use
it are in :mod:`envfit.sampling._importance`.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> s = MapSampler(EnvMap(np.full((8, 16, 3), 0.5)))
>>> d, pdf = s.sample([[0.5, 0.5]])
>>> bool(np.allclose(pdf, 1 / (4 * np.pi))), bool(np.allclose(s.pdf(d), pdf))
(True, True)
"""
from __future__ import annotations

import numpy as np

from envfit.base import as_square_points
from envfit.base import ParameterError
from envfit.maps import local_to_world, row_solid_angles, rows_times
from envfit.maps import EnvMap
from envfit.sampling._sample_kernel import pixel_indices, warp_points

__all__ = ["MapSampler", "DEFAULT_FLOOR"]


#: default floor of :class:`MapSampler`, as a fraction of the solid-angle mean luminance
DEFAULT_FLOOR = 0.01


# ----------------------------------------------------------------------------- inputs

def square_samples(u, name: str = "u") -> np.ndarray:
    """Square points (..., 2) as a float64 (N, 2) array in [0, 1) (1 is moved just below 1)."""
    a = as_square_points(u, name=name)
    return np.minimum(a, np.nextafter(1.0, 0.0))


# ----------------------------------------------------------------------------- map sampler

def bilinear_cell_average(y: np.ndarray) -> np.ndarray:
    r"""Mean of the bilinear interpolant of y over each pixel cell (in pixel coordinates).

    On a cell :math:`[-\frac12, \frac12]^2` about a pixel centre the interpolant averages to
    :math:`(\frac18, \frac34, \frac18)^{\otimes 2}` times the 3×3 neighbourhood (separable),
    with columns wrapping and the virtual rows −1, H being rows 0, H−1 at φ + π.
    """
    h, w = y.shape
    up = np.vstack([np.roll(y[:1], w // 2, axis=1), y[:-1]])
    down = np.vstack([y[1:], np.roll(y[-1:], w // 2, axis=1)])
    r = 0.75 * y + 0.125 * (up + down)
    return 0.75 * r + 0.125 * (np.roll(r, 1, axis=1) + np.roll(r, -1, axis=1))


class MapSampler:
    r"""Importance sampling of a lat-long map: pdf ∝ luminance × pixel solid angle.

    Pixel (i, j) gets the probability

    .. math::  P_{ij} = \frac{(Y_{ij} + \epsilon\bar Y)\,\Omega_{ij}}
                            {\sum_{kl}(Y_{kl} + \epsilon\bar Y)\,\Omega_{kl}},
               \qquad \bar Y = \frac{1}{4\pi}\sum_{kl} Y_{kl}\Omega_{kl},

    and inside the pixel the density per solid angle is constant, :math:`P_{ij}/\Omega_{ij}`.
    :math:`Y` is the absolute Rec. 709 luminance of the pixel values
    (:meth:`envfit.maps._envmap.EnvMap.luminance`; channel 0 for 1–2 channels; absolute so that
    signed maps — a GP without offset — get the density :math:`\propto |f|`, the optimal one),
    with ``smooth=True`` (default) averaged over each cell as the *bilinear interpolant* sees
    it (:math:`(\frac18,\frac34,\frac18)^{\otimes2}` of the 3×3 neighbourhood, across the
    poles and the seam). Why smooth: the integrand is the bilinear interpolant, which
    spreads a bright pixel into the cells of its neighbours; with the raw pixel luminance (
    ``smooth=False``, what pbrt-v4's ``Image::GetSamplingDistribution`` and Mitsuba do) a dark
    pixel next to the sun holds up to half the sun's radiance at the floor density — a rare,
    huge weight f/p.

    Floor ``floor`` = ε (default :data:`DEFAULT_FLOOR` = 0.01 of the mean :math:`\bar Y`):
    adding :math:`\epsilon\bar Y` to every pixel makes the distribution the *defensive
    mixture* (Hesterberg 1995) :math:`(1-\beta)\,p_Y + \beta/(4\pi)`,
    :math:`\beta = \epsilon/(1+\epsilon)` ≈ 1 % uniform: every direction stays samplable, so
    the estimator is unbiased even where the luminance is zero but the integrand is not
    (another channel, a neighbour's interpolated value), and the weight :math:`f\rho/p` is
    bounded by :math:`4\pi(1+\epsilon)/\epsilon \cdot \max f\rho`; it costs at most 1 % of the
    samples. ``floor=0`` is the pure luminance distribution (a zero pixel is never sampled). A
    map with zero luminance everywhere gets the uniform distribution.

    Sampling (:meth:`sample`): :math:`u_0` picks the row by the inverse of the marginal CDF
    :math:`\sum_{k<i}\sum_l P_{kl}` and, rescaled to [0, 1) inside the row's interval, sets
    :math:`\cos\theta` linearly between the row's edges; :math:`u_1` picks the column by the
    row's conditional CDF and, rescaled, sets φ linearly inside the column. Each step is a
    measure-preserving piecewise-linear map, so the stratification of a QMC set carries over
    (pbrt-v4 ``PiecewiseConstant2D::Sample``), and on a constant map (with ``smooth`` or not)
    it is exactly the Lambert equal-area lift :math:`\cos\theta = 1 - 2u_0`, :math:`\phi = 2\pi u_1`.

    Attributes
    ----------
    probabilities : (H, W) the :math:`P_{ij}` (sum 1)
    pixel_pdf : (H, W) density per solid angle in each pixel, :math:`P_{ij}/\Omega_{ij}`

    >>> from envfit.maps._envmap import EnvMap
    >>> s = MapSampler(EnvMap(np.ones((4, 8)), up="z"))
    >>> d, pdf = s.sample([[0.25, 0.5]])
    >>> d.round(12).tolist(), bool(np.isclose(pdf[0], 1 / (4 * np.pi)))   # cos θ = 1 − 2·0.25
    ([[-0.866025403784, 0.0, 0.5]], True)
    """

    def __init__(self, envmap: EnvMap, *, floor: float = DEFAULT_FLOOR, smooth: bool = True):
        try:
            eps = float(floor)
        except (TypeError, ValueError):
            raise ParameterError(f"floor must be a number >= 0, got {floor!r}") from None
        if not (np.isfinite(eps) and eps >= 0.0):
            raise ParameterError(f"floor must be a finite number >= 0, got {floor!r}")
        y = np.abs(envmap.luminance())
        if not np.all(np.isfinite(y)):
            raise ParameterError("the map's luminance is not finite; cannot build a sampling pdf")
        h, w = y.shape
        if smooth:
            y = bilinear_cell_average(y)
        om = row_solid_angles(h, w)                           # (H,)
        mean = float(om @ y.sum(axis=1)) / (4.0 * np.pi)
        dens = y + eps * mean if mean > 0.0 else np.ones_like(y)
        mass = dens * om[:, None]
        total = float(mass.sum())
        if not (total > 0.0 and np.isfinite(total)):
            raise ParameterError("the map's luminance gives no sampling distribution")
        self.up = envmap.up
        self.height, self.width = h, w
        self.floor, self.smooth = eps, bool(smooth)
        self.probabilities = mass / total
        self.pixel_pdf = self.probabilities / om[:, None]
        self._z_edges = np.cos(np.pi * np.arange(h + 1) / h)          # top edge of row i = [i]
        self._z_edges[-1] = -1.0
        rows = self.probabilities.sum(axis=1)
        self._row_mass = rows
        cdf = np.concatenate([[0.0], np.cumsum(rows)])
        self._row_cdf = cdf / cdf[-1]
        cc = np.cumsum(self.probabilities, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cc = np.where(rows[:, None] > 0, cc / rows[:, None], (np.arange(w) + 1.0) / w)
        cc[:, -1] = 1.0
        self._col_cdf = np.hstack([np.zeros((h, 1)), cc])             # (H, W+1)
        # rows stacked with offsets i: one monotone table for the conditional search
        self._col_flat = (self._col_cdf + np.arange(h)[:, None]).ravel()
        self._m = local_to_world(envmap.up)

    def sample(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Directions (N, 3) in the world frame of the map's ``up`` and their pdf per solid
        angle (N,), from square points u (N, 2) in [0, 1)² (u₀ → rows/θ, u₁ → columns/φ).

        >>> from envfit.maps._envmap import EnvMap
        >>> s = MapSampler(EnvMap(np.ones((4, 8, 3))))
        >>> d, p = s.sample(np.random.default_rng(0).random((5, 2)))
        >>> d.shape, bool(np.allclose(s.pdf(d), p))
        ((5, 3), True)
        """
        U = square_samples(u)
        return warp_points(U, self._row_cdf, self._col_cdf, self._z_edges, self.pixel_pdf,
                           self._m)

    def pixel_point(self, i, j, t, s) -> np.ndarray:
        """World directions (N, 3) at fractions (t, s) ∈ [0, 1]² of pixels (i, j): cos θ
        linear between the row's edges, φ linear across the column (the sampler's warp)."""
        zt, zb = self._z_edges[i], self._z_edges[i + 1]
        z = zt - t * (zt - zb)
        phi = 2.0 * np.pi * (j + s) / self.width
        r = np.sqrt(np.maximum((1.0 - z) * (1.0 + z), 0.0))
        local = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
        return rows_times(local, self._m.T)

    def pixel_of(self, dirs) -> tuple[np.ndarray, np.ndarray]:
        """Pixel (row, column) indices of world directions (..., 3) (any nonzero length)."""
        d = np.asarray(dirs, dtype=np.float64)
        if d.ndim < 1 or d.shape[-1] != 3:
            raise ParameterError(f"directions must have shape (..., 3), got {d.shape}")
        i, j = pixel_indices(d.reshape(-1, 3), self._m, self.height, self.width)
        return i.reshape(d.shape[:-1]), j.reshape(d.shape[:-1])

    def pdf(self, dirs) -> np.ndarray:
        r"""Density per solid angle at world directions (..., 3): :math:`P_{ij}/\Omega_{ij}` of
        the pixel that contains each direction.

        >>> from envfit.maps._envmap import EnvMap
        >>> s = MapSampler(EnvMap(np.ones((4, 8))))
        >>> bool(np.allclose(s.pdf([[0, 1.0, 0], [1.0, 0, 0]]), 1 / (4 * np.pi)))
        True
        """
        i, j = self.pixel_of(dirs)
        return self.pixel_pdf[i, j]

r"""The estimators renderers use for the shading integral: map importance sampling, BRDF
(lobe) sampling and Veach's multiple importance sampling of the two.

All of them estimate the same integral as :func:`envfit.shading.ground_truth.shading_integral`
(Eq. 17 of Marques, Bouville, Bouatouch), with the same integrand — the map's bilinear
interpolant :math:`f` = :meth:`envfit.maps.envmap.EnvMap.lookup` times the normalised zonal
lobe about the axis :math:`a`,

.. math::  I(a) = \int_{S^2} f(\omega)\,\rho_a(\omega)\,d\omega, \qquad
           \rho_a(\omega) = \frac{p(\omega\cdot a)}{2\pi r_s}, \qquad
           r_s = \int_0^1 p(z)\,dz,

with :math:`p` = :func:`envfit.shading.ground_truth.weight_function` (diffuse :math:`p = z`,
glossy :math:`p = e^{n(z-1)}`), zero on the lower hemisphere of :math:`a`, so
:math:`\int\rho_a = 1`.

Techniques (each maps square points :math:`u\in[0,1)^2` of *any* point set — random,
jitter, Sobol, LP, BNOT, the square lattice of spherical Fibonacci, see
:func:`envfit.theory.pointsets.square_points` — to directions with a known pdf per solid
angle, so quasi-Monte Carlo and importance sampling combine):

* **map** — :class:`MapSampler`: a piecewise-constant 2-D distribution over the pixels,
  pdf per solid angle constant inside each pixel, sampled by the marginal (rows) /
  conditional (columns) inverse CDF and uniformly in :math:`(\cos\theta, \phi)` inside the
  pixel; the image infinite light of pbrt-v4 (Pharr, Jakob, Humphreys, *Physically Based
  Rendering*, 4th ed., §12.5 "Image Infinite Lights", with ``PiecewiseConstant2D``, §A.5)
  and Mitsuba 3's ``envmap`` emitter (``src/emitters/envmap.cpp``: luminance × sin θ
  warp), on envfit's lat-long geometry (exact pixel solid angles).
* **brdf** — the lobe's own sampler, the morph of :mod:`envfit.theory.pointsets`
  (Lambert lift :math:`z'=u_0, \phi = 2\pi u_1`, then :math:`z = F^{-1}(z')` =
  ``weight.morph``: diffuse :math:`z=\sqrt{z'}`, glossy Eq. 67), whose pdf per solid angle is
  exactly :math:`q_a(\omega) = p(\omega\cdot a)/(2\pi r_s) = \rho_a(\omega)`
  (:func:`brdf_pdf`): the lobe is sampled perfectly, so :math:`\rho_a/q_a = 1` and the
  estimate is the mean of :math:`f` — :func:`envfit.shading.estimators.quadrature_estimates`
  with equal weights, written here with its pdf explicit for MIS.
* **mis** — Veach, *Robust Monte Carlo Methods for Light Transport Simulation* (PhD thesis,
  Stanford 1997), ch. 9: the multi-sample and one-sample models with the balance and power
  heuristics (:func:`mis_estimates`, :func:`mis_weights`).

:data:`ESTIMATORS` maps the names to the functions and :func:`importance_estimates`
dispatches on it (no string if-chains; :data:`HEURISTICS` and :data:`MODES` likewise).

Randomisation (``seed``): each axis m gets an independent uniform twist :math:`\alpha_m`
of its frame about the axis — the same draws as ``quadrature_estimates(..., seed=seed)``,
:func:`envfit.shading.estimators.twisted_frames` — and, with ``shift=True``, an independent
Cranley–Patterson rotation :math:`u \mapsto (u + s_m) \bmod 1`, :math:`s_m` uniform on
:math:`[0,1)^2` (Cranley & Patterson 1976), drawn next from the same generator. With a
shift, every estimator is unbiased for *any* point set (each shifted point is uniform on
the square); without one, a deterministic set gives a deterministic (QMC) estimate.

Example
-------
>>> import numpy as np
>>> from envfit.maps.envmap import EnvMap
>>> from envfit.theory.pointsets import square_points
>>> m = EnvMap(np.full((8, 16, 3), 0.5))
>>> u = square_points("sobol", 64)
>>> est = importance_estimates(m, [[0.0, 1.0, 0.0]], u, "brdf")     # constant map: exact
>>> est.round(12).tolist()
[[0.5, 0.5, 0.5]]
>>> sorted(ESTIMATORS)
['brdf', 'map', 'mis']
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from envfit.base.checks import as_unit_vectors
from envfit.base.errors import ParameterError
from envfit.base.resources import check_memory
from envfit.maps import latlong
from envfit.maps.envmap import EnvMap
from envfit.shading.estimators import LOOKUP_BLOCK, twisted_frames
from envfit.shading.ground_truth import weight_function
from envfit.theory.brdf import WeightFunction
from envfit.theory.pointsets import lambert_to_hemisphere

__all__ = ["MapSampler", "DEFAULT_FLOOR", "brdf_pdf", "map_is_estimates",
           "brdf_sampling_estimates", "mis_estimates", "mis_weights", "importance_estimates",
           "ESTIMATORS", "HEURISTICS", "MODES"]

#: default floor of :class:`MapSampler`, as a fraction of the solid-angle mean luminance
DEFAULT_FLOOR = 0.01


# ----------------------------------------------------------------------------- inputs

def _square(u, name: str = "u") -> np.ndarray:
    """Square points (..., 2) as a float64 (N, 2) array in [0, 1) (1 is moved just below 1)."""
    try:
        a = np.asarray(u, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array of points in [0, 1)^2") from None
    if a.ndim < 1 or a.shape[-1] != 2:
        raise ParameterError(f"{name} must have shape (..., 2), got {a.shape}")
    a = a.reshape(-1, 2)
    if not np.all(np.isfinite(a)) or a.size and (a.min() < 0.0 or a.max() > 1.0):
        raise ParameterError(f"{name} must be finite points in [0, 1]^2")
    return np.minimum(a, np.nextafter(1.0, 0.0))


def _randomisation(A: np.ndarray, seed, shift: bool) -> tuple[np.ndarray, np.ndarray]:
    """Frames (M, 3, 3) (twisted with ``seed``, as quadrature_estimates) and CP shifts (M, 2)."""
    R = twisted_frames(A, seed)
    s = np.zeros((A.shape[0], 2))
    if seed is not None and shift:
        rng = np.random.default_rng(seed)
        rng.uniform(0.0, 2.0 * np.pi, A.shape[0])        # the twists, drawn first
        s = rng.random((A.shape[0], 2))
    return R, s


def _blocks(m_total: int, n: int, c: int, what: str):
    """Axis blocks (m0, m1) with about LOOKUP_BLOCK directions each, memory checked once."""
    mb = max(1, LOOKUP_BLOCK // max(n, 1))
    check_memory(min(m_total, mb) * max(n, 1) * 8 * (20 + 3 * c),
                 f"{what}: a block of {min(m_total, mb)} axes x {n} samples",
                 hint="use fewer samples")
    return [(m0, min(m_total, m0 + mb)) for m0 in range(0, m_total, mb)]


def _shifted(U: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(mb, N, 2): the points shifted by each axis's s (mod 1), kept in [0, 1)."""
    out = U[None, :, :] + s[:, None, :]
    out -= np.floor(out)
    return np.minimum(out, np.nextafter(1.0, 0.0))


# ----------------------------------------------------------------------------- map sampler

def _bilinear_cell_average(y: np.ndarray) -> np.ndarray:
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
    (:meth:`envfit.maps.envmap.EnvMap.luminance`; channel 0 for 1–2 channels; absolute so that
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

    >>> from envfit.maps.envmap import EnvMap
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
            y = _bilinear_cell_average(y)
        om = latlong.row_solid_angles(h, w)                           # (H,)
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
        self._m = latlong.local_to_world(envmap.up)

    def sample(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Directions (N, 3) in the world frame of the map's ``up`` and their pdf per solid
        angle (N,), from square points u (N, 2) in [0, 1)² (u₀ → rows/θ, u₁ → columns/φ).

        >>> from envfit.maps.envmap import EnvMap
        >>> s = MapSampler(EnvMap(np.ones((4, 8, 3))))
        >>> d, p = s.sample(np.random.default_rng(0).random((5, 2)))
        >>> d.shape, bool(np.allclose(s.pdf(d), p))
        ((5, 3), True)
        """
        U = _square(u)
        h, w = self.height, self.width
        i = np.clip(np.searchsorted(self._row_cdf, U[:, 0], side="right") - 1, 0, h - 1)
        lo = self._row_cdf[i]
        t = np.clip((U[:, 0] - lo) / np.maximum(self._row_cdf[i + 1] - lo, 1e-300), 0.0, 1.0)
        k = np.searchsorted(self._col_flat, U[:, 1] + i, side="right") - 1
        j = np.clip(k - i * (w + 1), 0, w - 1)
        c0 = self._col_cdf[i, j]
        s = np.clip((U[:, 1] - c0) / np.maximum(self._col_cdf[i, j + 1] - c0, 1e-300), 0.0, 1.0)
        zt, zb = self._z_edges[i], self._z_edges[i + 1]
        z = zt - t * (zt - zb)
        phi = 2.0 * np.pi * (j + s) / w
        r = np.sqrt(np.maximum((1.0 - z) * (1.0 + z), 0.0))
        local = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
        return local @ self._m.T, self.pixel_pdf[i, j]

    def pixel_of(self, dirs) -> tuple[np.ndarray, np.ndarray]:
        """Pixel (row, column) indices of world directions (..., 3) (any nonzero length)."""
        d = np.asarray(dirs, dtype=np.float64)
        if d.ndim < 1 or d.shape[-1] != 3:
            raise ParameterError(f"directions must have shape (..., 3), got {d.shape}")
        loc = d @ self._m                                               # rows: local = world M
        theta = np.arctan2(np.hypot(loc[..., 0], loc[..., 1]), loc[..., 2])
        phi = np.mod(np.arctan2(loc[..., 1], loc[..., 0]), 2.0 * np.pi)
        i = np.clip(np.floor(theta * (self.height / np.pi)).astype(np.int64), 0, self.height - 1)
        j = np.floor(phi * (self.width / (2.0 * np.pi))).astype(np.int64) % self.width
        return i, j

    def pdf(self, dirs) -> np.ndarray:
        r"""Density per solid angle at world directions (..., 3): :math:`P_{ij}/\Omega_{ij}` of
        the pixel that contains each direction.

        >>> from envfit.maps.envmap import EnvMap
        >>> s = MapSampler(EnvMap(np.ones((4, 8))))
        >>> bool(np.allclose(s.pdf([[0, 1.0, 0], [1.0, 0, 0]]), 1 / (4 * np.pi)))
        True
        """
        i, j = self.pixel_of(dirs)
        return self.pixel_pdf[i, j]


# ----------------------------------------------------------------------------- the lobe

def brdf_pdf(weight: WeightFunction, cos) -> np.ndarray:
    r"""Pdf per solid angle of the lobe sampler (the morph), :math:`q(z) = p(z)/(2\pi r_s)`.

    It is also the normalised lobe :math:`\rho_a` of the integrand: with the Lambert lift
    (uniform :math:`z'`, φ) and :math:`z = F^{-1}(z')`, :math:`F(z) = \int_0^z p/r_s`, the
    density in z is :math:`p(z)/r_s` and per solid angle (:math:`d\omega = dz\,d\phi`)
    :math:`p(z)/(2\pi r_s)`; zero for z < 0. Diffuse: z/π; glossy:
    :math:`n e^{n(z-1)}/(2\pi(1-e^{-n}))`.

    >>> from envfit.theory.brdf import Diffuse
    >>> bool(np.isclose(brdf_pdf(Diffuse(), 0.5), 0.5 / np.pi)), float(brdf_pdf(Diffuse(), -0.1))
    (True, 0.0)
    """
    return np.asarray(weight.p(cos), dtype=np.float64) / (2.0 * np.pi * float(weight.r_s))


# ----------------------------------------------------------------------------- techniques

def _map_technique(envmap, sampler, weight, A, U):
    """Map samples for axes A (K, 3), one point each (K, 2): f (K, C), p_map (K,), ρ = q (K,)."""
    d, pm = sampler.sample(U)
    rho = brdf_pdf(weight, np.einsum("ki,ki->k", d, A))
    return envmap.lookup(d), pm, rho


def _brdf_technique(envmap, sampler, weight, R, U):
    """Lobe samples for frames R (K, 3, 3), one point each: f (K, C), p_map (K,) or None, ρ = q."""
    local = lambert_to_hemisphere(U, morph=weight.morph)
    d = np.einsum("kij,kj->ki", R, local)
    rho = brdf_pdf(weight, local[:, 2])
    pm = None if sampler is None else sampler.pdf(d)
    return envmap.lookup(d), pm, rho


def _setup(envmap, axes, brdf, shininess, seed, shift):
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    weight = weight_function(brdf, shininess)
    A = as_unit_vectors(axes, name="axes", allow_empty=True)
    R, s = _randomisation(A, seed, shift)
    return weight, A, R, s


def map_is_estimates(envmap: EnvMap, axes, u, sampler: MapSampler | None = None,
                     brdf="diffuse", shininess: float = 30.0, *, seed=None,
                     shift: bool = True) -> np.ndarray:
    r"""Map importance-sampling estimates :math:`\frac1N\sum_j f(\omega_j)\rho_a(\omega_j)/p(\omega_j)`, (M, C).

    :math:`\omega_j` = ``sampler.sample(u)`` (:class:`MapSampler`, built from the map with its
    defaults when None), p its pdf per solid angle, :math:`\rho_a` the normalised lobe
    (:func:`brdf_pdf`), 0 below the horizon of a — samples there are wasted, which is why
    this technique alone is poor for a glossy lobe and good for a small bright source.

    Parameters
    ----------
    envmap : the map; f = ``envmap.lookup``.
    axes : (M, 3) or (3,) world axes (normalised internally).
    u : (N, 2) square points in [0, 1)² of any point set.
    sampler : a :class:`MapSampler` of this map (reuse it across calls: it costs O(HW)).
    brdf, shininess : the lobe, as :func:`envfit.shading.ground_truth.weight_function`.
    seed, shift : None — the same N directions for every axis (computed once); otherwise an
        independent Cranley–Patterson shift of u per axis (module docstring), which makes
        the estimate unbiased for deterministic sets too.

    Work: N lookups (M·N with a shift), in blocks of
    :data:`envfit.shading.estimators.LOOKUP_BLOCK` directions, memory checked.

    >>> from envfit.maps.envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> u = np.random.default_rng(1).random((256, 2))
    >>> float(map_is_estimates(m, [0, 1.0, 0], u, MapSampler(m, floor=0))[0, 0]) > 0
    True
    """
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U = _square(u)
    sampler = MapSampler(envmap) if sampler is None else sampler
    n, c = U.shape[0], envmap.channels
    out = np.empty((A.shape[0], c))
    if not (seed is not None and shift):
        d, pm = sampler.sample(U)
        f = envmap.lookup(d)                                            # (N, C)
        for m0, m1 in _blocks(A.shape[0], n, c, "map importance sampling"):
            rho = brdf_pdf(weight, A[m0:m1] @ d.T)                       # (mb, N)
            out[m0:m1] = (rho / pm) @ f / n
        return out
    for m0, m1 in _blocks(A.shape[0], n, c, "map importance sampling"):
        mb = m1 - m0
        Ub = _shifted(U, s[m0:m1]).reshape(-1, 2)
        f, pm, rho = _map_technique(envmap, sampler, weight, np.repeat(A[m0:m1], n, axis=0), Ub)
        out[m0:m1] = np.einsum("mn,mnc->mc", (rho / pm).reshape(mb, n), f.reshape(mb, n, c)) / n
    return out


def brdf_sampling_estimates(envmap: EnvMap, axes, u, sampler=None, brdf="diffuse",
                            shininess: float = 30.0, *, seed=None,
                            shift: bool = True) -> np.ndarray:
    r"""BRDF (lobe) importance-sampling estimates :math:`\frac1N\sum_j f(\omega_j)\rho_a(\omega_j)/q_a(\omega_j)`, (M, C).

    :math:`\omega_j = R_a\,\ell(u_j)`: the Lambert lift of u morphed for the lobe
    (``weight.morph``, diffuse :math:`z=\sqrt{z'}`, glossy Eq. 67), rotated by the axis's frame
    (:func:`envfit.shading.estimators.twisted_frames`); :math:`q_a` = :func:`brdf_pdf` is its
    pdf. Since :math:`q_a = \rho_a` the ratio is 1 (taken as 1 also at the one point where both
    vanish, z = 0 of the diffuse lobe, e.g. LP's (0, 0)), so this equals
    :func:`envfit.shading.estimators.quadrature_estimates` with the morphed points and equal
    weights 1/N — for ``seed=None``, or any seed with ``shift=False`` (same twists). With a
    seed and ``shift=True`` the points are also Cranley–Patterson shifted per axis.
    ``sampler`` is accepted for a uniform signature and unused.

    >>> from envfit.maps.envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> brdf_sampling_estimates(m, [0, 1.0, 0], [[0.3, 0.7]], brdf="glossy").round(12).tolist()
    [[2.0]]
    """
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U = _square(u)
    n, c = U.shape[0], envmap.channels
    out = np.empty((A.shape[0], c))
    for m0, m1 in _blocks(A.shape[0], n, c, "BRDF sampling"):
        mb = m1 - m0
        Ub = _shifted(U, s[m0:m1]).reshape(-1, 2)
        f, _, rho = _brdf_technique(envmap, None, weight, np.repeat(R[m0:m1], n, axis=0), Ub)
        ratio = np.divide(rho, rho, out=np.ones_like(rho), where=rho > 0)   # ρ/q, q = ρ
        out[m0:m1] = np.einsum("mn,mnc->mc", ratio.reshape(mb, n), f.reshape(mb, n, c)) / n
    return out


# ----------------------------------------------------------------------------- MIS

def _balance_weights(q: np.ndarray) -> np.ndarray:
    s = q.sum(axis=0)
    return np.divide(q, s, out=np.zeros_like(q), where=s > 0)


def _balance_over_q(q: np.ndarray, i: int) -> np.ndarray:
    s = q.sum(axis=0)
    return np.divide(1.0, s, out=np.zeros_like(s), where=s > 0)


def _power_weights(q: np.ndarray) -> np.ndarray:
    q2 = q * q
    s = q2.sum(axis=0)
    return np.divide(q2, s, out=np.zeros_like(q), where=s > 0)


def _power_over_q(q: np.ndarray, i: int) -> np.ndarray:
    s = (q * q).sum(axis=0)
    return np.divide(q[i], s, out=np.zeros_like(s), where=s > 0)


class Heuristic(NamedTuple):
    """A MIS heuristic: ``weights(q)`` → w (K, …) and ``over_q(q, i)`` → :math:`w_i/q_i`,
    for :math:`q_k = \\nu_k p_k` (K, …) (the second avoids 0/0 where :math:`q_i = 0`)."""

    weights: Callable[[np.ndarray], np.ndarray]
    over_q: Callable[[np.ndarray, int], np.ndarray]


#: Veach 1997 §9.2: balance :math:`w_i = q_i/\sum_k q_k`, power (β = 2) :math:`q_i^2/\sum_k q_k^2`
HEURISTICS: dict[str, Heuristic] = {
    "balance": Heuristic(_balance_weights, _balance_over_q),
    "power": Heuristic(_power_weights, _power_over_q),
}


def mis_weights(pdfs, fractions, heuristic: str = "balance") -> np.ndarray:
    r"""MIS weights :math:`w_i(\omega)` of K techniques at sample positions, (K, …).

    ``pdfs`` (K, …) are the techniques' densities :math:`p_k(\omega)` at the same positions,
    ``fractions`` (K,) their sample shares :math:`\nu_k` (:math:`n_k/N` multi-sample,
    :math:`c_k` one-sample); with :math:`q_k = \nu_k p_k`: balance :math:`w_i = q_i/\sum_k q_k`,
    power :math:`w_i = q_i^2/\sum_k q_k^2` (Veach 1997, Eqs. 9.4 and 9.13 with β = 2). They sum
    to 1 wherever some :math:`q_k > 0` (0 elsewhere).

    >>> mis_weights([[1.0, 0.0], [3.0, 2.0]], [0.5, 0.5]).tolist()
    [[0.25, 0.0], [0.75, 1.0]]
    >>> mis_weights([[1.0], [3.0]], [0.5, 0.5], "power").ravel().tolist()
    [0.1, 0.9]
    """
    p = np.asarray(pdfs, dtype=np.float64)
    nu = np.asarray(fractions, dtype=np.float64).reshape((-1,) + (1,) * (p.ndim - 1))
    return _heuristic(heuristic).weights(nu * p)


def _heuristic(name) -> Heuristic:
    try:
        return HEURISTICS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"heuristic must be one of {', '.join(HEURISTICS)}; "
                             f"got {name!r}") from None


def _multi_layout(U_parts, fraction, n):
    """Multi-sample: the first n₁ = round(fraction·N) points go to the map, the rest to the
    lobe (or the two given sets). Returns (map mask (N,), ν (2,), remap)."""
    n1 = U_parts[1]
    sel = np.arange(n) < n1
    return sel, np.array([n1 / n, (n - n1) / n]), None


def _one_layout(U_parts, fraction, n):
    """One-sample: u₀ < c picks the map (u₀/c), else the lobe ((u₀ − c)/(1 − c))."""
    return None, np.array([fraction, 1.0 - fraction]), fraction


#: sample allocation models of Veach 1997 §9.2.2 (multi-sample) and §9.2.4 (one-sample)
MODES = {"multi": _multi_layout, "one": _one_layout}


def _mis_points(u, mode, fraction):
    """(U (N, 2), n₁ or None) for the mode: a pair (u_map, u_brdf) only for multi."""
    if isinstance(u, (tuple, list)) and len(u) == 2 and not np.isscalar(u[0]) \
            and np.ndim(u[0]) == 2:
        if mode != "multi":
            raise ParameterError("a pair (u_map, u_brdf) of point sets needs mode='multi'")
        a, b = _square(u[0], "u_map"), _square(u[1], "u_brdf")
        return np.vstack([a, b]), a.shape[0]
    U = _square(u)
    return U, int(np.floor(fraction * U.shape[0] + 0.5))


def mis_estimates(envmap: EnvMap, axes, u, sampler: MapSampler | None = None,
                  brdf="diffuse", shininess: float = 30.0, *, heuristic: str = "balance",
                  mode: str = "multi", fraction: float = 0.5, seed=None,
                  shift: bool = True) -> np.ndarray:
    r"""Multiple importance sampling of the map and lobe techniques (Veach 1997, ch. 9), (M, C).

    With :math:`p_1` the map pdf (:class:`MapSampler`), :math:`p_2 = q_a` the lobe pdf
    (:func:`brdf_pdf`), :math:`g = f\rho_a` the integrand and :math:`\nu_k` the shares,

    .. math:: F = \frac1N\sum_{j=1}^{N} \frac{w_{i_j}(\omega_j)\,g(\omega_j)}
                                        {\nu_{i_j}\,p_{i_j}(\omega_j)},

    :math:`i_j` the technique of sample j, weights :func:`mis_weights`:

    * ``mode="multi"`` (Veach §9.2.2): :math:`n_1` = round(fraction·N) map samples (the first
      n₁ points of u) and :math:`n_2 = N - n_1` lobe samples (the rest),
      :math:`\nu_k = n_k/N`; the estimator is :math:`\sum_i \frac1{n_i}\sum_j w_i g/p_i`.
      ``u`` may instead be a pair ``(u_map, u_brdf)`` of two point sets (then n_k are their
      sizes and ``fraction`` is unused) — better for sets ordered along a coordinate (the
      first half of SF's lattice covers only z' > ½; LP is not a sequence), whose halves are
      poorly stratified; with a shift (``seed``) any split is still unbiased.
    * ``mode="one"`` (Veach §9.2.4): each sample picks the map with probability
      :math:`c_1` = fraction by :math:`u_0 < c_1` and reuses the rescaled :math:`u_0`
      (:math:`u_0/c_1`, or :math:`(u_0-c_1)/(1-c_1)`), so a QMC set stays stratified;
      :math:`\nu_k = c_k`. With the balance heuristic this is IS with the mixture pdf
      :math:`c_1p_1 + c_2p_2`: :math:`F = \frac1N\sum g/(c_1p_1 + c_2p_2)`.

    Defaults and why: ``heuristic="balance"`` — Veach's Theorem 9.2 bounds its variance by the
    optimum of any weighting plus :math:`(1/\min_i n_i - 1/N)\,I^2`, and in the one-sample
    model it is optimal (Theorem 9.5); ``"power"`` (β = 2) does better where one technique is
    already very good (low-variance cases, §9.2.3). ``mode="multi"`` — deterministic
    allocation, no variance from the technique choice. ``fraction=0.5`` — without knowing
    which technique suits the map and lobe (a sun favours the map, a sharp lobe on a smooth
    sky the BRDF), the even split is the minimax choice: MIS with it is never worse than the
    better technique with half the samples (plus the bound above), whereas a skewed split
    can starve the technique that matters.

    Other parameters as :func:`map_is_estimates`; with a seed each axis's frame is twisted
    and (``shift``) its points Cranley–Patterson shifted.

    >>> from envfit.maps.envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> u = np.random.default_rng(0).random((64, 2))
    >>> bool(np.isfinite(mis_estimates(m, [[0, 1.0, 0]], u, mode="one")).all())
    True
    """
    if mode not in MODES:
        raise ParameterError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    heur = _heuristic(heuristic)
    try:
        c1 = float(fraction)
    except (TypeError, ValueError):
        raise ParameterError(f"fraction must be a number in [0, 1], got {fraction!r}") from None
    if not 0.0 <= c1 <= 1.0:
        raise ParameterError(f"fraction must be a number in [0, 1], got {fraction!r}")
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U, n1 = _mis_points(u, mode, c1)
    n, c = U.shape[0], envmap.channels
    sel_pos, nu, split = MODES[mode]((U, n1), c1, n)
    sampler = MapSampler(envmap) if sampler is None else sampler
    out = np.empty((A.shape[0], c))
    for m0, m1 in _blocks(A.shape[0], n, c, "multiple importance sampling"):
        mb = m1 - m0
        Ub = _shifted(U, s[m0:m1])                                      # (mb, N, 2)
        if split is None:
            sel = np.broadcast_to(sel_pos, (mb, n))
        else:
            sel = Ub[..., 0] < split
            u0 = Ub[..., 0]
            Ub[..., 0] = np.where(sel, u0 / max(split, 1e-300),
                                  (u0 - split) / max(1.0 - split, 1e-300))
            Ub = np.clip(Ub, 0.0, np.nextafter(1.0, 0.0))
        axis_of = np.broadcast_to(np.arange(m0, m1)[:, None], (mb, n))
        contrib = np.zeros((mb, n, c))
        km = np.nonzero(sel)
        if km[0].size:
            f, pm, rho = _map_technique(envmap, sampler, weight, A[axis_of[km]], Ub[km])
            q = np.stack([nu[0] * pm, nu[1] * rho])
            contrib[km] = f * (rho * heur.over_q(q, 0))[:, None]
        kb = np.nonzero(~sel)
        if kb[0].size:
            f, pm, rho = _brdf_technique(envmap, sampler, weight, R[axis_of[kb]], Ub[kb])
            q = np.stack([nu[0] * pm, nu[1] * rho])
            contrib[kb] = f * (rho * heur.over_q(q, 1))[:, None]
        out[m0:m1] = contrib.sum(axis=1) / n
    return out


# ----------------------------------------------------------------------------- dispatch

#: name → estimator; every one takes (envmap, axes, u, sampler, brdf, shininess, *, seed, shift)
ESTIMATORS: dict[str, Callable[..., np.ndarray]] = {
    "map": map_is_estimates,
    "brdf": brdf_sampling_estimates,
    "mis": mis_estimates,
}


def importance_estimates(envmap: EnvMap, axes, u, method: str = "mis", **kwargs) -> np.ndarray:
    """The estimator named ``method`` in :data:`ESTIMATORS` (keywords passed on), (M, C).

    >>> from envfit.maps.envmap import EnvMap
    >>> m = EnvMap(np.full((4, 8, 1), 1.0))
    >>> importance_estimates(m, [1.0, 0, 0], [[0.5, 0.5]], "bogus")
    Traceback (most recent call last):
    ...
    envfit.base.errors.ParameterError: method must be one of map, brdf, mis; got 'bogus'
    """
    try:
        fn = ESTIMATORS[method]
    except (KeyError, TypeError):
        raise ParameterError(f"method must be one of {', '.join(ESTIMATORS)}; "
                             f"got {method!r}") from None
    return fn(envmap, axes, u, **kwargs)

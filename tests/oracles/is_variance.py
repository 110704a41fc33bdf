r"""Exact variance and RMSE of random-point importance-sampled shading estimators, from the map.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Eq. 17; E. Veach, "Robust Monte
Carlo Methods for Light Transport Simulation", PhD thesis, Stanford 1997, ch. 9
(multiple importance sampling); M. Pharr, W. Jakob, G. Humphreys, *Physically Based
Rendering*, 4th ed. (pbrt-v4), §12.5 (sampling a lat-long map: the density in solid
angle is :math:`p(\omega) = p(u, v)/(2\pi^2\sin\theta)` for the image coordinates
:math:`(u, v) \in [0,1]^2`; a pdf that is constant in (cos θ, φ) inside a pixel is its
pixel probability over the pixel's solid angle, :math:`q_{ij}/\Omega_{ij}`).

The integrand is the one of the ground truth (:mod:`envfit.shading._ground_truth`):

.. math:: f(\omega) = L(\omega)\,\rho_a(\omega), \qquad
          \rho_a(\omega) = \frac{p(\omega\cdot a)}{2\pi r_s}\ (\omega\cdot a > 0),\ 0\ \text{below},
          \qquad I(a) = \int_{S^2} f\,d\omega,

with :math:`L` the map's bilinear interpolant (``envmap.lookup``) and :math:`\rho_a` the
normalised zonal lobe (:func:`envfit.shading._ground_truth.weight_function`), a density.

Identities (exact; each is checked by simulation in tests/test_is_variance.py)
------------------------------------------------------------------------------
* One-sample importance sampling with a pdf :math:`p` (:func:`is_variance`):
  :math:`\mathrm{Var}[f/p] = \int f^2/p\,d\omega - I^2`; the mean of N i.i.d. samples has
  MSE :math:`\mathrm{Var}/N` exactly (it is unbiased).
* BRDF sampling, :math:`p = \rho_a`: :math:`f/p = L`, so :math:`\mathrm{Var} = \int
  (L - I)^2\rho_a\,d\omega` — the variance of the map under the lobe, computed in that
  centred form (0 to rounding for a constant map).
* Map sampling (:class:`MapPdf`, piecewise constant per pixel, :math:`p = q_{ij}/\Omega_{ij}`):
  :math:`\int f^2/p = \sum_{ij} (\Omega_{ij}/q_{ij}) \int_{\text{pixel}} f^2\,d\omega` — the
  fast path looks the pixel up instead of calling the pdf.
* One-sample MIS (:func:`mis_variance`, ``mode="one"``) choosing technique i with probability
  :math:`c_i`: :math:`\mathrm{Var} = \int f^2\sum_i w_i^2/(c_i p_i)\,d\omega - I^2`; with the
  balance heuristic :math:`w_i = c_ip_i/\sum_k c_kp_k` this is importance sampling with the
  mixture :math:`\sum_i c_ip_i` (:func:`mixture_pdf`); power heuristic
  :math:`w_i = (c_ip_i)^\beta/\sum_k(c_kp_k)^\beta`.
* Multi-sample MIS (``mode="multi"``, :math:`n_i` samples from :math:`p_i`, weights
  :math:`w_i` with :math:`n_ip_i` in place of :math:`c_ip_i`): :math:`\mathrm{Var} =
  \sum_i \frac{1}{n_i}\big[\int w_i^2f^2/p_i\,d\omega - (\int w_if\,d\omega)^2\big]`
  (Veach 1997, Thm. 9.2's setting).

Quadrature
----------
Every integral is computed by :func:`oracles.sphere_quadrature.sphere_integrals`
(Gauss–Legendre per quarter-pixel cell, horizon clipped exactly; ~1e-12 relative, see that
module). A :class:`MapPdf` of the map's size is looked up per pixel and a :class:`LobePdf`
evaluated as ρ_a(z), without calls; :func:`mis_variance` uses 2q (balance) or 3q (power) nodes
per direction, and a pdf given as an arbitrary callable 2q. Such callables are integrated
exactly only if they are smooth on the cells (constant per pixel, or smooth functions of the
direction such as a lobe no sharper than the BRDF's).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> m = EnvMap(np.full((8, 16, 1), 2.0))
>>> axes = [[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]]
>>> v = is_variance(m, axes, LobePdf("glossy", 30), "glossy", 30)       # f/p = L = 2
>>> float(np.abs(v).max()) < 1e-20
True
>>> u = is_variance(m, axes, MapPdf(m, floor=0.0), "diffuse")           # uniform pdf 1/4π
>>> bool(np.allclose(u, 4.0 * (8.0 / 3.0 - 1.0), rtol=1e-9))  # 4 (4π∫ρ² − 1)
True
"""
from __future__ import annotations

import inspect
import math
from typing import Callable

import numpy as np

from envfit.theory._brdf import WeightFunction

from envfit.base._checks import as_unit_vectors
from envfit.base._errors import ParameterError
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import local_to_world, pixel_solid_angles
from envfit.sampling._map_sampler import DEFAULT_FLOOR, MapSampler
from envfit.shading._estimators import RMSE
from envfit.shading._ground_truth import weight_function
from oracles.sphere_quadrature import sphere_integrals

__all__ = ["MapPdf", "LobePdf", "mixture_pdf", "is_variance", "mis_variance",
           "predicted_rmse_random"]


# ----------------------------------------------------------------------------- pdfs

class MapPdf:
    r"""Map importance-sampling pdf: piecewise constant per pixel, uniform in (cos θ, φ) inside.

    Pixel probabilities :math:`q_{ij}`: those of the sampler that draws the samples,
    :class:`envfit.sampling._map_sampler.MapSampler` (luminance × solid angle with its floor ε =
    ``floor`` and its bilinear-cell smoothing, ``smooth``; one construction for the sampler
    and its variance), or given directly (``probabilities``, (H, W), normalised here). The density
    in solid angle is :math:`p(\omega) = q_{ij}/\Omega_{ij}` for ω in pixel (i, j)
    (= pbrt-v4's :math:`p(u,v)/(2\pi^2\sin\theta)` averaged over the pixel's rows).

    Attributes: ``q`` (H, W) probabilities (sum 1), ``density`` (H, W) per steradian,
    ``envmap``. Calling it with world directions (..., 3) (and optionally axes, ignored)
    returns the density (...).

    >>> from envfit.maps._envmap import EnvMap
    >>> p = MapPdf(EnvMap(np.ones((4, 8, 3))))
    >>> bool(np.allclose(p([[0.0, 1.0, 0.0]]), 1.0 / (4.0 * np.pi)))
    True
    """

    def __init__(self, envmap: EnvMap, floor: float = DEFAULT_FLOOR, probabilities=None, *,
                 smooth: bool = True):
        om = pixel_solid_angles(envmap.height, envmap.width)
        if probabilities is None:
            q = MapSampler(envmap, floor=floor, smooth=smooth).probabilities
        else:
            q = np.array(probabilities, dtype=np.float64)
            if q.shape != om.shape or not np.all(np.isfinite(q)) or np.any(q < 0.0):
                raise ParameterError(f"probabilities must be {om.shape} finite numbers >= 0, "
                                     f"got shape {q.shape}")
        tot = float(q.sum())
        if not tot > 0.0:
            raise ParameterError("the pixel probabilities sum to 0")
        self.envmap = envmap
        self.q = q / tot
        self.density = self.q / om

    def pixel_of(self, dirs) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) integer pixel indices of world directions (..., 3)."""
        h, w = self.q.shape
        d = np.asarray(dirs, dtype=np.float64) @ local_to_world(self.envmap.up)
        theta = np.arctan2(np.hypot(d[..., 0], d[..., 1]), d[..., 2])
        phi = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2.0 * np.pi)
        i = np.clip(np.floor(theta * (h / np.pi)).astype(np.int64), 0, h - 1)
        j = np.floor(phi * (w / (2.0 * np.pi))).astype(np.int64) % w
        return i, j

    def __call__(self, dirs, axes=None) -> np.ndarray:
        i, j = self.pixel_of(dirs)
        return self.density[i, j]


class LobePdf:
    r"""BRDF-sampling pdf: the normalised lobe :math:`\rho_a(\omega) = p(\omega\cdot a)/(2\pi r_s)`.

    Called as ``pdf(dirs, axes)`` with world directions (..., 3) and unit axes broadcasting
    against them; 0 below the horizon of a.

    >>> p = LobePdf("diffuse")
    >>> bool(np.isclose(p([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]), 1.0 / np.pi))
    True
    """

    def __init__(self, brdf="diffuse", shininess: float = 30.0):
        self.weight: WeightFunction = weight_function(brdf, shininess)
        self.norm = 1.0 / (2.0 * math.pi * float(self.weight.r_s))

    def of_z(self, z) -> np.ndarray:
        """ρ as a function of z = ω·a."""
        return self.norm * self.weight.p(z)

    def __call__(self, dirs, axes) -> np.ndarray:
        z = np.sum(np.asarray(dirs, dtype=np.float64) * np.asarray(axes, dtype=np.float64),
                   axis=-1)
        return self.of_z(z)


def mixture_pdf(pdfs, fractions) -> Callable:
    r"""The mixture :math:`\sum_i c_i p_i` (one-sample MIS with the balance heuristic), as a
    callable ``(dirs, axes)``; ``fractions`` :math:`c_i \ge 0` are normalised to sum 1.

    >>> p = mixture_pdf([LobePdf("diffuse"), lambda d: np.full(d.shape[:-1], 0.25 / np.pi)],
    ...                 [0.5, 0.5])
    >>> v = p(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]))
    >>> bool(np.isclose(v, 0.5 / np.pi + 0.125 / np.pi))
    True
    """
    c = _fractions(fractions, len(pdfs))
    calls = [_as_callable(p) for p in pdfs]

    def pdf(dirs, axes):
        return sum(ci * f(dirs, axes) for ci, f in zip(c, calls))

    pdf.components = (tuple(pdfs), tuple(c))
    return pdf


def _fractions(fractions, count: int) -> np.ndarray:
    c = np.asarray(fractions, dtype=np.float64).ravel()
    if c.size != count or not np.all(np.isfinite(c)) or np.any(c < 0.0) or not c.sum() > 0.0:
        raise ParameterError(f"need {count} fractions >= 0 with a positive sum, got {fractions!r}")
    return c / c.sum()


def _as_callable(pdf) -> Callable:
    """A pdf as ``g(dirs, axes)``: callables of one positional argument get only dirs."""
    if isinstance(pdf, (MapPdf, LobePdf)):
        return pdf
    if not callable(pdf):
        raise ParameterError(f"a pdf must be callable, got {pdf!r}")
    try:
        params = inspect.signature(pdf).parameters.values()
        npos = sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)
        varargs = any(p.kind == p.VAR_POSITIONAL for p in params)
    except (TypeError, ValueError):
        npos, varargs = 2, False
    if npos >= 2 or varargs:
        return pdf
    return lambda dirs, axes: pdf(dirs)


# ----------------------------------------------------------------------------- variances

def _pdf_values(nd, pdf) -> np.ndarray:
    """Values (P, n) of a pdf at the quadrature nodes ``nd`` (of :func:`sphere_integrals`):
    table lookup for a :class:`MapPdf` of this map's size, ρ_a(z) for a :class:`LobePdf`,
    else the callable."""
    if isinstance(pdf, MapPdf) and pdf.q.shape == nd.envmap.data.shape[:2]:
        return np.broadcast_to(pdf.density[nd.pix_i, nd.pix_j][:, None], nd.z.shape)
    if isinstance(pdf, LobePdf):
        return pdf.of_z(nd.z)
    val = np.asarray(_as_callable(pdf)(nd.dirs, nd.axes), dtype=np.float64)
    return np.broadcast_to(val, nd.z.shape)


def _safe_div(num, den):
    """num/den with 0/0 = 0 and x/0 = inf for x > 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = num / den
    return np.where(num == 0.0, 0.0, r)


def _same_lobe(pdf, weight: WeightFunction) -> bool:
    """True if ``pdf`` is the :class:`LobePdf` of this very lobe (same parameters)."""
    if not isinstance(pdf, LobePdf):
        return False
    other = pdf.weight
    if other is weight:
        return True
    key = weight._cache_key()
    return type(other) is type(weight) and key is not None and other._cache_key() == key


def is_variance(envmap: EnvMap, axes, pdf, brdf="diffuse", shininess: float = 30.0, *,
                order: int | None = None, refine: int = 1, moments: bool = False):
    r"""Per-sample variance :math:`\mathrm{Var}[f/p] = \int f^2/p\,d\omega - I^2` of importance sampling, (M, C).

    Parameters
    ----------
    envmap : the map; :math:`f = L\rho_a`, L its bilinear interpolant.
    axes : (M, 3) or (3,) world axes (normal or mirror direction).
    pdf : the sampling density per steradian: a :class:`MapPdf` (fast path: one table
        lookup per node, :math:`\int f^2/p = \sum_{ij}(\Omega_{ij}/q_{ij})\int_{pixel}f^2`),
        a :class:`LobePdf` of the same lobe as ``brdf`` (BRDF sampling: :math:`f/p = L`, the
        centred form :math:`\int(L - I)^2\rho_a`, shifted by L(a) against cancellation), or
        any callable ``pdf(dirs)`` / ``pdf(dirs, axes)`` of world directions (P, n, 3) and
        axes (P, 1, 3) returning densities (P, n) — e.g. :func:`mixture_pdf` or another
        module's sampler.
    brdf, shininess : the lobe (:func:`envfit.shading._ground_truth.weight_function`).
    order, refine : quadrature controls (:func:`sphere_integrals`; the defaults give
        ~1e-12 relative, see :mod:`oracles.sphere_quadrature`; a generic callable
        gets 2q nodes).
    moments : also return the mean I (M, C) and the second moment :math:`\int f^2/p` (M, C).

    Returns ``var`` (M, C) float64, or ``(var, I, second)``. ``inf`` where p = 0 but f ≠ 0
    (the estimator is then biased). The MSE of the mean of N i.i.d. samples is var/N
    (:func:`predicted_rmse_random`).

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 1.0))
    >>> v, I, S = is_variance(m, [0.0, 1.0, 0.0], MapPdf(m, floor=0.0), "diffuse", moments=True)
    >>> round(float(I[0, 0]), 10), round(float(S[0, 0]), 10)                # 4π ∫ρ² = 4π · 2/(3π)
    (1.0, 2.6666666667)
    """
    weight = weight_function(brdf, shininess)
    A_world = as_unit_vectors(axes, name="axes", allow_empty=True)
    if _same_lobe(pdf, weight):
        shift = envmap.lookup(A_world)                                     # (M, C) ≈ I

        def integrands(nd):
            d = nd.L - shift[nd.m][:, None, :]
            r = nd.rho[..., None]
            return [r * d * d, r * d, nd.rho]

        J = sphere_integrals(envmap, A_world, integrands, 3, weight, order=order, refine=refine)
        Q = J[:, 2, :]
        mean_d = J[:, 1, :] / Q
        var = np.maximum(J[:, 0, :] / Q - mean_d ** 2, 0.0)
        I = shift + mean_d
        second = var + I * I
    else:
        def integrands(nd):
            f = nd.L * nd.rho[..., None]
            p = _pdf_values(nd, pdf)[..., None]
            return [_safe_div(f * f, p), f]

        generic = not isinstance(pdf, (MapPdf, LobePdf))
        J = sphere_integrals(envmap, A_world, integrands, 2, weight, order=order, refine=refine,
                             order_scale=2 if generic else 1)
        second, I = J[:, 0, :], J[:, 1, :]
        var = second - I * I
    return (var, I, second) if moments else var


def _mis_weights(vals, counts, heuristic: str, beta: float):
    """MIS weights w_i (list of (P, n)) from pdf values p_i and counts/fractions n_i."""
    x = [ni * pi for ni, pi in zip(counts, vals)]
    if heuristic == "balance":
        e = x
    else:
        e = [np.power(xi, beta) for xi in x]
    tot = sum(e)
    return [_safe_div(ei, tot) for ei in e]


def mis_variance(envmap: EnvMap, axes, map_pdf, brdf_pdf, brdf="diffuse",
                 shininess: float = 30.0, *, mode: str = "multi", heuristic: str = "balance",
                 counts=(1, 1), fractions=(0.5, 0.5), beta: float = 2.0,
                 order: int | None = None, refine: int = 1, moments: bool = False):
    r"""Variance of the MIS estimator of two techniques (map sampling, BRDF sampling), (M, C).

    ``mode="multi"`` (Veach 1997 §9.2): :math:`n_1, n_2` = ``counts`` samples from
    :math:`p_1` = ``map_pdf`` and :math:`p_2` = ``brdf_pdf``,
    :math:`F = \sum_i\frac1{n_i}\sum_j w_i f/p_i`, weights from :math:`n_ip_i` (balance:
    :math:`w_i = n_ip_i/\sum_k n_kp_k`; power: :math:`(n_ip_i)^\beta/\sum_k(n_kp_k)^\beta`).
    Returns the variance of F itself:

    .. math:: \mathrm{Var}[F] = \sum_i \frac{1}{n_i}\Big[\int\frac{w_i^2f^2}{p_i}d\omega
              - \Big(\int w_if\,d\omega\Big)^2\Big].

    ``mode="one"`` (Veach 1997 §9.2.4): one sample, technique i chosen with probability
    :math:`c_i` = ``fractions``, :math:`F = w_if/(c_ip_i)`, weights from :math:`c_ip_i`;
    returns the per-sample variance :math:`\int f^2\sum_i w_i^2/(c_ip_i)\,d\omega - I^2`
    (balance: = :func:`is_variance` with :func:`mixture_pdf`), to divide by N for N
    i.i.d. samples.

    The pdfs are callables as for :func:`is_variance` (:class:`MapPdf`, :class:`LobePdf`
    are evaluated without calls). ``moments=True`` also returns the per-technique terms
    ``(var, I_i, S_i)`` with :math:`I_i = \int w_if` and :math:`S_i = \int w_i^2f^2/p_i`
    (multi; for one-sample :math:`S_i = \int w_i^2f^2/(c_ip_i)`), each (2, M, C).

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 1.0))
    >>> v = mis_variance(m, [0.0, 1.0, 0.0], MapPdf(m), LobePdf("diffuse"), counts=(1, 1))
    >>> bool(0.0 < float(v[0, 0]) < 1.0 / 3.0)       # below map-only sampling's 1/3
    True
    """
    weight = weight_function(brdf, shininess)
    if mode not in ("multi", "one"):
        raise ParameterError(f"mode must be 'multi' or 'one', got {mode!r}")
    if heuristic not in ("balance", "power"):
        raise ParameterError(f"heuristic must be 'balance' or 'power', got {heuristic!r}")
    beta = float(beta)
    if not (np.isfinite(beta) and beta > 0.0):
        raise ParameterError(f"beta must be > 0, got {beta!r}")
    if mode == "multi":
        n = np.asarray(counts, dtype=np.float64).ravel()
        if n.size != 2 or not np.all(n >= 1) or not np.all(n == np.round(n)):
            raise ParameterError(f"counts must be two integers >= 1, got {counts!r}")
        k = n
    else:
        k = _fractions(fractions, 2)
    pdfs = (map_pdf, brdf_pdf)

    def integrands(nd):
        f = nd.L * nd.rho[..., None]
        f2 = f * f
        vals = [_pdf_values(nd, p) for p in pdfs]
        ws = _mis_weights(vals, k, heuristic, beta)
        out = []
        for ki, pi, wi in zip(k, vals, ws):
            den = pi if mode == "multi" else ki * pi
            out.append(_safe_div((wi * wi)[..., None] * f2, den[..., None]))
        out += [wi[..., None] * f for wi in ws]
        return out

    J = sphere_integrals(envmap, axes, integrands, 4, weight, order=order, refine=refine,
                         order_scale=3 if heuristic == "power" else 2)
    S = np.stack([J[:, 0, :], J[:, 1, :]])
    Ii = np.stack([J[:, 2, :], J[:, 3, :]])
    if mode == "multi":
        var = sum((S[i] - Ii[i] ** 2) / k[i] for i in range(2))
    else:
        I = Ii[0] + Ii[1]
        var = S[0] + S[1] - I * I
    return (var, Ii, S) if moments else var


def predicted_rmse_random(variance, n=1) -> RMSE:
    r"""The RMSE over axes that random points give: :math:`\sqrt{\frac{1}{MC}\sum_{m,c}\mathrm{Var}_{mc}/N}`.

    ``variance`` (M, C): per-sample variances (:func:`is_variance`, :func:`mis_variance`
    with ``mode="one"``; then ``n`` = N samples) or estimator variances
    (``mode="multi"``, n = 1). Same convention as
    :func:`envfit.shading._estimators.rmse_over_axes` (the expectation of its square over
    the randomness is this one's square): ``total`` over axes and channels,
    ``per_channel`` over axes; ``n`` may be an array of sample counts (leading shape of
    the result).

    >>> r = predicted_rmse_random(np.array([[4.0, 16.0]]), 4)
    >>> float(r.total), r.per_channel.tolist()
    (1.5811388300841898, [1.0, 2.0])
    """
    v = np.asarray(variance, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2 or v.shape[0] == 0:
        raise ParameterError(f"variance must be (M, C) with M >= 1, got shape {v.shape}")
    nn = np.asarray(n, dtype=np.float64)
    if not np.all(nn > 0):
        raise ParameterError(f"n must be > 0, got {n!r}")
    d2 = v / nn[..., None, None]
    per = np.sqrt(d2.mean(axis=-2))
    tot = np.sqrt(d2.mean(axis=(-2, -1)))
    return RMSE(total=float(tot) if tot.ndim == 0 else tot, per_channel=per)

r"""Exact variance and RMSE of random-point importance-sampled shading estimators, from the map.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Eq. 17; E. Veach, "Robust Monte
Carlo Methods for Light Transport Simulation", PhD thesis, Stanford 1997, ch. 9
(multiple importance sampling); M. Pharr, W. Jakob, G. Humphreys, *Physically Based
Rendering*, 4th ed. (pbrt-v4), §12.5 (sampling a lat-long map: the density in solid
angle is :math:`p(\omega) = p(u, v)/(2\pi^2\sin\theta)` for the image coordinates
:math:`(u, v) \in [0,1]^2`; a pdf that is constant in (cos θ, φ) inside a pixel is its
pixel probability over the pixel's solid angle, :math:`q_{ij}/\Omega_{ij}`).

The integrand is the one of the ground truth (:mod:`envfit.shading.ground_truth`):

.. math:: f(\omega) = L(\omega)\,\rho_a(\omega), \qquad
          \rho_a(\omega) = \frac{p(\omega\cdot a)}{2\pi r_s}\ (\omega\cdot a > 0),\ 0\ \text{below},
          \qquad I(a) = \int_{S^2} f\,d\omega,

with :math:`L` the map's bilinear interpolant (``envmap.lookup``) and :math:`\rho_a` the
normalised zonal lobe (:func:`envfit.shading.ground_truth.weight_function`), a density.

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

Quadrature (:func:`sphere_integrals`)
-------------------------------------
Every integrand above is smooth on each *cell* of the grid that splits every pixel into
2×2 (``refine`` = 1; :math:`(2r)^2` for ``refine`` = r) equal-angle quarters: inside a cell
L is bilinear in (θ, φ) (the cell lies in one bilinear patch, :mod:`envfit.shading.patches`)
and a pixel-constant pdf is constant. On each cell a q×q Gauss–Legendre rule in (θ, φ)
with the weight sin θ, q = :func:`~envfit.shading.patches.gauss_legendre_order` of
:math:`(2D + 3)\Delta/2` (Δ the cell's side, D the lobe's bandwidth,
:func:`~envfit.shading.ground_truth.polynomial_degree`: the rule integrates
:math:`L^2\rho_a^2\sin\theta` to ~1e-10 of each cell's scale; q ≥ 4). Cells where the lobe
is below 1e-16 of its peak for every point (rigorous corner bound) are skipped, so a
sharp glossy lobe (n = 1000) costs only the cells of its cap. Cells the horizon
:math:`\omega\cdot a = 0` may cut are integrated over their part above it exactly (φ split
where the horizon crosses the cell's rings, θ clipped at the horizon per φ node, as in
:mod:`envfit.shading.hemisphere`) unless the lobe is below 1e-13 of its peak within 2π/H of the
horizon (glossy n ≳ 30). The MIS weights make the integrands sharper than the lobe (the
power heuristic switches from one technique to the other over a ring of width ~1/(nγ)
about the axis; near the horizon of a diffuse lobe where ρ_a ≈ p_map), so
:func:`mis_variance` uses 2q (balance) or 3q (power) nodes per direction, and a pdf given
as an arbitrary callable 2q. Measured accuracy (tests/test_is_variance.py, a 32×16 map
with a sun, diffuse and glossy n = 5…1000, six axes, against ``refine=2`` with 2q + 4
nodes): relative differences of every second moment ≤ 2e-11 (map, BRDF, MIS balance and
power, one- and multi-sample); with only q nodes the power heuristic would be off by 6e-4
at n = 1000. The mean I agrees with
:func:`~envfit.shading.ground_truth.shading_integral` (``method="pixels"``) to ~1e-12.
Pdfs given as arbitrary callables are integrated exactly
only if they are smooth on these cells (constant per pixel, or smooth functions of the
direction such as a lobe no sharper than the BRDF's); the rule is then the same.

Example
-------
>>> import numpy as np
>>> from envfit.maps.envmap import EnvMap
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

from envfit.theory.brdf import WeightFunction, gauss_legendre_01

from envfit.base.checks import as_unit_vectors, check_int
from envfit.base.errors import ParameterError
from envfit.base.resources import check_memory
from envfit.maps.envmap import EnvMap
from envfit.maps.latlong import local_to_world, pixel_solid_angles
from envfit.shading.importance import DEFAULT_FLOOR, MapSampler
from envfit.shading.estimators import RMSE
from envfit.shading.ground_truth import polynomial_degree, weight_function
from envfit.shading.patches import (axes_to_local, gauss_legendre_order, local_angles,
                                    patch_corner_values)

__all__ = ["MapPdf", "LobePdf", "mixture_pdf", "is_variance", "mis_variance",
           "predicted_rmse_random", "sphere_integrals", "PAIR_BLOCK"]

#: quadrature nodes × channels processed per chunk (≈ 30 MB of temporaries)
PAIR_BLOCK = 1 << 20
#: lobe values below this fraction of the peak are treated as zero (cells skipped)
LOBE_CUT = 1e-16
#: horizon clipping is skipped when the lobe within 2π/H of the horizon is below this fraction of its peak
HORIZON_CUT = 1e-13


# ----------------------------------------------------------------------------- pdfs

class MapPdf:
    r"""Map importance-sampling pdf: piecewise constant per pixel, uniform in (cos θ, φ) inside.

    Pixel probabilities :math:`q_{ij}`: those of the sampler that draws the samples,
    :class:`envfit.shading.importance.MapSampler` (luminance × solid angle with its floor ε =
    ``floor`` and its bilinear-cell smoothing, ``smooth``; one construction for the sampler
    and its variance), or given directly (``probabilities``, (H, W), normalised here). The density
    in solid angle is :math:`p(\omega) = q_{ij}/\Omega_{ij}` for ω in pixel (i, j)
    (= pbrt-v4's :math:`p(u,v)/(2\pi^2\sin\theta)` averaged over the pixel's rows).

    Attributes: ``q`` (H, W) probabilities (sum 1), ``density`` (H, W) per steradian,
    ``envmap``. Calling it with world directions (..., 3) (and optionally axes, ignored)
    returns the density (...).

    >>> from envfit.maps.envmap import EnvMap
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


# ----------------------------------------------------------------------------- quadrature

class _Nodes:
    """Quadrature nodes of a chunk of (cell, axis) pairs, shape (P, n) each, and what the
    integrands need: the map L (P, n, C), z = ω·a, the lobe ρ_a, the pixel, the directions."""

    def __init__(self, envmap, rho, th, ph, wt, z, r, k, refine, m, A_world):
        self.envmap, self.th, self.ph, self.wt, self.z = envmap, th, ph, wt, z
        sub = 2 * refine
        self.pix_i, self.pix_j, self.m = r // sub, k // sub, m
        self._A_world = A_world
        self.rho = rho.of_z(z)
        # the cell's bilinear patch: rows split at pixel centres, columns likewise
        s = (r + refine) // sub
        jp = ((k - refine) // sub) % envmap.width
        self.L = _bilinear(envmap.data, s, jp, th, ph)
        self._dirs = None

    @property
    def dirs(self) -> np.ndarray:
        """World directions of the nodes (P, n, 3)."""
        if self._dirs is None:
            st = np.sin(self.th)
            loc = np.stack((st * np.cos(self.ph), st * np.sin(self.ph), np.cos(self.th)), -1)
            self._dirs = loc @ local_to_world(self.envmap.up).T
        return self._dirs

    @property
    def axes(self) -> np.ndarray:
        """World axis of each pair, (P, 1, 3) (broadcasts against :attr:`dirs`)."""
        return self._A_world[self.m][:, None, :]

    def pdf(self, pdf) -> np.ndarray:
        """Values (P, n) of a pdf at the nodes: table lookup for a :class:`MapPdf` of this
        map's size, ρ_a(z) for a :class:`LobePdf`, else the callable."""
        if isinstance(pdf, MapPdf) and pdf.q.shape == self.envmap.data.shape[:2]:
            return np.broadcast_to(pdf.density[self.pix_i, self.pix_j][:, None], self.z.shape)
        if isinstance(pdf, LobePdf):
            return pdf.of_z(self.z)
        val = np.asarray(_as_callable(pdf)(self.dirs, self.axes), dtype=np.float64)
        return np.broadcast_to(val, self.z.shape)


def _bilinear(data: np.ndarray, s: np.ndarray, jp: np.ndarray, th: np.ndarray,
              ph: np.ndarray) -> np.ndarray:
    """The bilinear interpolant at (θ, φ) (P, n) inside patches (s, jp) (P,), (P, n, C)."""
    h, w, _ = data.shape
    T0, T1, B0, B1 = patch_corner_values(data, s, jp)
    t = (th * (h / np.pi) - 0.5 - (s[:, None] - 1))[..., None]
    rel = np.mod(ph - 2.0 * np.pi * (jp[:, None] + 0.5) / w + np.pi, 2.0 * np.pi) - np.pi
    b = (rel * (w / (2.0 * np.pi)))[..., None]
    top = T0[:, None, :] + b * (T1 - T0)[:, None, :]
    bot = B0[:, None, :] + b * (B1 - B0)[:, None, :]
    return top + t * (bot - top)


def _lobe_threshold(weight: WeightFunction, frac: float) -> float:
    """Largest z0 ∈ [0, 1] with p(z) ≤ frac·p(1) for all z < z0 (p increasing assumed near
    the cut; bisection on a fine grid)."""
    zg = np.linspace(0.0, 1.0, 4097)
    pg = np.asarray(weight.p(zg), dtype=np.float64)
    peak = float(np.max(np.abs(pg)))
    above = np.nonzero(np.abs(pg) > frac * peak)[0]
    if above.size == 0 or above[0] == 0:
        return 0.0
    return float(zg[above[0] - 1])


def _cell_flags(a, th_e, ph_e, margin, z_cut, horizon):
    """(active, cut) flags (rows, cols, nb) of the cells for a block of local axes a (nb, 3)."""
    Q = np.outer(np.cos(ph_e), a[:, 0]) + np.outer(np.sin(ph_e), a[:, 1])     # (cols+1, nb)
    Zc = np.sin(th_e)[:, None, None] * Q[None] + np.cos(th_e)[:, None, None] * a[:, 2]
    zmax = np.maximum(np.maximum(Zc[:-1, :-1], Zc[1:, :-1]), np.maximum(Zc[:-1, 1:], Zc[1:, 1:]))
    zmin = np.minimum(np.minimum(Zc[:-1, :-1], Zc[1:, :-1]), np.minimum(Zc[:-1, 1:], Zc[1:, 1:]))
    active = zmax + margin > max(z_cut, 0.0)
    if horizon:
        cut = active & (zmin - margin < 0.0)
    else:
        cut = np.zeros_like(active)
    return active, cut


def _full_nodes(r, k, dth, x, wq):
    """Tensor nodes (P, q*q) of whole cells (r, k)."""
    q = x.size
    th = (r[:, None] + x[None, :]) * dth                                       # (P, q)
    ph = (k[:, None] + x[None, :]) * dth
    wt = (dth * wq)[None, :, None] * np.sin(th)[:, :, None] * (dth * wq)[None, None, :]
    TH = np.broadcast_to(th[:, :, None], (r.size, q, q)).reshape(r.size, -1)
    PH = np.broadcast_to(ph[:, None, :], (r.size, q, q)).reshape(r.size, -1)
    return TH, PH, wt.reshape(r.size, -1)


def _clipped_nodes(r, k, dth, sa, ca, pa, x, wq):
    r"""Nodes (P, 5·q·q) of the parts of cells (r, k) above the horizon of axes (sa, ca, pa).

    The φ-range is split where the horizon crosses the cell's two rings (≤ 4 points), and at
    each φ node the θ-range is clipped at the root of :math:`\sin\theta_a\cos(\varphi-\varphi_a)
    \sin\theta + \cos\theta_a\cos\theta = 0`; every piece is then smooth.
    """
    P, q = r.size, x.size
    t0, t1 = r * dth, (r + 1) * dth
    p0 = k * dth
    cand = []
    for te in (t0, t1):
        den = sa * np.sin(te)
        with np.errstate(divide="ignore", invalid="ignore"):
            kap = -ca * np.cos(te) / den
        ok = (den > 1e-300) & (np.abs(kap) <= 1.0)
        psi = np.arccos(np.clip(np.where(ok, kap, 0.0), -1.0, 1.0))
        for sg in (1.0, -1.0):
            rel = np.mod(pa + sg * psi - p0, 2.0 * np.pi)
            cand.append(np.where(ok & (rel > 0.0) & (rel < dth), rel, dth))
    pts = np.sort(np.stack([np.zeros(P)] + cand + [np.full(P, dth)], axis=1), axis=1)
    lo, hi = p0[:, None] + pts[:, :-1], p0[:, None] + pts[:, 1:]             # (P, 5)
    phn = lo[:, :, None] + (hi - lo)[:, :, None] * x                          # (P, 5, q)
    wph = (hi - lo)[:, :, None] * wq
    Aph = sa[:, None, None] * np.cos(phn - pa[:, None, None])
    T0, T1 = t0[:, None, None], t1[:, None, None]
    C = ca[:, None, None]
    ztop = Aph * np.sin(T0) + C * np.cos(T0)
    zbot = Aph * np.sin(T1) + C * np.cos(T1)
    root = np.where(-C >= 0.0, np.arctan2(-C, Aph), np.arctan2(C, -Aph))
    root = np.clip(root, T0, T1)
    tlo = np.where(ztop >= 0.0, T0, np.where(zbot >= 0.0, root, T1))
    thi = np.where(zbot >= 0.0, T1, np.where(ztop >= 0.0, root, T0))
    thi = np.maximum(thi, tlo)
    thn = tlo[..., None] + (thi - tlo)[..., None] * x                         # (P, 5, q, q)
    wt = wph[..., None] * (thi - tlo)[..., None] * wq * np.sin(thn)
    phb = np.broadcast_to(phn[..., None], thn.shape)
    return thn.reshape(P, -1), phb.reshape(P, -1), wt.reshape(P, -1)


def sphere_integrals(envmap: EnvMap, axes, integrands, count: int, brdf="diffuse",
                     shininess: float = 30.0, *, order: int | None = None,
                     refine: int = 1, order_scale: int = 1) -> np.ndarray:
    r""":math:`J_k(a) = \int_{S^2} g_k(\omega; a)\,d\omega` for k < ``count``, per axis, (M, count, C).

    ``integrands(nodes)`` returns ``count`` arrays (P, n) or (P, n, C) of :math:`g_k` at the
    nodes of a chunk (a :class:`_Nodes`: ``L`` (P, n, C), ``z`` = ω·a, ``rho`` = ρ_a(ω),
    ``pdf(p)`` the values of a pdf, ``dirs``, ``axes``); each :math:`g_k` must vanish where
    the lobe ρ_a does (it carries a factor f). The rule is the one of the module doc: q×q
    Gauss–Legendre per cell of (2·``refine``)² per pixel, q = ``order`` or the bandwidth
    rule times ``order_scale`` (for integrands sharper than the lobe: MIS weights);
    cells with a negligible lobe skipped, horizon-cut cells clipped.

    >>> m = EnvMap(np.full((4, 8, 1), 3.0))
    >>> J = sphere_integrals(m, [[0.0, 0.0, 1.0]], lambda nd: [nd.L * nd.rho[..., None]], 1)
    >>> round(float(J[0, 0, 0]), 12)
    3.0
    """
    weight = weight_function(brdf, shininess)
    count = check_int(count, "count", 1)
    refine = check_int(refine, "refine", 1)
    A_world = as_unit_vectors(axes, name="axes", allow_empty=True)
    A = axes_to_local(A_world, envmap.up)
    h, w, c = envmap.data.shape
    m_total = A.shape[0]
    out = np.zeros((m_total, count, c))
    if m_total == 0:
        return out
    sub = 2 * refine
    nr, nc = sub * h, sub * w
    dth = math.pi / nr                                                         # = 2π / nc
    D = polynomial_degree(weight)
    q = (max(4, gauss_legendre_order((2 * D + 3) * dth / 2.0))
         * check_int(order_scale, "order_scale", 1) if order is None
         else check_int(order, "order", 1))
    x, wq = gauss_legendre_01(q)
    rho = LobePdf(weight)
    z_cut = _lobe_threshold(weight, LOBE_CUT)
    # clip at the horizon unless the lobe is negligible on the band z ∈ [0, 2π/H] above it
    band = np.abs(weight.p(np.linspace(0.0, min(1.0, 2.0 * math.pi / h), 65))).max()
    horizon = bool(band > HORIZON_CUT * np.abs(weight.p(np.linspace(0.0, 1.0, 1025))).max())
    margin = dth * dth / 2.0 + 1e-12
    th_e = np.arange(nr + 1) * dth
    ph_e = np.arange(nc + 1) * dth
    ta, pa_all = local_angles(A)
    sa_all, ca_all = np.sin(ta), np.cos(ta)
    nb = int(max(1, min(m_total, (1 << 22) // ((nr + 1) * (nc + 1)))))
    check_memory(8 * 6 * nb * (nr + 1) * (nc + 1), f"the cell flags of a {w}x{h} map",
                 hint="use a smaller map (EnvMap.resized)")
    per_pair = 5 * q * q * (c + 12)
    step = int(max(1, PAIR_BLOCK // per_pair))
    check_memory(8 * step * per_pair * 2, "a chunk of quadrature nodes")
    for m0 in range(0, m_total, nb):
        m1 = min(m_total, m0 + nb)
        active, cut = _cell_flags(A[m0:m1], th_e, ph_e, margin, z_cut, horizon)
        for clipped in (False, True):
            sel = (active & ~cut) if not clipped else cut
            rr, kk, mm = np.nonzero(sel)
            mm = mm + m0
            for p0 in range(0, rr.size, step if clipped else 5 * step):
                sl = slice(p0, p0 + (step if clipped else 5 * step))
                r, k, m = rr[sl], kk[sl], mm[sl]
                if clipped:
                    th, ph, wt = _clipped_nodes(r, k, dth, sa_all[m], ca_all[m], pa_all[m], x, wq)
                else:
                    th, ph, wt = _full_nodes(r, k, dth, x, wq)
                a = A[m]
                z = np.sin(th) * (a[:, :1] * np.cos(ph) + a[:, 1:2] * np.sin(ph)) \
                    + np.cos(th) * a[:, 2:3]
                nodes = _Nodes(envmap, rho, th, ph, wt, z, r, k, refine, m, A_world)
                vals = integrands(nodes)
                for kk_, g in enumerate(vals):
                    g = np.asarray(g, dtype=np.float64)
                    if g.ndim == 2:
                        g = g[..., None]
                    contrib = np.einsum("pnc,pn->pc", np.broadcast_to(g, th.shape + (c,)), wt)
                    for ch in range(c):
                        out[:, kk_, ch] += np.bincount(m, weights=contrib[:, ch],
                                                       minlength=m_total)
    return out


# ----------------------------------------------------------------------------- variances

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
    brdf, shininess : the lobe (:func:`envfit.shading.ground_truth.weight_function`).
    order, refine : quadrature controls (:func:`sphere_integrals`; the defaults give
        ~1e-12 relative, see the module doc; a generic callable gets 2q nodes).
    moments : also return the mean I (M, C) and the second moment :math:`\int f^2/p` (M, C).

    Returns ``var`` (M, C) float64, or ``(var, I, second)``. ``inf`` where p = 0 but f ≠ 0
    (the estimator is then biased). The MSE of the mean of N i.i.d. samples is var/N
    (:func:`predicted_rmse_random`).

    >>> from envfit.maps.envmap import EnvMap
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
            p = nd.pdf(pdf)[..., None]
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

    >>> from envfit.maps.envmap import EnvMap
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
        vals = [nd.pdf(p) for p in pdfs]
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
    :func:`envfit.shading.estimators.rmse_over_axes` (the expectation of its square over
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

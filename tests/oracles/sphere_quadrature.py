r"""Quadrature over the sphere of lobe-weighted map integrands: :math:`J_k(a) = \int_{S^2}
g_k(\omega; a)\,d\omega` per axis (:func:`sphere_integrals`), the engine of the exact
importance-sampling variances of :mod:`oracles.is_variance`.

Each :math:`g_k` carries a factor :math:`f = L\rho_a` (L the map's bilinear interpolant,
``envmap.lookup``; :math:`\rho_a` the normalised zonal lobe,
:func:`envfit.shading._ground_truth.weight_function`), so it vanishes where the lobe does.

Quadrature (:func:`sphere_integrals`)
-------------------------------------
Every integrand of :mod:`oracles.is_variance` is smooth on each *cell* of the grid that
splits every pixel into 2×2 (``refine`` = 1; :math:`(2r)^2` for ``refine`` = r) equal-angle
quarters: inside a cell L is bilinear in (θ, φ) (the cell lies in one bilinear patch,
:mod:`envfit.shading._patches`) and a pixel-constant pdf is constant. On each cell a q×q
Gauss–Legendre rule in (θ, φ) with the weight sin θ, q =
:func:`~envfit.shading._patches.gauss_legendre_order` of :math:`(2D + 3)\Delta/2` (Δ the cell's
side, D the lobe's bandwidth, :func:`~envfit.shading._ground_truth.polynomial_degree`: the rule
integrates :math:`L^2\rho_a^2\sin\theta` to ~1e-10 of each cell's scale; q ≥ 4). Cells where the
lobe is below 1e-16 of its peak for every point (rigorous corner bound) are skipped, so a sharp
glossy lobe (n = 1000) costs only the cells of its cap. Cells the horizon
:math:`\omega\cdot a = 0` may cut are integrated over their part above it exactly (φ split where
the horizon crosses the cell's rings, θ clipped at the horizon per φ node, as in
:mod:`envfit.shading._hemisphere`) unless the lobe is below 1e-13 of its peak within 2π/H of the
horizon (glossy n ≳ 30). The MIS weights make the integrands sharper than the lobe (the power
heuristic switches from one technique to the other over a ring of width ~1/(nγ) about the axis;
near the horizon of a diffuse lobe where ρ_a ≈ p_map), so
:func:`~oracles.is_variance.mis_variance` uses 2q (balance) or 3q (power) nodes per
direction, and a pdf given as an arbitrary callable 2q. Measured accuracy
(tests/test_is_variance.py, a 32×16 map with a sun, diffuse and glossy n = 5…1000, six axes,
against ``refine=2`` with 2q + 4 nodes): relative differences of every second moment ≤ 2e-11
(map, BRDF, MIS balance and power, one- and multi-sample); with only q nodes the power heuristic
would be off by 6e-4 at n = 1000. The mean I agrees with
:func:`~envfit.shading._ground_truth.shading_integral` (``method="pixels"``) to ~1e-12. Pdfs
given as arbitrary callables are integrated exactly only if they are smooth on these cells
(constant per pixel, or smooth functions of the direction such as a lobe no sharper than the
BRDF's); the rule is then the same.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> m = EnvMap(np.full((4, 8, 1), 2.0))
>>> J = sphere_integrals(m, [[0.0, 1.0, 0.0]], lambda nd: [nd.rho, nd.L * nd.rho[..., None]], 2)
>>> [round(float(v), 12) for v in J[0, :, 0]]                  # ∫ρ_a = 1, ∫Lρ_a = 2
[1.0, 2.0]
"""
from __future__ import annotations

import math

import numpy as np

from envfit.theory._brdf import WeightFunction, gauss_legendre_01

from envfit.base._checks import as_unit_vectors, check_int
from envfit.base._resources import check_memory
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import local_to_world
from envfit.shading._ground_truth import polynomial_degree, weight_function
from envfit.shading._patches import (axes_to_local, gauss_legendre_order, horizon_breaks,
                                     local_angles, patch_corner_values)

__all__ = ["sphere_integrals", "PAIR_BLOCK"]

#: quadrature nodes × channels processed per chunk (≈ 30 MB of temporaries)
PAIR_BLOCK = 1 << 20
#: lobe values below this fraction of the peak are treated as zero (cells skipped)
LOBE_CUT = 1e-16
#: horizon clipping is skipped when the lobe within 2π/H of the horizon is below this fraction of its peak
HORIZON_CUT = 1e-13


class _Nodes:
    """Quadrature nodes of a chunk of (cell, axis) pairs, shape (P, n) each, and what the
    integrands need: the map L (P, n, C), z = ω·a, the lobe ρ_a, the pixel, the directions."""

    def __init__(self, envmap, norm, weight, th, ph, wt, z, r, k, refine, m, A_world):
        self.envmap, self.th, self.ph, self.wt, self.z = envmap, th, ph, wt, z
        sub = 2 * refine
        self.pix_i, self.pix_j, self.m = r // sub, k // sub, m
        self._A_world = A_world
        self.rho = norm * weight.p(z)                                       # ρ_a(ω)
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
    P = r.size
    t0, t1 = r * dth, (r + 1) * dth
    p0 = k * dth
    pts = horizon_breaks(t0, t1, p0, dth, sa, ca, pa)
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
    ``pix_i``, ``pix_j`` the pixel, ``dirs``, ``axes``); each :math:`g_k` must vanish where
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
    norm = 1.0 / (2.0 * math.pi * float(weight.r_s))                       # ρ_a = norm·p(z)
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
                nodes = _Nodes(envmap, norm, weight, th, ph, wt, z, r, k, refine, m, A_world)
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



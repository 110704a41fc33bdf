r"""Direct quadrature of hemisphere integrals of a map's bilinear interpolant (the reference).

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 4.1–4.3, 9.2.

:func:`hemisphere_integrals` computes

.. math:: J_k(a) = \int_{u\cdot a > 0} f(u)\,g_k(u\cdot a)\,dS(u)

(Eq. 17 for :math:`g = p/(2\pi r_s)`, the HSH projections of the truncation estimators for
:math:`g_k = P_k(2z-1)`) with a q×q Gauss–Legendre rule on every bilinear patch
(:mod:`envfit.shading._patches`; q from the bandwidth of g and the pixel size,
:func:`~envfit.shading._patches.gauss_legendre_order`: the rule integrates every trig
polynomial of the patch's degree to 1e-10, so the lobe of a large shininess is resolved
near the axis by a larger q instead of ad-hoc supersampling), evaluated for a block of
axes at once (the dot products :math:`u\cdot a` are outer products of ring and meridian
factors; the sum over nodes is one BLAS product per block). The only non-smooth set is
the horizon :math:`u\cdot a = 0` (the kink of the diffuse lobe, the jump :math:`e^{-n}` of
the glossy one, the jump of the hemispherical harmonics): patches that the horizon may
cut (corner values of :math:`u\cdot a` within :math:`h^2/4` of 0, a rigorous bound) are
masked out and integrated exactly over their part above the horizon: the φ-range is
split where the horizon crosses the patch's rings, and for each Gauss node in φ the
θ-range is clipped at the horizon's colatitude :math:`\theta^*(\varphi)` (closed form), so
every piece is smooth. The cost is one kernel evaluation per node per axis:
:math:`(H+1)W q^2` per axis.
"""
from __future__ import annotations

from typing import Callable, Iterable, NamedTuple

import numpy as np

from envfit.theory import gauss_legendre_01

from envfit.base import check_int
from envfit.base import check_memory
from envfit.maps import EnvMap
from envfit.maps import local_to_world
from envfit.shading._patches import (axes_to_local, bilinear_in_patch, gauss_legendre_order,
                                     horizon_breaks, local_angles, patch_rows)

__all__ = ["hemisphere_integrals", "BLOCK_ELEMENTS"]

#: kernel evaluations per chunk in the pixel method: small enough (0.5 MB per array) that
#: the few elementwise passes over a chunk stay in cache — 2–3x faster than 32 MB chunks
BLOCK_ELEMENTS = 1 << 16

Kernel = Callable[[np.ndarray], Iterable[np.ndarray]]


class _Grid(NamedTuple):
    """Tensor Gauss nodes of all patches: q per patch and direction, ring (θ) and meridian
    (φ) factors of u·a, and the map times the node weights, WF (rings, meridians, C)."""

    q: int
    lo: np.ndarray
    hi: np.ndarray
    st: np.ndarray
    ct: np.ndarray
    cph: np.ndarray
    sph: np.ndarray
    WF: np.ndarray


def _node_grid(envmap: EnvMap, q: int) -> _Grid:
    """The q×q rule on every patch, with f evaluated through the estimators' own lookup."""
    h, w, c = envmap.data.shape
    dphi = 2.0 * np.pi / w
    x, wq = gauss_legendre_01(q)
    lo, hi = patch_rows(h)
    th = (lo[:, None] + (hi - lo)[:, None] * x[None, :]).ravel()           # ((H+1) q,)
    wth = ((hi - lo)[:, None] * wq[None, :]).ravel() * np.sin(th)
    ph = (2.0 * np.pi * (np.arange(w) + 0.5)[:, None] / w + dphi * x[None, :]).ravel()
    wph = np.tile(dphi * wq, w)
    nth, nph = th.size, ph.size
    check_memory(8 * nth * nph * (c + 4), f"the {nph}x{nth} quadrature grid of a {w}x{h} map",
                 hint="use a smaller map (EnvMap.resized) or method='sh'")
    st, ct = np.sin(th), np.cos(th)
    local = np.empty((nth, nph, 3))
    local[..., 0] = st[:, None] * np.cos(ph)[None, :]
    local[..., 1] = st[:, None] * np.sin(ph)[None, :]
    local[..., 2] = ct[:, None]
    F = envmap.lookup(local @ local_to_world(envmap.up).T)                 # (nth, nph, C)
    del local
    WF = F * (wth[:, None, None] * wph[None, :, None])
    return _Grid(q, lo, hi, st, ct, np.cos(ph), np.sin(ph), WF)


def _horizon_flags(a: np.ndarray, lo: np.ndarray, w: int, hh: float) -> np.ndarray:
    """Patches (H+1, W, nb) whose corner values of u·a lie within h²/4 of 0 for some axis
    of the block: the horizon may cut them (|z − bilinear(corners)| ≤ (Δθ² + Δφ²)/8 ≤ h²/4)."""
    ring_e = np.concatenate((lo, [np.pi]))                                  # rings ∪ {π}
    pj = 2.0 * np.pi * (np.arange(w) + 0.5) / w                             # meridians φ_j
    margin = hh * hh / 4.0 + 1e-12
    Qc = np.outer(np.cos(pj), a[:, 0]) + np.outer(np.sin(pj), a[:, 1])     # (W, nb)
    Zc = np.sin(ring_e)[:, None, None] * Qc[None] + np.cos(ring_e)[:, None, None] * a[:, 2]
    Zc1 = np.roll(Zc, -1, axis=1)
    zmax = np.maximum(np.maximum(Zc[:-1], Zc[1:]), np.maximum(Zc1[:-1], Zc1[1:]))
    zmin = np.minimum(np.minimum(Zc[:-1], Zc[1:]), np.minimum(Zc1[:-1], Zc1[1:]))
    return (zmax > -margin) & (zmin < margin)


def _add_uncut(out: np.ndarray, grid: _Grid, a: np.ndarray, kernel: Kernel,
               flag: np.ndarray | None, rows_per_chunk: int) -> None:
    """Add the global rule over the patches not in ``flag`` (all above the horizon part if
    ``flag`` is None) to ``out`` (nb, count, C), chunked over patch rows."""
    q, nb = grid.q, a.shape[0]
    nrow, w, c = grid.lo.size, grid.cph.size // q, grid.WF.shape[2]
    Qn = np.outer(grid.cph, a[:, 0]) + np.outer(grid.sph, a[:, 1])         # (nph, nb)
    for s0 in range(0, nrow, rows_per_chunk):
        s1 = min(nrow, s0 + rows_per_chunk)
        sl = slice(s0 * q, s1 * q)
        Z = grid.st[sl, None, None] * Qn[None] + grid.ct[sl, None, None] * a[:, 2][None, None, :]
        pos = Z > 0.0
        if flag is not None:
            keep = ~flag[s0:s1]                                              # (ns, W, nb)
            pos = (pos.reshape(s1 - s0, q, w, q, nb)
                   & keep[:, None, :, None, :]).reshape(pos.shape)
        np.clip(Z, 0.0, 1.0, out=Z)
        wf_chunk = grid.WF[sl].reshape(-1, c)                                # (n, C)
        buf = np.empty(Z.size)
        for k, g in enumerate(kernel(Z)):
            np.multiply(g.reshape(-1), pos.reshape(-1), out=buf)
            # (nb, n) @ (n, C): this operand order is the fast one in OpenBLAS
            out[:, k, :] += buf.reshape(-1, nb).T @ wf_chunk


def _horizon_pieces(s, j, sa, ca, pa, lo, hi, w):
    """Split each flagged patch's φ-range where the horizon crosses its two rings.

    Returns (pair index, φ_lo, φ_hi) of the non-empty pieces that are (partly) above the
    horizon. Within a piece θ*(φ) stays inside the patch's θ-range or outside it.
    """
    dphi = 2.0 * np.pi / w
    p0 = 2.0 * np.pi * (j + 0.5) / w
    pts = horizon_breaks(lo[s], hi[s], p0, dphi, sa, ca, pa)
    plo = p0[:, None] + pts[:, :-1]
    phi_ = p0[:, None] + pts[:, 1:]
    mid = 0.5 * (plo + phi_)
    A = sa[:, None] * np.cos(mid - pa[:, None])
    ztop = A * np.sin(lo[s])[:, None] + (ca * np.cos(lo[s]))[:, None]
    zbot = A * np.sin(hi[s])[:, None] + (ca * np.cos(hi[s]))[:, None]
    keep = (phi_ - plo > 0.0) & ((ztop > 0.0) | (zbot > 0.0))
    return np.nonzero(keep)[0], plo[keep], phi_[keep]


def _clipped_nodes(t_lo, t_hi, sa, ca, pa, plo, phi_hi, rule):
    r"""Gauss nodes (θ, φ), u·a and weights (P, qf, qf) of the pieces above the horizon.

    Per piece the φ-range [plo, phi_hi] gets qf nodes (``rule`` = (nodes, weights) of the
    qf-point Gauss–Legendre rule on [0, 1]); at each the θ-range [t_lo, t_hi] of the piece's
    patch row is clipped at the root :math:`\theta^*` of
    :math:`A\sin\theta + B\cos\theta = u\cdot a = 0`,
    :math:`A = \sin\theta_a\cos(\varphi - \varphi_a)`, :math:`B = \cos\theta_a`.
    """
    xf, wf = rule
    L = phi_hi - plo
    phn = plo[:, None] + L[:, None] * xf[None, :]                          # (P, qf)
    wphn = L[:, None] * wf[None, :]
    Aph = sa[:, None] * np.cos(phn - pa[:, None])                          # (P, qf)
    t0, t1 = t_lo[:, None], t_hi[:, None]
    ztop = Aph * np.sin(t0) + ca[:, None] * np.cos(t0)
    zbot = Aph * np.sin(t1) + ca[:, None] * np.cos(t1)
    # the root of A sinθ + B cosθ in [0, π]
    neg = (-ca)[:, None] >= 0.0
    root = np.where(neg, np.arctan2(-ca[:, None], Aph), np.arctan2(ca[:, None], -Aph))
    root = np.clip(root, t0, t1)
    tlo = np.where(ztop >= 0.0, t0, np.where(zbot >= 0.0, root, t1))
    thi = np.where(zbot >= 0.0, t1, np.where(ztop >= 0.0, root, t0))
    thi = np.maximum(thi, tlo)
    thn = tlo[:, :, None] + (thi - tlo)[:, :, None] * xf[None, None, :]   # (P, qf, qf)
    wn = wphn[:, :, None] * (thi - tlo)[:, :, None] * wf[None, None, :] * np.sin(thn)
    phb = np.broadcast_to(phn[:, :, None], thn.shape)
    z = np.clip(Aph[:, :, None] * np.sin(thn) + ca[:, None, None] * np.cos(thn), 0.0, 1.0)
    return thn, phb, z, wn


def _add_cut(out: np.ndarray, data: np.ndarray, flag: np.ndarray, sa, ca, pa, grid: _Grid,
             kernel: Kernel) -> None:
    """Add the exact integrals over the flagged patches' parts above the horizon to ``out``
    (nb, count, C); sa, ca, pa: sin θ_a, cos θ_a, φ_a of the block's axes."""
    ss, jj, mm = np.nonzero(flag)
    if ss.size == 0:
        return
    nb, c = out.shape[0], out.shape[2]
    pair, plo, phi_hi = _horizon_pieces(ss, jj, sa[mm], ca[mm], pa[mm], grid.lo, grid.hi,
                                        data.shape[1])
    rule = gauss_legendre_01(grid.q + 1)
    step = int(max(1, BLOCK_ELEMENTS // (4 * (grid.q + 1) ** 2)))
    for p0 in range(0, pair.size, step):
        p1 = min(pair.size, p0 + step)
        pr = pair[p0:p1]
        s_, j_, m_ = ss[pr], jj[pr], mm[pr]
        thn, phb, z, wn = _clipped_nodes(grid.lo[s_], grid.hi[s_], sa[m_], ca[m_], pa[m_],
                                         plo[p0:p1], phi_hi[p0:p1], rule)
        P = s_.size
        fv = bilinear_in_patch(data, s_, j_, thn.reshape(P, -1), phb.reshape(P, -1))
        fw = fv * wn.reshape(P, -1)[:, :, None]                              # (P, n, C)
        for k, g in enumerate(kernel(z.reshape(P, -1))):
            contrib = np.einsum("pnc,pn->pc", fw, g)
            for ch in range(c):
                out[:, k, ch] += np.bincount(m_, weights=contrib[:, ch], minlength=nb)


def hemisphere_integrals(envmap: EnvMap, axes, kernel: Kernel, count: int, *, degree: int,
                         horizon: bool = True, axes_are_local: bool = False) -> np.ndarray:
    r""":math:`J_k(a) = \int_{u\cdot a > 0} f(u)\,g_k(u\cdot a)\,dS(u)` for k < ``count``, (M, count, C).

    f is the map's bilinear interpolant; ``kernel(z)`` yields the ``count`` arrays
    :math:`g_k(z)` (same shape as z, z ∈ [0, 1]); ``degree`` is their bandwidth D (trig
    degree in θ and φ, :func:`~envfit.shading._ground_truth.polynomial_degree` for a weight
    function, l for :math:`P_l(2z-1)`). The integral stops at the horizon even where
    g_k(0) ≠ 0 (Eq. 17 integrates over the hemisphere u·a > 0).

    Rule (see the module doc): q×q Gauss–Legendre per bilinear patch, q =
    :func:`~envfit.shading._patches.gauss_legendre_order` of (D + 2)·h/2 (:func:`_node_grid`,
    :func:`_add_uncut`); patches the horizon may cross (:func:`_horizon_flags`) are masked
    out and integrated piecewise with the horizon clipped exactly (q+1 nodes per piece and
    direction; :func:`_add_cut`). ``horizon=False`` skips that refinement (for kernels that
    vanish at the horizon to rounding, e.g. glossy n ≥ 30: the masked error is bounded by
    :math:`\max_{z<2h}|g|\cdot 4\pi h`). Work per axis: (H+1)·W·q² kernel evaluations plus
    O(H q²) on the cut patches; blocked over axes (:data:`BLOCK_ELEMENTS`).

    >>> m = EnvMap(np.full((8, 16, 1), 3.0))
    >>> J = hemisphere_integrals(m, [[0.0, 1.0, 0.0]], lambda z: iter([np.ones_like(z)]), 1,
    ...                          degree=0)
    >>> bool(abs(J[0, 0, 0] - 3.0 * 2.0 * np.pi) < 1e-9)          # f = 3 over 2π steradians
    True
    """
    count = check_int(count, "count", 1)
    degree = check_int(degree, "degree", 0)
    data = np.asarray(envmap.data, dtype=np.float64)
    h, w, c = data.shape
    A = (np.asarray(axes, dtype=np.float64) if axes_are_local
         else axes_to_local(axes, envmap.up))
    m_total = A.shape[0]
    out = np.zeros((m_total, count, c))
    if m_total == 0:
        return out
    hh = np.pi / h
    grid = _node_grid(envmap, gauss_legendre_order((degree + 2) * hh / 2.0))
    q, nph = grid.q, grid.cph.size
    theta_a, phi_a = local_angles(A)
    sa_all, ca_all = np.sin(theta_a), np.cos(theta_a)
    # block sizes: axes per block and patch rows per chunk
    mb = int(max(1, min(m_total, BLOCK_ELEMENTS // max(1, nph * q))))
    rows_per_chunk = int(max(1, BLOCK_ELEMENTS // max(1, mb * nph * q)))
    for m0 in range(0, m_total, mb):
        m1 = min(m_total, m0 + mb)
        a = A[m0:m1]
        flag = _horizon_flags(a, grid.lo, w, hh) if horizon else None
        _add_uncut(out[m0:m1], grid, a, kernel, flag, rows_per_chunk)
        if horizon:
            _add_cut(out[m0:m1], data, flag, sa_all[m0:m1], ca_all[m0:m1], phi_a[m0:m1],
                     grid, kernel)
    return out

r"""The near/far split that evaluates kernel sums in O(N log N): the kernel's power part
:math:`g(t) = (2 - 2t)^{s-1}` outside a cap of chordal radius δ is a polynomial
:math:`P_L(t)`, i.e. an SH convolution (ducc0), and pairs closer than δ get the exact
correction :math:`g - P_L` from a 3-D cell list (see :mod:`envfit.sobolev._interpolation`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
from scipy import special

from envfit.base import check_s
from envfit.base import ParameterError
from envfit.sobolev import _interpolation_kernels as _kernels

__all__ = ["FarFieldExpansion", "far_field_expansion", "near_radius", "CellList",
           "nearfar_power_sums", "SHT_EPSILON", "NEAR_NEIGHBOURS"]

#: ducc0 NUFFT SH transforms: requested accuracy (2e-13 is ducc0's float64 floor)
SHT_EPSILON = 3e-13
#: near/far split: target mean number of nodes within delta of a query
NEAR_NEIGHBOURS = 8.0
_DELTA_MIN, _DELTA_MAX = 0.02, 0.6


@dataclass(frozen=True)
class FarFieldExpansion:
    r"""Polynomial far field of :math:`g(t) = (2 - 2t)^a`, a = s - 1, for ``"nearfar"``.

    ``lmax`` = L, the degree of :math:`P_L \approx g` on :math:`[-1, 1 - \delta^2/2]`;
    ``sh_weights[l]`` = :math:`w_l = 4\pi g_l/(2l+1)`, :math:`P_L = \sum_l g_l P_l`, so that
    :math:`P_L(u\cdot v) = \sum_{l,m} w_l Y_{lm}(u) Y^*_{lm}(v)`; ``near_cheb``: Chebyshev
    coefficients of :math:`S(d^2) = P_L(1 - d^2/2)` on :math:`d^2 \in [0, \delta^2]`;
    ``far_error``: max :math:`|P_L - g|` on the far interval (checked on a fine grid).
    """
    s: float
    delta: float
    lmax: int
    sh_weights: np.ndarray
    near_cheb: np.ndarray
    far_error: float


def _chebyshev_coefficients(values: np.ndarray) -> np.ndarray:
    """Coefficients of the Chebyshev interpolant through values at x_k = cos(pi (k+1/2)/n)."""
    n = values.shape[0]
    c = scipy.fft.dct(values, type=2) / n
    c[0] /= 2
    return c


def _far_chebyshev(a: float, d2min: float, rtol: float) -> np.ndarray:
    r"""Step 1: Chebyshev coefficients of :math:`g(t) = (2-2t)^a` on :math:`[-1, t_0]`,
    :math:`t_0 = 1 - \delta^2/2`, evaluated as :math:`(d^2)^a` with
    :math:`d^2 = \delta^2 + (4 - \delta^2)\sin^2(\theta_k/2)` (no cancellation); truncated
    after the last coefficient above ``rtol * 4^a`` (the grid quadruples until it resolves)."""
    gmax = 4.0 ** a
    n = 1024
    while True:
        theta = np.pi * (np.arange(n) + 0.5) / n
        # t = ((t0 + 1) x + t0 - 1) / 2, x = cos(theta): 2 - 2t = d2min + (4 - d2min) sin^2(theta/2)
        d2 = d2min + (4.0 - d2min) * np.sin(theta / 2) ** 2
        c = _chebyshev_coefficients(d2 ** a)
        big = np.nonzero(np.abs(c) > rtol * gmax)[0]
        lmax = int(big[-1]) if big.size else 0
        if lmax < 0.6 * n or n >= 2**16:
            break
        n *= 4
    return c[: lmax + 1]


def _far_poly(t, c: np.ndarray, t0: float):
    """P_L(t) through the mapped Chebyshev variable of :func:`_far_chebyshev` on [-1, t0]."""
    x = (2.0 * t - (t0 - 1.0)) / (t0 + 1.0)
    return np.polynomial.chebyshev.chebval(x, c)


def _sh_weights(poly, lmax: int) -> np.ndarray:
    r"""Step 2: :math:`w_l = 4\pi g_l/(2l+1)`, :math:`P_L = \sum_l g_l P_l`, so that
    :math:`P_L(u\cdot v) = \sum_{lm} w_l Y_{lm}(u) Y^*_{lm}(v)`.

    The Legendre coefficients g_l by interpolation at the L + 1 Gauss-Legendre nodes (a
    well-conditioned square solve; the quadrature form sum_i w_i P_L(u_i) P_l(u_i) is
    mathematically the same but scipy's weights near +-1 carry ~1e-11 relative errors, which
    show up as 1e-10 errors of the series at t = -1)."""
    u, _ = special.roots_legendre(lmax + 1)
    vander = np.polynomial.legendre.legvander(u, lmax)
    g = np.linalg.solve(vander, poly(u))
    return 4.0 * np.pi * g / (2.0 * np.arange(lmax + 1) + 1.0)


def _near_chebyshev(poly, d2min: float, gmax: float) -> np.ndarray:
    r"""Step 3: Chebyshev coefficients of :math:`S(d^2) = P_L(1 - d^2/2)` on
    :math:`[0, \delta^2]` (degree ~20: those above 1e-14·4^a, plus two)."""
    m = 64
    y = np.cos(np.pi * (np.arange(m) + 0.5) / m)
    d2n = d2min * (1.0 + y) / 2.0
    cn = _chebyshev_coefficients(poly(1.0 - d2n / 2.0))
    keep = np.nonzero(np.abs(cn) > 1e-14 * gmax)[0]
    return np.ascontiguousarray(cn[: (int(keep[-1]) + 3 if keep.size else 1)])


def _far_error(poly, d2min: float, a: float) -> float:
    """Max |P_L - g| on the far interval, on a fine grid in d2 (geometric near the cut)."""
    d2c = np.concatenate([d2min * np.geomspace(1.0, 4.0 / d2min, 4001), np.linspace(d2min, 4.0, 4001)])
    return float(np.max(np.abs(poly(1.0 - d2c / 2.0) - d2c ** a)))


@functools.lru_cache(maxsize=32)
def far_field_expansion(s: float, delta: float, rtol: float = 1e-15) -> FarFieldExpansion:
    r"""The near/far split of the kernel for smoothness s and near radius ``delta``.

    1. Chebyshev interpolation of :math:`g(t) = (2-2t)^{s-1}` on :math:`[-1, t_0]`,
       :math:`t_0 = 1 - \delta^2/2`, evaluated as :math:`(d^2)^{s-1}` with
       :math:`d^2 = \delta^2 + (4 - \delta^2)\sin^2(\theta_k/2)` (no cancellation);
       truncated after the last coefficient above ``rtol * 4^(s-1)``: degree L
       (:func:`_far_chebyshev`).
    2. Legendre coefficients of :math:`P_L` on [-1, 1] by interpolation at the L + 1
       Gauss-Legendre nodes (:func:`_sh_weights`).
    3. :math:`S(d^2) = P_L(1 - d^2/2)` re-expanded on the near interval (degree ~20,
       :func:`_near_chebyshev`), and the far error checked on a fine grid (:func:`_far_error`).

    >>> ff = far_field_expansion(1.5, 0.1)
    >>> ff.lmax > 100 and ff.far_error < 1e-13
    True
    """
    s = check_s(s)
    a = s - 1.0
    delta = float(delta)
    if not (0.0 < delta < 2.0):
        raise ParameterError(f"near radius delta must be in (0, 2), got {delta}")
    d2min = delta * delta
    c = _far_chebyshev(a, d2min, rtol)
    lmax = c.size - 1
    poly = functools.partial(_far_poly, c=c, t0=1.0 - d2min / 2.0)
    return FarFieldExpansion(s=s, delta=delta, lmax=lmax, sh_weights=_sh_weights(poly, lmax),
                             near_cheb=_near_chebyshev(poly, d2min, 4.0 ** a),
                             far_error=_far_error(poly, d2min, a))


def near_radius(n: int) -> float:
    """delta with about :data:`NEAR_NEIGHBOURS` of N uniformly spread nodes within it
    (cap area fraction delta^2/4), rounded to 2 significant digits so that the cached
    expansion is reused across nearby N."""
    d = math.sqrt(4.0 * NEAR_NEIGHBOURS / max(n, 1))
    d = min(max(d, _DELTA_MIN), _DELTA_MAX)
    return float(f"{d:.2g}")


@dataclass
class CellList:
    """Nodes sorted by the cell of a uniform grid of side h >= delta over [-1, 1]^3."""
    h: float
    ngrid: int
    order: np.ndarray
    cell_start: np.ndarray
    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray

    @classmethod
    def build(cls, points: np.ndarray, delta: float) -> "CellList":
        ngrid = max(1, int(math.floor(2.0 / delta)))
        h = 2.0 / ngrid  # >= delta
        idx = np.minimum(((points + 1.0) / h).astype(np.int64), ngrid - 1)
        lin = (idx[:, 0] * ngrid + idx[:, 1]) * ngrid + idx[:, 2]
        order = np.argsort(lin, kind="stable")
        counts = np.bincount(lin, minlength=ngrid**3)
        start = np.zeros(ngrid**3 + 1, dtype=np.int64)
        np.cumsum(counts, out=start[1:])
        sp = points[order]
        return cls(h=h, ngrid=ngrid, order=order, cell_start=start,
                   px=np.ascontiguousarray(sp[:, 0]), py=np.ascontiguousarray(sp[:, 1]),
                   pz=np.ascontiguousarray(sp[:, 2]))


def _to_theta_phi(p: np.ndarray) -> np.ndarray:
    """(M, 2) colatitude, longitude in [0, 2 pi) of unit vectors (accurate at the poles)."""
    loc = np.empty((p.shape[0], 2))
    loc[:, 0] = np.arctan2(np.hypot(p[:, 0], p[:, 1]), p[:, 2])
    phi = np.arctan2(p[:, 1], p[:, 0])
    loc[:, 1] = np.where(phi < 0, phi + 2 * np.pi, phi)
    return loc


def nearfar_power_sums(points: np.ndarray, cells: "CellList", q: np.ndarray, alpha: np.ndarray,
                       s: float, delta: float, a: float, kind: int, nthreads: int) -> np.ndarray:
    r""":math:`\sum_j \alpha_j |q - p_j|^{2a}` for every query q and channel: the far field
    :math:`P_L` by two ducc0 SH transforms (adjoint synthesis at the nodes, synthesis at the
    queries, accuracy :data:`SHT_EPSILON`), plus the exact near correction :math:`g - P_L`
    for pairs closer than ``delta`` (numba, over the cell list). Returns (M, C)."""
    import ducc0  # heavy import, only here

    m, nc = q.shape[0], alpha.shape[1]
    ff = far_field_expansion(s, delta)
    lmax = ff.lmax
    # far field: alm = w_l sum_j alpha_j Y*_lm(p_j)
    node_loc = _to_theta_phi(points)
    l_of_index = np.concatenate([np.arange(mm, lmax + 1) for mm in range(lmax + 1)])
    weights = ff.sh_weights[l_of_index]
    alms = []
    for c in range(nc):  # ducc0: one scalar (spin-0) map per call
        alm = ducc0.sht.adjoint_synthesis_general(
            lmax=lmax, spin=0, map=np.ascontiguousarray(alpha[:, c])[None, :], loc=node_loc,
            epsilon=SHT_EPSILON, nthreads=nthreads)
        alm *= weights
        alms.append(alm)
    sw = np.ascontiguousarray(alpha[cells.order])
    near_cells = _kernels.NearCells(cells.h, cells.ngrid, cells.cell_start, cells.px, cells.py,
                                    cells.pz)
    law = _kernels.NearLaw(delta * delta, a, kind, ff.near_cheb)
    out = np.empty((m, nc))
    near = np.empty((min(m, 2**18), nc))
    for i0 in range(0, m, 2**18):  # bounded temporaries: loc (4 MB) and near (2 MB * C)
        i1 = min(m, i0 + 2**18)
        qb = q[i0:i1]
        qloc = _to_theta_phi(qb)
        nb = near[: i1 - i0]
        _kernels.near_field_correction(qb, near_cells, sw, law, nb)
        for c in range(nc):
            far = ducc0.sht.synthesis_general(alm=alms[c], spin=0, lmax=lmax, loc=qloc,
                                              epsilon=SHT_EPSILON, nthreads=nthreads)
            np.add(far[0], nb[:, c], out=out[i0:i1, c])
    return out

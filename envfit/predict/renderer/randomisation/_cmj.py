r"""Correlated multi-jittered sampling (Kensler 2013) as Mitsuba 3's ``multijitter`` builds it:
the exact MSE over uniformly random permutations and jitter.

Construction (Mitsuba 3.9 ``src/samplers/multijitter.cpp``: ``MultijitterSampler::next_2d``;
A. Kensler, "Correlated Multi-Jittered Sampling", Pixar Technical Memo 13-01, 2013, §3): a grid
of :math:`n_x\times n_y` coarse cells, N = :math:`n_x n_y` (Mitsuba: :math:`n_y = \lfloor\sqrt
{spp}\rfloor`, :math:`n_x = \lceil spp/n_y\rceil`); coarse cell (x, y) holds one point

.. math::  u = \Big(\frac{x + (\sigma_y(y) + j_x)/n_y}{n_x},\;
                    \frac{y + (\sigma_x(x) + j_y)/n_x}{n_y}\Big)

with *one* permutation :math:`\sigma_x` of :math:`n_x` (all columns' sub-rows) and one
:math:`\sigma_y` of :math:`n_y` (all rows' sub-columns), and fresh uniform jitter. With the fine
cells (1/N × 1/N) :math:`X = x n_y + b`, :math:`Y = y n_x + a`, the point of (x, y) is uniform in
fine cell :math:`(x n_y + \sigma_y(y),\, y n_x + \sigma_x(x))`. Write
:math:`G[x,b,y,a]` for the mean of :math:`h - I` over that fine cell and :math:`W` for the mean
within-fine-cell variance. For uniformly random :math:`\sigma_x, \sigma_y` (two points of one
column share a, of one row share b; distinct columns get distinct a, distinct rows distinct b):

.. math::  E(F - I)^2 = \frac{W}{N} + \frac1{N^2}\Big[\frac{T_1}{n_x n_y}
    + \frac{T_{x}}{n_x n_y(n_y-1)} + \frac{T_{y}}{n_y n_x(n_x-1)}
    + \frac{T_{xy}}{n_x(n_x-1)\,n_y(n_y-1)}\Big]

where :math:`T_1 = \sum G^2`, :math:`T_x = \sum_{x,a}\sum_{y\ne y',b\ne b'} G[x,b,y,a]
G[x,b',y',a]`, :math:`T_y` likewise with x ↔ y, a ↔ b, and :math:`T_{xy}` the sum over all four
indices different. Each restricted sum is an inclusion–exclusion over the index sets held
equal, :math:`\sum_{S}(-1)^{|S|}\sum_{\text{indices in }S}(\sum_{\text{others}} G)^2` — sums of
squared marginals of G, O(N²) in all. The power above the grid enters exactly as
:math:`P_\text{above}/N` (inside W) when N divides M; otherwise the fine cells cut grid cells
(:mod:`._strata`).
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._strata import rectangle_moments

__all__ = ["cmj_mse", "mitsuba_cmj_shape"]

_AXES = ("x", "b", "y", "a")            # G's axes: coarse column, sub-column, row, sub-row


def mitsuba_cmj_shape(spp: int) -> tuple[int, int]:
    r"""Mitsuba 3.9's ``multijitter`` grid :math:`(n_x, n_y)` = (⌈spp/⌊√spp⌋⌉, ⌊√spp⌋); the
    sample count becomes :math:`n_x n_y` (32 → 35)."""
    ny = max(1, math.isqrt(int(spp)))
    return -(-int(spp) // ny), ny


def _restricted(g: np.ndarray, equal: tuple[str, ...], different: tuple[str, ...]) -> float:
    """Σ over pairs of index tuples equal on ``equal`` and different on every axis of
    ``different`` of G[i]·G[i'], by inclusion–exclusion (axes not named are not allowed)."""
    total = 0.0
    for k in range(len(different) + 1):
        for extra in itertools.combinations(different, k):
            keep = {_AXES.index(a) for a in equal + extra}
            other = tuple(i for i in range(4) if i not in keep)
            marginal = g.sum(axis=other) if other else g
            total += (-1.0) ** k * float(np.sum(marginal * marginal))
    return total


def _pair_sum(g: np.ndarray, nx: int, ny: int) -> float:
    r""":math:`E(\sum_p g_p)^2` over the permutations for one channel, G (nx, ny, ny, nx)."""
    out = float(np.sum(g * g)) / (nx * ny)
    if ny > 1:
        out += _restricted(g, ("x", "a"), ("b", "y")) / (nx * ny * (ny - 1))
    if nx > 1:
        out += _restricted(g, ("y", "b"), ("x", "a")) / (ny * nx * (nx - 1))
    if nx > 1 and ny > 1:
        out += _restricted(g, (), ("x", "b", "y", "a")) / (nx * (nx - 1) * ny * (ny - 1))
    return out


def cmj_mse(grid: DyadicGrid, n: int, *, nx: int | None = None,
            ny: int | None = None) -> RandomisedMSE:
    """The exact MSE of correlated multi-jittered sampling on an nx × ny grid, N = nx·ny
    (default: Mitsuba's shape for ``n``, which must then equal nx·ny)."""
    if nx is None and ny is None:
        nx, ny = mitsuba_cmj_shape(n)
    elif nx is None or ny is None:
        raise ParameterError("give both nx and ny, or neither (Mitsuba's shape)")
    if not (isinstance(nx, (int, np.integer)) and isinstance(ny, (int, np.integer))
            and nx >= 1 and ny >= 1 and nx * ny == n):
        raise ParameterError(f"correlated multi-jittering takes N = nx·ny points: N = {n}, "
                             f"nx = {nx!r}, ny = {ny!r} (Mitsuba's multijitter rounds spp up "
                             f"to nx·ny: {n} → {math.prod(mitsuba_cmj_shape(n))})")
    nx, ny = int(nx), int(ny)
    edges = np.arange(n + 1) / n
    fine, within = rectangle_moments(grid, edges, edges)       # (C, N, N): X along u1
    g = fine.reshape(grid.channels, nx, ny, ny, nx)            # [c, x, b, y, a]
    perm = np.array([_pair_sum(g[c], nx, ny) for c in range(grid.channels)]) / float(n * n)
    jitter = within.mean(axis=(1, 2)) / n
    above = grid.above / n
    aligned = grid.size % n == 0
    note = "exact (N divides M)" if aligned else \
        "fine cells cut grid cells: their share by the cell-constant interpolant"
    return make_result("cmj", n, perm + jitter - above, above, exact=aligned, note=note)

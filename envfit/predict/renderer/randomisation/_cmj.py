r"""Correlated multi-jittered sampling (Kensler 2013): the exact MSE over uniformly random
permutations and jitter, or over a sampler's hashed permutations given by their pair tables.

Construction (A. Kensler, "Correlated Multi-Jittered Sampling", Pixar Technical Memo 13-01,
2013, §3): a grid of :math:`n_x\times n_y` coarse cells, N = :math:`n_x n_y` (by default
:func:`cmj_shape`: :math:`n_y = \lfloor\sqrt N\rfloor`, :math:`n_x = \lceil N/n_y\rceil`);
coarse cell (x, y) holds one point

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

A sampler may draw its permutations from a hash rather than uniformly (Kensler's own
``permute``, far from uniform for small :math:`n_x, n_y`). With ``permutations`` a
:class:`~envfit.renderers.PermutationLaw` (the sampler's record gives it) the expectation is
taken over that law instead, through its pair tables
:math:`P_x[(x,a),(x',a')] = \Pr(\sigma_x(x)=a, \sigma_x(x')=a')` (and :math:`P_y`), σ_x and
σ_y independent:

.. math::  E\Big(\sum_p g_p\Big)^2 = \sum P_x[(x,a),(x',a')]\,
           \big(\mathbf G P_y \mathbf G^\top\big)[(x,a),(x',a')],\qquad
           \mathbf G[(x,a),(y,b)] = G[x,b,y,a],

two matrix products of side N (the uniform tables give back the formula above — a test),
and the jitter term weights each fine cell's within-variance by
:math:`\Pr(\sigma_x(x)=a)\Pr(\sigma_y(y)=b)`.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._strata import rectangle_moments

__all__ = ["cmj_mse", "cmj_shape", "table_moments", "uniform_pair_table"]

_AXES = ("x", "b", "y", "a")            # G's axes: coarse column, sub-column, row, sub-row


def cmj_shape(n: int) -> tuple[int, int]:
    r"""The most nearly square grid of at least N cells, :math:`(n_x, n_y)` =
    (⌈N/⌊√N⌋⌉, ⌊√N⌋): :func:`cmj_mse`'s default (32 → 35 cells)."""
    ny = max(1, math.isqrt(int(n)))
    return -(-int(n) // ny), ny


def uniform_pair_table(length: int) -> np.ndarray:
    r"""The pair table of a uniformly random permutation: :math:`\delta_{yy'}\delta_{bb'}/l`
    on the diagonal, :math:`(1-\delta_{yy'})(1-\delta_{bb'})/(l(l-1))` off it."""
    eye = np.eye(length)
    same = np.einsum("yz,bc->ybzc", eye, eye) / length
    if length == 1:
        return same.reshape(1, 1)
    other = np.einsum("yz,bc->ybzc", 1.0 - eye, 1.0 - eye) / (length * (length - 1))
    return (same + other).reshape(length * length, length * length)


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


def table_moments(g: np.ndarray, within: np.ndarray, px: np.ndarray,
                  py: np.ndarray) -> tuple[float, float]:
    r"""(E(Σ_p g_p)², E Σ_p w_p) for one channel over permutations with pair tables
    ``px`` (nx², nx²) and ``py`` (ny², ny²); g and within are (nx, ny, ny, nx) = [x, b, y, a]."""
    nx, ny = g.shape[0], g.shape[1]
    gm = g.transpose(0, 3, 2, 1).reshape(nx * nx, ny * ny)           # [(x, a), (y, b)]
    pairs = float(np.sum(px * (gm @ py @ gm.T)))
    wm = within.transpose(0, 3, 2, 1).reshape(nx * nx, ny * ny)
    return pairs, float(np.diag(px) @ wm @ np.diag(py))


def _shape(n: int, nx, ny) -> tuple[int, int]:
    if nx is None and ny is None:
        nx, ny = cmj_shape(n)
    elif nx is None or ny is None:
        raise ParameterError("give both nx and ny, or neither (the most nearly square grid)")
    if not (isinstance(nx, (int, np.integer)) and isinstance(ny, (int, np.integer))
            and nx >= 1 and ny >= 1 and nx * ny == n):
        raise ParameterError(f"correlated multi-jittering takes N = nx·ny points: N = {n}, "
                             f"nx = {nx!r}, ny = {ny!r} (the most nearly square grid rounds N "
                             f"up to nx·ny: {n} → {math.prod(cmj_shape(n))})")
    return int(nx), int(ny)


def cmj_mse(grid: DyadicGrid, n: int, *, nx: int | None = None, ny: int | None = None,
            permutations="uniform") -> RandomisedMSE:
    """The exact MSE of correlated multi-jittered sampling on an nx × ny grid, N = nx·ny
    (default: :func:`cmj_shape` of ``n``, which must then equal nx·ny), over uniformly random
    permutations (``"uniform"``) or over a sampler's hashed ones (``permutations`` a
    :class:`~envfit.renderers.PermutationLaw`: its ``pair_table``)."""
    nx, ny = _shape(n, nx, ny)
    hashed = permutations != "uniform"
    if hashed and not callable(getattr(permutations, "pair_table", None)):
        raise ParameterError(f"permutations must be 'uniform' or a PermutationLaw, "
                             f"got {permutations!r}")
    edges = np.arange(n + 1) / n
    fine, within = rectangle_moments(grid, edges, edges)       # (C, N, N): X along u1
    g = fine.reshape(grid.channels, nx, ny, ny, nx)            # [c, x, b, y, a]
    if not hashed:
        perm = np.array([_pair_sum(g[c], nx, ny) for c in range(grid.channels)])
        jitter = within.mean(axis=(1, 2)) * n
    else:
        px, py = permutations.pair_table(nx), permutations.pair_table(ny)
        w = within.reshape(grid.channels, nx, ny, ny, nx)
        both = np.array([table_moments(g[c], w[c], px, py) for c in range(grid.channels)])
        perm, jitter = both[:, 0], both[:, 1]
    total = (perm + jitter) / float(n * n)
    above = grid.above / n
    aligned = grid.size % n == 0 and not hashed
    name = permutations.name if hashed else permutations
    note = f"{name} permutations; " + ("exact (N divides M)" if grid.size % n == 0 else
                                       "fine cells cut grid cells: their share by the "
                                       "cell-constant interpolant")
    if hashed and permutations.note:
        note += f"; {permutations.note}"
    return make_result("cmj", n, total - above, above, exact=aligned, note=note)

r"""A random digital (XOR) shift of a digital net: one XOR scramble per pixel of the net's
integer digits (in base 2, random digit permutations are such a shift). Which renderers'
samplers randomise so, read from which source, their folders say.

With :math:`y_j = x_j \oplus \Delta`, Δ uniform, :math:`\mathrm{wal}_k(x\oplus\Delta) =
\mathrm{wal}_k(x)\,\mathrm{wal}_k(\Delta)`, so :math:`F - I = \sum_{k\ne0}\hat h(k)\,
\mathrm{wal}_k(\Delta)\,S(k)` with :math:`S(k) = \frac1N\sum_j\mathrm{wal}_k(x_j)` = 1 on the
dual net :math:`D^*` and 0 elsewhere; the Walsh functions are orthonormal in Δ, hence

.. math::  E_\Delta (F - I)^2 = \sum_{k\in D^*\setminus\{0\}} \hat h(k)^2

(the Walsh analogue of the shifted-lattice variance of Sloan & Joe 1994, Lemma 2.3; J. Dick,
F. Pillichshammer, *Digital Nets and Sequences* (2010), ch. 13; exact for every h in L²). Indices below M come exactly from the grid's Walsh
coefficients (:mod:`._walsh`). Above the grid (:math:`k_1 \ge M` or :math:`k_2 \ge M`)
membership is fixed by the low m digits, i.e. by :math:`k \bmod M`; the part is estimated as

.. math::  P_\text{above}\;\frac{\sum_{k\in\text{shell}\,\cap D^*}\hat h(k)^2}
           {\sum_{k\in\text{shell}}\hat h(k)^2},\qquad
           \text{shell} = \{k < M:\ \max(k_1, k_2)\ge M/2\}

(needs N ≤ M/2), the dual net's share of the power in the grid's finest resolved shell. It is
exact when h is linear inside the cells of the level-(L−1) grid (the Walsh coefficients of the
within-cell ramps sit at :math:`(c_1 + 2^{s-1}, c_2)`, s > L − 1, with the membership of
:math:`(c_1, c_2)`, the same at every level beyond m), and tends to the density 1/N of dual
indices when the fine structure is incoherent from cell to cell (a jump along a non-dyadic
line). It is an estimate (``exact=False``) within :math:`[0, P_\text{above}]`; where N = M it
falls back to 1/N (the Owen-scrambled value of that power). On the tests' smooth integrand at
M = 4N the plain 1/N rule misses 8 % of the MSE, this one 1.5 %.

Where the grid holds a sampled value of the power above it (:mod:`._shift_samples`), that
value is used instead: unbiased, for any N — also N > M, where this estimate has nothing to
stand on.

The order in which a renderer visits the points does not change the mean, so a sampler's
per-dimension index permutation plays no part.
"""
from __future__ import annotations

import numpy as np

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._nets import get_net, net_exponent

__all__ = ["digital_shift_mse", "dual_sum", "shell_share"]


def dual_sum(first: np.ndarray, second: np.ndarray, mask: np.ndarray) -> np.ndarray:
    r""":math:`\sum_{k\in D^*\setminus 0,\,k<M}\hat h(k)\hat h'(k)` per channel."""
    mask = mask.copy()
    mask[0, 0] = False
    return np.einsum("cij,cij->c", first * mask, second)


def shell_share(coeffs: np.ndarray, mask: np.ndarray, n: int) -> np.ndarray:
    """The dual net's share of the Walsh power in the finest shell of the grid, per channel
    (1/N where N = M or the shell holds no power)."""
    size = mask.shape[0]
    if n > size // 2:
        return np.full(coeffs.shape[0], 1.0 / n)
    power = coeffs[:, size // 2:, :] ** 2, coeffs[:, :size // 2, size // 2:] ** 2
    total = power[0].sum(axis=(1, 2)) + power[1].sum(axis=(1, 2))
    dual = (power[0] * mask[size // 2:, :]).sum(axis=(1, 2)) \
        + (power[1] * mask[:size // 2, size // 2:]).sum(axis=(1, 2))
    return np.where(total > 0, dual / np.where(total > 0, total, 1.0), 1.0 / n)


def digital_shift_mse(grid: DyadicGrid, n: int, *, net: str = "sobol") -> RandomisedMSE:
    """The MSE of the first ``n`` points of ``net`` under a uniform random digital shift.

    The power above the grid is the grid's sampled value where it holds one for (net, n)
    (:meth:`DyadicGrid.with_shift_above`, :mod:`._shift_samples`; any N, also N > M),
    else the estimate of the module docstring (N ≤ M)."""
    sampled = grid.shift_above.get((net, int(n)))
    m = net_exponent(n, None if sampled is not None else grid.size)
    coeffs = grid.walsh
    mask = get_net(net).dual_mask(m, grid.size)
    resolved = dual_sum(coeffs, coeffs, mask)
    if sampled is not None:
        return make_result("digital_shift", n, resolved, sampled[0], exact=False,
                           above_se=sampled[1],
                           note="indices < M exact; the power above the grid sampled over "
                                "random shifts with a control variate (an estimate, with "
                                "its standard error)")
    share = shell_share(coeffs, mask, n)
    return make_result("digital_shift", n, resolved, grid.above * share, exact=False,
                       note="indices < M exact; the power above the grid at the dual net's "
                            "share of the finest resolved shell (an estimate)")

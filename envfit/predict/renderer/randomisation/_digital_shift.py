r"""A random digital (XOR) shift of a digital net — Mitsuba 3's ``ldsampler`` (one XOR scramble
per pixel of the (0, 2)-sequence's integer digits; ``src/samplers/ldsampler.cpp``:
``LowDiscrepancySampler::next_2d``) and pbrt-v4's ``permutedigits``-style randomisation of
a Sobol' block.

With :math:`y_j = x_j \oplus \Delta`, Δ uniform, :math:`\mathrm{wal}_k(x\oplus\Delta) =
\mathrm{wal}_k(x)\,\mathrm{wal}_k(\Delta)`, so :math:`F - I = \sum_{k\ne0}\hat h(k)\,
\mathrm{wal}_k(\Delta)\,S(k)` with :math:`S(k) = \frac1N\sum_j\mathrm{wal}_k(x_j)` = 1 on the
dual net :math:`D^*` and 0 elsewhere; the Walsh functions are orthonormal in Δ, hence

.. math::  E_\Delta (F - I)^2 = \sum_{k\in D^*\setminus\{0\}} \hat h(k)^2

(the Walsh analogue of the shifted-lattice variance of Sloan & Joe 1994, Lemma 2.3; J. Dick,
F. Pillichshammer, *Digital Nets and Sequences* (2010), ch. 13; exact for every h in L²). Indices below M come exactly from the grid's Walsh
coefficients (:mod:`._walsh`). Above the grid (:math:`k_1 \ge M` or :math:`k_2 \ge M`, M ≥ N)
membership is fixed by the low m digits; for a (0, m, 2)-net every dyadic block there holds
exactly a fraction 1/N of dual indices, so the part is taken as :math:`P_\text{above}/N` —
exact on average over the digits' order inside each block (it *is* the Owen-scrambled value
of that power), not exact for the shift: it lies in :math:`[0, P_\text{above}]`, and is
reported with ``exact=False``.

The order in which a renderer visits the points does not change the mean, so Mitsuba's
per-dimension index permutation plays no part.
"""
from __future__ import annotations

import numpy as np

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._nets import get_net, net_exponent
from ._walsh import walsh_coefficients

__all__ = ["digital_shift_mse", "dual_sum"]


def dual_sum(first: np.ndarray, second: np.ndarray, mask: np.ndarray) -> np.ndarray:
    r""":math:`\sum_{k\in D^*\setminus 0,\,k<M}\hat h(k)\hat h'(k)` per channel."""
    mask = mask.copy()
    mask[0, 0] = False
    return np.einsum("cij,cij->c", first * mask, second)


def digital_shift_mse(grid: DyadicGrid, n: int, *, net: str = "sobol") -> RandomisedMSE:
    """The MSE of the first ``n`` points of ``net`` under a uniform random digital shift."""
    m = net_exponent(n, grid.size)
    coeffs = walsh_coefficients(grid.centred()[0])
    mask = get_net(net).dual_mask(m, grid.size)
    resolved = dual_sum(coeffs, coeffs, mask)
    return make_result("digital_shift", n, resolved, grid.above / n, exact=False,
                       note="indices < M exact; the power above the grid at the net's block "
                            "density 1/N (approximation within [0, P_above])")

r"""Nested uniform (Owen) scrambling of a digital net — what renderers' Owen-scrambled Sobol'
samplers draw (hashed scramblers whose law the tests check against this one; which samplers,
read from which source, their folders say).

Owen (1997) showed for a scrambled (0, m, 2)-net, and Dick & Pillichshammer (2010, ch. 13) for
any digital net, that the variance is a weighted sum of the base-2 Haar variance components:

.. math::  \mathrm{Var}\,F = \sum_{\kappa\ne(-1,-1)} \Gamma_\kappa\,\sigma^2_\kappa,\qquad
           \Gamma_\kappa = \frac{|D^*\cap B_\kappa|}{|B_\kappa|},

:math:`\sigma^2_\kappa = \sum_{k\in B_\kappa}\hat h(k)^2` the Walsh power of dyadic block κ
(:mod:`._walsh`) and :math:`\Gamma_\kappa` the share of the block in the dual net
(:mod:`._nets`; N·Γ is Owen's *gain*, 1 for Monte Carlo; Pan & Owen (2023) tabulate the gains
of Sobol' nets). The tests check this identity by brute force against a bit-by-bit nested
uniform scramble rather than trusting it. Blocks inside the grid are exact. Above the grid
(M ≥ N) every block of a (0, m, 2)-net has :math:`\Gamma_\kappa = 1/N` exactly (for each low
digit pattern of :math:`k_1` one of :math:`k_2` completes a dual index), so the power above the
grid enters exactly as :math:`P_\text{above}/N`; for nets without that property the gains above
the grid are checked and the largest used (``exact=False``).

Beyond the grid (N > M/2), where the grid holds a sampled value of the power above it for
(net, N) (:meth:`DyadicGrid.with_sampled_above`, :mod:`._owen_samples`), the blocks below the
grid keep their exact gains (the net's dual read modulo N) and the rest is that sampled value:
an unbiased estimate with its standard error, for any N.

References: A. B. Owen, "Scrambled net variance for integrals of smooth functions", Ann. Stat.
25 (1997) and "Monte Carlo variance of scrambled net quadrature", SIAM J. Numer. Anal. 34
(1997); J. Dick, F. Pillichshammer, *Digital Nets and Sequences* (2010), ch. 13; Z. Pan,
A. B. Owen, "The nonzero gain coefficients of Sobol's sequences are always powers of two",
J. Complexity 75 (2023).
"""
from __future__ import annotations

import functools

import numpy as np

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._nets import get_net, net_exponent
from ._walsh import block_edges, block_sums

__all__ = ["owen_gains", "owen_mse"]


@functools.lru_cache(maxsize=256)
def owen_gains(net: str, m: int, size: int) -> np.ndarray:
    r""":math:`\Gamma_\kappa` for the blocks below ``size``, shape (L + 1, L + 1) (position
    κ + 1; the block (0, 0) of the mean gets 0); a property of the net alone, computed once
    per (net, m, size) and read-only (the model asks it for every normal and cell)."""
    mask = get_net(net).dual_mask(m, size).astype(np.float64)
    count = np.diff(np.append(block_edges(size), size))
    gains = block_sums(mask) / (count[:, None] * count[None, :])
    gains[0, 0] = 0.0
    gains.flags.writeable = False
    return gains


@functools.lru_cache(maxsize=64)
def _above_gain(net: str, m: int) -> tuple[float, bool]:
    """The largest gain of the blocks beyond 2^m (they repeat the residues), and whether all
    blocks with an index ≥ 2^m have gain 1/N."""
    size = 1 << (m + 1)
    g = owen_gains(net, m, size)
    outside = g[m + 1:, :].ravel().tolist() + g[:, m + 1:].ravel().tolist()
    n = 1 << m
    return max(outside), bool(np.allclose(outside, 1.0 / n, rtol=1e-12, atol=0.0))


def owen_mse(grid: DyadicGrid, n: int, *, net: str = "sobol") -> RandomisedMSE:
    """The variance of the first ``n`` points of ``net`` under nested uniform scrambling:
    exact from the grid (N ≤ M), or with the power above the grid sampled where the grid
    holds it for (net, n) (:mod:`._owen_samples`; any N)."""
    sampled = grid.sampled.get(("owen", net, int(n)))
    m = net_exponent(n, None if sampled is not None else grid.size)
    coeffs = grid.walsh
    sigma2 = block_sums(coeffs ** 2)
    gains = owen_gains(net, m, grid.size)
    resolved = np.einsum("ij,cij->c", gains, sigma2)
    if sampled is not None:
        return make_result("owen", n, resolved, sampled[0], exact=False, above_se=sampled[1],
                           note="blocks below the grid exact; the power above it sampled "
                                "over random nested uniform scrambles with a control variate "
                                "(an estimate, with its standard error)")
    top, exact = _above_gain(net, m)
    gain = 1.0 / n if exact else top
    note = "exact: every block above the grid has gain 1/N" if exact else \
        "blocks above the grid at their largest gain (a bound)"
    return make_result("owen", n, resolved, grid.above * gain, exact=exact, note=note)

r"""Independent uniform points (a renderer's ``independent`` sampler): the Monte Carlo
variance

.. math::  E(F - I)^2 = \frac{V}{N}, \qquad V = \int h^2 - \Big(\int h\Big)^2 ,

split as (resolved variance)/N + :math:`P_\text{above}`/N, both exact (the grid's split of V
is exact).

Reference: any Monte Carlo text, e.g. A. B. Owen, *Monte Carlo theory, methods and examples*
(2013), ch. 2.
"""
from __future__ import annotations

from ._grid import DyadicGrid, RandomisedMSE, make_result

__all__ = ["independent_mse"]


def independent_mse(grid: DyadicGrid, n: int) -> RandomisedMSE:
    """The exact MSE of the mean of ``n`` i.i.d. uniform points, V/N per channel."""
    return make_result("independent", n, grid.resolved_variance / n, grid.above / n,
                       note="V/N (exact)")

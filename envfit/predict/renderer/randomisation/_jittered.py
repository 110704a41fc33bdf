r"""Jittered (stratified) sampling on r × r strata, one uniform point per stratum
(Mitsuba ``stratified``, pbrt-v4 ``stratified``):

.. math::  E(F - I)^2 = \frac1{N^2}\sum_{a,b} \sigma^2_{ab}
           = \frac1N\int h^2 - \sum_{a,b}\Big(\int_{S_{ab}} h\Big)^2, \qquad N = r^2,

:math:`\sigma^2_{ab}` the variance of h under a uniform point of stratum
:math:`S_{ab} = [a/r,(a+1)/r)\times[b/r,(b+1)/r)` (the order in which a renderer visits the
strata does not change the mean). The power above the grid enters exactly as
:math:`P_\text{above}/N` when r divides M (each stratum is a union of cells); the rest is the
within-stratum variance of the cell means. When r does not divide M the strata means are those
of the cell-constant interpolant on the cut cells (:mod:`._strata`; tests bound the effect:
r = 3, 5, 6, 7 on M = 256 agree with brute force within its standard error).

Reference: A. B. Owen, *Monte Carlo theory, methods and examples* (2013), ch. 10
(stratification); Mitsuba 3 ``src/samplers/stratified.cpp``: ``StratifiedSampler::next_2d``
(spp rounded up to the next square).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._strata import rectangle_moments

__all__ = ["jittered_mse"]


def jittered_mse(grid: DyadicGrid, n: int, *, r: int | None = None) -> RandomisedMSE:
    """The exact MSE of r × r jittered sampling, N = r² (``r`` defaults to √n, which must then
    be an integer)."""
    if r is None:
        r = math.isqrt(n)
    if not (isinstance(r, (int, np.integer)) and r >= 1 and r * r == n):
        raise ParameterError(f"jittered sampling takes N = r² points: N = {n} with r = {r!r} "
                             f"(Mitsuba's stratified rounds spp up to the next square)")
    edges = np.arange(r + 1) / r
    _, within = rectangle_moments(grid, edges, edges)
    total = within.sum(axis=(1, 2)) / float(n * n)
    aligned = grid.size % r == 0
    above = grid.above / n
    note = "exact (r divides M)" if aligned else \
        "strata cut grid cells: their share by the cell-constant interpolant"
    return make_result("jittered", n, total - above, above, exact=aligned, note=note)

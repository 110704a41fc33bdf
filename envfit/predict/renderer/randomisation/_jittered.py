r"""Jittered (stratified) sampling, one uniform point per stratum of N strata of area 1/N:

.. math::  E(F - I)^2 = \frac1{N^2}\sum_s \sigma^2_s
           = \frac1N\int h^2 - \sum_s\Big(\int_{S_s} h\Big)^2,

:math:`\sigma^2_s` the variance of h under a uniform point of stratum :math:`S_s` (the order
in which a renderer visits the strata does not change the mean). The strata's layout:

* ``layout="square"``: r × r cells, N = r² (a sampler that rounds its spp up to a square);
* ``strata=(x, y)``: x × y cells, x along :math:`u_0`, N = x·y (a sampler's own rectangle,
  from its record's options); x = y gives ``"square"``;
* ``layout="rows"``: envfit's own :func:`envfit.theory.jitter_strata` — k = round(√N) bands in
  :math:`u_1`, band b holding :math:`c_b = \lfloor N/k\rfloor` or :math:`\lceil N/k\rceil`
  cells of width :math:`1/c_b` and height :math:`c_b/N`; a square N gives ``"square"``.

The power above the grid enters exactly as :math:`P_\text{above}/N` when every stratum edge
is on the grid (each stratum a union of cells); otherwise the strata means are those of the
cell-constant interpolant on the cut cells (:mod:`._strata`; tests bound the effect:
r = 3, 5, 6, 7 on M = 256 agree with brute force within its standard error).

Reference: A. B. Owen, *Monte Carlo theory, methods and examples* (2013), ch. 10
(stratification).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._strata import rectangle_moments

__all__ = ["jittered_mse", "JITTER_LAYOUTS"]

#: the strata layouts of :func:`jittered_mse` (besides explicit ``strata=(x, y)``)
JITTER_LAYOUTS = ("square", "rows")


def _within_sum(grid: DyadicGrid, n: int, strata) -> tuple[np.ndarray, bool]:
    """(Σ over strata of the within-stratum variance (C,), whether every edge is on the
    grid) for N strata: ``strata`` (x, y), or None for envfit's rows."""
    m = grid.size
    on = (lambda e: bool(np.all(np.abs(np.asarray(e) * m - np.rint(np.asarray(e) * m))
                                < 1e-9)))
    if strata is not None:
        x, y = strata
        e1, e2 = np.arange(x + 1) / x, np.arange(y + 1) / y
        _, within = rectangle_moments(grid, e1, e2)
        return within.sum(axis=(1, 2)), on(e1) and on(e2)
    k = max(1, int(round(math.sqrt(n))))                  # envfit's rows (jitter_strata)
    counts = np.full(k, n // k, dtype=np.int64)
    counts[: n % k] += 1
    bands = np.concatenate([[0], np.cumsum(counts)]) / n   # edges in u_1
    total, aligned = np.zeros(grid.channels), on(bands)
    for c in np.unique(counts):
        e1 = np.arange(c + 1) / c
        _, within = rectangle_moments(grid, e1, bands)     # (C, c, k): every band cut c ways
        total += within[:, :, counts == c].sum(axis=(1, 2))
        aligned = aligned and on(e1)
    return total, aligned


def jittered_mse(grid: DyadicGrid, n: int, *, r: int | None = None,
                 layout: str = "square", strata: tuple[int, int] | None = None
                 ) -> RandomisedMSE:
    """The exact MSE of jittered sampling of N strata (module docstring): ``layout``
    ``"square"`` takes r × r strata, N = r² (``r`` defaults to √n, which must then be an
    integer); ``strata=(x, y)`` x × y strata, N = x·y; ``"rows"`` any N."""
    if layout not in JITTER_LAYOUTS:
        raise ParameterError(f"layout must be one of {', '.join(JITTER_LAYOUTS)}, "
                             f"got {layout!r}")
    if strata is not None:
        x, y = strata
        if not (isinstance(x, (int, np.integer)) and isinstance(y, (int, np.integer))
                and x >= 1 and y >= 1 and x * y == n):
            raise ParameterError(f"jittered strata (x, y) take N = x·y points: N = {n}, "
                                 f"strata = {strata!r}")
        layout, r = ("square", int(x)) if x == y else ("strata", None)
    if r is None:
        r = math.isqrt(n)
    if layout == "rows" and r * r == n:
        layout = "square"
    if layout == "square":
        if not (isinstance(r, (int, np.integer)) and r >= 1 and r * r == n):
            raise ParameterError(f"jittered sampling takes N = r² points: N = {n} with "
                                 f"r = {r!r} (a sampler whose strata are square rounds its "
                                 f"spp up to the next square)")
        edges = np.arange(r + 1) / r
        _, within = rectangle_moments(grid, edges, edges)
        total = within.sum(axis=(1, 2))
        aligned = grid.size % r == 0
    else:
        total, aligned = _within_sum(grid, n, (int(x), int(y)) if layout == "strata" else None)
    total = total / float(n * n)
    above = grid.above / n
    note = "exact (every stratum a union of cells)" if aligned else \
        "strata cut grid cells: their share by the cell-constant interpolant"
    return make_result("jittered", n, total - above, above, exact=aligned, note=note)

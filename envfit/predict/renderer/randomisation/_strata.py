r"""Means and within-variances of h over the rectangles of a product partition of the square,
from a :class:`~envfit.predict.renderer.randomisation._grid.DyadicGrid` (the strata of jittered
sampling, the fine cells of correlated multi-jittering).

Where every edge is a multiple of 1/M the rectangles are unions of grid cells and the moments
are exact (sums of cell means). Otherwise the rectangle integrals of h and h² are those of the
*cell-constant* interpolant of A and B (the 2-D cumulative integral is bilinear inside a cell,
so its bilinear interpolation at the edges is exact for that interpolant): only the cells cut by
an edge are approximated, each by its area share, an error of at most a cell's within-cell
variation on ~2·(strata per side)·M of the M² cells.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rectangle_moments", "cumulative_integral"]


def _aligned(edges: np.ndarray, m: int) -> np.ndarray | None:
    """The edges as integer cell indices, or None when one is not on the grid."""
    scaled = edges * m
    idx = np.rint(scaled)
    if np.all(np.abs(scaled - idx) < 1e-9):
        return idx.astype(np.int64)
    return None


def _interp_nodes(edges: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """(i0, t): the linear interpolation on the nodes 0…M at the points ``edges``·M — the
    lower node and the weight of the upper one (1 − t on i0)."""
    x = np.clip(edges * m, 0.0, float(m))
    i0 = np.minimum(np.floor(x).astype(np.int64), m - 1)
    return i0, x - i0


def cumulative_integral(cells: np.ndarray) -> np.ndarray:
    """The cumulative integral (C, M + 1, M + 1) at the grid's nodes of the cell-constant
    function with cell means ``cells`` (C, M, M): a summed-area table over M²."""
    m = cells.shape[1]
    q = np.zeros((cells.shape[0], m + 1, m + 1))
    q[:, 1:, 1:] = np.cumsum(np.cumsum(cells, axis=1), axis=2) / float(m * m)
    return q


def _rect_integrals(q: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Integrals over the rectangles of the cell-constant function whose cumulative integral
    is ``q`` (:func:`cumulative_integral`), by the bilinear interpolation of ``q``."""
    m = q.shape[1] - 1
    (i1, t1), (i2, t2) = _interp_nodes(e1, m), _interp_nodes(e2, m)
    q = (1.0 - t1)[None, :, None] * q[:, i1] + t1[None, :, None] * q[:, i1 + 1]
    qe = (1.0 - t2)[None, None, :] * q[:, :, i2] + t2[None, None, :] * q[:, :, i2 + 1]
    return np.diff(np.diff(qe, axis=1), axis=2)


def rectangle_moments(grid, edges1, edges2) -> tuple[np.ndarray, np.ndarray]:
    r"""Per rectangle :math:`[e^1_a, e^1_{a+1})\times[e^2_b, e^2_{b+1})`: the mean of
    :math:`h - \int h` and the within-rectangle variance of h.

    Parameters
    ----------
    grid : DyadicGrid
    edges1, edges2 : array_like
        Increasing edges from 0 to 1 along :math:`u_1` and :math:`u_2`.

    Returns
    -------
    mean, within : ndarray, shape (C, len(edges1) − 1, len(edges2) − 1)
        Exact when every edge is a multiple of 1/M (see the module docstring otherwise).
    """
    e1, e2 = np.asarray(edges1, dtype=np.float64), np.asarray(edges2, dtype=np.float64)
    m = grid.size
    i1, i2 = _aligned(e1, m), _aligned(e2, m)
    if i1 is not None and i2 is not None:
        a, _ = grid.centred()
        w = grid.within
        count = np.diff(i1)[:, None] * np.diff(i2)[None, :]

        def box_mean(x):
            s = np.add.reduceat(np.add.reduceat(x, i1[:-1], axis=1), i2[:-1], axis=2)
            return s / count

        mean = box_mean(a)
        within = box_mean(w) + np.clip(box_mean(a * a) - mean ** 2, 0.0, None)
        return mean, within
    area = np.diff(e1)[:, None] * np.diff(e2)[None, :]
    q_mean, q_second = grid.strata_tables              # once per grid, for every N
    mean = _rect_integrals(q_mean, e1, e2) / area
    second = _rect_integrals(q_second, e1, e2) / area
    return mean, np.clip(second - mean ** 2, 0.0, None)

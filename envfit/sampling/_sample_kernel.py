"""The compiled inverse-CDF warp of :meth:`envfit.sampling._map_sampler.MapSampler.sample`.

Per point: the row by binary search in the marginal CDF, the column by binary search in that
row's conditional CDF (W + 1 entries, not the whole stacked table), the fractions inside the
pixel, and the direction (cos θ linear between the row's edges, φ linear across the column) —
the arithmetic of the numpy form ``sample_numpy`` in tests/oracles/numpy_kernels.py
(the tests' reference).
Two builds, as :mod:`envfit.maps._lookup`: parallel in the main thread, serial elsewhere.
"""
from __future__ import annotations

import math
import threading

import numba
import numpy as np


@numba.njit(inline="always")
def _right(a, lo, hi, x):
    """The last index k in [lo, hi) with a[k] <= x (a sorted; a[lo] <= x assumed, else lo)."""
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if a[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


def _sample_body(U, row_cdf, col_cdf, z_edges, pixel_pdf, m, dirs, pdf):
    h, w1 = col_cdf.shape
    w = w1 - 1
    for n in numba.prange(U.shape[0]):
        u0, u1 = U[n, 0], U[n, 1]
        i = min(max(_right(row_cdf, 0, h + 1, u0), 0), h - 1)
        lo = row_cdf[i]
        t = min(max((u0 - lo) / max(row_cdf[i + 1] - lo, 1e-300), 0.0), 1.0)
        j = min(max(_right(col_cdf[i], 0, w + 1, u1), 0), w - 1)
        c0 = col_cdf[i, j]
        s = min(max((u1 - c0) / max(col_cdf[i, j + 1] - c0, 1e-300), 0.0), 1.0)
        zt, zb = z_edges[i], z_edges[i + 1]
        z = zt - t * (zt - zb)
        phi = 2.0 * math.pi * (j + s) / w
        r = math.sqrt(max((1.0 - z) * (1.0 + z), 0.0))
        x, y = r * math.cos(phi), r * math.sin(phi)
        for k in range(3):
            dirs[n, k] = x * m[k, 0] + y * m[k, 1] + z * m[k, 2]
        pdf[n] = pixel_pdf[i, j]


_sample_parallel = numba.njit(parallel=True, cache=True)(_sample_body)
_sample_serial = numba.njit(cache=True)(_sample_body)


def warp_points(U: np.ndarray, row_cdf, col_cdf, z_edges, pixel_pdf, m):
    """(directions (N, 3), pdf (N,)) of square points U (N, 2) in [0, 1)²."""
    n = U.shape[0]
    dirs, pdf = np.empty((n, 3)), np.empty(n)
    kernel = (_sample_parallel if threading.current_thread() is threading.main_thread()
              else _sample_serial)
    kernel(np.ascontiguousarray(U, dtype=np.float64), row_cdf, col_cdf, z_edges,
           pixel_pdf, np.ascontiguousarray(m, dtype=np.float64), dirs, pdf)
    return dirs, pdf


def _pixel_body(d, m, h, w, rows, cols):
    for n in numba.prange(d.shape[0]):
        x = d[n, 0] * m[0, 0] + d[n, 1] * m[1, 0] + d[n, 2] * m[2, 0]
        y = d[n, 0] * m[0, 1] + d[n, 1] * m[1, 1] + d[n, 2] * m[2, 1]
        z = d[n, 0] * m[0, 2] + d[n, 1] * m[1, 2] + d[n, 2] * m[2, 2]
        theta = math.atan2(math.hypot(x, y), z)
        phi = math.atan2(y, x)
        if phi < 0.0:
            phi += 2.0 * math.pi
        rows[n] = min(max(int(math.floor(theta * (h / math.pi))), 0), h - 1)
        cols[n] = int(math.floor(phi * (w / (2.0 * math.pi)))) % w


_pixel_parallel = numba.njit(parallel=True, cache=True)(_pixel_body)
_pixel_serial = numba.njit(cache=True)(_pixel_body)


def pixel_indices(d: np.ndarray, m, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows, columns) (N,) int64 of the pixels holding world directions d (N, 3)."""
    n = d.shape[0]
    rows, cols = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    kernel = (_pixel_parallel if threading.current_thread() is threading.main_thread()
              else _pixel_serial)
    kernel(np.ascontiguousarray(d, dtype=np.float64), np.ascontiguousarray(m, dtype=np.float64),
           int(h), int(w), rows, cols)
    return rows, cols

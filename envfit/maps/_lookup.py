"""The compiled bilinear lat-long lookup behind :func:`envfit.maps._latlong.bilinear_lookup`.

One fused pass per direction — local angles, continuous pixel coordinates, the snapped
floor/fraction, the two (possibly virtual, across-the-pole) rows and their longitude
interpolation — with exactly the arithmetic of the numpy reference
(``bilinear_lookup_numpy`` of tests/oracles/numpy_kernels.py), without its ~20 temporaries per block.
Two builds of one kernel: parallel over directions (numba ``prange``) for the main thread,
serial for calls from worker threads (numba's ``workqueue`` threading layer, the fallback
where neither OpenMP nor TBB is present, must not be entered by two threads at once).
"""
from __future__ import annotations

import math
import threading

import numba
import numpy as np

_TWO_PI = 2.0 * math.pi


@numba.njit(inline="always")
def _floor_frac(x, snap):
    x0 = float(math.floor(x))
    f = x - x0
    if f > 1.0 - snap:
        return x0 + 1.0, 0.0
    if f < snap:
        f = 0.0
    return x0, f


@numba.njit(inline="always")
def _row_value(flat, r, c, h, w, k, snap):
    """Row r (in [-1, H]; -1 and H are the edge rows across the pole, at column + W/2)
    interpolated in longitude at column c, channel k."""
    if r < 0:
        r = 0
        c = c + 0.5 * w
    elif r > h - 1:
        r = h - 1
        c = c + 0.5 * w
    c0f, fc = _floor_frac(c, snap)
    c0 = int(c0f) % w
    c1 = c0 + 1
    if c1 == w:
        c1 = 0
    v0 = np.float64(flat[r * w + c0, k])
    v1 = np.float64(flat[r * w + c1, k])
    return v0 + fc * (v1 - v0)


def _lookup_body(flat, d, m, h, w, snap, out):
    n = d.shape[0]
    nch = flat.shape[1]
    for i in numba.prange(n):
        x = d[i, 0] * m[0, 0] + d[i, 1] * m[1, 0] + d[i, 2] * m[2, 0]
        y = d[i, 0] * m[0, 1] + d[i, 1] * m[1, 1] + d[i, 2] * m[2, 1]
        z = d[i, 0] * m[0, 2] + d[i, 1] * m[1, 2] + d[i, 2] * m[2, 2]
        theta = math.atan2(math.hypot(x, y), z)
        u = math.atan2(y, x) * (w / _TWO_PI)
        if u < 0.0:
            u += w
        if u >= w:
            u -= w
        col = u - 0.5
        r0f, a = _floor_frac(theta * (h / math.pi) - 0.5, snap)
        r0 = int(r0f)
        for k in range(nch):
            top = _row_value(flat, r0, col, h, w, k, snap)
            if a > 0.0:
                top += a * (_row_value(flat, r0 + 1, col, h, w, k, snap) - top)
            out[i, k] = top


_lookup_parallel = numba.njit(parallel=True, cache=True)(_lookup_body)
_lookup_serial = numba.njit(cache=True)(_lookup_body)


def lookup_rows(flat: np.ndarray, d: np.ndarray, m: np.ndarray, h: int, w: int,
                snap: float) -> np.ndarray:
    """Bilinear values (N, C) float64 of the (H·W, C) pixel table ``flat`` at world directions
    d (N, 3) (finite, any nonzero length) for the map frame m (``world = m @ local``)."""
    out = np.empty((d.shape[0], flat.shape[1]), dtype=np.float64)
    kernel = (_lookup_parallel if threading.current_thread() is threading.main_thread()
              else _lookup_serial)
    kernel(np.ascontiguousarray(flat), np.ascontiguousarray(d, dtype=np.float64),
           np.ascontiguousarray(m, dtype=np.float64), int(h), int(w), float(snap), out)
    return out

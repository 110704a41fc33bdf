r"""Walsh coefficients of h from the cell means of a dyadic grid, and their dyadic block sums.

The Walsh function of index :math:`k = \sum_t \kappa_t 2^t` (Paley order) is
:math:`\mathrm{wal}_k(x) = (-1)^{\sum_t \kappa_t\,\xi_{t+1}}` with :math:`x = \sum_s \xi_s 2^{-s}`;
in 2-D :math:`\mathrm{wal}_{k}(u) = \mathrm{wal}_{k_1}(u_1)\,\mathrm{wal}_{k_2}(u_2)`, and
:math:`\hat h(k) = \int h\,\mathrm{wal}_k`. For :math:`k_1, k_2 < M = 2^L` the function is
constant on the grid cells: its value on cell (i, j) is
:math:`(-1)^{\mathrm{pop}(k_1\,\&\,\rho(i)) + \mathrm{pop}(k_2\,\&\,\rho(j))}` with ρ the
reversal of L bits (the first binary digit of :math:`u_1` is the top bit of i). So

.. math::  \hat h(k) = \frac1{M^2}\sum_{i,j} A_{\rho(i)\rho(j)}\,
           (-1)^{\mathrm{pop}(k_1\& i) + \mathrm{pop}(k_2 \& j)},

the natural-order fast Walsh–Hadamard transform of the bit-reversed cell means —
**exact** for every index below M (no aliasing: the grid's cell means determine these
coefficients and nothing else). Parseval: :math:`\sum_{k<M}\hat h(k)^2 = \frac1{M^2}\sum A^2`.

Dyadic blocks: :math:`B_\kappa`, :math:`\kappa = (\kappa_1, \kappa_2)`, holds the indices with
:math:`\lfloor\log_2 k_d\rfloor = \kappa_d` (κ_d = −1 for :math:`k_d = 0`), stored at array
position κ + 1; :math:`\sigma^2_\kappa = \sum_{k\in B_\kappa}\hat h(k)^2` is Owen's (1997)
variance component of the base-2 Haar (multiresolution) ANOVA, because the Walsh functions of
a block span the same space as the Haar wavelets of that level.

References: J. L. Walsh (1923); N. J. Fine, "On the Walsh functions", Trans. AMS 65 (1949);
J. Dick, F. Pillichshammer, *Digital Nets and Sequences* (2010), App. A and ch. 13.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["bit_reverse", "block_edges", "block_sums", "fwht", "walsh_coefficients"]


def bit_reverse(values, bits: int) -> np.ndarray:
    """The integers ``values`` with their low ``bits`` bits in reverse order."""
    v = np.asarray(values, dtype=np.uint64)
    out = np.zeros_like(v)
    for t in range(bits):
        out |= ((v >> np.uint64(t)) & np.uint64(1)) << np.uint64(bits - 1 - t)
    return out.astype(np.int64)


def fwht(a: np.ndarray, axis: int) -> np.ndarray:
    """The natural-order (Hadamard) fast Walsh–Hadamard transform along ``axis`` (unnormalised:
    out[k] = Σ_i a[i]·(−1)^pop(k & i)); the length must be a power of two."""
    x = np.moveaxis(np.asarray(a, dtype=np.float64), axis, -1)
    lead, n = x.shape[:-1], x.shape[-1]
    h = 1
    while h < n:
        y = x.reshape(*lead, n // (2 * h), 2, h)
        x = np.stack((y[..., 0, :] + y[..., 1, :], y[..., 0, :] - y[..., 1, :]), axis=-2)
        x = x.reshape(*lead, n)
        h *= 2
    return np.moveaxis(x, -1, axis)


@numba.njit(cache=True)
def _fwht_row(x, r):  # pragma: no cover - numba
    """:func:`fwht` of row ``r`` of ``x`` (R, n), in place."""
    n = x.shape[1]
    h = 1
    while h < n:
        for i in range(0, n, 2 * h):
            for j in range(i, i + h):
                a = x[r, j]
                b = x[r, j + h]
                x[r, j] = a + b
                x[r, j + h] = a - b
        h *= 2


@numba.njit(cache=True, parallel=True)
def _fwht_rows(x):  # pragma: no cover - numba
    """:func:`fwht` along the last axis of ``x`` (R, n), in place, rows in parallel."""
    for r in numba.prange(x.shape[0]):
        _fwht_row(x, r)


@numba.njit(cache=True)
def _fwht_rows_small(x):  # pragma: no cover - numba
    """:func:`_fwht_rows` in one thread (the same numbers), for a transform too small to
    share."""
    for r in range(x.shape[0]):
        _fwht_row(x, r)


#: the coefficients (channels × M²) up to which a transform runs in one thread
SERIAL_SIZE = 1 << 16


def walsh_coefficients(mean: np.ndarray) -> np.ndarray:
    r""":math:`\hat h(k_1, k_2)` for :math:`k_1, k_2 < M` from the cell means (C, M, M).

    The 2-D transform as two passes of a compiled in-place row transform (the numpy
    :func:`fwht` is the tests' reference; 10-20x slower at M = 512), in one thread up to
    :data:`SERIAL_SIZE` coefficients."""
    mean = np.asarray(mean, dtype=np.float64)
    m = mean.shape[-1]
    rev = bit_reverse(np.arange(m), m.bit_length() - 1)
    a = np.ascontiguousarray(mean[..., rev, :][..., rev])
    shape = a.shape
    rows = _fwht_rows_small if a.size <= SERIAL_SIZE else _fwht_rows
    rows(a.reshape(-1, m))
    a = np.ascontiguousarray(np.swapaxes(a, -1, -2))
    rows(a.reshape(-1, m))
    a = np.swapaxes(a, -1, -2).reshape(shape)
    return a / float(m * m)


def block_edges(m: int) -> np.ndarray:
    """The first index of each dyadic block below M: 0, 1, 2, 4, …, M/2 (L + 1 blocks)."""
    return np.concatenate(([0], 1 << np.arange(m.bit_length() - 1))).astype(np.int64)


def block_sums(x: np.ndarray) -> np.ndarray:
    """Sums of ``x`` (…, M, M) over the dyadic blocks: shape (…, L + 1, L + 1)."""
    e = block_edges(x.shape[-1])
    return np.add.reduceat(np.add.reduceat(x, e, axis=-2), e, axis=-1)

r"""Numba loop behind :mod:`envfit.sobolev._bandlimited`: a kernel matrix from a table in the angle.

A zonal kernel band-limited to degree L is a cosine polynomial of degree L in the angle
θ between the two directions, even about θ = 0 and about θ = π. It is tabulated at
:math:`\theta_k = k h`, :math:`h = \pi/M`, k = 0…M, padded by reflection (one value
before 0, two after π) and read by 4-point Lagrange (cubic) interpolation in θ; θ comes
from the chordal distance computed from coordinate differences,
:math:`\theta = 2\arcsin(|u-v|/2)`, which is accurate for nearby points (the Gram form
``arccos(u.v)`` is not).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["fill_table_kernel_matrix", "table_kernel_values"]

_OPTS = dict(fastmath=True, error_model="numpy", cache=True)


@njit(inline="always", **_OPTS)
def _interp(theta, table, inv_h, m):
    # table[k + 1] holds θ_k = k h for k = -1 … m + 2
    x = theta * inv_h
    i = int(x)
    if i > m - 1:
        i = m - 1
    if i < 0:
        i = 0
    f = x - i
    fm1 = f - 1.0
    fm2 = f - 2.0
    fp1 = f + 1.0
    return (-f * fm1 * fm2 * table[i] + 3.0 * fp1 * fm1 * fm2 * table[i + 1]
            - 3.0 * fp1 * f * fm2 * table[i + 2] + fp1 * f * fm1 * table[i + 3]) * (1.0 / 6.0)


@njit(inline="always", **_OPTS)
def _angle(d2):
    r = 0.5 * np.sqrt(d2)
    if r > 1.0:
        r = 1.0
    return 2.0 * np.arcsin(r)


@njit(inline="always", **_OPTS)
def _fill_column(j, px, py, pz, table, inv_h, m, K):
    n = px.shape[0]
    xj = px[j]
    yj = py[j]
    zj = pz[j]
    K[j, j] = table[1]
    for i in range(j + 1, n):
        dx = px[i] - xj
        dy = py[i] - yj
        dz = pz[i] - zj
        K[i, j] = _interp(_angle(dx * dx + dy * dy + dz * dz), table, inv_h, m)


@njit(parallel=True, **_OPTS)
def fill_table_kernel_matrix(px, py, pz, table, inv_h, m, K):
    """Lower triangle (diagonal included) of ``K[i, j] = k(θ_ij)`` from the padded table.

    ``K`` is N×N Fortran-ordered; columns j and N−1−j share a task (balanced triangle).
    The strict upper triangle is not written.
    """
    n = px.shape[0]
    for t in prange((n + 1) // 2):
        _fill_column(t, px, py, pz, table, inv_h, m, K)
        j2 = n - 1 - t
        if j2 != t:
            _fill_column(j2, px, py, pz, table, inv_h, m, K)


@njit(parallel=True, **_OPTS)
def table_kernel_values(d2, table, inv_h, m, out):
    """``out[i] = k(θ(d2[i]))`` for squared chordal distances ``d2``."""
    for i in prange(d2.shape[0]):
        out[i] = _interp(_angle(d2[i]), table, inv_h, m)

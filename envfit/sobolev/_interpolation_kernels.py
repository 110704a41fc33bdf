r"""Numba kernels behind :mod:`envfit.sobolev._interpolation` (the hot loops of envfit).

Everything here works on the *power part* of the generalized distance kernel (Eq. 14),

.. math::  K^{(s)}_{gd}(u, v) = c_s - g(|u - v|^2), \qquad
           g(d^2) = (d^2)^{a}, \quad a = s - 1 \in (0, 1), \quad c_s = 2^{2s-1}/s,

with the squared chordal distance computed from coordinate *differences*,
``d2 = (ux-vx)^2 + (uy-vy)^2 + (uz-vz)^2``, which is accurate to a few ulps even for
nearby points (the Gram form ``2 - 2 u.v`` loses all relative accuracy as u -> v, and
``g`` has a cusp there).

The power
---------
``x**a`` through libm costs ~20 ns and does not vectorise.  :func:`fast_pow` computes
``2**(a * log2(x))`` with branch-free float64 arithmetic that LLVM vectorises (AVX2):

* ``x = 2**k * m`` with ``m`` in ``[sqrt(1/2), sqrt(2))`` by integer operations on the bits
  (the fdlibm reduction; ``k`` is converted to float64 with the ``2**52`` magic number, as
  AVX2 has no 64-bit integer -> double conversion);
* ``log2(m) = s R(s^2)``, ``s = (m-1)/(m+1)``, ``R`` a degree-6 polynomial (max abs error
  2.2e-16 on the interval; coefficients: Chebyshev interpolation in extended precision);
* ``y = a (k + log2 m)``, ``n = rint(y)``, ``2**(y-n)`` by a degree-10 polynomial on
  ``[-1/2, 1/2]`` (max rel. error 4.5e-16), and ``2**n`` by adding ``n << 52`` to the bits.

Accuracy (checked in ``tests/test_interpolation.py`` against ``numpy.power``): relative
error below 4e-15 for ``x >= 1e-10`` and below ~1e-13 down to ``x = 1e-300`` (the error
of ``a*k`` grows with ``|k|``); ``x < 2**-1000`` returns 0 (two distinct float64 unit
vectors are never that close).  ``a = 1/2`` (s = 1.5) uses ``sqrt`` instead.

Compilation is cached on disk (``cache=True``); the first call in a fresh environment
compiles for a few seconds, later processes load the machine code.

Example
-------
>>> import numpy as np
>>> out = np.empty(3)
>>> pow_array(np.array([4.0, 0.25, 0.0]), 0.5, KIND_GENERIC, out)
>>> bool(np.allclose(out, [2.0, 0.5, 0.0], rtol=1e-15, atol=0))
True
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic

__all__ = ["fast_pow", "power_kind", "KIND_GENERIC", "KIND_SQRT",
           "fill_kernel_matrix", "power_sums_1", "power_sums_3", "power_block",
           "near_field_correction", "NearCells", "NearLaw", "pow_array", "local_lagrange"]

#: generic exponent: :func:`fast_pow`
KIND_GENERIC = 0
#: a = 1/2 (s = 1.5): ``sqrt``
KIND_SQRT = 1

# fastmath without reassociation-sensitive tricks: every rounding trick below is done on
# the integer bits (intrinsics), so the full fast-math flag set is safe.
_FM = True
_OPTS = dict(fastmath=_FM, error_model="numpy", cache=True)

_I64 = ir.IntType(64)
_F64 = ir.DoubleType()
_SQRT_HALF_BITS = 0x3FE6A09E667F3BCD          # bits of sqrt(1/2)
_SHIFT = 0x3FF0000000000000 - _SQRT_HALF_BITS  # moves [sqrt(1/2), sqrt(2)) onto one binade
_MANT_MASK = 0x000FFFFFFFFFFFFF
_MAGIC_BITS = 0x4330000000000000               # bits of 2**52


@intrinsic
def _reduced_mantissa(typingctx, x):
    """m in [sqrt(1/2), sqrt(2)) with x = 2**k m (x positive and normal)."""
    sig = types.float64(types.float64)

    def codegen(context, builder, signature, args):
        ix = builder.add(builder.bitcast(args[0], _I64), ir.Constant(_I64, _SHIFT))
        mb = builder.add(builder.and_(ix, ir.Constant(_I64, _MANT_MASK)),
                         ir.Constant(_I64, _SQRT_HALF_BITS))
        return builder.bitcast(mb, _F64)
    return sig, codegen


@intrinsic
def _biased_exponent(typingctx, x):
    """``2**52 + 1023 + k`` as a float64 (subtract :data:`_KOFF` to get k)."""
    sig = types.float64(types.float64)

    def codegen(context, builder, signature, args):
        ix = builder.add(builder.bitcast(args[0], _I64), ir.Constant(_I64, _SHIFT))
        kb = builder.or_(builder.lshr(ix, ir.Constant(_I64, 52)), ir.Constant(_I64, _MAGIC_BITS))
        return builder.bitcast(kb, _F64)
    return sig, codegen


@intrinsic
def _scale_by_pow2(typingctx, p, t):
    """``p * 2**n`` where ``t = n + 1.5 * 2**52`` (n an integer, result normal)."""
    sig = types.float64(types.float64, types.float64)

    def codegen(context, builder, signature, args):
        ip = builder.bitcast(args[0], _I64)
        it = builder.bitcast(args[1], _I64)
        r = builder.add(ip, builder.shl(it, ir.Constant(_I64, 52)))
        return builder.bitcast(r, _F64)
    return sig, codegen


# log2(m) = s * R(s^2), s = (m-1)/(m+1), m in [sqrt(1/2), sqrt(2)): degree 6 in s^2
_L0 = 2.885390081777927
_L1 = 0.9617966939243316
_L2 = 0.577078017246968
_L3 = 0.4121984019797534
_L4 = 0.3206163919523099
_L5 = 0.26144414357735246
_L6 = 0.24291722914542913
# 2**r on [-1/2, 1/2]: degree 10 (Chebyshev interpolant computed in extended precision;
# max relative error 4.5e-16)
_E0 = 1.0
_E1 = 0.69314718055995
_E2 = 0.24022650695910097
_E3 = 0.055504108664447695
_E4 = 0.00961812910760687
_E5 = 0.001333355823016814
_E6 = 0.00015403530441763784
_E7 = 1.5252657258547322e-05
_E8 = 1.3215442576793237e-06
_E9 = 1.0208690586037056e-07
_E10 = 7.072587226569927e-09
_KOFF = 4503599627370496.0 + 1023.0   # 2**52 + exponent bias
_ROUND_MAGIC = 6755399441055744.0     # 1.5 * 2**52
_TINY = 2.0 ** -1000


def power_kind(a: float) -> int:
    """Which specialised power to use for exponent ``a = s - 1``."""
    return KIND_SQRT if a == 0.5 else KIND_GENERIC


@njit(inline="always", **_OPTS)
def fast_pow(x, a):
    """``x**a`` for ``x >= 0``, ``0 < a < 1`` (vectorisable; see the module docstring)."""
    m = _reduced_mantissa(x)
    k = _biased_exponent(x) - _KOFF
    s = (m - 1.0) / (m + 1.0)
    z = s * s
    z2 = z * z
    r_log = (_L0 + _L1 * z) + z2 * ((_L2 + _L3 * z) + z2 * ((_L4 + _L5 * z) + z2 * _L6))
    y = a * (k + s * r_log)
    n = np.rint(y)
    r = y - n
    t = n + _ROUND_MAGIC
    r2 = r * r
    r4 = r2 * r2
    p = (((_E0 + _E1 * r) + r2 * (_E2 + _E3 * r))
         + r4 * (((_E4 + _E5 * r) + r2 * (_E6 + _E7 * r))
                 + r4 * ((_E8 + _E9 * r) + r2 * _E10)))
    v = _scale_by_pow2(p, t)
    return v if x >= _TINY else 0.0


@njit(inline="always", **_OPTS)
def _power(x, a, kind):
    # ``kind`` is loop-invariant: LLVM unswitches the loops that call this
    if kind == KIND_SQRT:
        return np.sqrt(x)
    return fast_pow(x, a)


@njit(**_OPTS)
def pow_array(x, a, kind, out):
    """``out[i] = x[i]**a`` with the kernel's power (for tests and benchmarks)."""
    for i in range(x.shape[0]):
        out[i] = _power(x[i], a, kind)


@njit(inline="always", **_OPTS)
def _fill_column(j, px, py, pz, a, kind, c, K):
    n = px.shape[0]
    xj = px[j]
    yj = py[j]
    zj = pz[j]
    K[j, j] = c
    for i in range(j + 1, n):
        dx = px[i] - xj
        dy = py[i] - yj
        dz = pz[i] - zj
        K[i, j] = c - _power(dx * dx + dy * dy + dz * dz, a, kind)


@njit(parallel=True, **_OPTS)
def fill_kernel_matrix(px, py, pz, a, kind, c, K):
    """Write the lower triangle (diagonal included) of ``K[i, j] = c - |p_i - p_j|^(2a)``.

    ``K`` is an N x N Fortran-ordered buffer, so each column's lower part is contiguous;
    columns j and N-1-j are paired in one task to balance the triangular work. The strict
    upper triangle is not touched (LAPACK ``dpotrf(lower=1)`` never reads it; its pages
    are never faulted in).
    """
    n = px.shape[0]
    for t in prange((n + 1) // 2):
        _fill_column(t, px, py, pz, a, kind, c, K)
        j2 = n - 1 - t
        if j2 != t:
            _fill_column(j2, px, py, pz, a, kind, c, K)


@njit(parallel=True, **_OPTS)
def power_sums_1(q, px, py, pz, w, a, kind, out):
    """``out[i] = sum_j w[j] |q_i - p_j|^(2a)`` (one right-hand side)."""
    m = q.shape[0]
    n = px.shape[0]
    for i in prange(m):
        qx = q[i, 0]
        qy = q[i, 1]
        qz = q[i, 2]
        acc = 0.0
        for j in range(n):
            dx = qx - px[j]
            dy = qy - py[j]
            dz = qz - pz[j]
            acc += w[j] * _power(dx * dx + dy * dy + dz * dz, a, kind)
        out[i] = acc


@njit(parallel=True, **_OPTS)
def power_sums_3(q, px, py, pz, w0, w1, w2, a, kind, out):
    """``out[i, c] = sum_j wc[j] |q_i - p_j|^(2a)`` for three right-hand sides (RGB)."""
    m = q.shape[0]
    n = px.shape[0]
    for i in prange(m):
        qx = q[i, 0]
        qy = q[i, 1]
        qz = q[i, 2]
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for j in range(n):
            dx = qx - px[j]
            dy = qy - py[j]
            dz = qz - pz[j]
            g = _power(dx * dx + dy * dy + dz * dz, a, kind)
            acc0 += w0[j] * g
            acc1 += w1[j] * g
            acc2 += w2[j] * g
        out[i, 0] = acc0
        out[i, 1] = acc1
        out[i, 2] = acc2


@njit(parallel=True, **_OPTS)
def power_block(q, px, py, pz, a, kind, out):
    """``out[i, j] = |q_i - p_j|^(2a)`` (a block of the evaluation matrix, for BLAS)."""
    m = q.shape[0]
    n = px.shape[0]
    for i in prange(m):
        qx = q[i, 0]
        qy = q[i, 1]
        qz = q[i, 2]
        for j in range(n):
            dx = qx - px[j]
            dy = qy - py[j]
            dz = qz - pz[j]
            out[i, j] = _power(dx * dx + dy * dy + dz * dz, a, kind)


_NEAR_BUFFER = 128
_NEAR_BLOCK = 64

#: the near field's cell list as the kernel reads it: nodes sorted by the cell of a uniform
#: 3-D grid of side ``h >= delta`` (``ngrid`` cells per axis over [-1, 1], z fastest),
#: ``cell_start`` (ngrid^3 + 1) the CSR offsets of the cells, ``px, py, pz`` the sorted nodes
NearCells = namedtuple("NearCells", "h ngrid cell_start px py pz")
#: the near zone's law: pairs with ``d2 < delta2`` get ``d2^a - S(d2)``, ``a`` with its
#: :func:`power_kind` ``kind``, ``S(d2) = sum_k cheb[k] T_k(2 d2 / delta2 - 1)``
NearLaw = namedtuple("NearLaw", "delta2 a kind cheb")
#: a thread's buffer of candidate pairs: squared distances, node indices, and the two
#: Clenshaw registers (each of length ``_NEAR_BUFFER + 1``)
_NearBuffer = namedtuple("_NearBuffer", "d2 k b1 b2")


@njit(inline="always", **_OPTS)
def _flush_near(nb, buf, sw, law, scale, acc):
    """acc[c] += sum_t (d2_t^a - S(d2_t)) sw[k_t, c] over the ``nb`` buffered near pairs.

    Loops run over the buffer (vectorised), the Clenshaw recurrence for S one coefficient
    at a time across all pairs (throughput- instead of latency-bound).
    """
    bd2, bk, b1, b2 = buf.d2, buf.k, buf.b1, buf.b2
    cheb = law.cheb
    for t in range(nb):
        b1[t] = 0.0
        b2[t] = 0.0
    for k in range(cheb.shape[0] - 1, 0, -1):
        ck = cheb[k]
        for t in range(nb):
            y2 = 2.0 * (bd2[t] * scale - 1.0)
            b0 = y2 * b1[t] - b2[t] + ck
            b2[t] = b1[t]
            b1[t] = b0
    c0 = cheb[0]
    for t in range(nb):
        x = bd2[t]
        b1[t] = _power(x, law.a, law.kind) - ((x * scale - 1.0) * b1[t] - b2[t] + c0)
    for c in range(sw.shape[1]):
        s = 0.0
        for t in range(nb):
            s += b1[t] * sw[bk[t], c]
        acc[c] += s


@njit(inline="always", **_OPTS)
def _near_of_query(qx, qy, qz, cells, sw, law, buf, acc):
    """acc[c] = sum over the nodes closer than delta to q of sw[k, c] (d2^a - S(d2)).

    Every such node lies in the 27 cells around q's cell (9 contiguous runs of 3 cells);
    candidates are compacted branch-free into ``buf`` and flushed in vectorised passes.
    """
    ngrid, cell_start = cells.ngrid, cells.cell_start
    spx, spy, spz = cells.px, cells.py, cells.pz
    bd2, bk = buf.d2, buf.k
    delta2 = law.delta2
    scale = 2.0 / delta2
    inv_h = 1.0 / cells.h
    cx = min(int((qx + 1.0) * inv_h), ngrid - 1)
    cy = min(int((qy + 1.0) * inv_h), ngrid - 1)
    cz = min(int((qz + 1.0) * inv_h), ngrid - 1)
    for c in range(acc.shape[0]):
        acc[c] = 0.0
    nb = 0
    for ix in range(max(cx - 1, 0), min(cx + 2, ngrid)):
        for iy in range(max(cy - 1, 0), min(cy + 2, ngrid)):
            base = (ix * ngrid + iy) * ngrid
            for k in range(cell_start[base + max(cz - 1, 0)], cell_start[base + min(cz + 2, ngrid)]):
                dx = qx - spx[k]
                dy = qy - spy[k]
                dz = qz - spz[k]
                d2 = dx * dx + dy * dy + dz * dz
                bd2[nb] = d2
                bk[nb] = k
                if d2 < delta2:
                    nb += 1
                    if nb == _NEAR_BUFFER:
                        _flush_near(nb, buf, sw, law, scale, acc)
                        nb = 0
    if nb > 0:
        _flush_near(nb, buf, sw, law, scale, acc)


@njit(parallel=True, **_OPTS)
def near_field_correction(q, cells, sw, law, out):
    """Near-field part of the near/far split (see ``envfit.sobolev._nearfar.FarFieldExpansion``).

    ``out[i, c] = sum_{j: d2_ij < delta2} sw[j, c] (d2_ij^a - S(d2_ij))`` where
    ``S(d2) = sum_k cheb[k] T_k(2 d2 / delta2 - 1)`` is the far-field polynomial restricted
    to the near zone (``law``, a :data:`NearLaw`), over the nodes of the cell list ``cells``
    (a :data:`NearCells`; ``sw`` their weights in the same order). Queries run in blocks of
    ``_NEAR_BLOCK`` per thread, each with one candidate buffer (:func:`_near_of_query`).
    """
    m = q.shape[0]
    nc = sw.shape[1]
    nblocks = (m + _NEAR_BLOCK - 1) // _NEAR_BLOCK
    for blk in prange(nblocks):
        buf = _NearBuffer(np.empty(_NEAR_BUFFER + 1), np.empty(_NEAR_BUFFER + 1, dtype=np.int64),
                          np.empty(_NEAR_BUFFER + 1), np.empty(_NEAR_BUFFER + 1))
        acc = np.empty(nc)
        for i in range(blk * _NEAR_BLOCK, min(m, (blk + 1) * _NEAR_BLOCK)):
            _near_of_query(q[i, 0], q[i, 1], q[i, 2], cells, sw, law, buf, acc)
            for c in range(nc):
                out[i, c] = acc[c]


@njit(inline="always", **_OPTS)
def _local_matrix(m, nbi, pts, a, kind, c):
    """Lower triangle of :math:`K_{loc} = c - |p_a - p_b|^{2a}` over the neighbours ``nbi``."""
    px, py, pz = pts
    k = nbi.shape[0]
    for jj in range(k):
        j = nbi[jj]
        m[jj, jj] = c
        for ll in range(jj + 1, k):
            l2 = nbi[ll]
            dx = px[j] - px[l2]
            dy = py[j] - py[l2]
            dz = pz[j] - pz[l2]
            m[ll, jj] = c - _power(dx * dx + dy * dy + dz * dz, a, kind)


@njit(inline="always", **_OPTS)
def _cholesky_lower(m):
    """In-place Cholesky factor of the lower triangle of ``m`` (column by column)."""
    k = m.shape[0]
    for jj in range(k):
        d = m[jj, jj]
        for t in range(jj):
            d -= m[jj, t] * m[jj, t]
        d = np.sqrt(d)
        m[jj, jj] = d
        for ll in range(jj + 1, k):
            acc = m[ll, jj]
            for t in range(jj):
                acc -= m[ll, t] * m[jj, t]
            m[ll, jj] = acc / d


@njit(inline="always", **_OPTS)
def _cholesky_solve_two(m, u, v):
    """u, v <- (L L^T)^{-1} u, (L L^T)^{-1} v in place, L the lower triangle of ``m``."""
    k = m.shape[0]
    for jj in range(k):
        su = u[jj]
        sv = v[jj]
        for t in range(jj):
            su -= m[jj, t] * u[t]
            sv -= m[jj, t] * v[t]
        u[jj] = su / m[jj, jj]
        v[jj] = sv / m[jj, jj]
    for jj in range(k - 1, -1, -1):
        su = u[jj]
        sv = v[jj]
        for t in range(jj + 1, k):
            su -= m[t, jj] * u[t]
            sv -= m[t, jj] * v[t]
        u[jj] = su / m[jj, jj]
        v[jj] = sv / m[jj, jj]


@njit(parallel=True, **_OPTS)
def local_lagrange(px, py, pz, nb, a, kind, c, out):
    r"""Local Lagrange coefficients with constant reproduction (the iterative solver's
    preconditioner, :mod:`envfit.sobolev._iterative`).

    For node i with neighbours ``nb[i]`` (k indices, ``nb[i, 0] = i``):
    :math:`K_{loc} = c - |p_a - p_b|^{2a}` (k x k, SPD, :func:`_local_matrix`), Cholesky in
    place (:func:`_cholesky_lower`), :math:`u = K_{loc}^{-1} e_1`, :math:`v = K_{loc}^{-1} 1`
    (:func:`_cholesky_solve_two`), ``out[i] = u - v (1^T u) / (1^T v)`` (so
    ``sum(out[i]) = 0``): the coefficients of :math:`[K_{loc}\; 1; 1^T\; 0][c; d] = [e_1; 0]`.
    O(k^3 / 6) per node, no temporaries beyond one k x k block per thread.
    """
    n, k = nb.shape
    for i in prange(n):
        m = np.empty((k, k))
        u = np.zeros(k)
        v = np.ones(k)
        _local_matrix(m, nb[i], (px, py, pz), a, kind, c)
        _cholesky_lower(m)
        u[0] = 1.0
        _cholesky_solve_two(m, u, v)
        su = 0.0
        sv = 0.0
        for jj in range(k):
            su += u[jj]
            sv += v[jj]
        r = su / sv
        for jj in range(k):
            out[i, jj] = u[jj] - v[jj] * r

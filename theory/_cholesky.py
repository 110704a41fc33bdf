r"""A dense Cholesky factorisation that cannot crash in OpenBLAS, at the speed of ``dpotrf``.

Why not plain LAPACK
--------------------
NumPy and SciPy wheels ship OpenBLAS (0.3.30/0.3.31 as of 2026). On CPUs with AVX-512 it
selects its "SkylakeX" kernels, and with two or more BLAS threads its threaded ``dsyrk``
(``dsyrk_thread_LN``) overruns its packing buffer once one thread's share of the rows
times the packed depth (``GEMM_Q`` = 384 there) outgrows the buffer: a segmentation fault
in ``dgemm_otcopy_SKYLAKEX``. ``dpotrf`` reaches that path through
``dpotrf_L_parallel -> dsyrk_thread_LN`` for N >= 16 000, even on ``np.eye(16000)``
(backtrace under gdb, OpenBLAS 0.3.30, 2 threads). ``dsyrk`` called alone crashes the same
way (n = 16 000 with k = 384, 768 or 1 000; not with k = 256 or 512, whose packed depth is
smaller), while ``dgemm`` and ``dtrsm`` of any size tried (up to 20 000 x 20 000 x 1 000)
do not. OpenBLAS issues #352, #1413, #2562 and #2821 report the same family.

What this module does
---------------------
A right-looking blocked Cholesky over BLAS-3 calls whose sizes stay in the safe range
(Golub & Van Loan, *Matrix Computations*, 4th ed., Alg. 4.2.2, "block Cholesky"). With
:math:`A = \begin{pmatrix} A_{11} & \\ A_{21} & A_{22}\end{pmatrix}`, for each panel of
``PANEL`` columns:

.. math::  L_{11} = \mathrm{chol}(A_{11}), \quad L_{21} = A_{21} L_{11}^{-T}, \quad
           A_{22} \leftarrow A_{22} - L_{21} L_{21}^T

``chol`` is LAPACK ``dpotrf`` on a ``PANEL`` x ``PANEL`` block; the panel solve is one
``dtrsm``; the trailing update is split into column tiles of ``TILE`` columns: ``dsyrk`` on
the tile's diagonal block (at most ``TILE`` rows, four times below the smallest crashing
size) and one ``dgemm`` below it. Every call works in place on sub-matrices passed by
pointer and leading dimension (scipy's ``cython_blas``/``cython_lapack`` through ctypes), so
nothing is copied and only the lower triangle is read or written. The flops are those of
``dpotrf`` (N³/3) and the BLAS-3 calls are as large, so it runs at the same speed
(``bench/bench_cholesky.py`` on a 2-core AMD Zen 4 with AVX-512: ×0.93–1.02 of bare
``dpotrf`` for N = 4 000–12 000, ×0.93–0.98 of ``dpotrf`` with the AVX2 kernels at 16 000 and
20 000, where bare ``dpotrf`` crashes), with BLAS's own threads and no environment variable.

Matrices of at most ``PANEL`` rows go to ``dpotrf`` in one call (the crash needs thousands
of rows per thread).

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> x = rng.normal(size=(300, 40))
>>> a = np.asfortranarray(x @ x.T + 300 * np.eye(300))
>>> ref = a.copy()
>>> cholesky_inplace(a, panel=64, tile=96)     # small blocks to exercise the blocked path
0
>>> L = np.tril(a)
>>> bool(np.allclose(L @ L.T, ref, rtol=0, atol=1e-10 * np.abs(ref).max()))
True
"""
from __future__ import annotations

import ctypes
import functools

import numpy as np
from scipy.linalg import cython_blas, cython_lapack, lapack

__all__ = ["cholesky_inplace", "cho_factor", "cho_solve", "cholesky", "inverse_diagonal", "PANEL",
           "TILE"]

#: columns per panel (one ``dpotrf`` call on a PANEL x PANEL block, one ``dtrsm``)
PANEL = 2048
#: columns per tile of the trailing update: the largest ``dsyrk`` has TILE rows
TILE = 4096


@functools.lru_cache(maxsize=None)
def _routines():
    """scipy's LAPACK ``dpotrf`` and BLAS ``dtrsm``, ``dsyrk``, ``dgemm`` as ctypes functions."""
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype, get_name.argtypes = ctypes.c_char_p, [ctypes.py_object]
    get_ptr = ctypes.pythonapi.PyCapsule_GetPointer
    get_ptr.restype, get_ptr.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]

    def fn(module, name, *argtypes):
        capsule = module.__pyx_capi__[name]
        return ctypes.CFUNCTYPE(None, *argtypes)(get_ptr(capsule, get_name(capsule)))

    c, i = ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)
    d, v = ctypes.POINTER(ctypes.c_double), ctypes.c_void_p
    return {
        "dpotrf": fn(cython_lapack, "dpotrf", c, i, v, i, i),
        "dtrsm": fn(cython_blas, "dtrsm", c, c, c, c, i, i, d, v, i, v, i),
        "dsyrk": fn(cython_blas, "dsyrk", c, c, i, i, d, v, i, d, v, i),
        "dgemm": fn(cython_blas, "dgemm", c, c, i, i, i, d, v, i, v, i, d, v, i),
    }


def _check_square_fortran(a: np.ndarray) -> int:
    if not (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 2
            and a.shape[0] == a.shape[1] and a.flags.f_contiguous and a.flags.writeable):
        raise ValueError("cholesky_inplace needs a writeable, Fortran-ordered, square float64 array")
    return a.shape[0]


def cholesky_inplace(a: np.ndarray, *, panel: int = PANEL, tile: int = TILE) -> int:
    r"""Overwrite the lower triangle of the SPD matrix ``a`` with its Cholesky factor L.

    Parameters
    ----------
    a : (N, N) float64, Fortran-ordered, writeable
        Only the lower triangle is read and written (the strict upper one is left as it is).
    panel, tile : int
        Block sizes (see the module docstring); the defaults suit every OpenBLAS kernel.

    Returns
    -------
    info : int
        0 on success; otherwise the 1-based column of the first pivot that is not positive
        (LAPACK's convention: the leading ``info - 1`` columns hold a valid partial factor).
    """
    n = _check_square_fortran(a)
    panel, tile = max(1, int(panel)), max(1, int(tile))
    r = _routines()
    info = ctypes.c_int(0)
    lda = ctypes.byref(ctypes.c_int(max(n, 1)))
    base = a.ctypes.data

    def at(i: int, j: int):  # pointer to a[i, j] (column-major)
        return ctypes.c_void_p(base + 8 * (i + j * n))

    def num(x, kind=ctypes.c_int):
        return ctypes.byref(kind(x))

    one, minus_one = num(1.0, ctypes.c_double), num(-1.0, ctypes.c_double)
    for k in range(0, n, panel):
        kb = min(panel, n - k)
        r["dpotrf"](b"L", num(kb), at(k, k), lda, ctypes.byref(info))
        if info.value != 0:
            return k + info.value if info.value > 0 else info.value
        s = k + kb
        if s == n:
            break
        r["dtrsm"](b"R", b"L", b"T", b"N", num(n - s), num(kb), one, at(k, k), lda, at(s, k), lda)
        for j0 in range(s, n, tile):
            j1 = min(n, j0 + tile)
            r["dsyrk"](b"L", b"N", num(j1 - j0), num(kb), minus_one, at(j0, k), lda,
                       one, at(j0, j0), lda)
            if j1 < n:
                r["dgemm"](b"N", b"T", num(n - j1), num(j1 - j0), num(kb), minus_one,
                           at(j1, k), lda, at(j0, k), lda, one, at(j1, j0), lda)
    return 0


def cho_factor(a, *, overwrite_a: bool = False) -> tuple[np.ndarray, bool]:
    r"""``(c, True)``: the lower Cholesky factor, as :func:`scipy.linalg.cho_factor` returns it.

    A drop-in for ``scipy.linalg.cho_factor(a, lower=True)`` that runs
    :func:`cholesky_inplace`. ``a`` is factorised in place when ``overwrite_a`` and it is a
    Fortran-ordered float64 array (for a symmetric C-ordered matrix pass ``a.T``, the same
    memory); otherwise a Fortran copy is made. The strict upper triangle of ``c`` is not
    referenced. Raises :class:`numpy.linalg.LinAlgError` if ``a`` is not positive definite.

    >>> import numpy as np
    >>> c, lower = cho_factor(np.array([[4.0, 2.0], [2.0, 5.0]]))
    >>> np.tril(c).tolist(), lower
    ([[2.0, 0.0], [1.0, 2.0]], True)
    """
    arr = np.asarray(a)
    if not (overwrite_a and arr.dtype == np.float64 and arr.flags.f_contiguous
            and arr.flags.writeable):
        arr = np.array(arr, dtype=np.float64, order="F", copy=True)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"expected a square matrix, got shape {arr.shape}")
    info = cholesky_inplace(arr)
    if info > 0:
        raise np.linalg.LinAlgError(f"{info}-th leading minor not positive definite")
    if info < 0:  # pragma: no cover - argument error, cannot happen with checked input
        raise RuntimeError(f"dpotrf argument {-info} is invalid")
    return arr, True


def cho_solve(cf: tuple[np.ndarray, bool], b) -> np.ndarray:
    r""":math:`A^{-1} b` from ``cf = cho_factor(A)`` (LAPACK ``dpotrs``: two ``dtrsm``, safe)."""
    c, lower = cf
    x, info = lapack.dpotrs(c, np.asarray(b, dtype=np.float64), lower=int(bool(lower)))
    if info != 0:  # pragma: no cover - argument error
        raise RuntimeError(f"dpotrs failed (info={info})")
    return x


def cholesky(a) -> np.ndarray:
    r"""The lower Cholesky factor L (strict upper triangle zero), as
    ``scipy.linalg.cholesky(a, lower=True)``; raises :class:`numpy.linalg.LinAlgError`."""
    c, _ = cho_factor(a)
    return np.tril(c)


def inverse_diagonal(factor: np.ndarray, block: int = 512) -> np.ndarray:
    r"""``diag(K^-1)`` from the lower Cholesky factor L (Fortran-ordered, K = L L^T).

    :math:`(K^{-1})_{ii} = \|L^{-1} e_i\|^2` and, L being lower triangular, the columns
    ``i0:i1`` of :math:`L^{-1}` vanish above row i0 and equal
    :math:`L[i0:, i0:]^{-1} E`: one ``dtrsm`` per block on the trailing triangle.
    Flops :math:`\sum (N - i_0)^2 b \approx N^3/3`; workspace N x b.
    """
    n = factor.shape[0]
    if n == 0:
        return np.zeros(0)
    if not (factor.flags.f_contiguous and factor.dtype == np.float64):
        raise ValueError("factor must be a Fortran-ordered float64 array")
    block = max(1, min(block, n))
    dtrsm = _routines()["dtrsm"]
    out = np.empty(n)
    work = np.empty(n * block)  # Fortran (rows, cols) buffer, reused
    one = ctypes.c_double(1.0)
    lda = ctypes.c_int(n)
    side, uplo, trans, diag = b"L", b"L", b"N", b"N"
    base = factor.ctypes.data
    for i0 in range(0, n, block):
        i1 = min(n, i0 + block)
        rows, cols = n - i0, i1 - i0
        x = work[: rows * cols].reshape(cols, rows).T  # Fortran view, ld = rows
        x[...] = 0.0
        x[np.arange(cols), np.arange(cols)] = 1.0
        dtrsm(side, uplo, trans, diag, ctypes.byref(ctypes.c_int(rows)),
              ctypes.byref(ctypes.c_int(cols)), ctypes.byref(one),
              ctypes.c_void_p(base + 8 * (i0 + i0 * n)), ctypes.byref(lda),
              ctypes.c_void_p(x.ctypes.data), ctypes.byref(ctypes.c_int(rows)))
        out[i0:i1] = np.einsum("ij,ij->j", x, x)
    return out

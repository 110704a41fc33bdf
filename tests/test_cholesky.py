"""envfit.theory._cholesky: the blocked Cholesky that avoids OpenBLAS's threaded-dsyrk crash.

Oracles: scipy.linalg.cholesky (LAPACK in one call) on small matrices, L L^T = A, LAPACK's
info convention on matrices with a known first non-positive pivot, and the interpolation
property of the Table 2 cell evaluated by the independent direct kernel sum at N = 5 000
(three panels); at N = 16 000 (the size where bare dpotrf segfaults on AVX-512 with two
threads): ``python bench/table2_cell_16000.py``.
"""
from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
import scipy.linalg

from envfit.theory._cholesky import PANEL, TILE, cho_factor, cho_solve, cholesky, cholesky_inplace


def _spd(n, seed=0, rank=30):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, rank))
    return np.asfortranarray(x @ x.T + n * np.eye(n))


@pytest.mark.parametrize("n,panel,tile", [(1, 4, 8), (7, 4, 8), (130, 16, 40), (257, 64, 64),
                                          (300, 100, 33), (500, 500, 500)])
def test_blocked_equals_lapack(n, panel, tile):
    a = _spd(n, seed=n)
    ref = scipy.linalg.cholesky(a, lower=True)
    upper_before = np.triu(a, 1).copy()
    assert cholesky_inplace(a, panel=panel, tile=tile) == 0
    L = np.tril(a)
    assert np.max(np.abs(L - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert np.array_equal(np.triu(a, 1), upper_before)          # upper triangle untouched


def test_default_blocks_on_a_matrix_larger_than_one_panel():
    n = PANEL + 300                                              # two panels, one tile
    a = _spd(n, seed=3)
    ref = a.copy(order="F")
    assert cholesky_inplace(a) == 0
    L = np.tril(a)
    assert np.max(np.abs(L @ L.T - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert TILE >= PANEL


@pytest.mark.parametrize("bad", [5, 37, 64, 199])
def test_info_is_the_first_non_positive_pivot(bad):
    d = np.ones(200)
    d[bad - 1] = -1.0                                            # leading minor `bad` fails
    a = np.asfortranarray(np.diag(d))
    assert cholesky_inplace(a, panel=32, tile=64) == bad
    with pytest.raises(np.linalg.LinAlgError):
        cho_factor(np.diag(d))


def test_cho_factor_and_solve_match_scipy():
    a = _spd(150, seed=9)
    b = np.random.default_rng(1).normal(size=(150, 3))
    x = cho_solve(cho_factor(a), b)
    x_ref = scipy.linalg.cho_solve(scipy.linalg.cho_factor(a, lower=True), b)
    assert np.allclose(x, x_ref, rtol=1e-12, atol=0)
    assert np.allclose(cholesky(a), scipy.linalg.cholesky(a, lower=True), rtol=1e-12, atol=1e-14)


def test_cho_factor_in_place_only_when_allowed():
    a = _spd(40)
    keep = a.copy()
    c, lower = cho_factor(a)                                    # default: a copy
    assert lower and not np.shares_memory(c, a) and np.array_equal(a, keep)
    c2, _ = cho_factor(a, overwrite_a=True)
    assert np.shares_memory(c2, a)


def test_rejects_c_ordered_input():
    with pytest.raises(ValueError, match="Fortran"):
        cholesky_inplace(np.ascontiguousarray(_spd(20)))


def _table2_cell_child(n: int, cwd) -> float:
    """The Table 2 cell's interpolant (blocked Cholesky, default panels and tiles) at ``n``
    spherical-Fibonacci samples, built in a child process so that a crash is a clear failure;
    returns the largest error of the interpolant at 300 of its samples by the direct kernel
    sum (which does not use the factor)."""
    code = textwrap.dedent(f"""
        import numpy as np
        from envfit.sobolev._interpolation import SobolevInterpolator
        from envfit.theory._sphere_points import sphere_points
        n = {int(n)}
        p = sphere_points("sf", n, seed=0)
        f = np.c_[p[:, 2] ** 2 + 0.3 * p[:, 0], np.abs(p[:, 1])]
        it = SobolevInterpolator(p, f, 1.5, solver="cholesky")
        idx = np.random.default_rng(0).choice(n, 300, replace=False)
        err = np.max(np.abs(it.evaluate(p[idx], method="direct") - f[idx]))
        print(err, it.timings["cholesky"])
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd)
    assert proc.returncode == 0, f"child exited with {proc.returncode}: {proc.stderr[-2000:]}"
    return float(proc.stdout.split()[0])


def test_table2_cell_over_several_panels_and_tiles_reproduces_its_samples(tmp_path):
    """N = 5 000: three of the 2048-column panels and two of the 4096-row tiles of the trailing
    update, the Table 2 cell's path (a child process); the interpolant reproduces its samples
    by the direct kernel sum. N = 16 000, where bare OpenBLAS dpotrf segfaults on AVX-512 with
    2 threads, is ``python bench/table2_cell_16000.py`` (the same child, ~100 s)."""
    assert 2 * PANEL < 5000 < 3 * PANEL and TILE < 5000
    assert _table2_cell_child(5000, tmp_path) < 1e-6

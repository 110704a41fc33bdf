"""Independent, jittered and correlated multi-jittered sampling: the exact MSE of
envfit.predict.renderer.randomisation against brute force over thousands of randomisations
(seeded numpy Generators) of the points themselves — i.i.d. points, r × r jittered strata
(r = 2…16, powers of two or not) and Kensler's own array algorithm for correlated
multi-jittering (square and non-square grids, Mitsuba's 35 = 7 × 5 among them) — on a smooth
integrand, one with a jump along a non-dyadic line and a narrow peak (the shapes of a warped
sun). Tolerance: |prediction − brute force| ≤ Z standard errors of the brute force (plus 1 % for
the grid's quadrature)."""
from __future__ import annotations

import numpy as np
import pytest
from oracles.randomisers import (INTEGRANDS, jittered_points, kensler_cmj_points,
                                 mse_estimate)

from envfit.predict.renderer.randomisation import DyadicGrid, randomised_mse
from envfit.predict.renderer.randomisation._cmj import table_moments, uniform_pair_table
from envfit.predict.renderer.randomisation._strata import rectangle_moments

#: randomisations per brute-force estimate, and the z-score allowed
REPS, Z = 3000, 4.0


@pytest.fixture(scope="module")
def grids():
    return {name: DyadicGrid.from_callable(f.h, 8, nodes=4) for name, f in INTEGRANDS.items()}


def _agree(pred: float, points: np.ndarray, name: str) -> None:
    bf, se = mse_estimate(INTEGRANDS[name], points)
    z = (pred - bf) / se
    assert abs(pred - bf) <= Z * se + 0.01 * pred, \
        f"{name}: predicted {pred:.4e}, brute force {bf:.4e} ± {se:.1e} (z = {z:+.2f})"


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("n", [4, 16, 64, 256])
def test_independent(grids, name, n):
    rng = np.random.default_rng(n)
    _agree(randomised_mse("independent", grids[name], n).mse[0],
           rng.random((REPS, n, 2)), name)


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
def test_jittered_r_2_to_16(grids, name):
    """Every r from 2 to 16; r = 3, 5, 6, 7, … cut the 256-cell grid's cells."""
    rng = np.random.default_rng(7)
    for r in range(2, 17):
        res = randomised_mse("jittered", grids[name], r * r)
        assert res.exact == (256 % r == 0)
        _agree(res.mse[0], jittered_points(rng, REPS, r), name)


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("nx, ny", [(2, 2), (4, 4), (8, 8), (16, 16), (7, 5), (4, 2), (2, 8)])
def test_cmj_against_kenslers_algorithm(grids, name, nx, ny):
    rng = np.random.default_rng(nx * 31 + ny)
    res = randomised_mse("cmj", grids[name], nx * ny, nx=nx, ny=ny)
    _agree(res.mse[0], kensler_cmj_points(rng, REPS, nx, ny), name)


def test_cmj_beats_jittered_and_jittered_beats_random_on_smooth(grids):
    """The ordering the constructions are built for (a check of signs, on the smooth case)."""
    g = grids["smooth"]
    for n in (16, 64, 256):
        mse = {m: randomised_mse(m, g, n).mse[0] for m in ("independent", "jittered", "cmj")}
        assert mse["cmj"] < mse["jittered"] < mse["independent"]


def test_power_above_the_grid_enters_at_one_over_n():
    """A pure within-cell function (a checkerboard finer than the grid) has nothing resolved:
    every stratified method gives exactly V/N (all of V is above the grid)."""
    g = DyadicGrid.from_callable(lambda u: np.where((np.floor(u[:, 0] * 64) + np.floor(
        u[:, 1] * 64)) % 2 == 0, 1.0, -1.0), 4, nodes=8)
    for method in ("independent", "jittered", "cmj"):
        res = randomised_mse(method, g, 16)
        np.testing.assert_allclose(res.resolved, 0.0, atol=1e-12)
        np.testing.assert_allclose(res.mse, g.variance / 16, rtol=1e-12)
    np.testing.assert_allclose(g.variance, 1.0, rtol=1e-12)


@pytest.mark.parametrize("nx, ny", [(1, 4), (4, 1), (3, 3), (7, 5), (16, 16)])
def test_cmj_inclusion_exclusion_equals_the_table_contraction(grids, nx, ny):
    """Two algorithms for the uniform-permutation expectation: inclusion–exclusion over the
    marginals of G (cmj_mse) and the pair-table contraction with uniform tables."""
    n = nx * ny
    e = np.arange(n + 1) / n
    fine, within = rectangle_moments(grids["edge"], e, e)
    g, w = fine[0].reshape(nx, ny, ny, nx), within[0].reshape(nx, ny, ny, nx)
    pairs, jitter = table_moments(g, w, uniform_pair_table(nx), uniform_pair_table(ny))
    res = randomised_mse("cmj", grids["edge"], n, nx=nx, ny=ny)
    np.testing.assert_allclose(res.mse[0], (pairs + jitter) / n ** 2, rtol=1e-11)

"""The inputs of the randomisation predictions (envfit.predict.renderer.randomisation): the dyadic
grid, the Walsh coefficients, the digital nets' dual nets and Owen's gains — each against an
independent computation (closed forms, explicit Walsh sums, character sums over the points the
oracle builds by Mitsuba's own loops) — and the user errors."""
from __future__ import annotations

import numpy as np
import pytest
from oracles.randomisers import sobol_digits

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import (NETS, DyadicGrid, mis_mse, owen_gains,
                                                   randomised_mse, walsh_coefficients)


def _wal(k: int, x: np.ndarray) -> np.ndarray:
    """wal_k(x) from the binary digits of x (Paley order), digit by digit."""
    out = np.ones_like(x)
    t = 0
    while k >> t:
        if (k >> t) & 1:
            out *= 1 - 2 * (np.floor(x * 2 ** (t + 1)) % 2)
        t += 1
    return out


def test_walsh_coefficients_are_the_explicit_sums():
    rng = np.random.default_rng(0)
    m = 8
    a = rng.normal(size=(2, m, m))
    got = walsh_coefficients(a)
    centre = (np.arange(m) + 0.5) / m
    for k1 in range(m):
        for k2 in range(m):
            w = _wal(k1, centre)[:, None] * _wal(k2, centre)[None, :]
            np.testing.assert_allclose(got[:, k1, k2], (a * w).mean(axis=(1, 2)), atol=1e-13)
    np.testing.assert_allclose((got ** 2).sum(axis=(1, 2)), (a ** 2).mean(axis=(1, 2)))


def test_net_points_are_mitsubas_loops():
    for m in range(0, 9):
        np.testing.assert_array_equal(NETS["sobol"].digits(m), sobol_digits(1 << m))


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5])
def test_dual_net_is_where_the_character_sum_is_n(m):
    """k ∈ D* ⇔ Σ_j wal_k(x_j) = N, over the points themselves, for k below 2^(m+1)."""
    n, size = 1 << m, 1 << (m + 1)
    x = sobol_digits(n).astype(np.float64) / 2.0 ** 32
    w1 = np.array([_wal(k, x[:, 0]) for k in range(size)])           # (k, j)
    w2 = np.array([_wal(k, x[:, 1]) for k in range(size)])
    sums = w1 @ w2.T                                                  # Σ_j wal_k1 wal_k2
    assert set(np.unique(np.round(sums))) <= {0.0, float(n)}
    np.testing.assert_array_equal(NETS["sobol"].dual_mask(m, size), np.isclose(sums, n))


def test_owen_gains_of_a_zero_m_two_net():
    """t = 0: no dual index in the blocks with κ1 + κ2 ≤ m − 2, and N·Γ of every block is 0 or
    a power of two (Pan & Owen 2023); N = 1: every gain is 1."""
    for m in range(1, 7):
        g = owen_gains("sobol", m, 1 << (m + 2)) * (1 << m)
        kappa = np.arange(g.shape[0]) - 1
        small = kappa[:, None] + kappa[None, :] <= m - 2
        assert np.all(g[small] == 0.0)
        nz = g[g > 0]
        np.testing.assert_allclose(np.log2(nz), np.round(np.log2(nz)), atol=1e-12)
    g1 = owen_gains("sobol", 0, 8)
    assert g1[0, 0] == 0.0 and np.all(np.delete(g1.ravel(), 0) == 1.0)


def test_from_callable_is_exact_for_cubics():
    """Two Gauss nodes per axis integrate degree 3: h = u1³ + u1·u2 has closed-form cell
    means; V = ∫h² − (∫h)² in closed form (h² has degree 6: exact with four nodes)."""
    g = DyadicGrid.from_callable(lambda u: u[:, 0] ** 3 + u[:, 0] * u[:, 1], 3, nodes=2)
    e = np.arange(9) / 8
    p4 = np.diff(e ** 4) / 4 * 8                       # mean of u1³ per cell
    p2 = np.diff(e ** 2) / 2 * 8                       # mean of u per cell
    np.testing.assert_allclose(g.mean[0], p4[:, None] + p2[:, None] * p2[None, :], atol=1e-14)
    mean = 1 / 4 + 1 / 4
    second = 1 / 7 + 2 * (1 / 5) * (1 / 2) + (1 / 3) * (1 / 3)      # ∫u1⁶ + 2∫u1⁴u2 + ∫u1²u2²
    # h² has degree 6 in u1: the rule is not exact for it; 2 nodes err by O(M^-4)
    np.testing.assert_allclose(g.variance[0], second - mean ** 2, rtol=1e-4)
    g4 = DyadicGrid.from_callable(lambda u: u[:, 0] ** 3 + u[:, 0] * u[:, 1], 3, nodes=4)
    np.testing.assert_allclose(g4.variance[0], second - mean ** 2, rtol=1e-13)


def test_from_arrays_trusts_the_given_variance():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(16, 16))
    b = a ** 2 + rng.random((16, 16))
    g = DyadicGrid.from_arrays(a, b, variance=a.var() + 0.25)
    np.testing.assert_allclose(g.variance, [a.var() + 0.25])
    np.testing.assert_allclose(g.above, [0.25])
    np.testing.assert_allclose(g.resolved_variance, [a.var()])
    r = randomised_mse("independent", g, 4)
    np.testing.assert_allclose(r.mse, g.variance / 4)
    even = DyadicGrid.from_arrays(a, variance=a.var() + 0.25)
    np.testing.assert_allclose(even.within, 0.25)


def test_combined_grid_is_the_grid_of_the_sum():
    def h1(u):
        return np.exp(u[:, 0]) * u[:, 1]

    def h2(u):
        return (u[:, 0] + 0.3 * u[:, 1] > 0.5).astype(float)

    g1, g2 = (DyadicGrid.from_callable(h, 4, nodes=4) for h in (h1, h2))
    cross = DyadicGrid.from_callable(lambda u: h1(u) * h2(u), 4, nodes=4).mean
    both = DyadicGrid.from_callable(lambda u: h1(u) + h2(u), 4, nodes=4)
    got = g1.combined(g2, cross)
    np.testing.assert_allclose(got.mean, both.mean, rtol=1e-13)
    np.testing.assert_allclose(got.variance, both.variance, rtol=1e-12)
    assert randomised_mse("owen", got, np.int64(4)).n == 4             # numpy ints accepted


@pytest.mark.parametrize("call, match", [
    (lambda g: randomised_mse("sobolish", g, 4), "unknown randomisation"),
    (lambda g: randomised_mse("owen", g, 0), "n must be"),
    (lambda g: randomised_mse("owen", g, 12), "2\\^m"),
    (lambda g: randomised_mse("owen", g, 64), "at least 64 cells"),
    (lambda g: randomised_mse("digital_shift", g, 4, net="halton"), "unknown net"),
    (lambda g: randomised_mse("jittered", g, 12), "r²"),
    (lambda g: randomised_mse("cmj", g, 32), "32 → 35"),
    (lambda g: randomised_mse("cmj", g, 12, nx=4), "both nx and ny"),
    (lambda g: randomised_mse("independent", g, 4, r=2), "options"),
    (lambda g: randomised_mse("cp_shift", g, 3, points=np.zeros((2, 2))), "points must be"),
    (lambda g: mis_mse("digital_shift", g, g, 4, shared=True), "total"),
    (lambda g: DyadicGrid.from_arrays(np.zeros((6, 6)), np.zeros((6, 6))), "power of two"),
    (lambda g: DyadicGrid.from_arrays(np.full((4, 4), np.nan), np.zeros((4, 4))), "NaN"),
    (lambda g: DyadicGrid.from_arrays(np.ones((4, 4)), np.zeros((4, 4))), "below mean"),
    (lambda g: DyadicGrid.from_arrays(np.ones((4, 4))), "needs mean_sq or variance"),
    (lambda g: DyadicGrid.from_callable(lambda u: u[:, 0], 20), "level"),
])
def test_user_errors_are_parameter_errors(call, match):
    g = DyadicGrid.from_callable(lambda u: u[:, 0] * u[:, 1], 5, nodes=1)
    with pytest.raises(ParameterError, match=match):
        call(g)

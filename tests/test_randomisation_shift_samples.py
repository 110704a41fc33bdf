"""The digital shift's power above the grid, sampled (``randomisation._shift_samples``): the
MSE of a digitally shifted Sobol' net for N beyond the grid, against the exact dual-net sum
of a function whose Walsh spectrum a finer grid holds whole."""
import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import (DyadicGrid, mis_mse, randomised_mse,
                                                   sampled_above, shift_sample)

FINE = 10                     # the functions below are constant on the cells of level FINE


def _cells(seed: int, level: int = 8):
    """A rough function constant on the cells of ``level`` (random values to the 4th power
    over a ramp): all its Walsh power lies below 2^level."""
    m = 1 << level
    rng = np.random.default_rng(seed)
    vals = rng.random((m, m)) ** 4 + np.add.outer(np.linspace(0, 1, m), np.linspace(0, 2, m))

    def h(u):
        i = np.minimum((u[:, 0] * m).astype(int), m - 1)
        j = np.minimum((u[:, 1] * m).astype(int), m - 1)
        return vals[i, j]
    return h, vals


def _exact(vals, n):
    """The exact MSE: the dual-net sum on the function's own grid (nothing above it)."""
    g = DyadicGrid.from_arrays(np.kron(vals, np.ones((4, 4))), np.kron(vals, np.ones((4, 4))) ** 2)
    return randomised_mse("digital_shift", g, n).mse


def _sampled(h, level, n, *, shifts=512, seed=1, nodes=None):
    g = DyadicGrid.from_callable(h, level, nodes=nodes or (1 << (8 - level)))
    s = shift_sample(n, shifts, seed)
    above, se = sampled_above(s, g.mean, np.asarray(h(s.points)).reshape(len(s.points), -1))
    return randomised_mse("digital_shift", g.with_shift_above("sobol", n, above, se), n)


@pytest.mark.parametrize("n,level", [(64, 4), (256, 4), (256, 6), (1024, 6)])
def test_sampled_mse_equals_the_exact_dual_sum_beyond_the_grid(n, level):
    h, vals = _cells(3)
    exact = _exact(vals, n)[0]
    r = _sampled(h, level, n)
    assert not r.exact and r.above_se is not None
    assert abs(r.mse[0] - exact) <= 4.0 * r.above_se[0]
    assert r.above_se[0] < 0.15 * exact                   # Q = 512: ≈ √(2/Q) of the part


def test_smooth_integrand_matches_a_grid_four_times_finer_than_the_net():
    """A smooth integrand, predicted at M = N/2 (sampled) and at M = 4N (the grid's own
    estimate, 1.5 % on the tests' smooth integrand): its dual-net power lies mostly at
    indices ≥ N (a ramp's Walsh coefficients sit at powers of two), so the sampled part is
    most of the MSE and its standard error ≈ √(2/Q) of it."""
    def h(u):
        return np.exp(u[:, 0] + 2.0 * u[:, 1]) + np.sin(7.0 * u[:, 0] * u[:, 1])
    n = 256
    ref = randomised_mse("digital_shift", DyadicGrid.from_callable(h, FINE, nodes=2), n).mse[0]
    g = DyadicGrid.from_callable(h, 7, nodes=2)
    s = shift_sample(n, 256, seed=5)
    above, se = sampled_above(s, g.mean, h(s.points)[:, None])
    r = randomised_mse("digital_shift", g.with_shift_above("sobol", n, above, se), n)
    assert abs(r.mse[0] - ref) <= 4.0 * r.above_se[0] + 0.02 * ref
    assert r.above[0] > 0.9 * r.mse[0]
    assert 0.5 * np.sqrt(2 / 256) < r.above_se[0] / r.above[0] < 2.0 * np.sqrt(2 / 256)


def test_inaccurate_cell_means_are_corrected():
    """Cell means by the midpoint rule on a coarse grid, with a jump across cells at a
    non-dyadic line: the resolved part alone is off, the sum with the sampled correction
    agrees with brute force (20 000 random shifts of the plain estimator)."""
    def h(u):
        return np.where(u[:, 0] + 0.37 * u[:, 1] < 0.61, 4.0, 0.5) + u[:, 1]
    n = 256
    brute = shift_sample(n, 20000, seed=9)
    f = h(brute.points).reshape(20000, n).mean(axis=1)
    ref = np.mean((f - f.mean()) ** 2) * 20000 / 19999
    ref_se = np.std((f - f.mean()) ** 2) / np.sqrt(20000)
    r = _sampled(h, 4, n, shifts=1024, nodes=1)
    assert abs(r.resolved[0] - ref) > 0.2 * ref                  # the grid alone is off
    assert abs(r.mse[0] - ref) <= 4.0 * (r.above_se[0] + ref_se)


def test_shared_net_cross_term_by_polarisation():
    """Two streams on one shifted net (Mitsuba's ldsampler MIS): the sampled grids give the
    exact MSE of h1 + h2 and the exact cross term."""
    h1, v1 = _cells(11)
    h2, v2 = _cells(12)
    n, level = 512, 5
    s = shift_sample(n, 1024, seed=2)
    grids = []
    for h in (h1, h2, lambda u: h1(u) + h2(u)):
        g = DyadicGrid.from_callable(h, level, nodes=8)
        grids.append(g.with_shift_above("sobol", n, *sampled_above(s, g.mean,
                                                                   h(s.points)[:, None])))
    m = mis_mse("digital_shift", grids[0], grids[1], n, shared=True, total=grids[2])
    exact_total = _exact(v1 + v2, n)[0]
    exact_cross = (exact_total - _exact(v1, n)[0] - _exact(v2, n)[0]) / 2.0
    se = (m.first.above_se[0] + m.second.above_se[0]
          + randomised_mse("digital_shift", grids[2], n).above_se[0])
    assert abs(m.mse[0] - exact_total) <= 4.0 * se
    assert abs(m.cross[0] - exact_cross) <= 4.0 * se


def test_beyond_the_grid_without_samples_is_refused_and_bad_input_is_one_line():
    g = DyadicGrid.from_callable(lambda u: u[:, 0], 4)
    with pytest.raises(ParameterError, match="grid of at least"):
        randomised_mse("digital_shift", g, 64)
    with pytest.raises(ParameterError, match="2\\^m"):
        shift_sample(48, 16)
    with pytest.raises(ParameterError, match="shifts"):
        shift_sample(16, 2)
    s = shift_sample(16, 8)
    with pytest.raises(ParameterError, match="channels"):
        sampled_above(s, np.zeros((2, 4, 4)), np.zeros((len(s.points), 3)))


def test_shifts_are_the_net_xor_one_shift_each():
    s = shift_sample(16, 8, seed=4)
    d = s.digits
    base = d[0] ^ d[0, 0]                    # the net itself: its point 0 is the origin
    for q in range(8):
        assert np.array_equal(d[q] ^ d[q, 0], base)
    assert np.all(s.points >= 0.0) and np.all(s.points < 1.0)

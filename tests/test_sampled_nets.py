"""The sampled nets of the renderer model (``envfit.predict.renderer._sampled_nets``): every N
of a pass read as a prefix of one table, the prefix variances, and the MSE of an
Owen-scrambled prefix sampler between the powers of two — against brute force over the law
Cycles' samplers run (an index shuffle that keeps aligned blocks, ``oracles.randomisers``'
bit-by-bit nested uniform scramble of the points), on the oracle's analytic integrands."""
import numpy as np
import pytest
from oracles.randomisers import INTEGRANDS, owen_tabled_points, sobol_digits

from envfit.predict.renderer._sampled_nets import SampledNets, curve_parts, prefix_variance
from envfit.predict.renderer.randomisation import (DyadicGrid, ShiftSample, owen_sample,
                                                   randomised_mse, sampled_above,
                                                   sampled_above_prefixes, shift_sample)

LEVEL, Q, REPS, Z = 8, 512, 1200, 4.0


def test_prefix_variance_is_the_sample_variance_of_each_prefix_mean():
    rng = np.random.default_rng(0)
    v = rng.normal(5.0, 0.1, size=(7, 33, 2))
    means = np.cumsum(v, axis=1) / np.arange(1, 34)[None, :, None]
    np.testing.assert_allclose(prefix_variance(v), means.var(axis=0, ddof=1), rtol=1e-9)


def test_prefixes_are_each_ns_own_sample():
    """A digital shift's prefix is ``shift_sample(n)`` itself; an Owen-scrambled prefix is a
    (0, m, 2)-net; ``sampled_above_prefixes`` is ``sampled_above`` of each prefix."""
    nets = SampledNets(8, seed=3)

    class R:
        name, n, level = "owen", 64, 4
    nets.plan([R()])
    assert np.array_equal(nets.sample("shift", 16).digits, shift_sample(16, 8, 3).digits)
    cells = (nets.sample("owen", 16).digits >> np.uint64(30)).astype(int)   # 4 x 4 cells
    for q in range(8):
        assert len({(a, b) for a, b in cells[q]}) == 16
    top = nets.sample("owen", 64)
    h = INTEGRANDS["edge"].h
    vals = h(top.points)[:, None]
    grid = DyadicGrid.from_callable(h, 3, nodes=3)
    many = sampled_above_prefixes(top, grid.mean, vals, [16, 40, 64])
    for n in (16, 40, 64):
        one = sampled_above(ShiftSample("sobol", n, top.digits[:, :n], "owen"), grid.mean,
                            vals.reshape(8, 64, 1)[:, :n])
        np.testing.assert_allclose(many[n][0], one[0], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(many[n][1], one[1], rtol=1e-9, atol=1e-15)


def _index_shuffled_points(rng, reps: int, n: int) -> np.ndarray:
    """Cycles' law of N points: a nested uniform scramble of the sample index (bit j flipped
    by a random bit drawn per value of the bits above it, so the first 2^k indices stay an
    aligned block) into an Owen-scrambled Sobol' sequence of 2^(m+1) points."""
    m1 = n.bit_length()                                   # 2^(m+1) > n
    pts = owen_tabled_points(rng, reps, sobol_digits(1 << m1), m1)
    idx = np.broadcast_to(np.arange(n), (reps, n))
    out = np.zeros((reps, n), dtype=np.int64)
    rows = np.arange(reps)[:, None]
    for j in range(m1 - 1, -1, -1):
        table = rng.integers(0, 2, size=(reps, 1 << (m1 - 1 - j)))
        out |= (((idx >> j) & 1) ^ table[rows, idx >> (j + 1)]) << j
    return pts[rows, out]


@pytest.mark.parametrize("name, n", [("smooth", 600), ("edge", 600), ("peak", 1500),
                                     ("edge", 1500)])
def test_between_powers_of_two_against_brute_force(name, n):
    """The calibrated prefix variance (module docstring) against brute force over Cycles'
    law: within 4 standard errors of the brute force and 15 %."""
    f = INTEGRANDS[name]
    grid = DyadicGrid.from_callable(f.h, LEVEL, nodes=3)
    lo = 1 << (n.bit_length() - 1)
    s = owen_sample(2 * lo, Q, seed=n)
    vals = f.h(s.points)[:, None]
    above = sampled_above_prefixes(s, grid.mean, vals, [lo, 2 * lo])
    exact = [randomised_mse("owen", grid.with_sampled_above("owen", "sobol", k, *above[k]),
                            k).mse for k in (lo, 2 * lo)]
    nets = SampledNets(Q, seed=n)
    nets.curves, nets.curves_top = {"map": prefix_variance(vals.reshape(Q, 2 * lo, 1))}, 2 * lo
    got = nets.between("map", False, n, *exact)[0]
    err2 = (f.h(_index_shuffled_points(np.random.default_rng(n), REPS, n)).mean(axis=1)
            - f.integral) ** 2
    bf, se = err2.mean(), err2.std(ddof=1) / np.sqrt(REPS)
    assert abs(got - bf) <= Z * se and abs(got - bf) <= 0.15 * bf, \
        f"{name} N={n}: calibrated {got:.4e}, brute {bf:.4e} ± {se:.1e}"
    assert np.isclose(nets.between("map", False, lo + 1, *exact)[0],
                      exact[0][0] * prefix_variance(vals.reshape(Q, 2 * lo, 1))[lo, 0]
                      / prefix_variance(vals.reshape(Q, 2 * lo, 1))[lo - 1, 0], rtol=1e-2)


def test_curve_parts_of_the_strategies():
    assert curve_parts("mis", shared=False) == ("mis_e", "mis_b")
    assert curve_parts("mis", shared=True) == ("mis_t",)
    assert curve_parts("brdf", shared=False) == ("brdf",)

"""Owen-scrambled nets above the grid, sampled (``randomisation._owen_samples``): the MSE of a
nested-uniform-scrambled Sobol' net at N = 512 … 4096 on a grid of M = 256 cells per side
(N > M/2: the exact formula does not reach), against brute force over independent bit-by-bit
nested uniform scrambles of the oracle (``oracles.randomisers.owen_tabled_points``, not
scipy's LMS + digital shift) on the oracle's analytic integrands (smooth, a jump, a peak); and
against the exact formula where the grid resolves N."""
import numpy as np
import pytest
from oracles.randomisers import (INTEGRANDS, mse_estimate, owen_scrambled_points,
                                 owen_tabled_points, sobol_digits)

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import (DyadicGrid, owen_sample, randomised_mse,
                                                   sampled_above)

LEVEL, SCRAMBLES, REPS, Z = 8, 1024, 800, 4.0


@pytest.fixture(scope="module")
def grids():
    return {name: DyadicGrid.from_callable(f.h, LEVEL, nodes=3)
            for name, f in INTEGRANDS.items()}


def _sampled(grid, h, n, scrambles=SCRAMBLES, seed=1):
    s = owen_sample(n, scrambles, seed)
    above, se = sampled_above(s, grid.mean, h(s.points)[:, None])
    return randomised_mse("owen", grid.with_sampled_above("owen", "sobol", n, above, se), n)


@pytest.mark.parametrize("name, n", [(name, n) for name in sorted(INTEGRANDS)
                                     for n in (512, 4096)] + [("smooth", 1024),
                                                              ("edge", 2048)])
def test_sampled_owen_mse_against_brute_force_scrambles(grids, name, n):
    f = INTEGRANDS[name]
    r = _sampled(grids[name], f.h, n, seed=n)
    assert not r.exact and r.above_se is not None and "sampled" in r.note
    pts = owen_tabled_points(np.random.default_rng(40 + n), REPS, sobol_digits(n),
                             n.bit_length() - 1)
    bf, se = mse_estimate(f, pts)
    err = abs(r.mse[0] - bf)
    assert err <= Z * np.hypot(r.above_se[0], se), \
        f"{name} N={n}: sampled {r.mse[0]:.4e} ± {r.above_se[0]:.1e}, brute {bf:.4e} ± {se:.1e}"
    assert err <= 0.12 * bf


def test_tabled_oracle_is_the_bit_by_bit_scramble():
    """The oracle's two scrambles (one distinct-prefix draw per digit, one table) agree on the
    MSE of the smooth integrand at N = 64 within their standard errors."""
    f, n = INTEGRANDS["smooth"], 64
    a = mse_estimate(f, owen_scrambled_points(np.random.default_rng(3), 3000, sobol_digits(n), 6))
    b = mse_estimate(f, owen_tabled_points(np.random.default_rng(4), 3000, sobol_digits(n), 6))
    assert abs(a[0] - b[0]) <= Z * np.hypot(a[1], b[1])


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
def test_sampled_agrees_with_the_exact_formula_where_the_grid_resolves(grids, name):
    """At N = 64 and 128 ≤ M/2 the grid's exact formula holds; the sampled estimate (the
    same blocks below the grid, the rest sampled) agrees within its standard error."""
    f = INTEGRANDS[name]
    for n in (64, 128):
        exact = randomised_mse("owen", grids[name], n)
        assert exact.exact
        r = _sampled(grids[name], f.h, n, scrambles=512, seed=7)
        assert np.allclose(r.resolved, exact.resolved)
        assert abs(r.mse[0] - exact.mse[0]) <= Z * r.above_se[0] + 1e-3 * exact.mse[0]


def test_scrambles_keep_the_net_and_are_uniform():
    s = owen_sample(256, 64, seed=2)
    assert s.randomisation == "owen" and s.digits.shape == (64, 256, 2)
    cells = (s.digits >> np.uint64(24)).astype(np.int64)        # first 8 digits
    for q in range(64):                                          # a (0, 8, 2)-net: 1-D strata
        assert len(set(cells[q, :, 0])) == 256 and len(set(cells[q, :, 1])) == 256
        quads = (cells[q, :, 0] >> 4) * 16 + (cells[q, :, 1] >> 4)
        assert np.bincount(quads, minlength=256).tolist() == [1] * 256
    first = s.points.reshape(64, 256, 2)[:, 0, :]                # point 0 over the scrambles
    assert abs(first.mean() - 0.5) < 0.06 and first.min() >= 0.0 and first.max() < 1.0


def test_bad_input_is_one_line():
    g = DyadicGrid.from_callable(lambda u: u[:, 0], 4)
    with pytest.raises(ParameterError, match="grid of at least"):
        randomised_mse("owen", g, 64)                            # no samples: N ≤ M
    with pytest.raises(ParameterError, match="2\\^m"):
        owen_sample(48, 16)
    with pytest.raises(ParameterError, match="scrambles"):
        owen_sample(16, 2)

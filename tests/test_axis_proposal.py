"""envfit.measure._axis_proposal and the importance-sampled measurement: the proposal is a
density (it integrates to 1 over the sphere, its draws fall in the cells as often as it
says), the weighted mean is unbiased for a closed-form mean over uniform axes and far less
variable than the uniform mean where the integrand is peaked, and measure_rule's
importance-sampled interval contains the exact RMSE of random BRDF sampling of a sun map
(closed form, envfit.predict.warped._pixel_moments.exact_mean_variances) and is narrower than the
uniform one.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from envfit.base._errors import ParameterError
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.maps._envmap import EnvMap
from envfit.measure._axis_proposal import UNIFORM_SHARE, AxisProposal, cell_centres
from envfit.shading._ground_truth import weight_function
from envfit.sampling._map_sampler import MapSampler
from envfit.measure._adaptive_rmse import adaptive_rmse
from envfit.sampling._rules import RendererRule
from envfit.measure._rules import RendererSetup, measure_rule

SUN = np.array([np.sin(0.7) * np.cos(1.0), np.sin(0.7) * np.sin(1.0), np.cos(0.7)])


@pytest.fixture(scope="module")
def sun_map():
    f, _ = sun_gp_map(32, seed=3, sun_theta=0.7, sun_phi=1.0, sun_radius=0.12,
                      sun_radiance=400.0, channels=1)
    return EnvMap(f, up="z", name="sun32")


@pytest.fixture(scope="module")
def proposal(sun_map):
    return AxisProposal.of(sun_map, MapSampler(sun_map), weight_function("glossy", 30.0),
                           rows=16)


def _uniform(rng, m):
    v = rng.normal(size=(m, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("up", ["y", "z", "x"])
def test_cells_are_equal_area_and_ordered(up):
    q = AxisProposal.uniform_density(up, rows=6)
    assert q.cell_of(cell_centres(6, up)).tolist() == list(range(72))
    counts = np.bincount(q.cell_of(_uniform(np.random.default_rng(0), 72000)), minlength=72)
    # equal areas: uniform axes fall in every cell with probability 1/72 (chi-square test)
    assert stats.chisquare(counts).pvalue > 1e-3


def test_the_density_integrates_to_one_and_the_draws_follow_it(proposal):
    rng = np.random.default_rng(1)
    dens = proposal.relative_density(_uniform(rng, 200000))
    assert abs(dens.mean() - 1.0) < 4.0 * dens.std() / np.sqrt(dens.size)
    axes, w = proposal.draw(rng, 100000)
    assert np.allclose(np.linalg.norm(axes, axis=1), 1.0)
    assert np.allclose(w, 1.0 / proposal.relative_density(axes))
    assert w.max() <= 1.0 / UNIFORM_SHARE + 1e-12 and w.min() < 0.2   # peaked, and bounded
    expected = (UNIFORM_SHARE / proposal.cells + (1 - UNIFORM_SHARE) * proposal.cell_mass)
    counts = np.bincount(proposal.cell_of(axes), minlength=proposal.cells)
    keep = expected * axes.shape[0] > 5
    assert stats.chisquare(counts[keep], expected[keep] / expected[keep].sum()
                           * counts[keep].sum()).pvalue > 1e-3
    # the mass sits where the glossy lobe catches the sun
    assert np.median(axes[w < 0.5] @ SUN) > 0.9


def test_weighted_mean_is_unbiased_and_less_variable(proposal):
    kappa = 40.0                     # d(a) = exp(κ(a·μ − 1)): E_u d = (1 − e^{−2κ})/(2κ)
    exact = (1.0 - np.exp(-2.0 * kappa)) / (2.0 * kappa)
    second = (1.0 - np.exp(-4.0 * kappa)) / (4.0 * kappa)     # E_u d²
    rng = np.random.default_rng(2)
    axes, w = proposal.draw(rng, 40000)
    wd = w * np.exp(kappa * (axes @ SUN - 1.0))
    assert abs(wd.mean() - exact) < 4.0 * wd.std() / np.sqrt(wd.size)
    assert wd.std() < 0.35 * np.sqrt(second - exact ** 2)      # uniform axes' spread


def test_adaptive_rmse_with_a_proposal(proposal):
    kappa = 40.0
    exact_rmse = np.sqrt((1.0 - np.exp(-2.0 * kappa)) / (2.0 * kappa))

    def d(axes):
        return np.exp(kappa * (axes @ SUN - 1.0))

    imp = adaptive_rmse(d, axes_start=200, max_axes=6400, target_relative=0.05, seed=4,
                        resamples=500, proposal=proposal)
    uni = adaptive_rmse(d, axes_start=200, max_axes=6400, target_relative=0.05, seed=4,
                        resamples=500)
    assert imp.sampling == "importance" and uni.sampling == "uniform"
    assert imp.target_met and imp.interval.low < exact_rmse < imp.interval.high
    assert imp.axes < uni.axes


def test_measure_rule_importance_contains_the_exact_rmse(sun_map):
    from envfit.predict.warped._pixel_moments import _Pixels, exact_mean_variances

    setup = RendererSetup.of(sun_map, sources=[])
    weight = weight_function("glossy", 30.0)
    v = exact_mean_variances(sun_map, _Pixels(sun_map, setup.sampler, 1), weight)["brdf"]
    rule = RendererRule("brdf", "random", 64)
    exact = np.sqrt(v / 64)
    kw = dict(seed=5, target_relative=0.5, axes_start=400, max_axes=400, resamples=500)
    imp = measure_rule(setup, rule, "glossy", 30.0, sampling="importance", **kw)
    uni = measure_rule(setup, rule, "glossy", 30.0, sampling="uniform", **kw)
    assert imp.sampling == "importance" and uni.sampling == "uniform"
    assert imp.interval.contains(exact), (imp.interval, exact)
    assert imp.interval.relative_half_width < 0.7 * uni.interval.relative_half_width


@pytest.mark.parametrize("kw, msg", [
    (dict(up="z", rows=2, cell_mass=np.ones(7)), "8 finite"),
    (dict(up="z", rows=2, cell_mass=-np.ones(8)), "8 finite"),
    (dict(up="z", rows=2, cell_mass=np.zeros(8)), "all zero"),
    (dict(up="z", rows=2, cell_mass=np.ones(8), uniform=0.0), "uniform must"),
    (dict(up="w", rows=2, cell_mass=np.ones(8)), "up must"),
])
def test_bad_proposals_are_one_line_errors(kw, msg):
    with pytest.raises(ParameterError, match=msg):
        AxisProposal(**kw)


def test_bad_sampling_is_a_one_line_error(sun_map):
    setup = RendererSetup.of(sun_map, sources=[])
    with pytest.raises(ParameterError, match="sampling must be one of importance, uniform"):
        measure_rule(setup, RendererRule("brdf", "random", 16), sampling="stratified")

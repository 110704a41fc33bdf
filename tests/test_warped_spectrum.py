"""The warped-integrand spectrum predicts the shifted estimators' error (envfit.predict.renderer._warped_spectrum).

Every reference is independent: brute-force means over thousands of Cranley–Patterson shifts
and twists of the estimators themselves, the exact variances of oracles.is_variance
(sphere quadrature, a second algorithm), the dual lattice of a rank-1 lattice and Funk–Hecke's
mean of the shading integral.
"""
import numpy as np
import pytest
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.theory._pointsets import square_points

from envfit.base._errors import ParameterError
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import pixel_solid_angles
from envfit.predict.renderer import _warped_spectrum as ws
from envfit.shading._ground_truth import shading_integral, weight_function
from envfit.sampling._importance import importance_estimates
from oracles.is_variance import LobePdf, MapPdf, is_variance, mis_variance
from envfit.sampling._map_sampler import MapSampler


@pytest.fixture(scope="module")
def sun_map():
    arr, _ = sun_gp_map(16, seed=3, channels=1, sun_radiance=30.0, sun_radius=0.25)
    m = EnvMap(arr)
    return m, MapSampler(m)


AXES = np.array([[0.3, 0.8, -0.5], [-0.6, 0.2, 0.77]])
AXES = AXES / np.linalg.norm(AXES, axis=1, keepdims=True)


@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
@pytest.mark.parametrize("technique", ["map", "brdf", "mis"])
@pytest.mark.parametrize("pointset", ["sobol", "sf"])
def test_prediction_matches_brute_force_over_shifts(sun_map, brdf, technique, pointset):
    m, sampler = sun_map
    u = square_points(pointset, 16, seed=0)
    pred = ws.shifted_mse_per_axis(m, AXES, u, technique, brdf, sampler=sampler, grid=256)
    reps = 3000
    truth = shading_integral(m, AXES, brdf, 30.0, method="pixels")
    est = importance_estimates(m, np.repeat(AXES, reps, axis=0), u, technique,
                               sampler=sampler, brdf=brdf, shininess=30.0, seed=11)
    err2 = ((est - np.repeat(truth, reps, axis=0)) ** 2).mean(axis=1).reshape(len(AXES), reps)
    meas = err2.mean(axis=1)
    se = err2.std(axis=1) / np.sqrt(reps)
    # the model's own error (grid aliasing, pixel quadrature) is a few %; the MC error se
    assert np.all(np.abs(pred - meas) <= 0.08 * meas + 4 * se), (pred / meas, se / meas)


@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
def test_variances_equal_the_sphere_quadrature_of_is_variance(sun_map, brdf):
    """The pixel-quadrature V of each technique against is_variance / mis_variance."""
    m, sampler = sun_map
    wf = weight_function(brdf, 30.0)
    px = ws._Pixels(m, sampler, ws._subdivision(m, wf))
    nu = np.array([0.5, 0.5])
    heur = ws.HEURISTICS["balance"]
    for tech, ref in [("map", is_variance(m, AXES, MapPdf(m), brdf, 30.0)),
                      ("brdf", is_variance(m, AXES, LobePdf(brdf, 30.0), brdf, 30.0))]:
        got = np.array([ws._pixel_moments(px, tech, wf, nu, heur, a)[0][0, 0] for a in AXES])
        # 4 %: on this 32×16 map a diffuse lobe gets 2×2 midpoint nodes per pixel (no
        # cell-exact square), and the sun is 1.3 pixels wide
        np.testing.assert_allclose(got, np.asarray(ref).reshape(len(AXES), -1)[:, 0], rtol=0.04)
    # multi-sample MIS with n1 = n2 = 1: Var F = V1 + V2
    ref = np.asarray(mis_variance(m, AXES, MapPdf(m), LobePdf(brdf, 30.0), brdf, 30.0,
                                  counts=(1, 1))).reshape(len(AXES), -1)[:, 0]
    got = np.array([ws._pixel_moments(px, "mis", wf, nu, heur, a)[0][:, 0].sum() for a in AXES])
    np.testing.assert_allclose(got, ref, rtol=0.04)


def test_random_points_give_the_monte_carlo_variance(sun_map):
    """For a fixed random set the box term fluctuates about V/N: over 40 sets its mean is V/N."""
    m, sampler = sun_map
    spec = ws.warped_spectrum(m, "map", sampler=sampler, grid=128, axes=16)
    n = 64
    vals = [ws.shifted_mse_terms(spec, np.random.default_rng(k).random((n, 2)))
            for k in range(40)]
    tot = np.array([v["box"] + v["tail"] for v in vals])
    assert abs(tot.mean() / (spec.variance[0] / n) - 1) < 3 * tot.std() / np.sqrt(40) / tot.mean() + 0.02


def test_exponential_sums_of_a_rank1_lattice_live_on_its_dual():
    """Fibonacci lattice N = 13, z = (1, 8): |S(k)| = 1 iff k0 + 8 k1 ≡ 0 (mod 13), else 0."""
    n, z = 13, np.array([1, 8])
    u = (np.arange(n)[:, None] * z[None, :] / n) % 1.0
    S = ws._exp_sums(u, 6)
    k0, k1 = np.meshgrid(np.arange(-6, 7), np.arange(0, 7), indexing="ij")
    dual = (k0 * z[0] + k1 * z[1]) % n == 0
    np.testing.assert_allclose(np.abs(S), dual.astype(float), atol=1e-9)


def test_mean_is_the_solid_angle_mean_of_the_map(sun_map):
    m, sampler = sun_map
    spec = ws.warped_spectrum(m, "mis", sampler=sampler, grid=64, axes=256)
    om = pixel_solid_angles(16, 32)
    # Funk–Hecke: the mean of I over the sphere of axes is the map's solid-angle mean
    ref = float((ws._cell_average(m.data)[:, :, 0] * om).sum() / (4 * np.pi))
    assert abs(spec.mean / ref - 1) < 0.01


def test_cell_square_average_is_exact_for_a_linear_ramp():
    """Along columns v = j: the cell mean of v² is j² + 1/12 (the interpolant is v itself)."""
    a = np.tile(np.arange(16.0), (8, 1))
    got = ws.cell_square_average(a)[1:-1, 2:14]       # (the pole rows see the ramp at φ + π)
    ref = np.tile(np.arange(2, 14.0) ** 2 + 1 / 12, (6, 1))
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_uniform_map_gives_uniform_axes_with_equal_weights():
    m = EnvMap(np.ones((8, 16, 1)))
    A, w = ws.proposal_axes(m, MapSampler(m), weight_function("diffuse", 30.0), 32)
    np.testing.assert_allclose(w, 1 / 32, rtol=0.1)   # the proxies' block quadrature varies a little
    assert abs(A[:, 2].mean()) < 0.05          # spread over the sphere, not clustered


@pytest.mark.parametrize("kw, msg", [({"technique": "bogus"}, "technique must be one of"),
                                     ({"grid": 30}, "multiple of 4"),
                                     ({"fraction": 1.0}, "fraction must be in")])
def test_bad_parameters_are_one_line_errors(kw, msg):
    m = EnvMap(np.ones((8, 16, 1)))
    args = {"technique": "mis", "grid": 32, **kw}
    with pytest.raises(ParameterError, match=msg):
        ws.warped_spectrum(m, args.pop("technique"), **args)

"""The warped-integrand spectrum predicts the shifted estimators' error
(envfit.predict.warped._warped_spectrum and the modules it is split into).

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
from envfit.predict.warped import _warped_spectrum as ws
from envfit.predict.warped._pixel_moments import (_cell_average, _pixel_moments, _Pixels,
                                                    _subdivision)
from envfit.predict.warped._prediction_sums import _exp_sums
from envfit.predict.warped._techniques import Technique
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
    px = _Pixels(m, sampler, _subdivision(m, wf))
    for tech, ref in [("map", is_variance(m, AXES, MapPdf(m), brdf, 30.0)),
                      ("brdf", is_variance(m, AXES, LobePdf(brdf, 30.0), brdf, 30.0))]:
        t = Technique.of(tech, wf, "balance", 0.5)
        got = np.array([_pixel_moments(px, t, a).variance[0, 0] for a in AXES])
        # 4 %: on this 32×16 map a diffuse lobe gets 2×2 midpoint nodes per pixel (no
        # cell-exact square), and the sun is 1.3 pixels wide
        np.testing.assert_allclose(got, np.asarray(ref).reshape(len(AXES), -1)[:, 0], rtol=0.04)
    # multi-sample MIS with n1 = n2 = 1: Var F = V1 + V2
    ref = np.asarray(mis_variance(m, AXES, MapPdf(m), LobePdf(brdf, 30.0), brdf, 30.0,
                                  counts=(1, 1))).reshape(len(AXES), -1)[:, 0]
    t = Technique.of("mis", wf, "balance", 0.5)
    got = np.array([_pixel_moments(px, t, a).variance[:, 0].sum() for a in AXES])
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
    S = _exp_sums(u, 6)
    k0, k1 = np.meshgrid(np.arange(-6, 7), np.arange(0, 7), indexing="ij")
    dual = (k0 * z[0] + k1 * z[1]) % n == 0
    np.testing.assert_allclose(np.abs(S), dual.astype(float), atol=1e-9)


def test_mean_is_the_solid_angle_mean_of_the_map(sun_map):
    m, sampler = sun_map
    spec = ws.warped_spectrum(m, "mis", sampler=sampler, grid=64, axes=256)
    om = pixel_solid_angles(16, 32)
    # Funk–Hecke: the mean of I over the sphere of axes is the map's solid-angle mean
    ref = float((_cell_average(m.data)[:, :, 0] * om).sum() / (4 * np.pi))
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


@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
@pytest.mark.parametrize("technique", ["map", "brdf"])
def test_warped_integrand_mean_is_the_estimate(sun_map, brdf, technique):
    """The mean of h over the points is the (unshifted, untwisted) estimator with them (Sobol
    moved off its point (0, 0): there the diffuse lobe is 0, where h takes BRDF sampling's
    ratio ρ/q as 0 and the estimator as 1)."""
    m, sampler = sun_map
    u = (square_points("sobol", 64) + 1.0 / 128) % 1.0
    for a in AXES:
        h = ws.warped_integrand(m, technique, a, u, brdf=brdf, shininess=30.0, sampler=sampler)
        est = importance_estimates(m, a, u, technique, sampler=sampler, brdf=brdf,
                                   shininess=30.0)
        assert h.shape == (1, 64, 1)
        np.testing.assert_allclose(h[0].mean(axis=0), est[0], rtol=1e-12)


@pytest.mark.parametrize("heuristic, n_map", [("balance", 32), ("power", 16)])
def test_warped_integrand_of_mis_sums_to_the_mis_estimate(sun_map, heuristic, n_map):
    """Multi-sample MIS with n₁ map and n₂ lobe points: Σ_i mean_j h_i(u_ij) = F."""
    m, sampler = sun_map
    u_map, u_brdf = square_points("sobol", n_map), square_points("random", 64 - n_map, seed=2)
    fraction = n_map / 64
    for a in AXES:
        h_map = ws.warped_integrand(m, "mis", a, u_map, brdf="glossy", shininess=30.0,
                                    sampler=sampler, heuristic=heuristic, fraction=fraction)
        h_brdf = ws.warped_integrand(m, "mis", a, u_brdf, brdf="glossy", shininess=30.0,
                                     sampler=sampler, heuristic=heuristic, fraction=fraction)
        est = importance_estimates(m, a, (u_map, u_brdf), "mis", sampler=sampler,
                                   brdf="glossy", shininess=30.0, heuristic=heuristic)
        got = h_map[0].mean(axis=0) + h_brdf[1].mean(axis=0)
        np.testing.assert_allclose(got, est[0], rtol=1e-12)
        assert h_map.shape == (2, n_map, 1)


def test_warped_integrand_rejects_several_axes_and_bad_points():
    m = EnvMap(np.ones((8, 16, 1)))
    with pytest.raises(ParameterError, match="one vector"):
        ws.warped_integrand(m, "map", AXES, [[0.5, 0.5]])
    with pytest.raises(ParameterError, match="technique must be one of"):
        ws.warped_integrand(m, "bogus", [0, 0, 1.0], [[0.5, 0.5]])
    with pytest.raises(ParameterError):
        ws.warped_integrand(m, "map", [0, 0, 1.0], [[1.5, 0.5]])


def test_shared_inputs_give_the_spectra_of_fresh_ones(sun_map):
    """Spectra built with one SpectrumInputs equal those built alone (bit for bit), and the
    map's nodes, pixels and exact means are computed once for all techniques."""
    m, sampler = sun_map
    inputs = ws.SpectrumInputs.of(m, sampler)
    shared = {t: ws.warped_spectrum(m, t, "glossy", 30.0, sampler=sampler, grid=32, axes=8,
                                    inputs=inputs) for t in ("map", "mis", "brdf")}
    nodes, px = inputs.nodes(8), inputs.pixels(weight_function("glossy", 30.0))
    for t, s in shared.items():
        alone = ws.warped_spectrum(m, t, "glossy", 30.0, sampler=sampler, grid=32, axes=8)
        for f in ("variance", "power", "cross"):
            assert np.array_equal(getattr(s, f), getattr(alone, f)), (t, f)
        assert s.to_dict() == alone.to_dict()
    assert inputs.nodes(8) is nodes and inputs.pixels(weight_function("glossy", 30.0)) is px
    other = EnvMap(np.ones((16, 32, 1)))
    with pytest.raises(ParameterError, match="another map"):
        ws.warped_spectrum(other, "map", grid=32, axes=8, inputs=inputs)


@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
def test_spectrum_is_the_fft_of_the_warped_integrand(sun_map, brdf):
    """The box power |ĥ_i|² and the variance V_i of one axis (map nodes / lobe grid / pixel
    quadrature) against a second algorithm: h_i = warped_integrand on a 512² midpoint grid,
    its FFT and its variance (the grid's own error on the sun: a few %)."""
    from envfit.predict.warped._axis_mean import _accumulate

    m, sampler = sun_map
    a, B, F = AXES[0], 8, 512
    x = (np.arange(F) + 0.5) / F
    U = np.column_stack([np.repeat(x, F), np.tile(x, F)])
    rows = np.r_[F - B:F, 0:B + 1]
    for tech in ("map", "brdf", "mis"):
        t = Technique.of(tech, weight_function(brdf, 30.0))
        sums = _accumulate(ws.SpectrumInputs.of(m, sampler), t, 4 * B, a[None], np.ones(1))
        h = ws.warped_integrand(m, tech, a, U, brdf=brdf, shininess=30.0, sampler=sampler)
        for i in range(h.shape[0]):
            P = np.abs((np.fft.fft2(h[i, :, 0].reshape(F, F)) / F ** 2)[rows][:, :B + 1]) ** 2
            P[B, 0] = 0.0
            assert np.abs(P - sums.power[i]).max() < 0.02 * sums.power[i].max(), (tech, i)
            assert h[i, :, 0].var() == pytest.approx(sums.variance[i], rel=0.08), (tech, i)

"""Tests of envfit.sampling._importance and map_sampler: the map sampler (pdf, histogram, round trip), the map /
BRDF / MIS estimators of the shading integral (unbiasedness against the ground truth of
envfit.shading._ground_truth, zero-variance cases, equality with quadrature_estimates), the MIS
weights and the one-sample balance = mixture-pdf identity (checked by an independent
implementation here)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from envfit.base._errors import ParameterError
from envfit.data_gen._analytic import SunSkyMap
from envfit.data_gen._gp import gaussian_process_map
from envfit.maps import _latlong as latlong
from envfit.maps._envmap import EnvMap
from envfit.shading import _estimators as E
from envfit.shading import _ground_truth as G
from envfit.sampling import _importance as I
from envfit.sampling._map_sampler import MapSampler
from envfit.theory._brdf import Glossy
from envfit.theory._pointsets import frame_from_axis, lambert_to_hemisphere, square_points


def _axes(n, seed):
    a = np.random.default_rng(seed).standard_normal((n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def gp_map():
    return EnvMap(gaussian_process_map(1.5, 16, seed=7, channels=3, offset=4.0))


@pytest.fixture(scope="module")
def sun_map():
    sun = SunSkyMap(sun_theta=0.6, sun_phi=1.0, sun_radius=0.15, sun_radiance=50.0,
                    sky=(0.5, 0.7, 1.0))
    return EnvMap(sun.render(32), up="z")


def _maps(gp_map, sun_map):
    zero = np.ones((8, 16, 3))
    zero[2:5, 3:9] = 0.0
    return [gp_map, sun_map, EnvMap(zero, up="x"), EnvMap(np.full((4, 8, 1), 3.0))]


# -- the sampler ----------------------------------------------------------------------------
@pytest.mark.parametrize("smooth", [True, False])
@pytest.mark.parametrize("floor", [0.0, 0.01, 1.0])
def test_pdf_integrates_to_one(gp_map, sun_map, smooth, floor):
    """Σ pdf·Ω = 1 to rounding; the Monte Carlo mean of 4π·pdf over uniform directions is 1."""
    rng = np.random.default_rng(3)
    d = rng.standard_normal((40000, 3))
    for m in _maps(gp_map, sun_map):
        s = MapSampler(m, floor=floor, smooth=smooth)
        assert abs((s.pixel_pdf * m.solid_angles()).sum() - 1.0) < 1e-12
        assert abs(s.probabilities.sum() - 1.0) < 1e-12
        v = 4 * np.pi * s.pdf(d)
        assert abs(v.mean() - 1.0) <= 4 * v.std() / np.sqrt(v.size) + 1e-12


def test_histogram_of_samples_matches_the_probabilities(gp_map, sun_map):
    """Chi-square of the pixel counts of 8192 random samples against N·P_ij (p-value > 1e-3);
    Sobol points give a far smaller statistic (the stratification carries over)."""
    small = gp_map.resized(8)
    sun = sun_map.resized(8)
    for m in (small, sun):
        s = MapSampler(m, floor=0.05)
        n = 8192
        counts = {}
        for name in ("random", "sobol"):
            d, _ = s.sample(square_points(name, n, seed=11))
            i, j = s.pixel_of(d)
            counts[name] = np.bincount(i * m.width + j, minlength=m.height * m.width)
        expected = n * s.probabilities.ravel()
        assert expected.min() > 5
        chi_r = stats.chisquare(counts["random"], expected)
        chi_s = stats.chisquare(counts["sobol"], expected)
        assert chi_r.pvalue > 1e-3
        assert chi_s.statistic < 0.25 * chi_r.statistic


@pytest.mark.parametrize("up", ["y", "z", "x"])
def test_pdf_of_sample_is_the_returned_pdf(gp_map, up):
    m = EnvMap(gp_map.data, up=up)
    s = MapSampler(m)
    d, p = s.sample(np.random.default_rng(5).random((4096, 2)))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-14)
    assert np.array_equal(s.pdf(d), p)


def test_uniform_inside_each_pixel_in_cos_theta_and_phi(sun_map):
    """The position inside the sampled pixel, ((z_top − z)/(z_top − z_bot), φW/2π − j), is
    uniform on the unit square (Kolmogorov–Smirnov, 20000 samples on the sun map)."""
    s = MapSampler(sun_map)
    d, _ = s.sample(np.random.default_rng(2).random((20000, 2)))
    i, j = s.pixel_of(d)
    h, w = sun_map.height, sun_map.width
    zt, zb = np.cos(np.pi * i / h), np.cos(np.pi * (i + 1) / h)
    a = (zt - d[:, 2]) / (zt - zb)
    b = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2 * np.pi) * w / (2 * np.pi) - j
    assert stats.kstest(a, "uniform").pvalue > 1e-3
    assert stats.kstest(b, "uniform").pvalue > 1e-3


def test_constant_map_sampler_is_the_equal_area_lift():
    """On a constant map the sampler is exactly cos θ = 1 − 2u₀, φ = 2πu₁ (pdf 1/4π)."""
    m = EnvMap(np.full((16, 32, 3), 2.0), up="z")
    u = np.random.default_rng(0).random((1000, 2))
    d, p = MapSampler(m).sample(u)
    z = 1 - 2 * u[:, 0]
    r = np.sqrt(1 - z * z)
    ref = np.column_stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z])
    assert np.abs(d - ref).max() < 1e-12
    assert np.allclose(p, 1 / (4 * np.pi), rtol=1e-12)


def test_floor_keeps_zero_pixels_samplable():
    data = np.ones((8, 16, 1))
    data[2:5, 3:9] = 0.0
    m = EnvMap(data)
    hole = data[..., 0] == 0
    pure = MapSampler(m, floor=0.0, smooth=False)
    assert (pure.probabilities[hole] == 0).all() and (pure.probabilities[~hole] > 0).all()
    d, _ = pure.sample(np.random.default_rng(1).random((5000, 2)))
    i, j = pure.pixel_of(d)
    assert not hole[i, j].any()
    floored = MapSampler(m, floor=0.01, smooth=False)
    assert (floored.probabilities > 0).all()
    # the floor is the defensive mixture: min pdf = ε/(1+ε) / 4π on a map of mean 1·(1−hole)
    ybar = (m.solid_angles() * (~hole)).sum() / (4 * np.pi)
    assert np.isclose(floored.pixel_pdf[hole].min(), 0.01 * ybar / (4 * np.pi * 1.01 * ybar))
    smooth = MapSampler(m, floor=0.0)               # the interpolant reaches into the hole's rim
    assert (smooth.probabilities[2, 3] > 0) and smooth.probabilities[3, 5] == 0
    assert np.allclose(MapSampler(EnvMap(np.zeros((4, 8)))).pixel_pdf, 1 / (4 * np.pi), rtol=1e-13)


# -- the estimators -------------------------------------------------------------------------
@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
@pytest.mark.parametrize("method,kw", [("map", {}), ("brdf", {}), ("mis", {}),
                                       ("mis", {"heuristic": "power"}),
                                       ("mis", {"mode": "one"}),
                                       ("mis", {"mode": "one", "heuristic": "power",
                                                "fraction": 0.3})])
@pytest.mark.parametrize("which", ["gp", "sun"])
def test_unbiased(gp_map, sun_map, which, method, kw, brdf):
    """The mean of 100 realisations (N = 256 random points, M = 20 axes, 3 channels) is the
    ground truth within 4 standard errors; where an estimate has zero variance (BRDF
    sampling on axes whose lobe sees only the constant sky in all 25600 samples) it is the
    truth to 1e-4 of the largest value: there the sun lies in the lobe's far tail or just
    above the horizon (missed contributions of 6e-8 diffuse, 1.2e-5 glossy — rare events an
    unbiased estimator only sees with far more samples; the map technique and MIS do see them)."""
    m = gp_map if which == "gp" else sun_map
    axes = _axes(20, 1)
    truth = G.shading_integral(m, axes, brdf, 30, method="pixels")
    s = MapSampler(m)
    rng = np.random.default_rng(17)
    R = 100
    est = np.array([I.importance_estimates(m, axes, rng.random((256, 2)), method, sampler=s,
                                           brdf=brdf, seed=100 + r, **kw) for r in range(R)])
    se = est.std(axis=0, ddof=1) / np.sqrt(R)
    err = np.abs(est.mean(axis=0) - truth)
    zero = se < 1e-12 * np.abs(truth).max()
    assert (err[zero] < 1e-4 * np.abs(truth).max()).all()
    assert (err[~zero] < 4 * se[~zero]).all(), (err[~zero] / se[~zero]).max()


def test_brdf_sampling_on_a_constant_map_is_exact():
    m = EnvMap(np.full((8, 16, 2), [1.5, 0.25]))
    for brdf in ("diffuse", "glossy"):
        for pts in ("random", "lp", "sf"):
            est = I.brdf_sampling_estimates(m, _axes(50, 2), square_points(pts, 128, seed=3),
                                            brdf=brdf, seed=4)
            assert np.abs(est - [1.5, 0.25]).max() < 1e-13


def test_map_is_on_a_constant_map_is_uniform_sampling_of_the_lobe():
    """Constant c: map IS is 4πc·mean ρ(ω_j) over the equal-area lift of u (pdf 1/4π); its
    mean is c (not zero variance: ρ is not constant) and on a fine SF lattice it is within 1e-3."""
    c = 0.7
    m = EnvMap(np.full((8, 16, 1), c), up="z")
    axes = _axes(30, 5)
    u = np.random.default_rng(6).random((512, 2))
    est = I.map_is_estimates(m, axes, u, brdf="glossy", shininess=10)
    z = 1 - 2 * u[:, 0]
    r = np.sqrt(1 - z * z)
    d = np.column_stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z])
    rho = I.brdf_pdf(Glossy(10.0), axes @ d.T)
    assert np.allclose(est[:, 0], 4 * np.pi * c * rho.mean(axis=1), rtol=1e-11)
    fine = I.map_is_estimates(m, axes, square_points("sf", 1 << 14), brdf="diffuse")
    assert np.abs(fine - c).max() < 1e-3 * c


@pytest.mark.parametrize("brdf,shin", [("diffuse", 30), ("glossy", 30), ("glossy", 200)])
@pytest.mark.parametrize("pts", ["sf", "sobol", "lp", "random"])
@pytest.mark.parametrize("seed", [None, 5])
def test_brdf_sampling_equals_quadrature_with_equal_weights(gp_map, brdf, shin, pts, seed):
    axes = _axes(40, 8)
    u = square_points(pts, 200, seed=2)
    w = G.weight_function(brdf, shin)
    local = lambert_to_hemisphere(u, morph=w.morph)
    q = E.quadrature_estimates(gp_map, axes, local, np.full(200, 1 / 200), seed=seed)
    b = I.brdf_sampling_estimates(gp_map, axes, u, brdf=brdf, shininess=shin, seed=seed,
                                  shift=False)
    assert np.abs(b - q).max() < 1e-13 * np.abs(q).max()


def test_mis_weights_sum_to_one(sun_map):
    """At 10000 random directions and 5 axes, both heuristics, any shares: Σ_i w_i = 1 where a
    pdf is positive (everywhere with the floor), and w ∈ [0, 1]."""
    s = MapSampler(sun_map)
    d = np.random.default_rng(4).standard_normal((10000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for a in _axes(5, 9):
        p = np.stack([s.pdf(d), I.brdf_pdf(Glossy(30.0), d @ a)])
        for h in I.HEURISTICS:
            for c in (0.5, 0.1, 0.9, 0.0):
                w = I.mis_weights(p, [c, 1 - c], h)
                live = c * p[0] + (1 - c) * p[1] > 0      # all but the lobe's far side at c = 0
                assert live.all() or c == 0.0
                assert np.allclose(w.sum(axis=0)[live], 1.0, atol=1e-14)
                assert (w[:, ~live] == 0).all()
                assert (w >= 0).all() and (w <= 1).all()


def _one_sample_mixture_reference(m, s, axes, u, c, weight):
    """IS with the mixture pdf c·p_map + (1 − c)·q, samples picked by u₀ < c (own code)."""
    out = []
    for a in axes:
        R = frame_from_axis(a)
        vals = []
        for u0, u1 in u:
            if u0 < c:
                d, _ = s.sample([[u0 / c, u1]])
                d = d[0]
            else:
                d = R @ lambert_to_hemisphere([[(u0 - c) / (1 - c), u1]], morph=weight.morph)[0]
            rho = float(I.brdf_pdf(weight, d @ a))
            mix = c * float(s.pdf(d)) + (1 - c) * rho
            vals.append(m.lookup(d) * rho / mix)
        out.append(np.mean(vals, axis=0))
    return np.array(out)


@pytest.mark.parametrize("c", [0.5, 0.25])
def test_one_sample_balance_is_is_with_the_mixture_pdf(sun_map, c):
    axes = _axes(6, 12)
    u = np.random.default_rng(13).random((128, 2))
    w = Glossy(30.0)
    s = MapSampler(sun_map)
    ref = _one_sample_mixture_reference(sun_map, s, axes, u, c, w)
    est = I.mis_estimates(sun_map, axes, u, s, "glossy", 30, mode="one", fraction=c)
    assert np.allclose(est, ref, rtol=1e-12, atol=0)


def test_multi_sample_mis_reduces_to_the_single_techniques(gp_map):
    axes = _axes(25, 14)
    u = np.random.default_rng(15).random((300, 2))
    s = MapSampler(gp_map)
    for brdf in ("diffuse", "glossy"):
        m1 = I.mis_estimates(gp_map, axes, u, s, brdf, fraction=1.0)
        assert np.allclose(m1, I.map_is_estimates(gp_map, axes, u, s, brdf), rtol=1e-13)
        m0 = I.mis_estimates(gp_map, axes, u, s, brdf, fraction=0.0, heuristic="power")
        assert np.allclose(m0, I.brdf_sampling_estimates(gp_map, axes, u, s, brdf), rtol=1e-13)
        # a pair of sets = the concatenation split at its first set's size
        pair = I.mis_estimates(gp_map, axes, (u[:100], u[100:]), s, brdf)
        assert np.allclose(pair, I.mis_estimates(gp_map, axes, u, s, brdf, fraction=1 / 3),
                           rtol=1e-13)


def test_mis_beats_the_worse_technique_on_the_sun(sun_map):
    """RMSE over 60 realisations × 20 axes (N = 256, sun map): MIS (balance, multi, ½) is far
    below the worse technique and within 1.5× the better one, for both lobes; Sobol (shifted)
    lowers every RMSE."""
    axes = _axes(20, 1)
    s = MapSampler(sun_map)
    for brdf in ("diffuse", "glossy"):
        truth = G.shading_integral(sun_map, axes, brdf, 30, method="pixels")
        rmse = {}
        for name in I.ESTIMATORS:
            for pts in ("random", "sobol"):
                e = np.array([I.importance_estimates(sun_map, axes, square_points(pts, 256, seed=r),
                                                     name, sampler=s, brdf=brdf, seed=500 + r)
                              for r in range(60)])
                rmse[name, pts] = float(np.sqrt(((e - truth) ** 2).mean()))
        worse = max(rmse["map", "random"], rmse["brdf", "random"])
        better = min(rmse["map", "random"], rmse["brdf", "random"])
        assert rmse["mis", "random"] < 0.8 * worse
        assert rmse["mis", "random"] < 1.5 * better
        for name in I.ESTIMATORS:
            assert rmse[name, "sobol"] < rmse[name, "random"]


def test_blocks_do_not_change_the_result(gp_map, monkeypatch):
    axes = _axes(30, 3)
    u = np.random.default_rng(1).random((64, 2))
    ref = {k: I.importance_estimates(gp_map, axes, u, k, seed=9) for k in I.ESTIMATORS}
    monkeypatch.setattr(I, "LOOKUP_BLOCK", 200)          # 3 axes per block
    for k in I.ESTIMATORS:
        assert np.allclose(I.importance_estimates(gp_map, axes, u, k, seed=9), ref[k],
                           rtol=1e-13, atol=0)


def test_shared_samples_without_seed_match_the_per_axis_path(gp_map):
    """seed=None uses one set of map samples for all axes; a seed with shift=False gives the
    same numbers through the per-axis path (map samples do not depend on the twist)."""
    axes = _axes(10, 4)
    u = np.random.default_rng(2).random((100, 2))
    a = I.map_is_estimates(gp_map, axes, u)
    b = I.map_is_estimates(gp_map, axes, u, seed=3)
    c = I.map_is_estimates(gp_map, axes, u, seed=3, shift=False)
    assert np.allclose(a, c, rtol=1e-13) and not np.allclose(a, b, rtol=1e-6)


def test_bad_parameters(gp_map):
    u = [[0.5, 0.5]]
    with pytest.raises(ParameterError, match="method must be one of map, brdf, mis"):
        I.importance_estimates(gp_map, [0, 1.0, 0], u, "cosine")
    with pytest.raises(ParameterError, match="heuristic"):
        I.mis_estimates(gp_map, [0, 1.0, 0], u, heuristic="maximum")
    with pytest.raises(ParameterError, match="mode"):
        I.mis_estimates(gp_map, [0, 1.0, 0], u, mode="two")
    with pytest.raises(ParameterError, match="fraction"):
        I.mis_estimates(gp_map, [0, 1.0, 0], u, fraction=1.5)
    with pytest.raises(ParameterError, match="mode='multi'"):
        I.mis_estimates(gp_map, [0, 1.0, 0], (np.array(u), np.array(u)), mode="one")
    with pytest.raises(ParameterError, match=r"\[0, 1\]"):
        I.map_is_estimates(gp_map, [0, 1.0, 0], [[1.5, 0.2]])
    with pytest.raises(ParameterError, match="shape"):
        I.brdf_sampling_estimates(gp_map, [0, 1.0, 0], [[0.5, 0.2, 0.1]])
    with pytest.raises(ParameterError, match="floor"):
        MapSampler(gp_map, floor=-1)
    with pytest.raises(ParameterError, match="brdf"):
        I.map_is_estimates(gp_map, [0, 1.0, 0], u, brdf="phong")
    assert I.map_is_estimates(gp_map, np.zeros((0, 3)), u).shape == (0, 3)

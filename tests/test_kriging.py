"""Tests of envfit.fit._kriging: the closed-form expected interpolation error of a GP map.

The closed form is the oracle; Monte Carlo over many synthesized maps (data_gen, the real
lookup, resize and interpolator of Table 2) must agree with it within the MC confidence
interval, and must *reject* the models that leave out the band limit or the lookup.
"""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base._errors import ParameterError
from envfit.data_gen._gp import gaussian_process_map
from envfit.fit._kriging import (SynthesisModel, bilinear_stencil, expected_interpolation_mse,
                                 field_covariance)
from envfit.fit._table2 import sample_directions
from envfit.sobolev._interpolation import SobolevInterpolator
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import bilinear_lookup, pixel_directions, row_solid_angles
from envfit.theory._sobolev import kernel_from_distance2, kernel_series


def test_stencil_is_the_bilinear_lookup():
    rng = np.random.default_rng(0)
    for up in ("y", "z"):
        img = rng.random((12, 24))
        d = rng.normal(size=(3000, 3))
        d = np.vstack([d / np.linalg.norm(d, axis=1)[:, None], np.eye(3), -np.eye(3),
                       pixel_directions(12, up=up).reshape(-1, 3)])
        idx, w = bilinear_stencil(d, 12, up=up)
        assert np.allclose(w.sum(axis=1), 1.0) and np.all(w >= -1e-15)
        assert np.allclose((img.ravel()[idx] * w).sum(axis=1), bilinear_lookup(img, d, up=up),
                           atol=1e-13)


def test_field_covariance_is_the_legendre_series_and_eq14():
    t = np.r_[np.random.default_rng(1).uniform(-1, 1, 500), 1.0, -1.0]
    for s0 in (1.25, 1.5, 1.9):
        assert np.allclose(field_covariance(s0, 40)(2 - 2 * t), kernel_series(s0, t, 40),
                           atol=1e-8)
        assert np.allclose(field_covariance(s0, None)(2 - 2 * t),
                           kernel_from_distance2(s0, 2 - 2 * t))


def test_full_process_seen_exactly_is_best_at_s0():
    """The K_s0 interpolant is the best linear predictor: minimal exactly at s = s0."""
    s = [1.3, 1.4, 1.45, 1.5, 1.55, 1.6, 1.7]
    c = expected_interpolation_mse(SynthesisModel(1.5, 16, None, lookup=False), s, 120,
                                   max_pixels=None)
    assert c.s_best == 1.5 and c.s_best_solid_angle == 1.5
    assert np.all(np.diff(c.mse_pixel[:4]) < 0) and np.all(np.diff(c.mse_pixel[3:]) > 0)


def _mc_mse(s0, s, n, synth_h, height, maps, seed):
    """Per-map MSE (per pixel, solid-angle) of Table 2's reconstruction of ``maps`` GP maps."""
    f = gaussian_process_map(s0, synth_h, seed=seed, channels=maps)
    env = EnvMap(f).resized(height)
    pts = sample_directions(n)
    vals = env.lookup(pts)                                           # (N, maps)
    rec = SobolevInterpolator(pts, vals, s)(env.directions().reshape(-1, 3))
    err2 = (rec - env.data.reshape(-1, maps)) ** 2                   # (M, maps)
    om = np.repeat(row_solid_angles(height), 2 * height)
    return err2.mean(axis=0), (om @ err2) / om.sum()


@pytest.mark.parametrize("s0, s, n, synth_h, height", [
    (1.5, 1.5, 300, 64, 64), (1.5, 1.9, 300, 64, 64), (1.25, 1.6, 200, 64, 32)])
def test_closed_form_matches_monte_carlo(s0, s, n, synth_h, height):
    per_pixel, solid = _mc_mse(s0, s, n, synth_h, height, 400, seed=7)
    model = SynthesisModel.data_gen(s0, synth_h, height)
    c = expected_interpolation_mse(model, [s], n, max_pixels=None)
    for mc, cf in ((per_pixel, c.mse_pixel[0]), (solid, c.mse_solid_angle[0])):
        se = mc.std(ddof=1) / np.sqrt(mc.size)
        assert abs(mc.mean() - cf) < 3.5 * se, (mc.mean(), cf, se)
    # the MC is sharp enough to reject the models without the band limit or the lookup
    se = per_pixel.std(ddof=1) / np.sqrt(per_pixel.size)
    wrong = [SynthesisModel(s0, synth_h, None, lookup=height == synth_h)]
    if height == synth_h:
        wrong.append(SynthesisModel.data_gen(s0, synth_h, lookup=False))
    else:
        wrong.append(SynthesisModel.data_gen(s0, height, height))    # no resize
    for m in wrong:
        other = expected_interpolation_mse(m, [s], n, max_pixels=None).mse_pixel[0]
        assert abs(per_pixel.mean() - other) > 5 * se, (m.describe(), other)


def test_row_quadrature_close_to_all_pixels():
    m = SynthesisModel.data_gen(1.5, 32)
    full = expected_interpolation_mse(m, [1.5, 1.8], 150, max_pixels=None)
    part = expected_interpolation_mse(m, [1.5, 1.8], 150, max_pixels=16 * 64)
    assert part.rows == 16 and full.rows == 32
    assert np.allclose(part.mse_pixel, full.mse_pixel, rtol=0.05)


def test_offset_adds_the_constant_interpolation_error():
    """A constant c adds c² mean (1 − Σ_j w_j(x))²: brute force with the interpolator."""
    base = SynthesisModel(1.5, 8, 7, lookup=False)
    off = SynthesisModel(1.5, 8, 7, lookup=False, offset=3.0)
    a = expected_interpolation_mse(base, [1.2], 30, max_pixels=None).mse_pixel[0]
    b = expected_interpolation_mse(off, [1.2], 30, max_pixels=None).mse_pixel[0]
    pts = sample_directions(30)
    one = SobolevInterpolator(pts, np.ones(30), 1.2)(pixel_directions(8).reshape(-1, 3))
    assert np.isclose(b - a, 9.0 * np.mean((1.0 - one) ** 2), rtol=1e-6)


def test_bad_models_refused():
    with pytest.raises(ParameterError):
        SynthesisModel.data_gen(1.5, 64, 48)
    with pytest.raises(ParameterError):
        SynthesisModel(1.5, 32, 63, factor=2, lookup=False)
    with pytest.raises(ParameterError):
        expected_interpolation_mse(SynthesisModel(1.5, 4, None), [1.5], 100)
    with pytest.raises(ValueError):
        SynthesisModel(2.5, 4, None)


@pytest.mark.parametrize("h, f, lmax", [(6, 1, 20), (4, 2, 15), (3, 3, None), (2, 4, 7)])
def test_pixel_covariance_table_is_the_block_average_of_point_covariances(h, f, lmax):
    """Brute force: R K R^T with R the solid-angle weighted block average of EnvMap.resized."""
    from envfit.fit._kriging import _pixel_covariance_table, _sq_dist
    k0 = field_covariance(1.5, lmax)
    T = _pixel_covariance_table(SynthesisModel(1.5, h, lmax, factor=f), k0)
    hf, w = h * f, 2 * h
    fine = pixel_directions(hf).reshape(-1, 3)
    R = np.stack([EnvMap(e.reshape(hf, 2 * hf, 1)).resized(h).data.ravel()
                  for e in np.eye(fine.shape[0])], axis=1) if f > 1 else np.eye(fine.shape[0])
    C = R @ k0(_sq_dist(fine, fine)) @ R.T
    q = np.arange(h * w)
    got = T[q[:, None] // w, q[None, :] // w, (q[None, :] % w - q[:, None] % w) % w]
    assert np.allclose(got, C, atol=1e-12)


def test_expected_likelihood_minimal_at_s0_when_exact_and_matches_mc():
    from envfit.fit._kriging import expected_profiled_likelihood
    s = [1.3, 1.4, 1.5, 1.6, 1.7]
    exact = expected_profiled_likelihood(SynthesisModel(1.5, 16, None, lookup=False), s, 150)
    assert int(np.argmin(exact)) == 2
    # E[g^T K^-1 g] by Monte Carlo over synthesized maps read by the lookup (the log's argument)
    model = SynthesisModel.data_gen(1.5, 32)
    f = gaussian_process_map(1.5, 32, seed=3, channels=300)
    pts = sample_directions(200)
    g = EnvMap(f).lookup(pts)                                          # (N, maps)
    it = SobolevInterpolator(pts, g, 1.7)
    quad = np.einsum("jk,jk->k", g, it.coefficients) / 200.0           # g^T K^-1 g / N per map
    nll = expected_profiled_likelihood(model, [1.7], 200)[0]
    logdet = 2 * np.sum(np.log(np.diag(np.linalg.cholesky(
        kernel_from_distance2(1.7, np.sum((pts[:, None] - pts[None]) ** 2, -1))))))
    expected_quad = np.exp(2 * nll - logdet / 200 - 1 - np.log(2 * np.pi))
    se = quad.std(ddof=1) / np.sqrt(quad.size)
    assert abs(quad.mean() - expected_quad) < 3.5 * se, (quad.mean(), expected_quad, se)


def test_too_large_synthesis_refused_before_work():
    with pytest.raises(ParameterError, match="at most 256 rows"):
        SynthesisModel.data_gen(1.5, 512, 256)

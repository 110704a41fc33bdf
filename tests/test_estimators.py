"""Tests of envfit.shading._estimators: quadrature (Eq. 34), SH and HSH truncation (Eq. 35), RMSE.

Expected values come from the ground truth (envfit.shading._ground_truth, itself checked against closed
forms), from closed forms (envfit.data_gen._analytic, the errata's b̃_l = 0 for l >= 2), from an
exact 1-D formula for the mean of the bilinear interpolant, from a brute-force product rule
in the axis frame through envmap.lookup, and from explicit rotations with
envfit.theory._pointsets.
"""
from __future__ import annotations

import numpy as np
import pytest

from envfit.data_gen._analytic import SkyGradientMap, SunSkyMap
from envfit.data_gen._gp import gaussian_process_map
from envfit.shading import _estimators as E
from envfit.shading import _ground_truth as S
from envfit.maps._envmap import EnvMap
from envfit.base._errors import ParameterError
from envfit.theory._brdf import Glossy
from envfit.theory._pointsets import frame_from_axis, rotate_to_axes


def _axes(n, seed):
    a = np.random.default_rng(seed).standard_normal((n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def _fibonacci_hemisphere(n, morph):
    """Spherical Fibonacci on the hemisphere (errata, Sec. 7), z' morphed for the BRDF."""
    j = np.arange(n)
    zp = 1.0 - (2 * j + 1) / (2.0 * n)
    phi = 2 * np.pi * np.mod(j * (np.sqrt(5.0) - 1.0) / 2.0, 1.0)
    z = morph(zp)
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


@pytest.fixture(scope="module")
def gp_map():
    return EnvMap(gaussian_process_map(1.5, 32, seed=7, channels=2, offset=4.0))


# -- quadrature ---------------------------------------------------------------------------
@pytest.mark.parametrize("brdf,morph", [("diffuse", np.sqrt), ("glossy", Glossy(30).morph)])
def test_fine_equal_weight_rule_converges_to_the_truth(gp_map, brdf, morph):
    axes = _axes(16, 3)
    truth = S.shading_integral(gp_map, axes, brdf, 30)
    errs = []
    for n in (256, 4096, 65536):
        est = E.quadrature_estimates(gp_map, axes, _fibonacci_hemisphere(n, morph),
                                     np.full(n, 1.0 / n), seed=1)
        errs.append(E.rmse_over_axes(est, truth).total / np.abs(truth).mean())
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 2e-5


def test_single_point_rule_reads_the_map_along_the_axis(gp_map):
    axes = _axes(7, 4)
    est = E.quadrature_estimates(gp_map, axes, [[0.0, 0.0, 2.0]], [1.0], seed=3)
    np.testing.assert_allclose(est, gp_map.lookup(axes), rtol=0, atol=1e-13)


def test_random_rotation_is_seeded_and_blocking_independent(gp_map, monkeypatch):
    axes = _axes(30, 5)
    pts = _fibonacci_hemisphere(64, np.sqrt)
    w = np.random.default_rng(0).random(64)
    a = E.quadrature_estimates(gp_map, axes, pts, w, seed=42)
    b = E.quadrature_estimates(gp_map, axes, pts, w, seed=42)
    c = E.quadrature_estimates(gp_map, axes, pts, w, seed=43)
    d = E.quadrature_estimates(gp_map, axes, pts, w)
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() > 1e-6 and np.abs(a - d).max() > 1e-6
    # the same as rotating explicitly with envfit.theory._pointsets (one draw for all axes)
    explicit = np.einsum("mnc,n->mc", gp_map.lookup(rotate_to_axes(pts, axes, seed=42)), w)
    np.testing.assert_allclose(a, explicit, rtol=0, atol=1e-12)
    no_twist = np.einsum("mnc,n->mc", gp_map.lookup(np.einsum("mij,nj->mni",
                                                             frame_from_axis(axes), pts)), w)
    np.testing.assert_allclose(d, no_twist, rtol=0, atol=1e-12)
    # several blocks give the same numbers as one
    monkeypatch.setattr(E, "LOOKUP_BLOCK", 64 * 7)
    np.testing.assert_allclose(E.quadrature_estimates(gp_map, axes, pts, w, seed=42), a,
                               rtol=0, atol=1e-13)


def test_quadrature_parameter_errors(gp_map):
    with pytest.raises(ParameterError):
        E.quadrature_estimates(gp_map, [0, 0, 1.0], [[0, 0, 1.0]], [1.0, 2.0])
    with pytest.raises(ParameterError):
        E.quadrature_estimates(gp_map, [0, 0, 1.0], [[0, 0]], [1.0])
    with pytest.raises(ParameterError):
        E.quadrature_estimates(gp_map, [0, 0, 0.0], [[0, 0, 1.0]], [1.0])
    with pytest.raises(ParameterError):
        E.quadrature_estimates(gp_map, [0, 0, 1.0], [[0, 0, np.nan]], [1.0])


# -- SH truncation ------------------------------------------------------------------------
def _bilinear_mean(data):
    """Exact mean of the bilinear interpolant: the φ-integral of a row's hats is Δφ Σ_j v_j,
    so ∫ f dS = Δφ ∫ g(θ) sinθ dθ with g piecewise linear through the row sums (constant on
    the polar caps, whose virtual rows are the same rows turned by π)."""
    h, w = data.shape[:2]
    rows = data.sum(axis=1)                                   # (H, C)
    tc = np.pi * (np.arange(h) + 0.5) / h
    total = rows[0] * (1 - np.cos(tc[0])) + rows[-1] * (1 + np.cos(tc[-1]))
    for i in range(h - 1):
        a, b = tc[i], tc[i + 1]
        slope = (rows[i + 1] - rows[i]) / (b - a)
        # ∫ (r_i + slope (t - a)) sin t dt on [a, b];  ∫ t sin t = sin t - t cos t
        i0 = np.cos(a) - np.cos(b)
        i1 = (np.sin(b) - b * np.cos(b)) - (np.sin(a) - a * np.cos(a))
        total = total + rows[i] * i0 + slope * (i1 - a * i0)
    return total * (2 * np.pi / w) / (4 * np.pi)


def test_sh_truncation_at_L0_is_the_mean(gp_map):
    axes = _axes(12, 6)
    mean = _bilinear_mean(gp_map.data)
    for brdf in ("diffuse", "glossy"):
        est = E.sh_truncation_estimates(gp_map, axes, brdf, 0)
        np.testing.assert_allclose(est, np.broadcast_to(mean, est.shape), rtol=1e-12)
    # and the pixel mean differs from it only by the interpolation error O(h²)
    assert np.abs(mean - gp_map.mean()).max() < 2e-2 * np.abs(mean).max()


def test_sh_truncation_converges_to_the_truth(gp_map):
    axes = _axes(20, 7)
    Ls = [0, 1, 2, 4, 8, 16, 41, 63]
    for brdf in ("diffuse", "glossy"):
        truth = S.shading_integral(gp_map, axes, brdf, 30, method="pixels")
        curve = E.sh_truncation_curve(gp_map, axes, brdf, Ls)
        err = E.rmse_over_axes(curve, truth).total / np.abs(truth).max()
        assert err.shape == (len(Ls),)
        assert err[0] > 1e-3 and err[-1] < (1e-5 if brdf == "diffuse" else 1e-9)
        assert err[2] > err[4] > err[6]
        # the curve equals single-L calls
        for i in (1, 5):
            np.testing.assert_allclose(curve[i], E.sh_truncation_estimates(gp_map, axes, brdf,
                                                                           Ls[i]),
                                       rtol=0, atol=1e-13)


# -- HSH truncation -----------------------------------------------------------------------
def test_hsh_diffuse_is_exact_from_L1():
    sky = SkyGradientMap(horizon=(1.0, 0.5), zenith=(3.0, 0.25))
    m = EnvMap(sky.render(16, mode="point"))
    axes = _axes(15, 8)
    truth = S.shading_integral(m, axes, "diffuse", method="pixels")
    curve = E.hsh_truncation_curve(m, axes, "diffuse", [0, 1, 2, 5])
    assert np.abs(curve[0] - truth).max() > 1e-2            # the uniform hemisphere is not
    for k in (1, 2, 3):
        np.testing.assert_allclose(curve[k], truth, rtol=1e-9)
    # and the closed form a + (2/3) b (n·z), up to the bilinear interpolation error |b|h²/8
    ref = sky.diffuse_integral(S.axes_to_local(axes, m.up))
    assert np.abs(curve[1] - ref).max() <= np.abs(sky.b).max() * (np.pi / 16) ** 2 / 8


def test_hsh_projections_match_bruteforce_quadrature():
    m = EnvMap(gaussian_process_map(1.5, 16, seed=5, channels=1, offset=3.0))
    axis = np.array([0.3, 0.5, -0.8]) / np.linalg.norm([0.3, 0.5, -0.8])
    L = 4
    got = E.hsh_projections(m, axis, L)[0, :, 0]
    # independent: Gauss-Legendre in z × trapezoid in φ about the axis, through lookup
    x, w = np.polynomial.legendre.leggauss(400)
    z, wz = 0.5 * (x + 1), 0.5 * w
    phi = 2 * np.pi * (np.arange(800) + 0.5) / 800
    r = np.sqrt(1 - z * z)
    loc = np.stack(np.broadcast_arrays(r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                                       z[:, None]), -1)
    f = m.lookup(loc @ frame_from_axis(axis).T)[..., 0]
    ylz = np.polynomial.legendre.legvander(2 * z - 1, L).T * np.sqrt(
        (2 * np.arange(L + 1) + 1) / (2 * np.pi))[:, None]
    ref = np.einsum("zp,lz,z->l", f, ylz, wz) * 2 * np.pi / 800
    assert np.abs(got - ref).max() < 2e-6 * np.abs(ref).max()


def test_hsh_glossy_curve_converges_and_matches_single_L():
    sun = SunSkyMap(sun_theta=1.0, sun_phi=0.5, sun_radius=0.15, sun_radiance=20.0,
                    sky=SkyGradientMap(1.0, 2.0))
    m = EnvMap(sun.render(16))
    axes = _axes(12, 9)
    truth = S.shading_integral(m, axes, "glossy", 30)
    Ls = [1, 4, 8, 16, 24]
    curve = E.hsh_truncation_curve(m, axes, "glossy", Ls)
    err = E.rmse_over_axes(curve, truth).total
    assert np.all(np.diff(err) < 0) and err[-1] < 1e-3 * err[0]
    np.testing.assert_allclose(curve[2], E.hsh_truncation_estimates(m, axes, "glossy", 8),
                               rtol=1e-11)


# -- RMSE ---------------------------------------------------------------------------------
def test_rmse_over_axes():
    truth = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    est = truth + np.array([[0.0, 3.0], [0.0, 0.0], [0.0, 0.0]])
    r = E.rmse_over_axes(est, truth)
    assert r.total == pytest.approx(np.sqrt(9.0 / 6.0))
    np.testing.assert_allclose(r.per_channel, [0.0, np.sqrt(3.0)])
    stack = E.rmse_over_axes(np.stack([truth, est]), truth)
    np.testing.assert_allclose(stack.total, [0.0, np.sqrt(1.5)])
    assert stack.per_channel.shape == (2, 2)
    assert E.rmse_over_axes(np.array([1.0, 3.0]), np.array([1.0, 1.0])).total == pytest.approx(
        np.sqrt(2.0))
    with pytest.raises(ParameterError):
        E.rmse_over_axes(np.ones((3, 2)), np.ones((2, 2)))

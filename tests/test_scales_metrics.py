"""Tests of envfit.maps._scales (value scales) and envfit.maps._metrics (RMSE, PSNR, SSIM)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.ndimage import uniform_filter

from envfit.maps._envmap import EnvMap
from envfit.base._errors import ParameterError
from envfit.maps._latlong import pixel_solid_angles
from envfit.maps._metrics import psnr, rmse, rmse_solid_angle, ssim
from envfit.maps._scales import SCALES, Scale, fit_scale, srgb_oetf


# -- sRGB --------------------------------------------------------------------------------
def test_srgb_oetf_known_values():
    # IEC 61966-2-1 reference points: 0 → 0, breakpoint 0.0031308 → 0.04045 (12.92 x), 1 → 1,
    # 0.5 → 0.735357 (188/255 in 8 bits), 0.18 → 0.461356 (118/255)
    np.testing.assert_allclose(srgb_oetf([0.0, 1.0]), [0.0, 1.0], atol=1e-15)
    assert abs(srgb_oetf(0.0031308) - 12.92 * 0.0031308) < 1e-15
    assert abs(srgb_oetf(0.0031308) - 0.04045) < 1e-6
    assert abs(srgb_oetf(0.5) - 0.7353569830524495) < 1e-12
    assert round(float(srgb_oetf(0.5)) * 255) == 188
    assert round(float(srgb_oetf(0.18)) * 255) == 118
    # both branches meet at the breakpoint (continuity to the precision of the standard)
    x0 = 0.0031308
    assert abs(12.92 * x0 - (1.055 * x0 ** (1 / 2.4) - 0.055)) < 1e-7
    assert srgb_oetf(x0 * (1 + 1e-9)) == pytest.approx(srgb_oetf(x0), abs=5e-8)
    # inverse: the sRGB EOTF undoes it
    x = np.linspace(0, 1, 1001)
    v = srgb_oetf(x)
    back = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(back, x, atol=1e-12)
    assert np.all(np.diff(v) > 0)


# -- scales ------------------------------------------------------------------------------
@pytest.mark.parametrize("L", [1e-3, 0.18, 7.5, 3e4])
def test_display_of_constant_luminance_is_srgb_018(L):
    gray = EnvMap(np.full((8, 16, 3), L))
    s = fit_scale("display", gray)
    assert s.exposure == pytest.approx(0.18 / L, rel=1e-12)
    out = s.apply(gray.data)
    np.testing.assert_allclose(out, 0.4613561295004, atol=1e-10)
    mono = EnvMap(np.full((8, 16), L))                 # single channel: luminance = channel 0
    np.testing.assert_allclose(fit_scale("display", mono).apply(mono.data), 0.4613561295004,
                               atol=1e-10)


def test_display_clips_and_uses_reference_fit():
    rng = np.random.default_rng(0)
    ref = EnvMap(rng.random((8, 16, 3)) * 10)
    s = fit_scale("display", ref)
    om = pixel_solid_angles(8)
    y = ref.data @ np.array([0.2126, 0.7152, 0.0722])
    ybar = np.sum(om * y) / (4 * np.pi)
    assert s.exposure == pytest.approx(0.18 / ybar, rel=1e-12)
    assert s.reference_mean_luminance == pytest.approx(ybar, rel=1e-12)
    v = np.array([-1.0, 0.0, 1.0 / s.exposure, 100.0 / s.exposure])
    np.testing.assert_allclose(s.apply(v), [0.0, 0.0, 1.0, 1.0], atol=1e-12)
    # the same fitted transform on a reconstruction (not refitted)
    recon = ref.data * 0.5
    np.testing.assert_allclose(s.apply(recon), srgb_oetf(np.clip(recon * 0.18 / ybar, 0, 1)),
                               atol=1e-15)
    assert s.apply(recon).shape == recon.shape


def test_log_scale_definition():
    rng = np.random.default_rng(1)
    data = rng.random((4, 8, 3)) * 5
    ref = EnvMap(data)
    s = fit_scale("log", ref)
    ybar = np.sum(pixel_solid_angles(4) * ref.luminance()) / (4 * np.pi)
    assert s.normaliser == pytest.approx(ybar, rel=1e-12)
    np.testing.assert_allclose(s.apply(data), np.log(1 + data / ybar), rtol=1e-13)
    np.testing.assert_array_equal(s.apply(np.array([-3.0, 0.0])), [0.0, 0.0])


def test_linear_scale_and_frozen_and_errors():
    ref = EnvMap(np.ones((2, 4, 3)))
    s = fit_scale("linear", ref)
    x = np.array([[-1.5, 2.0, 1e6]])
    np.testing.assert_array_equal(s.apply(x), x)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.exposure = 2.0
    with pytest.raises(ParameterError):
        fit_scale("gamma", ref)
    with pytest.raises(ParameterError):
        Scale("nope")
    with pytest.raises(ParameterError):
        Scale("display", exposure=-1.0)
    black = EnvMap(np.zeros((2, 4, 3)))
    for name in ("display", "log"):
        with pytest.raises(ParameterError, match="positive mean luminance"):
            fit_scale(name, black)
    assert fit_scale("linear", black).name == "linear"
    # fit_scale also takes a bare array
    assert fit_scale("log", np.full((2, 4, 1), 4.0)).normaliser == pytest.approx(4.0)


def test_describe_is_one_line():
    ref = EnvMap(np.full((2, 4, 3), 2.0))
    for name in SCALES:
        d = fit_scale(name, ref).describe()
        assert d.startswith(name) and "\n" not in d
    assert "0.09" in fit_scale("display", ref).describe()


# -- metrics -----------------------------------------------------------------------------
def _pair(seed=0, shape=(16, 32, 3)):
    rng = np.random.default_rng(seed)
    a = rng.random(shape)
    return a, np.clip(a + 0.1 * rng.normal(size=shape), 0, 1)


def test_rmse_vs_numpy():
    a, b = _pair()
    d = (a - b).ravel()
    assert rmse(a, b) == pytest.approx(np.sqrt(d @ d / d.size), rel=1e-13)
    assert rmse(a, a) == 0.0
    with pytest.raises(ParameterError):
        rmse(a, b[:, :-1])


def test_rmse_solid_angle():
    a, b = _pair()
    om = pixel_solid_angles(16)
    sq = ((a - b) ** 2).mean(axis=-1)
    expected = np.sqrt(np.sum(om * sq) / (4 * np.pi))
    assert rmse_solid_angle(a, b, om) == pytest.approx(expected, rel=1e-12)
    # uniform weights reduce to the plain RMSE
    assert rmse_solid_angle(a, b, np.ones((16, 32))) == pytest.approx(rmse(a, b), rel=1e-13)
    # a pure polar error weighs less than in the plain RMSE
    c = a.copy()
    c[0] += 1.0
    assert rmse_solid_angle(a, c, om) < rmse(a, c)
    assert rmse_solid_angle(a[..., 0], c[..., 0], om) == pytest.approx(
        np.sqrt(om[0].sum() / (4 * np.pi)), rel=1e-12)
    with pytest.raises(ParameterError):
        rmse_solid_angle(a, b, om[:, :5])


def test_psnr_vs_formula():
    a, b = _pair(1)
    mse = np.mean((a - b) ** 2)
    assert psnr(a, b, data_range=1.0) == pytest.approx(10 * np.log10(1.0 / mse), rel=1e-12)
    assert psnr(a, b, data_range=2.0) == pytest.approx(10 * np.log10(4.0 / mse), rel=1e-12)
    assert psnr(a, a, data_range=1.0) == float("inf")
    with pytest.raises(ParameterError):
        psnr(a, b, data_range=0)


def _ssim_reference(x, y, R, win=7):
    """Wang et al. SSIM with a uniform 7x7 window and sample covariances, border-cropped."""
    c1, c2 = (0.01 * R) ** 2, (0.03 * R) ** 2
    n = win * win
    cov = n / (n - 1)
    vals = []
    for c in range(x.shape[-1]):
        X, Y = x[..., c], y[..., c]
        ux, uy = uniform_filter(X, win), uniform_filter(Y, win)
        vx = cov * (uniform_filter(X * X, win) - ux * ux)
        vy = cov * (uniform_filter(Y * Y, win) - uy * uy)
        vxy = cov * (uniform_filter(X * Y, win) - ux * uy)
        s = ((2 * ux * uy + c1) * (2 * vxy + c2)) / ((ux ** 2 + uy ** 2 + c1) * (vx + vy + c2))
        p = (win - 1) // 2
        vals.append(s[p:-p, p:-p].mean())
    return float(np.mean(vals))


def test_ssim_vs_independent_formula():
    a, b = _pair(2)
    assert ssim(a, b, data_range=1.0) == pytest.approx(_ssim_reference(a, b, 1.0), rel=1e-9)
    assert ssim(a, a, data_range=1.0) == pytest.approx(1.0)
    assert ssim(a[..., 0], b[..., 0], data_range=1.0) == pytest.approx(
        _ssim_reference(a[..., :1], b[..., :1], 1.0), rel=1e-9)
    with pytest.raises(ParameterError):
        ssim(a[:4, :8], b[:4, :8], data_range=1.0)


@pytest.mark.parametrize("name", ["linear", "log", "display"])
def test_scale_inverse_round_trip(name):
    # to_linear inverts apply (display: up to the clip at 1/k), to_display lands in [0, 1]
    rng = np.random.default_rng(5)
    m = EnvMap(rng.uniform(0.05, 3.0, size=(8, 16, 3)))
    sc = fit_scale(name, m)
    v = sc.apply(m.data)
    expected = np.minimum(m.data, 1.0 / sc.exposure) if name == "display" else m.data
    np.testing.assert_allclose(sc.to_linear(v), expected, rtol=1e-12, atol=1e-12)
    d = sc.to_display(v)
    assert d.min() >= 0.0 and d.max() <= 1.0
    np.testing.assert_allclose(d, fit_scale("display", m).apply(m.data), atol=1e-12)

"""envfit.shading.microfacet: distributions, the visible-normal warps, Fresnel and the Conductor
BSDF as each renderer's record builds it (Renderer.bsdf), for pbrt-v4 and Cycles (Mitsuba 3 is
checked against Mitsuba itself in test_microfacet_mitsuba.py): hand-worked values from the
source formulas, pdf normalisation by quadrature, sampling histograms against the pdf, weights,
reciprocity."""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.renderers import get_renderer
from envfit.shading.microfacet import (Conductor, MicrofacetDistribution, fr_complex,
                                       fresnel_conductor, sample_visible_normals)

CASES = [("pbrt4", "ggx"), ("cycles", "ggx"), ("cycles", "beckmann"), ("mitsuba3", "ggx"),
         ("mitsuba3", "beckmann")]


def _conductor(renderer, kind, alpha, eta=None, k=None):
    """The renderer's conductor (its record's ``bsdf``), coloured where ``eta``, ``k``."""
    kw = {} if eta is None else {"eta": eta, "k": k}
    return get_renderer(renderer).bsdf(kind, alpha, **kw)


def _sph(theta, phi):
    return np.array([[math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                      math.cos(theta)]])


@pytest.mark.parametrize("renderer", ["pbrt4", "cycles"])
def test_hand_worked_ggx_values(renderer):
    """α = 0.5, ω_i at 60°, ω_o at 30° on the other side: the half vector is at 15°."""
    a = 0.5
    wi, wo = _sph(math.radians(60), 0.0), _sph(math.radians(30), math.pi)
    th = math.radians(15)                       # (60° − 30°)/2 from the normal
    d = 1.0 / (math.pi * a * a * math.cos(th) ** 4 * (1 + math.tan(th) ** 2 / a ** 2) ** 2)
    lam_i = (math.sqrt(1 + a * a * 3.0) - 1) / 2          # tan²60° = 3
    lam_o = (math.sqrt(1 + a * a / 3.0) - 1) / 2          # tan²30° = 1/3
    c = _conductor(renderer, "ggx", a)
    assert c.eval(wi, wo)[0] == pytest.approx(d / (4 * 0.5 * (1 + lam_i + lam_o)), rel=1e-12)
    assert c.pdf(wi, wo)[0] == pytest.approx(d / (4 * 0.5 * (1 + lam_i)), rel=1e-12)
    m = _conductor("mitsuba3", "ggx", a)                   # separable G
    assert m.eval(wi, wo)[0] == pytest.approx(d / (1 + lam_i) / (1 + lam_o) / 2.0, rel=1e-12)


def _hemisphere_integral(fn, n=400):
    """∫ fn(ω) dω over the upper hemisphere: Gauss in cos θ, trapezoid in φ."""
    x, w = np.polynomial.legendre.leggauss(n)
    z = 0.5 * (x + 1)
    phi = 2 * np.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    s = np.sqrt(1 - z * z)
    d = np.stack(np.broadcast_arrays(s[:, None] * np.cos(phi), s[:, None] * np.sin(phi),
                                     z[:, None]), axis=-1).reshape(-1, 3)
    return float((fn(d).reshape(n, 2 * n) * (0.5 * w)[:, None]).sum() * 2 * np.pi / (2 * n))


def _u_grid(n):
    g = (np.arange(n) + 0.5) / n
    return np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)


@pytest.mark.parametrize("renderer,kind", CASES)
@pytest.mark.parametrize("alpha", [0.3, 0.6])
def test_pdf_integrates_to_the_valid_fraction(renderer, kind, alpha):
    """∫ pdf dω over the hemisphere = the share of u whose reflected ω_o is above the surface."""
    c = _conductor(renderer, kind, alpha)
    wi = _sph(math.radians(70), 0.4)
    total = _hemisphere_integral(lambda d: c.pdf(np.broadcast_to(wi, d.shape), d))
    u = _u_grid(300)
    s = c.sample(np.broadcast_to(wi, (len(u), 3)), u)
    valid = float(np.mean(s.weight > 0))
    # Beckmann: the pdf uses the rational Λ, the warp draws the exact visible normals, so the
    # pdf integrates to valid × (1 + Λ_exact(ω_i))/(1 + Λ_fit(ω_i)) (≤ 0.35 % from valid)
    d = c.distribution
    ratio = float((1 + d.lambda_exact(wi)[0]) / (1 + d.lambda_(wi)[0]))
    assert 0.8 < total < 1.0
    assert total == pytest.approx(valid * ratio, abs=1e-3)
    if kind == "beckmann" and alpha == 0.3:
        assert abs(ratio - 1) > 1e-3        # the gap is real at this view


@pytest.mark.parametrize("renderer,kind", CASES)
def test_sampling_histogram_matches_pdf(renderer, kind):
    """Counts of 200 000 samples in (cos θ, φ) cells against the pdf's integral over each cell."""
    rng = np.random.default_rng(7)
    c = _conductor(renderer, kind, 0.3)
    wi = _sph(math.radians(50), 1.0)
    n = 200_000
    s = c.sample(np.broadcast_to(wi, (n, 3)), rng.uniform(size=(n, 2)))
    ok = s.weight > 0
    nz, nphi = 8, 16
    iz = np.minimum((s.wo[ok, 2] * nz).astype(int), nz - 1)
    ip = (np.mod(np.arctan2(s.wo[ok, 1], s.wo[ok, 0]), 2 * np.pi) / (2 * np.pi) * nphi).astype(int)
    counts = np.bincount(iz * nphi + np.minimum(ip, nphi - 1), minlength=nz * nphi)
    g, gw = np.polynomial.legendre.leggauss(12)
    expected = np.zeros(nz * nphi)
    for a in range(nz):
        z = (a + 0.5 * (g + 1)) / nz
        for b in range(nphi):
            p = 2 * np.pi * (b + 0.5 * (g + 1)) / nphi
            zz, pp = np.meshgrid(z, p, indexing="ij")
            sz = np.sqrt(1 - zz ** 2)
            d = np.stack([sz * np.cos(pp), sz * np.sin(pp), zz], axis=-1).reshape(-1, 3)
            f = c.pdf(np.broadcast_to(wi, d.shape), d).reshape(12, 12)
            expected[a * nphi + b] = n * (np.outer(gw, gw) * f).sum() / 4 / nz * 2 * np.pi / nphi
    big = expected > 20
    assert np.all(np.abs(counts[big] - expected[big]) < 5 * np.sqrt(expected[big]) + 5)
    assert counts[~big].sum() < 5 * max(expected[~big].sum(), 20)


@pytest.mark.parametrize("renderer,kind", CASES)
@pytest.mark.parametrize("metal", [False, True])
def test_weight_is_eval_over_pdf_in_closed_form(renderer, kind, metal):
    rng = np.random.default_rng(3)
    c = _conductor(renderer, kind, 0.2, *((0.3, 2.5) if metal else (None, None)))
    d = c.distribution
    wi = np.broadcast_to(_sph(math.radians(65), 0.2), (500, 3))
    s = c.sample(wi, rng.uniform(size=(500, 2)))
    ok = s.weight > 0
    assert ok.sum() > 400
    np.testing.assert_allclose(s.weight[ok], c.eval(wi, s.wo)[ok] / c.pdf(wi, s.wo)[ok],
                               rtol=1e-9)
    np.testing.assert_allclose(s.pdf[ok], c.pdf(wi, s.wo)[ok], rtol=1e-9)
    f = c.fresnel(np.einsum("ij,ij->i", wi, s.m))
    if c.shadowing == "separable":                      # weight = F·G1(ω_o, m)
        expect = f * d.g1(s.wo, s.m)
    else:                                               # F (1 + Λ_i)/(1 + Λ_i + Λ_o)
        li, lo = d.lambda_(wi), d.lambda_(s.wo)
        expect = f * (1 + li) / (1 + li + lo)
    np.testing.assert_allclose(s.weight[ok], expect[ok], rtol=1e-12)


@pytest.mark.parametrize("renderer,kind", CASES)
def test_eval_is_reciprocal(renderer, kind):
    rng = np.random.default_rng(5)
    c = _conductor(renderer, kind, 0.25, 0.4, 2.0)
    a = rng.normal(size=(300, 3))
    b = rng.normal(size=(300, 3))
    a[:, 2], b[:, 2] = np.abs(a[:, 2]), np.abs(b[:, 2])
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    np.testing.assert_allclose(c.eval(a, b) / b[:, 2], c.eval(b, a) / a[:, 2], rtol=1e-10)


def test_same_u_differs_between_renderers_same_density():
    """Mitsuba's slope-space GGX warp at u is Cycles' at (1 − u₀, u₁): m mirrored across the
    plane of incidence; pbrt-v4's polar disk gives other normals for the same u."""
    rng = np.random.default_rng(11)
    u = rng.uniform(size=(400, 2))
    wi = np.broadcast_to(_sph(0.7, 0.0), (400, 3))      # plane of incidence: xz
    warp = {r: get_renderer(r).bsdf("ggx", 0.3).vndf for r in ("mitsuba3", "cycles", "pbrt4")}
    mit = sample_visible_normals(warp["mitsuba3"], "ggx", 0.3, wi, u)
    cyc = sample_visible_normals(warp["cycles"], "ggx", 0.3, wi, u)
    cyc_flip = sample_visible_normals(warp["cycles"], "ggx", 0.3, wi,
                                      np.c_[1 - u[:, 0], u[:, 1]])
    pbrt = sample_visible_normals(warp["pbrt4"], "ggx", 0.3, wi, u)
    np.testing.assert_allclose(mit, cyc_flip, atol=1e-12)
    np.testing.assert_allclose(mit * [1, -1, 1], cyc, atol=1e-12)
    assert np.median(np.linalg.norm(pbrt - cyc, axis=1)) > 0.05


def test_fresnel_two_forms_agree_and_limits():
    c = np.linspace(0, 1, 101)
    for eta, k in [(0.2, 3.0), (1.5, 0.0), (0.27, 2.78), (2.0, 1.0)]:
        np.testing.assert_allclose(fresnel_conductor(c, eta, k), fr_complex(c, eta, k),
                                   rtol=1e-10, atol=1e-12)
        r0 = ((eta - 1) ** 2 + k * k) / ((eta + 1) ** 2 + k * k)
        assert fresnel_conductor(1.0, eta, k) == pytest.approx(r0, rel=1e-12)
    np.testing.assert_allclose(fresnel_conductor(c, 0.0, 1.0), 1.0, atol=1e-12)
    np.testing.assert_allclose(fresnel_conductor(c[1:], 0.2, 3.0)[-1], 0.2 ** 0 * ((0.8 ** 2 + 9)
                               / (1.2 ** 2 + 9)), rtol=1e-12)


def test_beckmann_rational_masking_within_its_stated_error():
    """Mitsuba: "fast and accurate (<0.35% rel. error) rational approximation"."""
    d = MicrofacetDistribution("beckmann", 0.5)
    th = np.linspace(0.01, 1.55, 500)
    v = np.stack([np.sin(th), 0 * th, np.cos(th)], axis=1)
    g_fit = 1 / (1 + d.lambda_(v))
    g_exact = 1 / (1 + d.lambda_exact(v))
    assert np.max(np.abs(g_fit / g_exact - 1)) < 0.0035


def test_d_projected_area_is_one():
    """∫ D(m) cos θ_m dω_m = 1 (both distributions)."""
    for kind in ("ggx", "beckmann"):
        d = MicrofacetDistribution(kind, 0.4)
        assert _hemisphere_integral(lambda m: d.D(m) * m[:, 2], n=600) == pytest.approx(1, abs=1e-5)


def test_roughness_conventions_and_errors():
    def alpha(renderer, r):
        return get_renderer(renderer).roughness.to_alpha(r)
    assert alpha("mitsuba3", 0.3) == 0.3
    assert alpha("pbrt4", 0.09) == pytest.approx(0.3)
    assert alpha("cycles", 0.3) == pytest.approx(0.09)
    tech = {"shadowing": "separable", "vndf": "slope_space"}
    for bad in [lambda: _conductor("pbrt4", "beckmann", 0.3),
                lambda: _conductor("mitsuba3", "ggx", 0.0),
                lambda: _conductor("mitsuba3", "ggx", 1.5),
                lambda: _conductor("cycles", "phong", 0.3),
                lambda: Conductor("ggx", 0.3, shadowing="blender", vndf="slope_space"),
                lambda: Conductor("ggx", 0.3, shadowing="separable", vndf="blender"),
                lambda: Conductor("beckmann", 0.3, shadowing="separable", vndf="hemisphere_polar"),
                lambda: Conductor("ggx", 0.3, **tech, eta=1.0),
                lambda: Conductor("ggx", 0.3, **tech, eta=1.0, k=2.0),   # no Fresnel form
                lambda: sample_visible_normals("blender", "ggx", 0.3, [[0, 0, 1]], [[0.5, 0.5]]),
                lambda: alpha("cycles", 2.0), lambda: get_renderer("envfit").bsdf("ggx", 0.3)]:
        with pytest.raises(ParameterError):
            bad()

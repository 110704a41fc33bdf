"""Ground truth of the microfacet shading integral (envfit.shading.microfacet) against a
second algorithm: brute-force quadrature of ``eval``·L over the half-vector hemisphere
(θ_m = atan(α tan ψ), Gauss in ψ, trapezoid in φ), for a constant map (the directional
albedo), a smooth function, a small map's bilinear interpolant; and the mirror limit."""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.maps import EnvMap
from envfit.renderers import get_renderer
from envfit.shading.microfacet import GroundTruthOptions, microfacet_shading_integral


def _smooth(d):
    return 1.0 + 0.5 * d[:, 0] - 0.3 * d[:, 1] * d[:, 2] + 0.2 * d[:, 2] ** 2


def _frame(n):
    h = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    t = np.cross(h, n)
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(n, t), n])


def _brute(radiance, c, normal, view, n=400):
    """∫ eval(ω_i, ω_o) L(ω_o) dω_o = ∫ eval · L · 4 (ω_o·m) dω_m over visible m."""
    fr = _frame(normal)
    wi = fr @ view
    x, w = np.polynomial.legendre.leggauss(n)
    psi = 0.25 * np.pi * (x + 1)
    th = np.arctan(c.alpha * np.tan(psi))
    jac = c.alpha / np.cos(psi) ** 2 / (1 + (c.alpha * np.tan(psi)) ** 2) * 0.25 * np.pi * w
    phi = 2 * np.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    T, P = np.meshgrid(th, phi, indexing="ij")
    m = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    wis = np.broadcast_to(wi, m.shape)
    dot = m @ wi
    wo = 2 * dot[:, None] * m - wis
    f = np.where(dot > 0, c.eval(wis, wo) * 4 * dot, 0.0)
    f = f * np.asarray(radiance(wo @ fr)).reshape(len(m), -1).T
    return (f.reshape(-1, n, 2 * n) * (np.sin(th) * jac)[:, None]).sum(axis=(1, 2)) \
        * 2 * np.pi / (2 * n)


FRAMES = [(np.array([0, 0, 1.0]), np.array([math.sin(1.2), 0, math.cos(1.2)])),
          (np.array([0, 1.0, 0]), np.array([0.3, 0.5, 0.2]) / np.linalg.norm([0.3, 0.5, 0.2]))]
OPTS = GroundTruthOptions(rtol=1e-5, min_nodes=32, max_nodes=128)


@pytest.mark.parametrize("renderer,kind,alpha", [("mitsuba3", "ggx", 0.05),
                                                 ("mitsuba3", "beckmann", 0.05),
                                                 ("mitsuba3", "beckmann", 0.3),
                                                 ("cycles", "ggx", 0.3)])
def test_smooth_radiance_and_albedo_against_brute_force(renderer, kind, alpha):
    c = get_renderer(renderer).bsdf(kind, alpha, **({"eta": 0.3, "k": 2.5} if renderer == "cycles"
                                                    else {}))
    normals = np.array([f[0] for f in FRAMES])
    views = np.array([f[1] for f in FRAMES])
    got = microfacet_shading_integral(_smooth, c, normals, views, OPTS)
    one = microfacet_shading_integral(lambda d: np.ones(len(d)), c, normals, views, OPTS)
    assert got.converged.all() and one.converged.all()
    for i, (n, v) in enumerate(FRAMES):
        assert got.values[i, 0] == pytest.approx(_brute(_smooth, c, n, v)[0], rel=5e-5)
        assert one.values[i, 0] == pytest.approx(_brute(lambda d: np.ones(len(d)), c, n, v)[0],
                                                 rel=5e-5)
        assert 0.3 < one.values[i, 0] < 1.0                  # directional albedo


def test_envmap_bilinear_interpolant_against_brute_force():
    rng = np.random.default_rng(2)
    em = EnvMap(rng.uniform(0.5, 2.0, size=(8, 16, 2)))
    c = get_renderer("mitsuba3").bsdf("ggx", 0.3)
    n, v = FRAMES[0]
    got = microfacet_shading_integral(em, c, n[None], v[None],
                                      GroundTruthOptions(rtol=1e-6, max_nodes=512))
    assert got.converged.all() and got.nodes[0] >= 32
    ref = _brute(em.lookup, c, n, v, n=700)
    np.testing.assert_allclose(got.values[0], ref, rtol=5e-4)


def test_mirror_limit():
    """α → 0: the integral tends to F·L(reflect(ω_i)) (F = 1, G → 1)."""
    c = get_renderer("cycles").bsdf("ggx", 0.002)
    n, v = FRAMES[1]
    got = microfacet_shading_integral(_smooth, c, n[None], v[None], OPTS)
    r = 2 * (n @ v) * n - v
    assert got.values[0, 0] == pytest.approx(_smooth(r[None])[0], rel=2e-3)


def test_view_below_surface_gives_zero():
    c = get_renderer("mitsuba3").bsdf("ggx", 0.2)
    got = microfacet_shading_integral(_smooth, c, [[0, 0, 1.0]], [[0.6, 0, -0.8]])
    assert got.values[0, 0] == 0.0

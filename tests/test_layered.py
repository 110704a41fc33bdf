"""The albedo-layered BSDF (:class:`envfit.shading.microfacet.AlbedoLayered`: Cycles' Principled
BSDF at metallic 0) — its blend-factor table against the one Cycles ships, its eval, pdf and
sampling against direction-space quadrature, its compiled kernels against the numpy class, and
its closure pick by the third coordinate of Cycles' 3-D BSDF request against a simulation of
the estimator over Cycles' own points."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.predict.renderer import MicrofacetModel, RendererModelOptions
from envfit.renderers import get_renderer
from envfit.shading.microfacet import AlbedoLayered, blend_factor
from envfit.shading.microfacet._layered import _column, f0_of_ior, ior_of_f0
from envfit.shading.microfacet._plastic import fresnel_dielectric

CYCLES = get_renderer("cycles")

#: ``table_ggx_gen_schlick_ior_s`` of blender/cycles @ 97dbe6f57 (``src/scene/shader.tables``,
#: made by ``precompute_ggx_gen_schlick_s`` over 2^20 Sobol' points) at slice z, row y
#: (μ = y/15), column x (√α = x/15): the slices that η = 1.5 reads (z·15 = 6.7)
_CYCLES_TABLE = {(6, 4, 2): 0.194584, (6, 4, 8): 0.087983, (6, 0, 5): 0.345942,
                 (6, 15, 11): 0.001039, (7, 4, 5): 0.171112, (7, 0, 8): 0.173793,
                 (7, 4, 14): 0.030109, (7, 10, 3): 0.016639}


def _hemisphere_rule(n: int):
    """Directions (P, 3) and weights (P,) of a product Gauss–Legendre rule on the upper
    hemisphere (cos θ in [0, 1], φ in [0, 2π))."""
    x, w = np.polynomial.legendre.leggauss(n)
    mu, wm = (x + 1) / 2, w / 2
    phi, wp = np.pi * (x + 1), np.pi * w
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - m ** 2)
    d = np.stack([s * np.cos(p), s * np.sin(p), m], -1).reshape(-1, 3)
    return d, np.outer(wm, wp).ravel()


@pytest.mark.parametrize("node, value", sorted(_CYCLES_TABLE.items()))
def test_blend_factor_table_is_the_one_cycles_ships(node, value):
    """envfit's quadrature of the blend factor's mean over the lobe's sampled normals equals
    Cycles' Monte Carlo table (2^20 points) at its nodes within 5e-4."""
    z, y, x = node
    assert _column(x, z)[y] == pytest.approx(value, abs=5e-4)


def test_real_fresnel_mode_is_the_dielectric_and_the_lookup_interpolates():
    """At tint 1 the blend F = f0 + (1 − f0) sat((F_η − F0)/(1 − F0)) is the dielectric's own
    Fresnel; the table lookup is linear between nodes in μ."""
    b = AlbedoLayered(0.25)
    c = np.linspace(0.01, 1.0, 50)
    np.testing.assert_allclose(b.fresnel(c), fresnel_dielectric(c, 1.5)[0], atol=1e-12)
    z = np.sqrt(0.5 / 2.5) * 15
    t = z - 6
    node = lambda y: (1 - t) * _column(7, 6)[y] + t * _column(7, 7)[y]   # noqa: E731  √α = 7/15
    got = blend_factor((7 / 15) ** 2, np.array([4.5 / 15]), 1.5)[0]
    assert got == pytest.approx(0.5 * node(4) + 0.5 * node(5), rel=1e-9)
    assert ior_of_f0(f0_of_ior(1.5)) == pytest.approx(1.5)


@pytest.mark.parametrize("mu", [0.15, 0.6, 0.95])
def test_eval_pdf_and_sampling_agree_with_quadrature(mu):
    """∫ pdf = the mass of live samples, ∫ f·cos = the mean sample weight (a scrambled Sobol'
    set of 2^14 points), and E[g/pdf] over samples = ∫ g for a smooth g (the sampled
    directions have the stated density), each by a Gauss–Legendre rule on the
    hemisphere (800²: a grazing view's lobe is narrow in φ near the horizon)."""
    from scipy.stats import qmc
    b = AlbedoLayered(0.3 ** 2, base_color=0.7)
    wi = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
    d, w = _hemisphere_rule(800)
    wis = np.broadcast_to(wi, d.shape)
    albedo = w @ b.eval(wis, d)
    u = qmc.Sobol(2, seed=3).random_base2(14)
    s = b.sample_square(np.broadcast_to(wi, (len(u), 3)), u)
    assert s.weight.mean() == pytest.approx(albedo, rel=3e-3)
    g = lambda v: 1.0 + v[:, 0] * v[:, 2] + v[:, 2] ** 2            # noqa: E731
    live = s.pdf > 0
    est = np.sum(np.where(live, g(s.wo) / np.where(live, s.pdf, 1.0), 0.0)) / len(u)
    covered = w @ np.where(b.pdf(wis, d) > 0, g(d), 0.0)
    assert est == pytest.approx(covered, rel=1e-2)
    assert 0.9 < w @ b.pdf(wis, d) <= 1.0 + 1e-9
    ps = b.lobe_probability(np.array([mu]))[0]
    a, kd = b.weights(np.array([mu]))
    assert ps == pytest.approx(a[0] / (a[0] + kd[0])) and 0 < ps < 0.5
    assert kd[0] == pytest.approx(0.7 * (1 - a[0]))


def test_compiled_kernels_are_the_numpy_class():
    from envfit.predict.renderer._layered_kernels import (layered_eval_pdf, layered_proxies,
                                                          layered_sample)
    b = AlbedoLayered(0.2, base_color=0.5, eta=1.4, f0=0.02)
    rng = np.random.default_rng(0)
    for mu in (0.05, 0.5, 1.0):
        wi = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
        d = rng.normal(size=(3000, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        wis = np.broadcast_to(wi, d.shape)
        fc, pdf = layered_eval_pdf(b, wi, d)
        np.testing.assert_allclose(fc, b.eval(wis, d), atol=1e-12)
        np.testing.assert_allclose(pdf, b.pdf(wis, d), atol=1e-12)
        u = rng.random((3000, 2))
        for u1 in (None, 0.01, 0.9):
            wo, weight, p = layered_sample(b, wi, u, u1)
            s = (b.sample_square(wis, u) if u1 is None
                 else b.sample(wis, u, u1=np.full(len(u), u1)))
            np.testing.assert_allclose(weight, s.weight, atol=1e-12)
            live = s.weight > 0
            np.testing.assert_allclose(wo[live], s.wo[live], atol=1e-12)
    wis = np.array([[0.6, 0.0, 0.8], [0.0, 0.0, 1.0]])
    frames = np.broadcast_to(np.eye(3), (2, 3, 3))
    base, pdf = rng.random((500, 3)), rng.random(500) + 0.1
    got = layered_proxies(b, wis, frames, d[:500], base, pdf)
    for k, wi in enumerate(wis):
        fc = b.eval(np.broadcast_to(wi, (500, 3)), d[:500])
        pb = b.pdf(np.broadcast_to(wi, (500, 3)), d[:500])
        bb = np.pi * base
        mean2 = np.sum((bb * fc[:, None]).mean(axis=0) ** 2)
        v_e = max(0.0, np.mean((bb ** 2).sum(1) * fc ** 2) - mean2)
        sec = np.where(pb > 0, (bb ** 2).sum(1) * pdf * fc ** 2 / np.where(pb > 0, pb, 1), 0)
        np.testing.assert_allclose(got[k], [v_e, max(0.0, sec.mean() - mean2)], rtol=1e-10)


def test_cycles_principled_at_its_defaults_is_the_layered_bsdf():
    """Blender's Principled BSDF at metallic 0 (the node's default): the layered BSDF of η =
    IOR and f0 = F0(IOR)·tint; Specular IOR Level ℓ scales f0 by 2ℓ and η follows; metallic
    between 0 and 1 is refused in one line."""
    b = CYCLES.bsdf("principled", 0.25)
    assert isinstance(b, AlbedoLayered)
    assert (b.eta, b.base_color) == (1.5, 0.8) and b.f0 == pytest.approx(0.04)
    c = CYCLES.bsdf("principled", 0.25, specular_ior_level=0.25, specular_tint=0.5)
    assert c.f0 == pytest.approx(0.01) and f0_of_ior(c.eta) == pytest.approx(0.02)
    with pytest.raises(ParameterError, match="metallic 0.5"):
        CYCLES.bsdf("principled", 0.25, metallic=0.5)


def _sun_map(h: int = 16) -> EnvMap:
    w = 2 * h
    y, x = np.mgrid[0:h, 0:w]
    base = 1.0 + 0.5 * np.sin(2 * np.pi * x / w + 0.7)[..., None] * np.cos(np.pi * y / h)[..., None]
    img = np.repeat(base, 3, axis=2) * np.array([1.0, 0.8, 0.6])
    img[3, 5] = (400.0, 350.0, 300.0)
    return EnvMap(img.astype(np.float32))


@pytest.mark.parametrize("sampler, n", [("tabulated_sobol", 16), ("tabulated_sobol", 256),
                                        ("sobol_burley", 64)])
def test_cycles_closure_pick_by_the_third_coordinate_matches_a_simulation(sampler, n):
    """Cycles' BSDF sample at a Principled BSDF: the closure picked by the third coordinate of
    the same 3-D request whose first two draw the direction (``surface_shader_bsdf_bssrdf_pick``)
    — simulated over Cycles' own points (``first_hit_points``: 2^18 samples or more), each
    sample through ``AlbedoLayered.sample`` and the map, against the model (the random-order
    lobe choice plus the order's excess drawn over the same sampler's points): within 8 %.
    (The order changes little here: the shuffled simulation reads 2 % above the real one at
    16 spp.)"""
    from envfit.renderers.cycles._patterns import first_hit_points
    b = AlbedoLayered(0.25)
    reps = max(4000, (1 << 18) // n)
    normal = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    view = np.array([0.0, 0.2, 1.0]) / np.linalg.norm([0.0, 0.2, 1.0])

    m = MicrofacetModel(_sun_map(), CYCLES, b, (normal[None], view[None]),
                        options=RendererModelOptions(max_level=7))
    rows = np.asarray(CYCLES.tangent_frame(normal[None])[0])
    wi = rows @ view
    xyz = first_hit_points(sampler, n, reps, 5)[2]
    s = b.sample(np.broadcast_to(wi, (reps * n, 3)), xyz[..., :2].reshape(-1, 2),
                 u1=xyz[..., 2].ravel())
    value = m.technique.eval(s.wo @ rows) * s.weight[:, None]
    sim = value.reshape(reps, n, 3).mean(axis=1).var(axis=0, ddof=1)
    np.testing.assert_allclose(m.predict("brdf", sampler, n).mse, sim, rtol=0.08)

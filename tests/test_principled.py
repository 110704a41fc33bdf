"""envfit.shading.microfacet.Principled against Mitsuba 3's ``principled`` (scalar_rgb): eval,
pdf and sample (lobe, direction, pdf, weight) for the same float32 (wi, wo) and samples, at
the plugin's defaults and over roughness, metallic, specular, spec_tint, sheen and flatness,
views down to grazing; and, without Mitsuba, the sample weights' mean against the albedo by
quadrature of eval, the pdf's integral, and the two-number sampling's distribution."""
from __future__ import annotations

import math

import numpy as np
import pytest
from oracles.mitsuba_bsdf import mitsuba_bsdf_queries
from test_roughplastic import _cases, _over_hemisphere

from envfit.base import ParameterError
from envfit.shading.microfacet import Principled


def _check(props, seed):
    """Every comparison; Mitsuba is float32: eval and pdf agree to ~1e-5 relative."""
    pytest.importorskip("mitsuba")
    p = Principled(**props)
    wi, wo, u = _cases(np.random.default_rng(seed), p)
    u[:, 0] = np.where(np.arange(len(u)) % 3 == 0, 0.999, u[:, 0])     # specular lobe too
    ev, pdf, smp = mitsuba_bsdf_queries({"type": "principled", **props}, wi, wo, u[:, 0],
                                        u[:, 1:])
    np.testing.assert_allclose(p.eval(wi, wo), ev, rtol=3e-5, atol=1e-12)
    np.testing.assert_allclose(p.pdf(wi, wo), pdf, rtol=3e-5, atol=1e-12)
    s = p.sample(wi, u)
    valid = smp[:, 4] > 0
    assert np.array_equal(s.specular[valid], smp[valid, 5] == 3)       # component 3: specular
    assert np.array_equal(s.weight > 0, valid) and valid.sum() > len(u) // 2
    np.testing.assert_allclose(s.wo[valid], smp[valid, :3], atol=1e-5)
    mwo = smp[valid, :3]
    q = p.pdf(wi[valid], mwo)
    # float32 rounding in a sharp lobe seen at grazing (cos θ_i 0.01) reaches 3e-4
    np.testing.assert_allclose(q, smp[valid, 3], rtol=3e-4)
    np.testing.assert_allclose(p.eval(wi[valid], mwo) / q, smp[valid, 4], rtol=3e-4)
    ok = valid & (s.wo[:, 2] > 1e-3)
    np.testing.assert_allclose(s.weight[ok], smp[ok, 4], rtol=1e-3)


@pytest.mark.parametrize("roughness", [0.5, 0.25, 0.9])
def test_matches_mitsuba_defaults(roughness):
    _check({"roughness": roughness}, int(100 * roughness))


@pytest.mark.parametrize("props", [
    {"roughness": 0.3, "metallic": 1.0},
    {"roughness": 0.4, "metallic": 0.4, "base_color": 0.8, "spec_tint": 0.5, "sheen": 0.7},
    {"roughness": 0.7, "specular": 0.9, "flatness": 0.6, "sheen_tint": 0.5, "sheen": 0.2},
    {"roughness": 0.5, "specular": 0.1, "base_color": 1.0},
])
def test_matches_mitsuba_options(props):
    _check(props, 7)


def test_lobes_and_refusals():
    p = Principled(0.5, metallic=0.5)
    assert p.lobe_probability(np.array([0.1, 1.0])).tolist() == [1 / 3, 1 / 3]
    up = np.array([[0.0, 0.6, 0.8]])
    a = p.sample(np.repeat(up, 2, axis=0), np.full((2, 2), 0.4), u1=np.array([0.2, 0.5]))
    assert a.specular.tolist() == [False, True]
    down = np.array([[0.0, 0.6, -0.8]])
    assert p.eval(down, up)[0] == 0.0 and p.pdf(up, down)[0] == 0.0
    assert not p.sample(down, [[0.5, 0.5, 0.5]]).weight.any()
    assert Principled(0.5, metallic=1.0).lobe_probability(np.array([0.5]))[0] == 0.0
    for bad in [lambda: Principled(1.5), lambda: Principled(metallic=-0.1),
                lambda: Principled(specular=0.0), lambda: Principled(base_color="red")]:
        with pytest.raises(ParameterError):
            bad()


@pytest.mark.parametrize("props", [{}, {"roughness": 0.3, "metallic": 0.6, "sheen": 1.0}])
@pytest.mark.parametrize("cos_i", [0.95, 0.3, 0.05])
def test_weight_mean_is_albedo(props, cos_i):
    p = Principled(**props)
    wi = np.array([math.sqrt(1 - cos_i ** 2), 0.0, cos_i])
    albedo = _over_hemisphere(p, wi, p.eval)
    rng = np.random.default_rng(3)
    s = p.sample(np.broadcast_to(wi, (100_000, 3)), rng.uniform(size=(100_000, 3)))
    se = s.weight.std() / math.sqrt(len(s.weight))
    assert abs(s.weight.mean() - albedo) < 4.0 * se + 1e-4 * albedo


@pytest.mark.parametrize("cos_i", [0.95, 0.3, 0.05])
def test_pdf_integrates_to_one_less_lost_mass(cos_i):
    """∫ pdf = 1 − (1 − p_d)·P(the mirrored visible normal points below the surface)."""
    p = Principled(0.5)
    wi = np.array([math.sqrt(1 - cos_i ** 2), 0.0, cos_i])
    total = _over_hemisphere(p, wi, p.pdf)
    rng = np.random.default_rng(5)
    u = np.column_stack([np.ones(200_000), rng.uniform(size=(200_000, 2))])   # specular only
    lost = np.mean(p.sample(np.broadcast_to(wi, (len(u), 3)), u).wo[:, 2] <= 0)
    assert total == pytest.approx(1.0 - 0.5 * lost, abs=2e-3)


def test_sample_square_has_the_lobe_and_direction_distribution_of_sample():
    p = Principled(0.4, metallic=0.3)
    g = (np.arange(256) + 0.5) / 256
    u = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    wi = np.broadcast_to([0.6, 0.0, 0.8], (len(u), 3))
    a = p.sample_square(wi, u)
    b = [p.sample(wi, u, u1=np.full(len(u), x)) for x in (np.arange(32) + 0.5) / 32]
    assert (~a.specular).mean() == pytest.approx(np.mean([(~bb.specular).mean() for bb in b]),
                                                 abs=1.0 / 32)
    for k in (1, 2):
        assert np.mean(a.weight ** k) == pytest.approx(
            np.mean([np.mean(bb.weight ** k) for bb in b]), rel=1e-2)

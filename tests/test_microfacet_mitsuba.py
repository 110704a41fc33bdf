"""Mitsuba 3's roughconductor as its record builds it (Renderer.bsdf) against Mitsuba 3 itself
(``roughconductor``, scalar_rgb): eval, pdf and sample (direction, pdf, weight) for the same
(wi, wo) and (wi, u), GGX and Beckmann, α 0.05–0.6, F = 1 ("none") and a metal (η, k)."""
from __future__ import annotations

import numpy as np
import pytest
from oracles.mitsuba_bsdf import mitsuba_bsdf_queries

from envfit.renderers import get_renderer

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")

N = 120


def _dirs(rng, n):
    z = rng.uniform(0.03, 1.0, n)
    ph = rng.uniform(0.0, 2.0 * np.pi, n)
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(ph), s * np.sin(ph), z], axis=1)


def _mitsuba(kind, alpha, metal, wi, wo, u):
    d = {"type": "roughconductor", "distribution": kind, "alpha": alpha}
    d.update({"eta": 0.2, "k": 3.0} if metal else {"material": "none"})
    return mitsuba_bsdf_queries(d, wi, wo, np.full(len(u), 0.5), u)


@pytest.mark.parametrize("kind", ["ggx", "beckmann"])
@pytest.mark.parametrize("alpha", [0.05, 0.1, 0.3, 0.6])
@pytest.mark.parametrize("metal", [False, True])
def test_roughconductor_matches_mitsuba(kind, alpha, metal):
    rng = np.random.default_rng([int(1000 * alpha), kind == "ggx", metal])
    wi, wo, u = _dirs(rng, N), _dirs(rng, N), rng.uniform(size=(N, 2))
    c = get_renderer("mitsuba3").bsdf(kind, alpha, **({"eta": 0.2, "k": 3.0} if metal else {}))
    s = c.sample(wi, u)
    valid = s.weight > 0
    wo[valid[: N // 2].nonzero()[0]] = s.wo[valid[: N // 2].nonzero()[0]]  # half near the lobe
    ev, pdf, smp = _mitsuba(kind, alpha, metal, wi, wo, u)
    np.testing.assert_allclose(c.eval(wi, wo), ev, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(c.pdf(wi, wo), pdf, rtol=1e-4, atol=1e-6)
    assert np.array_equal(valid, smp[:, 4] > 0)
    np.testing.assert_allclose(s.wo[valid], smp[valid, :3], atol=2e-4)
    # the pdf of a sharp lobe amplifies float32 direction error (D ∝ exp(-tan²θ/α²))
    np.testing.assert_allclose(s.pdf[valid], smp[valid, 3], rtol=3e-3)
    np.testing.assert_allclose(s.weight, smp[:, 4], atol=1e-4)
    assert ev.max() > 0 and (smp[:, 4] > 0).sum() > N // 2

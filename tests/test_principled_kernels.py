"""The compiled principled BSDF (envfit.predict.renderer._principled_kernels) against its numpy
reference, envfit.shading.microfacet.Principled: f·cos and pdf, sampling with the lobe from
u_x (``sample_square``) and from a given ``sample1``, over roughness, metallic, specular,
spec_tint, sheen and flatness, views from the pole to grazing and below the surface; the
frames' proxies against the model's numpy loop; and the model's predictions with and without
the kernels."""
from __future__ import annotations

import numpy as np
import pytest
from test_plastic_kernels import ATOL, RTOL, VIEWS, _directions, _model, _reference, _rotation

from envfit.predict.renderer import band_frames
from envfit.predict.renderer._principled_kernels import (compiled_principled,
                                                         principled_eval_pdf,
                                                         principled_proxies,
                                                         principled_sample, two_lobe_kernels)
from envfit.renderers import get_renderer
from envfit.shading.microfacet import Principled, RoughPlastic

BSDFS = [Principled(), Principled(0.25, metallic=1.0), Principled(0.9, base_color=0.9),
         Principled(0.4, metallic=0.3, specular=0.8, spec_tint=0.5, sheen=0.7, flatness=0.4)]


@pytest.mark.parametrize("p", BSDFS, ids=repr)
def test_compiled_eval_pdf_is_the_numpy_principled(p):
    d = _directions()
    rows = _rotation(1)
    for wi in VIEWS:
        loc = np.vstack([d, [[-wi[0], -wi[1], wi[2]]]])
        w = np.broadcast_to(wi, loc.shape)
        f, q = principled_eval_pdf(p, wi, loc)
        np.testing.assert_allclose(f, p.eval(w, loc), rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(q, p.pdf(w, loc), rtol=RTOL, atol=ATOL)
        world = loc @ rows
        f2, q2 = principled_eval_pdf(p, wi, world, rows)
        np.testing.assert_allclose(f2, p.eval(w, world @ rows.T), rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(q2, p.pdf(w, world @ rows.T), rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("p", BSDFS, ids=repr)
def test_compiled_sampling_is_the_numpy_principled(p):
    rng = np.random.default_rng(3)
    u = rng.random((1500, 2))
    e = 1e-6
    u[:7] = [[0.5, 0.5], [e, e], [1 - e, 1 - e], [e, 1 - e], [0.5, e], [1 - e, 0.5],
             [1.0, 0.5]]
    for wi in VIEWS:
        for u1 in (None, 0.0, 0.999, 0.3):
            got, ref = principled_sample(p, wi, u, u1), _reference(p, wi, u, u1)
            for a, b in zip(got, ref):
                np.testing.assert_allclose(a, b, rtol=RTOL, atol=ATOL)
            if wi[2] > 0:
                assert np.mean(ref[1] > 0) > 0.3
            else:
                assert np.all(got[1] == 0) and np.all(got[2] == 0)


def test_kernels_are_picked_by_class():
    assert compiled_principled(Principled()) and not compiled_principled(RoughPlastic())
    assert two_lobe_kernels(Principled())[0] is principled_eval_pdf
    assert two_lobe_kernels(RoughPlastic("ggx", 0.2)) is not None
    assert two_lobe_kernels(get_renderer("mitsuba3").bsdf("ggx", 0.2)) is None


def test_compiled_proxies_and_predictions_are_the_numpy_ones(monkeypatch):
    import envfit.predict.renderer._lobe_parts as lp
    import envfit.predict.renderer._microfacet_model as mm
    n, v = band_frames(30, (0, 89), seed=5)
    bsdf = Principled(0.4, metallic=0.3, sheen=0.5)
    m = _model(bsdf)
    fast = m._proxies(n, v)
    reqs = [("mis", "independent", 16), ("mis", "ldsampler", 16), ("brdf", "stratified", 16)]
    fast_p = [_model(bsdf, level=4, frames=3).predict(*r).mse for r in reqs]
    monkeypatch.setattr(mm, "two_lobe_kernels", lambda c: None)
    monkeypatch.setattr(lp, "two_lobe_kernels", lambda c: None)
    slow = m._proxies(n, v)
    for a, b in zip(fast, slow):
        assert np.all(b >= 0) and np.any(b > 0)
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=1e-12 * b.max())
    slow_p = [_model(bsdf, level=4, frames=3).predict(*r).mse for r in reqs]
    for a, b in zip(fast_p, slow_p):
        np.testing.assert_allclose(a, b, rtol=1e-9)
    assert principled_proxies(bsdf, np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((4, 3)),
                              np.ones((4, 3)), np.ones(4)).shape == (0, 2)

"""The compiled rough plastic (envfit.predict.renderer._plastic_kernels) against its numpy
reference, envfit.shading.microfacet.RoughPlastic: f·cos and pdf, sampling with the lobe from
u_x (``sample_square``) and from a given ``sample1``, for GGX and Beckmann, visible-normal and
D(m)cos θ_m sampling, three roughnesses, linear and nonlinear diffuse, views from the pole to
grazing and below the surface; the frames' proxies against the model's numpy loop; and the
model's predictions with and without the kernels."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.maps import EnvMap
from envfit.predict.renderer import MicrofacetModel, RendererModelOptions, band_frames
from envfit.predict.renderer._plastic_kernels import (compiled_plastic, plastic_eval_pdf,
                                                      plastic_proxies, plastic_sample)
from envfit.renderers import get_renderer
from envfit.shading.microfacet import RoughPlastic

ALPHAS = (0.05, 0.2, 0.6)
VIEWS = np.array([[0.0, 0.0, 1.0], [0.5, 0.2, np.sqrt(0.71)], [0.3, -0.9, np.sqrt(0.1)],
                  [np.sqrt(1 - 0.02 ** 2), 0.0, 0.02], [0.6, 0.0, -0.8]])
RTOL, ATOL = 1e-10, 1e-12


def _plastics(kind, visible):
    for alpha in ALPHAS:
        for nonlinear in (False, True):
            yield RoughPlastic(kind, alpha, diffuse_reflectance=0.8, nonlinear=nonlinear,
                               sample_visible=visible)


def _directions(n=1500):
    rng = np.random.default_rng(0)
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:5] = [[0, 0, 1], [1, 0, 0], [0, 0, -1], [0.6, 0, 0.8], [0, 0.02, np.sqrt(1 - 4e-4)]]
    return d


def _rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return q


@pytest.mark.parametrize("visible", [True, False])
@pytest.mark.parametrize("kind", ["ggx", "beckmann"])
def test_compiled_eval_pdf_is_the_numpy_plastic(kind, visible):
    """f·cos and the mixture pdf equal RoughPlastic.eval and .pdf at random directions (below
    the surface too), the pole, the horizon and each view's mirror direction; local, and world
    through a frame's rows."""
    d = _directions()
    rows = _rotation(1)
    for p in _plastics(kind, visible):
        for wi in VIEWS:
            loc = np.vstack([d, [[-wi[0], -wi[1], wi[2]]]])
            w = np.broadcast_to(wi, loc.shape)
            f, q = plastic_eval_pdf(p, wi, loc)
            np.testing.assert_allclose(f, p.eval(w, loc), rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(q, p.pdf(w, loc), rtol=RTOL, atol=ATOL)
            world = loc @ rows
            f2, q2 = plastic_eval_pdf(p, wi, world, rows)     # the model's numpy branch:
            back = world @ rows.T                             # local = world @ rows.T
            np.testing.assert_allclose(f2, p.eval(w, back), rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(q2, p.pdf(w, back), rtol=RTOL, atol=ATOL)


def _reference(p, wi, u, u1):
    """MicrofacetModel._sample's numpy branch (u1 None) or _sample_lobe's (u1 a float)."""
    w = np.broadcast_to(wi, (len(u), 3))
    with np.errstate(all="ignore"):
        s = p.sample_square(w, u) if u1 is None else p.sample(w, u, u1=np.full(len(u), u1))
    dead = s.weight <= 0
    return np.where(dead[:, None], [0.0, 0.0, 1.0], s.wo), s.weight, np.where(dead, 0.0, s.pdf)


@pytest.mark.parametrize("visible", [True, False])
@pytest.mark.parametrize("kind", ["ggx", "beckmann"])
def test_compiled_sampling_is_the_numpy_plastic(kind, visible):
    """(ω_o, weight, pdf) equal RoughPlastic.sample_square and .sample with sample1 fixed (the
    specular lobe, the diffuse one, and 0.3 against p_s) at random points and points near the
    square's corners and edges (on the edge Mitsuba's GGX warp divides 0 by 0); dead samples
    at the pole with pdf 0."""
    rng = np.random.default_rng(3)
    u = rng.random((1500, 2))
    e = 1e-6
    u[:6] = [[0.5, 0.5], [e, e], [1 - e, 1 - e], [e, 1 - e], [0.5, e], [1 - e, 0.5]]
    for p in _plastics(kind, visible):
        for wi in VIEWS:
            for u1 in (None, 0.0, 1.0, 0.3):
                got, ref = plastic_sample(p, wi, u, u1), _reference(p, wi, u, u1)
                for a, b in zip(got, ref):
                    np.testing.assert_allclose(a, b, rtol=RTOL, atol=ATOL)
                if wi[2] > 0:
                    assert np.mean(ref[1] > 0) > 0.3
                else:
                    assert np.all(got[1] == 0) and np.all(got[2] == 0)


def test_the_warps_singular_edge_is_a_dead_sample():
    """u = (1, ½) in the specular lobe: Mitsuba's GGX visible-normal warp gives 0·∞ slopes (a
    NaN normal); the compiled sample is dead (weight 0, the pole, pdf 0), and so is the numpy
    plastic's (it had raised IndexError on the NaN's table index)."""
    p = RoughPlastic("ggx", 0.2)
    wo, weight, pdf = plastic_sample(p, VIEWS[1], np.array([[1.0, 0.5]]), 0.0)
    assert weight[0] == 0 and pdf[0] == 0 and wo.tolist() == [[0.0, 0.0, 1.0]]
    s = p.sample(VIEWS[1][None, :], np.array([[1.0, 0.5]]), u1=np.array([0.0]))
    assert s.weight[0] == 0 and s.pdf[0] == 0 and np.all(np.isfinite(s.wo))


def test_compiled_plastic_covers_roughplastic_only():
    assert compiled_plastic(RoughPlastic("ggx", 0.2, specular_reflectance=0.5,
                                         nonlinear=True, sample_visible=False))
    assert compiled_plastic(RoughPlastic("beckmann", 0.6, int_ior=1.2))
    assert not compiled_plastic(get_renderer("mitsuba3").bsdf("ggx", 0.2))

    class Other(RoughPlastic):
        pass

    assert not compiled_plastic(Other("ggx", 0.2))


def _model(plastic, level=6, frames=6):
    env = EnvMap(np.random.default_rng(0).random((8, 16, 3)) + 0.1)
    return MicrofacetModel(env, get_renderer("mitsuba3"), plastic, band_frames(frames, seed=1),
                           options=RendererModelOptions(max_level=level))


@pytest.mark.parametrize("kind", ["ggx", "beckmann"])
def test_compiled_proxies_are_the_numpy_loop(kind, monkeypatch):
    """The frames' (v_e, v_b) in one compiled pass equal the model's numpy loop (the plastic's
    eval and pdf at the pilot table) to 1e-10."""
    import envfit.predict.renderer._microfacet_model as mm
    n, v = band_frames(30, (0, 89), seed=5)
    m = _model(RoughPlastic(kind, 0.2, nonlinear=True))
    fast = m._proxies(n, v)
    monkeypatch.setattr(mm, "two_lobe_kernels", lambda c: None)
    slow = m._proxies(n, v)
    for a, b in zip(fast, slow):
        assert np.all(b >= 0) and np.any(b > 0)
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=1e-12 * b.max())
    assert plastic_proxies(m.conductor, np.zeros((0, 3)), np.zeros((0, 3, 3)),
                           np.zeros((4, 3)), np.ones((4, 3)), np.ones(4)).shape == (0, 2)


def test_model_predictions_with_and_without_kernels(monkeypatch):
    """The model's MIS predictions (one-square and lobe-choice samplers) are the same on the
    compiled and the numpy path."""
    import envfit.predict.renderer._lobe_parts as lp
    import envfit.predict.renderer._microfacet_model as mm
    reqs = [("mis", "independent", 16), ("mis", "ldsampler", 16)]
    fast = [_model(RoughPlastic("ggx", 0.2), level=4, frames=3).predict(*r).mse for r in reqs]
    monkeypatch.setattr(mm, "two_lobe_kernels", lambda c: None)
    monkeypatch.setattr(lp, "two_lobe_kernels", lambda c: None)
    slow = [_model(RoughPlastic("ggx", 0.2), level=4, frames=3).predict(*r).mse for r in reqs]
    for a, b in zip(fast, slow):
        np.testing.assert_allclose(a, b, rtol=1e-9)

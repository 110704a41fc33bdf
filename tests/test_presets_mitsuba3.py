"""The Mitsuba 3 preset against Mitsuba itself (``scalar_rgb``, the PyPI release the preset
was read from): the envmap emitter's sampled directions, pdfs and radiance, its
``pdf_direction`` and ``eval`` (float32 tolerance), with and without ``mis_compensation``;
the cosine map, the shading frame and every sampler's spp rounding; the snippets load. Plus
two checks that need no Mitsuba: the density integrates to 1 (quadrature) and a histogram
of samples matches it."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.maps import EnvMap
from envfit.renderers import (Hierarchical2D, Mitsuba3Envmap, mitsuba_frame, get_renderer)
from envfit.renderers._base import cosine_hemisphere

@pytest.fixture(scope="module")
def mi():
    """Mitsuba 3 in its ``scalar_rgb`` variant; a test that asks for it is skipped where it is
    not installed (the density and histogram checks need numpy only)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    return mi


def _sun_map(h=10, w=20, seed=3) -> np.ndarray:
    """A small random float32 RGB map with a sun-like peak (two bright pixels); 20 × 9 patches
    make the Hierarchical2D levels zero-padded (9 → 10, 5 → 6, 3 → 4)."""
    rng = np.random.default_rng(seed)
    a = (0.05 + 0.5 * rng.random((h, w, 3))).astype(np.float32)
    a[2, 13] *= 400.0
    a[3, 13] *= 60.0
    return a


def _mitsuba_samples(mi, emitter, U):
    it = mi.Interaction3f()
    d, pdf, pdf_dir, le = [], [], [], []
    for u in U:
        ds, _ = emitter.sample_direction(it, mi.Point2f(float(u[0]), float(u[1])))
        d.append(np.array(ds.d))
        pdf.append(ds.pdf)
        pdf_dir.append(emitter.pdf_direction(it, ds))
        si = mi.SurfaceInteraction3f()
        si.wi = -ds.d
        le.append(np.array(emitter.eval(si)))
    return np.array(d), np.array(pdf), np.array(pdf_dir), np.array(le)


@pytest.mark.parametrize("comp", [False, True])
def test_sample_pdf_eval_match_mitsuba(mi, comp):
    arr = _sun_map()
    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(arr), "mis_compensation": comp})
    tech = Mitsuba3Envmap(EnvMap(arr.astype(np.float64)), mis_compensation=comp)
    U = np.random.default_rng(7).random((300, 2))
    md, mp, mpd, mle = _mitsuba_samples(mi, emitter, U)
    d, p = tech.sample(U)
    assert np.abs(d - md).max() < 2e-4
    np.testing.assert_allclose(p, mp, rtol=2e-4)
    np.testing.assert_allclose(tech.pdf(md), mpd, rtol=2e-4)
    np.testing.assert_allclose(tech.eval(md), mle, rtol=2e-4, atol=2e-5 * mle.max())
    if comp:
        assert tech.offset > 0.0                 # the map is far from constant: compensated


@pytest.mark.parametrize("up", ["z", "x"])
def test_other_up_axes_are_the_emitters_to_world(mi, up):
    """A map with another ``up``: the technique's directions are Mitsuba's with the
    emitter's ``to_world`` = :attr:`native_to_world`, and the radiance follows them."""
    arr = _sun_map()
    tech = Mitsuba3Envmap(EnvMap(arr.astype(np.float64), up=up))
    m4 = np.eye(4)
    m4[:3, :3] = tech.native_to_world
    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(arr),
                            "to_world": mi.ScalarTransform4f(m4.tolist())})
    U = np.random.default_rng(8).random((100, 2))
    md, mp, _, mle = _mitsuba_samples(mi, emitter, U)
    d, p = tech.sample(U)
    assert np.abs(d - md).max() < 2e-4
    np.testing.assert_allclose(p, mp, rtol=2e-4)
    np.testing.assert_allclose(tech.eval(md), mle, rtol=2e-4, atol=2e-5 * mle.max())


def test_compensation_disabled_for_a_nearly_constant_map(mi):
    """Mitsuba's 1 % rule: mean − min ≤ 1 % of the mean → no offset (same density)."""
    arr = np.full((6, 12, 3), 2.0, dtype=np.float32)
    arr[1, 1] = 2.03
    t0 = Mitsuba3Envmap(EnvMap(arr.astype(np.float64)))
    t1 = Mitsuba3Envmap(EnvMap(arr.astype(np.float64)), mis_compensation=True)
    assert t1.offset == 0.0
    U = np.random.default_rng(0).random((50, 2))
    np.testing.assert_allclose(t1.sample(U).pdf, t0.sample(U).pdf)
    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(arr), "mis_compensation": True})
    np.testing.assert_allclose(t1.sample(U).pdf, _mitsuba_samples(mi, emitter, U)[1], rtol=2e-4)


def _sphere_grid(n_z=1200, n_phi=2400):
    """Midpoints of an equal-area (cos θ, φ) grid about +y and the cell solid angle."""
    z = -1 + (np.arange(n_z) + 0.5) * 2 / n_z
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    Z, P = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1 - Z ** 2)
    d = np.stack([r * np.cos(P), Z, r * np.sin(P)], axis=-1).reshape(-1, 3)
    return d, 4 * np.pi / (n_z * n_phi)


def test_density_integrates_to_one():
    for comp in (False, True):
        tech = Mitsuba3Envmap(EnvMap(_sun_map().astype(np.float64)), mis_compensation=comp)
        d, dw = _sphere_grid(500, 1000)
        assert abs(tech.pdf(d).sum() * dw - 1.0) < 2e-4       # midpoint rule: ~3e-5 here


def test_histogram_matches_pdf():
    """Samples fall into 8 × 16 equal-solid-angle cells in proportion to ∫cell pdf."""
    tech = Mitsuba3Envmap(EnvMap(_sun_map().astype(np.float64)))
    n = 200_000
    d, _ = tech.sample(np.random.default_rng(11).random((n, 2)))
    nz, nphi = 8, 16

    def cell(v):
        iz = np.minimum(((v[:, 1] + 1) / 2 * nz).astype(int), nz - 1)
        ip = np.minimum(((np.arctan2(v[:, 2], v[:, 0]) % (2 * np.pi)) / (2 * np.pi) * nphi)
                        .astype(int), nphi - 1)
        return iz * nphi + ip

    counts = np.bincount(cell(d), minlength=nz * nphi)
    g, dw = _sphere_grid(800, 1600)
    expected = np.bincount(cell(g), weights=tech.pdf(g) * dw, minlength=nz * nphi) * n
    assert abs(expected.sum() / n - 1) < 3e-3
    assert np.all(np.abs(counts - expected) < 5 * np.sqrt(expected) + 0.003 * expected + 3)


def test_hierarchical2d_uniform_is_identity():
    """On a constant grid every level splits evenly: the warp is the identity, pdf 1."""
    h = Hierarchical2D(np.ones((5, 9)))
    U = np.random.default_rng(1).random((100, 2))
    uv, pdf = h.sample(U)
    np.testing.assert_allclose(uv, U, atol=1e-12)
    np.testing.assert_allclose(pdf, 1.0)


def test_cosine_map_matches_mitsuba(mi):
    U = np.random.default_rng(2).random((200, 2))
    U[0] = (0.5, 0.5)
    ours = cosine_hemisphere(U)
    ref = np.array([np.array(mi.warp.square_to_cosine_hemisphere(mi.Point2f(*u))) for u in U])
    ref_pdf = np.array([mi.warp.square_to_cosine_hemisphere_pdf(mi.Vector3f(*v)) for v in ref])
    np.testing.assert_allclose(ours.directions, ref, atol=2e-6)
    np.testing.assert_allclose(ours.pdf, ref_pdf, rtol=1e-5, atol=2e-6)   # float32 1 − r²
    assert get_renderer("mitsuba3").cosine is cosine_hemisphere


def test_frame_matches_mitsuba(mi):
    n = np.random.default_rng(4).normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[0] = (0.0, 0.0, -1.0)
    ours = mitsuba_frame(n)
    for k, v in enumerate(n):
        s, t = mi.coordinate_system(mi.Vector3f(*v))
        np.testing.assert_allclose(ours[k, 0], np.array(s), atol=2e-6)
        np.testing.assert_allclose(ours[k, 1], np.array(t), atol=2e-6)


@pytest.mark.parametrize("name", ["independent", "stratified", "multijitter", "ldsampler",
                                  "orthogonal"])
def test_sampler_rounding_matches_mitsuba(mi, name):
    spec = get_renderer("mitsuba3").sampler(name)
    for spp in (1, 2, 3, 5, 16, 32, 64, 100, 128, 256, 1000, 1024):
        assert spec.spp(spp) == mi.load_dict({"type": name, "sample_count": spp}).sample_count()


@pytest.mark.parametrize("strategy", ["map", "brdf", "mis"])
def test_snippets_load_in_mitsuba(mi, tmp_path, strategy):
    path = str(tmp_path / "envmap.exr")
    mi.Bitmap(_sun_map()).write(path)
    p = get_renderer("mitsuba3")
    setting = p.strategy(strategy)
    for sampler in p.samplers:
        ns: dict = {}
        exec(p.snippet(strategy, sampler, 32, filename=path), ns)     # noqa: S102
        scene = ns["scene"]
        assert scene.sensors()[0].sampler().sample_count() == p.sampler(sampler).spp(32)
        assert len(scene.emitters()) == 1
        xml = mi.load_string(p.snippet(strategy, sampler, 32, filename=path, form="xml",
                                       mis_compensation=True))
        assert xml.sensors()[0].sampler().sample_count() == p.sampler(sampler).spp(32)
    text = str(ns["scene"].integrator())   # the strategy's integrator, as Mitsuba read it
    if strategy == "mis":                  # path at its defaults: no depth limit, RR from 5
        assert setting.integrator == "path" and not setting.settings
        assert text.startswith("PathIntegrator") and "max_depth = 4294967295" in text
        assert "rr_depth = 5" in text
    else:
        assert text.startswith("DirectIntegrator") and setting.integrator == "direct"
        assert f"emitter_samples = {setting.emitter_samples}," in text
        assert f"bsdf_samples = {setting.bsdf_samples}" in text

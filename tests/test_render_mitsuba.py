"""The sphere measurement of a real renderer's noise (envfit.renderers), checked with
Mitsuba 3 (scalar_rgb) on tiny scenes: 16×16-pixel views, 8×16 and 16×32 maps, low spp.

Independent values: closed-form sphere means; Mitsuba's own AOV normals; Mitsuba's own
emitter (eval and sample_direction) for the exact variances; brute force over many simulated
renders for the reference-variance subtraction.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.renderers import (VIEWS, Mitsuba3Options, Mitsuba3Sphere, cached_reference,
                                      sphere_error, sphere_geometry, sphere_mean, view_normals)

R = 16


def _fibonacci(m: int) -> np.ndarray:
    i = np.arange(m) + 0.5
    z = 1.0 - 2.0 * i / m
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def test_weights_integrate_uniform_normals():
    """The kept pixels weighted 1/(n·v) give the sphere mean of functions of the normal."""
    g = sphere_geometry(R)
    a = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    assert sphere_mean(lambda n: n[..., 0] ** 2, g) == pytest.approx(1 / 3, abs=1e-12)
    assert sphere_mean(lambda n: n[..., 2] ** 4, g) == pytest.approx(1 / 5, rel=0.015)
    assert sphere_mean(lambda n: np.exp(2 * n @ a), g) == pytest.approx(math.sinh(2) / 2,
                                                                        rel=2e-3)
    # every normal counted once: the kept regions of the six views tile the sphere (their
    # weighted image area is its 4π; the pixel-centre test is coarse at 16 px, 5 %)
    for res, tol in ((16, 0.06), (64, 0.002)):
        h = sphere_geometry(res)
        total = len(VIEWS) * h.weight[h.keep].sum() * (2 / res) ** 2
        assert total == pytest.approx(4 * math.pi, rel=tol)


def test_normals_match_mitsuba_aov():
    """The normals from the orthographic geometry are Mitsuba's (aov nn:sh_normal)."""
    from envfit.renderers import mitsuba_normals
    g = sphere_geometry(R)
    aov = mitsuba_normals(R, spp=64)
    for k, view in enumerate(VIEWS):
        d = np.abs(aov[k][g.keep] - view_normals(view, g)[g.keep])
        assert d.mean() < 0.01 and d.max() < 0.05, view.name


def _mitsuba_function(data: np.ndarray):
    """Mitsuba 3's envmap radiance (src/emitters/envmap.cpp, eval_spectrum): bilinear, rows on
    the poles θ = π y/(H−1), columns texel-centred and periodic, φ = atan2(d.x, −d.z)."""
    h, w = data.shape[:2]
    D = data.astype(np.float64)

    def f(d):
        th = np.arccos(np.clip(d[..., 1], -1, 1))
        ph = np.mod(np.arctan2(d[..., 0], -d[..., 2]), 2 * np.pi)
        y, x = th / np.pi * (h - 1), ph / (2 * np.pi) * w - 0.5
        y0 = np.clip(np.floor(y), 0, h - 2).astype(int)
        x0 = np.floor(x).astype(int)
        fy, fx = (y - y0)[..., None], (x - x0)[..., None]
        c0, c1 = np.mod(x0, w), np.mod(x0 + 1, w)
        return ((1 - fy) * ((1 - fx) * D[y0, c0] + fx * D[y0, c1])
                + fy * ((1 - fx) * D[y0 + 1, c0] + fx * D[y0 + 1, c1]))
    return f


def _exact_brdf_variance(f) -> float:
    r"""Mean over uniform normals and channels of the one-sample variance of cosine sampling
    of f: (1/4π)∫f² − mean_n I(n)², I(n) = ∫ f cos⁺/π, by a fine midpoint rule (f sampled on
    a 128×256 grid; I over 2000 Fibonacci normals by envfit's exact SH integrator of that grid)."""
    from envfit.maps import pixel_directions, pixel_solid_angles
    from envfit.shading import shading_integral
    hf = 128
    dirs = pixel_directions(hf, 2 * hf, up="y")
    om = pixel_solid_angles(hf, 2 * hf)
    fine = f(dirs)
    m2 = (om[..., None] * fine ** 2).sum(axis=(0, 1)) / (4 * math.pi)
    I = shading_integral(EnvMap(fine), _fibonacci(2000))
    return float(np.mean(m2 - (I ** 2).mean(axis=0)))


def test_mitsuba_function_replica_is_mitsubas():
    """The numpy replica of Mitsuba's lookup used by the exact variance is Mitsuba's own."""
    from envfit.renderers.mitsuba3._render import import_mitsuba
    mi = import_mitsuba()
    data = np.random.default_rng(3).random((8, 16, 3)).astype(np.float32)
    with Mitsuba3Sphere(EnvMap(data), Mitsuba3Options(resolution=8, reference_spp=4)) as r:
        em = r._scene("independent", False).emitters()[0]
        d = np.random.default_rng(4).normal(size=(100, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        got = []
        for v in d:
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*(-v))
            got.append(np.array(em.eval(si)))
    np.testing.assert_allclose(np.array(got), _mitsuba_function(data)(d), atol=1e-5)


def test_constant_map_brdf_exact_and_map_sampling_variance(tmp_path):
    """Constant map: BSDF sampling is exact (0 error, to float noise); map sampling's RMSE is
    the exact one from Mitsuba's own pdf, L²(∫dω/p /(6π²) − 1)/N (mean over normals of cos⁺²
    is 1/6 at every direction), ∫dω/p = E_p[1/p²] over Mitsuba's own samples."""
    L, spp = 0.5, 16
    opts = Mitsuba3Options(resolution=R, reference_spp=256, cache_dir=str(tmp_path))
    with Mitsuba3Sphere(EnvMap(np.full((8, 16, 3), L)), opts) as r:
        ref = r.reference()
        brdf = r.measure("brdf", "independent", spp, seed=1, reference=ref)
        imgs, _ = r.render("brdf", "stratified", 4, seed=5)
        assert np.abs(imgs[:, sphere_geometry(R).keep] - L).max() < 1e-5
        mis = r.measure("mis", "ldsampler", spp, seed=2, reference=ref)
        assert mis.rmse > 0
        m = r.measure("map", "independent", spp, seed=3, reference=ref)
        mi = r.mi
        em = r._scene("independent", False).emitters()[0]
        it = mi.Interaction3f()
        u = (np.arange(128) + 0.5) / 128
        inv2 = []
        for a in u:
            for b in u:
                ds, _ = em.sample_direction(it, mi.Point2f(a, b))
                inv2.append(1.0 / ds.pdf ** 2)
    v = L ** 2 * (np.mean(inv2) / (6 * math.pi ** 2) - 1.0)
    pred = math.sqrt(v / spp)
    assert m.low <= pred <= m.high, (pred, m)
    # BSDF sampling: only the reference's own noise is left, and it is subtracted
    assert brdf.rmse <= brdf.high < 0.02 * m.rmse
    assert m.renderer == "mitsuba3" and m.pixels == 6 * sphere_geometry(R).kept


def test_brdf_independent_matches_exact_variance(tmp_path):
    """BSDF-only, independent sampler, small GP map: measured RMSE ∋ √(V/N), V the exact
    cosine-sampling variance of the function Mitsuba renders (Mitsuba samples the diffuse lobe
    exactly: weight = L(ω)). Also the reference cache: the second read is verified and equal."""
    import envfit.data_gen as data_gen
    f = data_gen.gaussian_process_map(1.5, 16, seed=5, channels=3)
    data = (f - f.min() + 0.3 * (f.max() - f.min())).astype(np.float32)
    spp = 16
    opts = Mitsuba3Options(resolution=R, reference_spp=1024, cache_dir=str(tmp_path))
    with Mitsuba3Sphere(EnvMap(data), opts) as r:
        ref = r.reference()
        again = r.reference()
        m = r.measure("brdf", "independent", spp, seed=11, reference=ref)
    assert again.cached and not ref.cached and np.array_equal(again.a, ref.a)
    pred = math.sqrt(_exact_brdf_variance(_mitsuba_function(data)) / spp)
    assert m.low <= pred <= m.high, (pred, m)
    assert 0.85 < pred / m.rmse < 1.15


def test_reference_subtraction_unbiased():
    """Over many simulated renders, the mean of the measured MSE is the true weighted mean
    variance of the render (the reference's variance subtracted); without the subtraction it
    is biased by the reference's."""
    g = sphere_geometry(8)
    rng = np.random.default_rng(0)
    truth = rng.random((6, 8, 8, 3)) + 1.0
    sig = 0.05 + 0.1 * rng.random((6, 8, 8, 3))          # the render's noise per pixel
    sig_r = 0.08                                           # the references' noise
    want = float((g.weight[g.keep] * (sig ** 2).mean(axis=-1)[:, g.keep]).sum()
                 / (6 * g.weight[g.keep].sum()))
    got, raw, off = [], [], []
    for _ in range(600):
        img = truth + sig * rng.standard_normal(truth.shape)
        a = truth + sig_r * rng.standard_normal(truth.shape)
        b = truth + sig_r * rng.standard_normal(truth.shape)
        e = sphere_error(img, a, b, g, seed=1, resamples=10)
        got.append(e.rmse ** 2)
        raw.append(e.raw_rmse ** 2)
        off.append(e.mean_offset)
    se = np.std(got) / math.sqrt(len(got))
    assert abs(np.mean(got) - want) < 4 * se
    assert np.mean(raw) - want > 20 * se                  # the bias the subtraction removes
    # the mean offset: 0 on average for unbiased renders; a render missing 10 % reads −10 %
    assert abs(np.mean(off)) < 4 * np.std(off) / math.sqrt(len(off))
    assert sphere_error(0.9 * truth, truth, truth, g).mean_offset == pytest.approx(-0.1)


def test_sphere_error_mask_selects_a_band_of_view_angles():
    """With a mask the error is the weighted RMS over the masked kept pixels only: errors of
    1 where θ_o < 30° and 3 elsewhere give 1 and 3 by band (computed here by hand), and a
    mask that keeps no pixel is one line."""
    g = sphere_geometry(32)
    theta = np.degrees(np.arccos(np.clip(g.z, -1, 1)))
    near = theta < 30.0
    truth = np.ones((6, 32, 32, 3))
    img = truth + np.where(near, 1.0, 3.0)[None, :, :, None]
    assert sphere_error(img, truth, truth, g, mask=near).rmse == pytest.approx(1.0)
    assert sphere_error(img, truth, truth, g, mask=~near).rmse == pytest.approx(3.0)
    w = g.weight[g.keep]
    whole = math.sqrt(float((w * np.where(near[g.keep], 1.0, 9.0)).sum() / w.sum()))
    assert sphere_error(img, truth, truth, g).rmse == pytest.approx(whole)
    with pytest.raises(ParameterError, match="selecting kept pixels"):
        sphere_error(img, truth, truth, g, mask=np.zeros((32, 32), bool))


def test_cache_rejects_corrupt_file(tmp_path):
    calls = []

    def render():
        calls.append(1)
        return np.full((6, 4, 4, 3), len(calls), float), np.zeros((6, 4, 4, 3)), 0.1

    key = {"renderer": "demo", "map": "x", "spp": 4}
    cached_reference(key, render, tmp_path)
    (p,) = tmp_path.glob("demo-ref-*.npz")
    p.write_bytes(p.read_bytes()[:100])                    # torn file
    r = cached_reference(key, render, tmp_path)
    assert len(calls) == 2 and not r.cached and float(r.a.mean()) == 2.0
    assert cached_reference(key, render, tmp_path).cached


def test_errors_are_parameter_errors(monkeypatch):
    with pytest.raises(ParameterError):
        Mitsuba3Options(resolution=2)
    with pytest.raises(ParameterError):
        sphere_error(np.zeros((5, 8, 8, 3)), np.zeros((6, 8, 8, 3)), np.zeros((6, 8, 8, 3)),
                     sphere_geometry(8))
    import sys
    monkeypatch.setitem(sys.modules, "mitsuba", None)
    from envfit.renderers.mitsuba3._render import import_mitsuba
    with pytest.raises(ParameterError, match="Mitsuba 3 is not installed"):
        import_mitsuba()
    monkeypatch.setitem(sys.modules, "bpy", None)
    from envfit.renderers.cycles._render import import_bpy
    with pytest.raises(ParameterError, match="Cycles is not available"):
        import_bpy()

"""The frame model (issue 42) against Mitsuba 3 renders of small scenes: the image RMSE and
each pixel's, with shadows, a texture-free albedo per shape, the box and Gaussian filters;
its shadow rays against Mitsuba's own ``ray_test``; its refusals."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from envfit.base import ParameterError

SCENE = """<scene version="3.0.0">
  <integrator type="{integrator}"/>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1.5, 5" target="0, 0.4, 0" up="0, 1, 0"/>
    </transform>
    <sampler type="{sampler}"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
      <rfilter type="{rfilter}"/></film>
  </sensor>
  <emitter type="envmap"><string name="filename" value="{map}"/>
    <transform name="to_world"><rotate y="1" angle="30"/></transform></emitter>
  <shape type="sphere"><point name="center" x="0" y="0.5" z="0"/><float name="radius" value="0.5"/>
    {bsdf}</shape>
  <shape type="cube"><transform name="to_world"><scale value="0.3"/>
    <translate x="1" y="0.3" z="0.3"/></transform><bsdf type="diffuse"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/>
    <rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
</scene>
"""


def _map(path):
    """A 64 × 32 map: a sky gradient and a small bright sun (shadows with a direction)."""
    from envfit.maps import save_envmap
    h, w = 32, 64
    y = (np.arange(h) + 0.5) / h
    img = np.zeros((h, w, 3))
    img[...] = (1.5 - y)[:, None, None] * np.array([0.6, 0.8, 1.0])
    img[6:8, 40:42] = 200.0
    return save_envmap(path, img)


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("frame")
    _map(d / "map.exr")
    return d


def _scene(d, name="s.xml", *, w=24, h=18, rfilter="box", sampler="independent",
           integrator="direct",
           bsdf='<bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.5, 0.3"/></bsdf>'):
    p = d / name
    p.write_text(SCENE.format(w=w, h=h, rfilter=rfilter, sampler=sampler, map=d / "map.exr",
                              integrator=integrator, bsdf=bsdf))
    return p


def _renders(path, spp: int, k: int) -> np.ndarray:
    from envfit.renderers.mitsuba3._render import import_mitsuba
    mi = import_mitsuba()
    sc = mi.load_file(str(path))
    return np.stack([np.array(mi.render(sc, seed=s, spp=spp))[..., :3] for s in range(k)])


#: a rough gold conductor with a textured specular reflectance (the sphere's BSDF)
GOLD = ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/>'
        '<float name="alpha" value="0.2"/><string name="material" value="Au"/>'
        '<texture type="checkerboard" name="specular_reflectance"><rgb name="color0" '
        'value="0.9"/><rgb name="color1" value="0.4"/><transform name="to_uv"><scale x="4" '
        'y="4"/></transform></texture></bsdf>')


#: a principled sphere (metallic 0.4, sheen 0.5; the plugin's defaults otherwise)
PRINCIPLED = ('<bsdf type="principled"><float name="metallic" value="0.4"/>'
              '<float name="sheen" value="0.5"/><float name="roughness" value="0.35"/></bsdf>')


@pytest.mark.parametrize("rfilter,bsdf", [("box", None), ("gaussian", None), ("box", GOLD),
                                          ("box", PRINCIPLED)])
def test_the_image_and_pixel_rmse_are_mitsubas(scene_dir, rfilter, bsdf):
    """Predicted against 40 renders at 4 spp (the estimator is unbiased: each pixel's MSE is
    its variance over renders): the image RMSE inside [0.8 × low, 1.25 × high] of its 95 %
    interval, and the pixels' ranks agree (Spearman ≥ 0.8)."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from scipy.stats import chi2, spearmanr

    from envfit.frame import predict_frame
    tag = "" if bsdf is None else "_gold" if bsdf == GOLD else "_principled"
    path = _scene(scene_dir, f"{rfilter}{tag}.xml", rfilter=rfilter,
                  **({"bsdf": bsdf} if bsdf else {}))
    p = predict_frame(path, spp=(4,), level=4)
    imgs = _renders(path, 4, 40)
    meas = imgs.var(axis=0, ddof=1).mean(axis=2)          # (H, W)
    k, m = imgs.shape[0] - 1, float(meas.mean())
    # the image MSE's interval: a sum of many pixels' variances, each with k degrees of
    # freedom; its effective degrees of freedom by Satterthwaite
    dof = k * meas.sum() ** 2 / (meas ** 2).sum()
    lo, hi = m * dof / chi2.ppf(0.975, dof), m * dof / chi2.ppf(0.025, dof)
    pred = p.rows[0].rmse ** 2
    assert 0.8 ** 2 * lo <= pred <= 1.25 ** 2 * hi, (pred, lo, hi)
    assert spearmanr(p.pixel_rmse(4).ravel(), meas.ravel()).correlation >= 0.8
    # the converged image the model implies is the renders' mean
    mean = imgs.mean(axis=0)
    assert abs(float(p.preview.mean()) / float(mean.mean()) - 1) < 0.03


def test_the_gaussian_filter_lowers_the_noise_as_mitsuba_splats(scene_dir):
    """Mitsuba's default Gaussian (σ = 0.5 px, radius 2) averages ~3 pixels' samples: the
    model's image RMSE under it is well below the box filter's, by the ratio the renders show."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from envfit.frame import predict_frame
    box = predict_frame(_scene(scene_dir, "b2.xml"), spp=(4,), level=4).rows[0].rmse
    gau = predict_frame(_scene(scene_dir, "g2.xml", rfilter="gaussian"), spp=(4,),
                        level=4).rows[0].rmse
    rb = np.sqrt(_renders(scene_dir / "b2.xml", 4, 24).var(axis=0, ddof=1).mean())
    rg = np.sqrt(_renders(scene_dir / "g2.xml", 4, 24).var(axis=0, ddof=1).mean())
    assert gau < 0.8 * box
    assert abs((gau / box) / (rg / rb) - 1) < 0.15


def test_a_rough_conductor_is_mitsubas_own_at_the_hits(scene_dir):
    """At first hits on a textured gold GGX sphere: the reader's specular reflectance × the
    lobe × its Fresnel per channel, and the lobe's pdf, against Mitsuba's own
    ``BSDF::eval_pdf`` at random directions (an independent evaluation of the same plugin)."""
    pytest.importorskip("mitsuba")
    from envfit.renderers.mitsuba3._frame_scene import read_scene
    from envfit.renderers.mitsuba3._render import import_mitsuba
    path = _scene(scene_dir, "gold_hits.xml", bsdf=GOLD)
    fs = read_scene(path)
    mi = import_mitsuba()
    sc = mi.load_file(str(path))
    sensor = sc.sensors()[0]
    rng = np.random.default_rng(3)
    xy = np.column_stack([rng.uniform(8, 16, 12), rng.uniform(3, 9, 12)])
    h = fs.hits_at(xy)
    gold = [i for i, b in enumerate(fs.bsdfs) if b.kind == "glossy"]
    assert len(gold) == 1 and [b.kind for b in fs.bsdfs].count("diffuse") == 2
    lobe = fs.bsdfs[gold[0]]
    assert lobe.fresnel is not None
    checked = 0
    for k, (x, y) in enumerate(xy):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x / 24, y / 18), mi.Point2f(0.5, 0.5))
        si = sc.ray_intersect(ray)
        if h["shape"][k] != gold[0] or not h["facing"][k]:
            continue
        for _ in range(8):
            wo = rng.normal(size=3)
            wo[2] = abs(wo[2])
            wo /= np.linalg.norm(wo)
            val, pdf = si.bsdf().eval_pdf(mi.BSDFContext(), si, mi.Vector3f(*wo))
            wi = h["wi"][k:k + 1]
            m = (wi + wo) / np.linalg.norm(wi + wo)
            ours = (h["albedo"][k] * lobe.lobe.eval(wi, wo[None])[0]
                    * lobe.fresnel(np.sum(wi * m, axis=1))[0])
            assert np.allclose(ours, np.array(tuple(val))[:3], rtol=2e-4, atol=1e-7)
            assert np.isclose(lobe.lobe.pdf(wi, wo[None])[0], float(pdf), rtol=2e-4)
            checked += 1
    assert checked >= 40
    assert len(np.unique(np.round(h["albedo"][h["shape"] == gold[0], 0], 3))) == 2   # texture


def test_the_net_simulation_is_the_digital_shifts_exact_mse():
    """One film cell whose map part is a 32 × 32 table (smooth, with a jump): the mean over
    4096 of
    ``ldsampler``'s scrambles of the pixel's squared error (the renderer's own points,
    :mod:`envfit.frame._nets`) against the exact MSE of a uniformly digitally shifted
    (0, 2)-net (the Walsh coefficients on the net's dual: a second algorithm)."""
    from envfit.frame._nets import _squared_errors
    from envfit.predict.renderer.randomisation import DyadicGrid, randomised_mse
    from envfit.renderers import get_renderer
    m, n = 32, 16
    x = (np.arange(m) + 0.5) / m
    table = x[:, None] ** 2 + np.sin(3 * x[None, :]) + (x[:, None] + 0.7 * x[None, :] > 0.9)
    flat = np.vstack([np.repeat(table.reshape(-1, 1), 3, axis=1), np.zeros((1, 3))])
    tabs = np.array([[[0, m], [m * m, 1], [m * m, 1]]])   # the map's table, an empty BSDF's
    pts = get_renderer("mitsuba3").sampler("ldsampler").film_points(4096, n, 3, 1)
    pts = np.concatenate([pts, np.zeros(pts.shape[:2] + (1, 2))], axis=2)   # lobe numbers
    out = np.zeros((1, 3))
    _squared_errors(flat, tabs, np.ones(1), np.arange(1), np.array([[0, 1]]),
                    np.ascontiguousarray(pts.transpose(2, 0, 1, 3)),
                    np.full((1, 3), table.mean()), out)
    exact = randomised_mse("digital_shift", DyadicGrid.from_arrays(table, table ** 2), n).mse[0]
    assert abs(out[0, 0] / exact - 1) < 0.08, (out[0, 0], exact)
    assert exact < 0.3 * table.var() / n                  # far below the independent MSE


def test_the_ldsampler_frame_is_mitsubas(scene_dir):
    """A frame under ``ldsampler`` (box filter) at 16 spp against 40 renders: the image RMSE
    inside [0.8 × low, 1.25 × high] of its 95 % interval; its error is not MSE₁/N (the
    independent sampler's scene predicts more at 64 spp)."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from scipy.stats import chi2

    from envfit.frame import predict_frame
    path = _scene(scene_dir, "ld.xml", sampler="ldsampler")
    p = predict_frame(path, spp=(16, 64), level=3)
    assert set(p.mse_by_spp) >= {16, 64}
    mse = {n: float(v.mean()) for n, v in p.mse_by_spp.items()}
    top, (n0, n1) = p.target ** 2, sorted(mse)[-2:]
    if p.answer_rate is None:                     # the answer among the predicted counts
        assert p.answer in mse and mse[p.answer] <= top
        assert p.below is None or mse[p.below] > top
    else:                                         # past them, at the last two's local rate
        a = 2 * p.answer_rate
        assert abs(mse[n0] / mse[n1] - (n1 / n0) ** a) < 1e-9 * mse[n0] / mse[n1]
        assert mse[n1] > top and p.answer == 4 * p.below
        assert mse[n1] * (n1 / p.answer) ** a <= top < mse[n1] * (n1 / p.below) ** a
    imgs = _renders(path, 16, 40)
    meas = imgs.var(axis=0, ddof=1).mean(axis=2)
    k, mm = imgs.shape[0] - 1, float(meas.mean())
    dof = k * meas.sum() ** 2 / (meas ** 2).sum()
    lo, hi = mm * dof / chi2.ppf(0.975, dof), mm * dof / chi2.ppf(0.025, dof)
    pred = p.rows[0].rmse ** 2
    assert 0.8 ** 2 * lo <= pred <= 1.25 ** 2 * hi, (pred, lo, hi)
    ind = predict_frame(_scene(scene_dir, "ind.xml"), spp=(64,), level=3)
    assert p.rows[1].rmse < 0.9 * ind.rows[0].rmse


def test_shadow_rays_agree_with_mitsubas_ray_test(scene_dir):
    """Random rays from points on the ground: Embree on the scene's triangles (an icosphere
    for the sphere) against Mitsuba's ``Scene::ray_test`` on its own shapes."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from envfit.frame._visibility import Visibility
    from envfit.renderers.mitsuba3._frame_scene import read_scene
    from envfit.renderers.mitsuba3._render import import_mitsuba
    mi = import_mitsuba()
    path = _scene(scene_dir, "v.xml", w=4, h=3)
    fs = read_scene(path)
    sc = mi.load_file(str(path))
    rng = np.random.default_rng(3)
    n = 4000
    o = np.column_stack([rng.uniform(-2, 2, n), np.full(n, 1e-3), rng.uniform(-2, 2, n)])
    d = rng.normal(size=(n, 3))
    d[:, 1] = np.abs(d[:, 1])
    d /= np.linalg.norm(d, axis=1)[:, None]
    ground = [i for i, oc in enumerate(fs.occluders) if oc.name == "Rectangle"][0]
    ours = Visibility(fs.occluders).visible(o, d, ground)
    theirs = np.array([not sc.ray_test(mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i])))
                       for i in range(n)])
    assert (~theirs).sum() > 100                        # the sphere and cube shadow some
    assert np.mean(ours == theirs) > 0.998


def test_the_background_is_the_emitters_own(scene_dir):
    """Where the camera sees the map, the model's stratum means equal Mitsuba's emitter
    ``eval`` at the film points (the rotated map included) to the map's bilinear accuracy."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from envfit.frame._model import _background, _Techniques, film_block
    from envfit.renderers._frame import HIT_NONE
    from envfit.renderers.mitsuba3._frame_scene import read_scene
    fs = read_scene(_scene(scene_dir, "bg.xml", w=12, h=9))
    yy, xx = np.mgrid[0:9, 0:12]
    block = film_block(fs, np.column_stack([yy.ravel(), xx.ravel()]), 1)
    idx = np.argwhere(block.hits["kind"] == HIT_NONE)
    assert len(idx) > 10
    mean, var = _background(block, _Techniques(fs, 2), idx)
    mid = block.hits["background"][tuple(idx.T)]
    assert np.allclose(mean, mid, rtol=0.05, atol=1e-3)
    assert np.all(var >= 0)


def test_the_box_filter_is_the_pixels_mean_variance():
    """With the box filter each pixel's MSE at one spp is the mean of v over its film points
    plus the variance of I over them (the model's formula, computed here by hand); any subset
    of target pixels gets the same values."""
    from envfit.frame._model import FilmBlock, PointMoments, pixel_mse

    class FS:
        width, height, filter_name, filter_radius = 3, 2, "box", 0.5
    rng = np.random.default_rng(0)
    mean, var = rng.random((2, 6, 2, 2, 3))
    yy, xx = np.mgrid[0:2, 0:3]
    px = np.column_stack([yy.ravel(), xx.ravel()])
    block = FilmBlock(px, 2, {}, None, None)
    pm = PointMoments(mean, var, np.zeros_like(var), 0)
    ip, mse = pixel_mse(FS, block, pm, px)
    assert np.allclose(ip, mean.mean(axis=(1, 2)))
    assert np.allclose(mse, var.mean(axis=(1, 2)) + mean.var(axis=(1, 2)))
    ip2, mse2 = pixel_mse(FS, block, pm, px[[4, 1]])
    assert np.allclose(mse2, mse[[4, 1]]) and np.allclose(ip2, ip[[4, 1]])


def test_a_sample_of_pixels_estimates_the_image_within_its_error(scene_dir):
    """Predicting one pixel per cell of a coarse grid gives the all-pixel image RMSE within
    three of its reported standard errors, and the standard error is not zero."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from envfit.frame import predict_frame
    path = _scene(scene_dir, "plan.xml", w=24, h=18, rfilter="gaussian")
    full = predict_frame(path, spp=(4,), level=3)
    part = predict_frame(path, spp=(4,), level=3, max_pixels=60, seed=5)
    assert full.exact and not part.exact and part.pixels <= 60
    se = part.rows[0].rmse_se
    assert 0 < se < 0.5
    assert abs(part.rows[0].rmse / full.rows[0].rmse - 1) <= 3 * se
    assert part.mse1.shape[:2] != full.mse1.shape[:2]


@pytest.mark.parametrize("change,words", [
    ({"bsdf": '<bsdf type="conductor"/>'}, "reads the diffuse, roughconductor and principled"),
    ({"bsdf": '<bsdf type="principled"><float name="clearcoat" value="0.5"/></bsdf>'},
     "principled clearcoat 0.5"),
    ({"bsdf": '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.1"/></bsdf>'},
     "coloured principled base_color"),
    ({"bsdf": '<bsdf type="principled"><texture type="checkerboard" name="roughness"/>'
              '</bsdf>'}, "textured principled roughness"),
    ({"bsdf": PRINCIPLED, "sampler": "ldsampler"}, "under the independent sampler so far"),
    ({"bsdf": '<bsdf type="roughconductor"><float name="alpha_u" value="0.1"/>'
              '<float name="alpha_v" value="0.3"/></bsdf>'}, "anisotropic or textured"),
    ({"sampler": "multijitter"}, "predicts the independent, ldsampler samplers"),
    ({"sampler": "ldsampler", "rfilter": "gaussian"}, "with the box filter only"),
    ({"integrator": "volpath"}, "is not modelled"),
])
def test_what_is_not_modelled_is_refused_in_one_line(scene_dir, change, words):
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    from envfit.frame import predict_frame
    path = _scene(scene_dir, f"bad_{'_'.join(change)}.xml", w=4, h=3, **change)
    with pytest.raises(ParameterError, match=words):
        predict_frame(path, spp=(4,), level=2)
    r = subprocess.run([sys.executable, "-m", "envfit.cli", "frame", str(path)],
                       capture_output=True, text=True, cwd=scene_dir)   # the installed envfit
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert words in r.stderr
    assert "Traceback" not in r.stderr


def test_the_answer_meets_the_target_and_one_less_does_not(scene_dir, tmp_path):
    """The CLI's answer N: the image RMSE at N (MSE₁/N) is ≤ the target, at N − 1 it is not;
    --json has the contract's predictions and --out the noise image."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("embreex")
    import json

    path = _scene(scene_dir, "a.xml", w=8, h=6)
    out, js = tmp_path / "out", tmp_path / "f.json"
    r = subprocess.run([sys.executable, "-m", "envfit.cli", "frame", str(path), "--spp", "4,16",
                        "--level", "3", "--target-relative", "0.05", "--json", str(js),
                        "--out", str(out), "-q"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(js.read_text())
    assert [x["spp"] for x in d["predictions"]] == [4, 16]
    r4, r16 = (x["predicted_rmse"] for x in d["predictions"])
    assert abs(r4 / r16 - 2.0) < 1e-9                    # independent: exactly N^-1/2
    n, t = d["answer_spp"], d["target"]
    mse1 = r4 ** 2 * 4
    assert mse1 / n <= t * t < mse1 / (n - 1)
    assert abs(t - 0.05 * d["mean_value"]) < 1e-12
    r = subprocess.run([sys.executable, "-m", "envfit.cli", "frame", str(path), "--spp", "4",
                        "--level", "3", "--target", "0.01", "--percentile", "90", "--json",
                        str(js), "-q"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(js.read_text())
    p90, n = d["predictions"][0]["pixel_rmse_percentiles"]["90"], d["answer_spp"]
    assert p90 * np.sqrt(4 / n) <= 0.01 < p90 * np.sqrt(4 / (n - 1))
    import OpenImageIO as oiio
    img = oiio.ImageBuf(str(out / "noise.exr"))
    assert (img.spec().width, img.spec().height) == (8, 6)
    assert (out / "frame.png").stat().st_size > 0

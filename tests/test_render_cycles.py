"""The sphere measurement with Blender's Cycles (envfit.renderers.cycles._render), on tiny
scenes: 16×16-pixel views, small maps, low spp. Only where ``bpy`` is installed (the
``cycles`` extra, not in CI's test extra); slow (each render with world sampling builds
Cycles' 4096×2048 importance map, ≈ 1 s).

Independent values: the orthographic geometry against Cycles' own shading normals; the map's
pixel direction in envfit's convention against the direction Cycles lights the sphere from.
"""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("bpy")

from envfit.base import ParameterError  # noqa: E402
from envfit.maps import EnvMap, convention, pixel_directions  # noqa: E402
from envfit.renderers import (VIEWS, CyclesOptions, CyclesSphere,  # noqa: E402
                                      sphere_geometry, view_normals)

pytestmark = pytest.mark.slow
R = 16


def test_normals_match_cycles():
    """The orthographic geometry's normals are the ones Cycles shades with."""
    g = sphere_geometry(R)
    with CyclesSphere(EnvMap(np.ones((4, 8, 3))), CyclesOptions(resolution=R)) as r:
        n = r.normals(16)
    for k, view in enumerate(VIEWS):
        d = np.abs(n[k][g.keep] - view_normals(view, g)[g.keep])
        assert d.mean() < 0.005 and d.max() < 0.02, view.name


def test_constant_map_and_direct_lighting_only():
    """Constant map L: BSDF sampling renders L exactly; MIS is unbiased around L; one bounce
    is all there is (a convex sphere: more bounces give the same image, same seed)."""
    L = 0.5
    g = sphere_geometry(R)
    env = EnvMap(np.full((8, 16, 3), L))
    with CyclesSphere(env, CyclesOptions(resolution=R)) as r:
        brdf, secs = r.render("brdf", "tabulated_sobol", 4, seed=1)
        mis1, _ = r.render("mis", "blue_noise", 16, seed=2)
        with pytest.raises(ParameterError, match="debug builds"):
            r.render("map", "tabulated_sobol", 4, seed=1)
    with CyclesSphere(env, CyclesOptions(resolution=R, max_bounces=3)) as r:
        mis3, _ = r.render("mis", "blue_noise", 16, seed=2)
    assert len(secs) == len(VIEWS) and all(s > 0 for s in secs)
    assert np.abs(brdf[:, g.keep] - L).max() < 1e-5
    assert np.array_equal(mis1, mis3)
    assert abs(mis1[:, g.keep].mean() - L) < 0.01 * L


def test_world_mapping_is_blenders_convention():
    """A map with one bright pixel lights the sphere from that pixel's direction in Blender's
    convention (the texture wired as a user wires it): the direction fitted to the lit
    pixels' radiance ∝ n·s is within a degree of it, and it is envfit's (up="y") direction
    of that pixel cyclically permuted, (w_z, w_x, w_y)."""
    h = 32
    data = np.zeros((h, 2 * h, 3), np.float32)
    data[9, 21] = 5000.0
    s = convention("blender").pixel_directions(h)[9, 21]
    w = pixel_directions(h, 2 * h, up="y")[9, 21]
    np.testing.assert_allclose(s, [w[2], w[0], w[1]], atol=1e-12)
    res = 32
    with CyclesSphere(EnvMap(data), CyclesOptions(resolution=res)) as r:
        img, _ = r.render("mis", "tabulated_sobol", 64, seed=3)
    g = sphere_geometry(res)
    n = np.concatenate([view_normals(v, g)[g.keep] for v in VIEWS])
    y = np.concatenate([img[k][g.keep].mean(axis=-1) for k in range(len(VIEWS))])
    lit = y > 0.3 * y.max()
    fit = np.linalg.lstsq(n[lit], y[lit], rcond=None)[0]
    angle = np.degrees(np.arccos(np.clip(fit @ s / np.linalg.norm(fit), -1, 1)))
    assert angle < 1.0


def test_cycles_measurement_fields(tmp_path):
    g = sphere_geometry(R)
    f = np.random.default_rng(0).random((8, 16, 3)) + 0.5
    opts = CyclesOptions(resolution=R, reference_spp=256, cache_dir=str(tmp_path))
    with CyclesSphere(EnvMap(f), opts) as r:
        ref = r.reference()
        m = r.measure("brdf", "tabulated_sobol", 16, seed=4, reference=ref)
        again = r.reference()
    assert again.cached and np.array_equal(again.a, ref.a)
    assert m.renderer == "cycles" and m.sampler == "tabulated_sobol" and m.spp == 16
    assert m.pixels == len(VIEWS) * g.kept and 0 < m.low <= m.rmse <= m.high
    assert len(m.view_seconds) == len(VIEWS)


@pytest.mark.parametrize("kind", ["ggx", "beckmann", "multiggx"])
def test_glossy_sphere_reflects_the_conductors_albedo(kind):
    """The Glossy BSDF sphere (glossy_bsdf, α = 0.3) under a constant map L: each pixel is
    L × the directional albedo of envfit's Cycles conductor at its view angle (the mean
    weight f·cos/pdf of the record's Conductor.sample, 200,000 points), to 1.5 % over
    the disk and per view-angle band: the roughness √α, the height-correlated G2 and Fresnel
    1, against Cycles' own BSDF. Multiscatter GGX (the node's default) conserves energy: its
    pixels are L (envfit's energy scale times the albedo, to 1.5 %), grazing views too."""
    from envfit.renderers import glossy_bsdf
    L, alpha = 0.5, 0.3
    g = sphere_geometry(R, "disk")
    env = EnvMap(np.full((8, 16, 3), L))
    with CyclesSphere(env, CyclesOptions(resolution=R, bsdf=glossy_bsdf(kind, alpha))) as r:
        img, _ = r.render("brdf", "tabulated_sobol", 256, seed=3)
    from envfit.renderers import get_renderer
    c = get_renderer("cycles").bsdf(kind, alpha)
    u = np.random.default_rng(0).random((200_000, 2))
    z = g.z[g.keep]
    want = []
    for cz in z:
        wi = np.broadcast_to([np.sqrt(max(0.0, 1 - cz * cz)), 0.0, cz], (len(u), 3))
        want.append(L * c.sample(wi, u).weight.mean())
    want = np.array(want)
    got = img[:, g.keep].mean(axis=(0, 2))               # the six views' mean per pixel
    assert abs(got.mean() / want.mean() - 1) < 0.015
    theta = np.degrees(np.arccos(z))
    for lo, hi in ((0, 30), (30, 60), (60, 80)):
        m = (theta >= lo) & (theta < hi)
        assert abs(got[m].mean() / want[m].mean() - 1) < 0.015, (lo, hi)
    if kind == "multiggx":
        assert np.all(np.abs(want / L - 1) < 0.01) and abs(got[theta >= 60].mean() / L - 1) < 0.015
    else:
        assert want[theta >= 60].mean() < 0.95 * want[theta < 30].mean()   # G2 darkens grazing


@pytest.mark.parametrize("kind", ["ggx", "multiggx"])
def test_principled_metallic_white_renders_the_glossy_image(kind):
    """The Principled BSDF with Metallic 1 and white Base Color and Specular Tint (what a
    user sets for a rough metal) renders the Glossy BSDF node's image, pixel for pixel, on a
    map with a sun, with BSDF sampling and MIS: its F82-tint Fresnel is 1 and its energy scale
    the node's (``glossy_bsdf``), so the Glossy node's rendered validation holds for it."""
    from envfit.renderers import glossy_bsdf
    rng = np.random.default_rng(4)
    data = 0.2 + 0.3 * rng.random((16, 32, 3))
    data[4, 9] = 300.0
    env = EnvMap(data.astype(np.float32))
    imgs = {}
    for node in ("glossy", "principled"):
        opts = CyclesOptions(resolution=R, bsdf=glossy_bsdf(kind, 0.2, node=node))
        with CyclesSphere(env, opts) as r:
            imgs[node] = [r.render(s, "tabulated_sobol", 16, seed=7)[0] for s in ("brdf", "mis")]
    for a, b in zip(imgs["glossy"], imgs["principled"]):
        assert a.std() > 0.01
        np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("base, tint", [(0.8, 1.0), (0.5, 0.6)])
def test_principled_metal_reflects_the_f82_conductors_albedo(base, tint):
    """The Principled BSDF with Metallic 1, Base Color ``base`` (Blender's default 0.8) and
    Specular Tint ``tint``, Multiscatter GGX (roughness 0.5) under a constant map L: each pixel
    is L × the directional albedo of envfit's F82 conductor (the record's
    ``bsdf("principled", …)``: the F82-tint Fresnel and the energy scale 1 + F_ms(1 − E)/E),
    to 1.5 % over the disk and per view-angle band."""
    from envfit.renderers import get_renderer, glossy_bsdf
    L, alpha = 0.5, 0.25
    g = sphere_geometry(R, "disk")
    env = EnvMap(np.full((8, 16, 3), L))
    bsdf = glossy_bsdf("multiggx", alpha, node="principled", base_color=base,
                       specular_tint=tint)
    with CyclesSphere(env, CyclesOptions(resolution=R, bsdf=bsdf)) as r:
        img, _ = r.render("brdf", "tabulated_sobol", 256, seed=3)
    c = get_renderer("cycles").bsdf("principled", alpha, metallic=1.0, base_color=base,
                                    specular_tint=tint)
    u = np.random.default_rng(0).random((200_000, 2))
    z = g.z[g.keep]
    want = np.array([L * c.sample(np.broadcast_to([np.sqrt(max(0.0, 1 - cz * cz)), 0.0, cz],
                                                  (len(u), 3)), u).weight.mean() for cz in z])
    got = img[:, g.keep].mean(axis=(0, 2))
    assert abs(got.mean() / want.mean() - 1) < 0.015
    theta = np.degrees(np.arccos(z))
    for lo, hi in ((0, 30), (30, 60), (60, 80)):
        m = (theta >= lo) & (theta < hi)
        assert abs(got[m].mean() / want[m].mean() - 1) < 0.015, (lo, hi)
    assert want.mean() < 0.98 * L                   # the Fresnel's loss is not compensated


@pytest.mark.parametrize("params", [{}, {"base_color": 0.4, "ior": 1.8, "specular_tint": 0.7}])
def test_principled_dielectric_reflects_the_layered_bsdfs_albedo(params):
    """The Principled BSDF at metallic 0 (the node's default: a dielectric GGX specular
    closure over a Lambert base weighted by 1 − the specular closure's albedo estimate),
    roughness 0.5, under a constant map L with BSDF sampling: each pixel is L × the
    directional albedo of envfit's ``AlbedoLayered`` (the record's ``bsdf("principled", …)``:
    its real-Fresnel blend, energy scale and layering weight from the tabulated estimate), to
    1.5 % over the disk and per view-angle band."""
    from envfit.renderers import get_renderer, glossy_bsdf
    from scipy.stats import qmc
    L, alpha = 0.5, 0.25
    p = {"base_color": 0.8, "specular_tint": 1.0, "ior": 1.5, **params}
    g = sphere_geometry(R, "disk")
    env = EnvMap(np.full((8, 16, 3), L))
    bsdf = glossy_bsdf("multiggx", alpha, node="principled", base_color=p["base_color"],
                       specular_tint=p["specular_tint"], metallic=0.0, ior=p["ior"])
    with CyclesSphere(env, CyclesOptions(resolution=R, bsdf=bsdf)) as r:
        img, _ = r.render("brdf", "tabulated_sobol", 256, seed=3)
    c = get_renderer("cycles").bsdf("principled", alpha, **p)
    u = qmc.Sobol(2, seed=1).random_base2(15)
    nodes = np.linspace(0.0, 1.0, 65)[1:]
    albedo = [c.sample_square(np.broadcast_to([np.sqrt(1 - z * z), 0.0, z], (len(u), 3)),
                              u).weight.mean() for z in nodes]
    z = g.z[g.keep]
    want = L * np.interp(z, nodes, albedo)
    got = img[:, g.keep].mean(axis=(0, 2))
    assert abs(got.mean() / want.mean() - 1) < 0.015
    theta = np.degrees(np.arccos(z))
    for lo, hi in ((0, 30), (30, 60), (60, 80)):
        m = (theta >= lo) & (theta < hi)
        assert abs(got[m].mean() / want[m].mean() - 1) < 0.015, (lo, hi)

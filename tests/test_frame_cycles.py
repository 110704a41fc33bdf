"""Cycles' frame reader (:mod:`envfit.renderers.cycles._frame_scene`) against Cycles' own
renders of small ``.blend`` scenes built here with bpy (a smooth UV sphere, a cube and a ground
plane under a 64 × 32 map, 32 × 24 px): the camera's first hits against the render passes
(Position, Normal, Object Index, Diffuse and Glossy Color at 1 spp: Cycles puts sample 0 at
the pixel's centre) and Blender's own ``Scene.ray_cast``; the map seen by escaping rays
against the Combined pass (the world alone, plain and through a Mapping node); the glossy
BSDFs' reflectance against renders under a white map; the camera's view plane against
Blender's ``view_frame``; the settings read; the refusals; ``predict_frame`` on a .blend."""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.base import ParameterError

bpy = pytest.importorskip("bpy")
pytest.importorskip("embreex")
pytest.importorskip("OpenImageIO")

W, H = 32, 24
#: the diffuse colours (the objects' pass indices, 1 2 3, are their shape index + 1)
DIFFUSE = {"sphere": (0.8, 0.5, 0.3), "cube": (0.9, 0.9, 0.9), "ground": (0.5, 0.5, 0.5)}


def _map(path):
    """A 64 × 32 map: a sky gradient down, a red ramp across, a bright spot."""
    from envfit.maps import save_envmap
    h, w = 32, 64
    y, x = (np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w
    img = (1.5 - y)[:, None, None] * np.array([0.6, 0.8, 1.0]) + np.zeros((h, w, 3))
    img[..., 0] += 0.5 * x[None, :]
    img[6:8, 40:42] = 200.0
    return save_envmap(path, img)


#: the sphere's glossy materials: (node, distribution, roughness, inputs)
GLOSSY = {"glossy": ("ShaderNodeBsdfGlossy", "MULTI_GGX", 0.4, {"Color": (0.9, 0.6, 0.3)}),
          "metal": ("ShaderNodeBsdfPrincipled", "MULTI_GGX", 0.4,
                    {"Metallic": 1.0, "Base Color": (0.9, 0.6, 0.3),
                     "Specular Tint": (1.0, 0.8, 0.6)}),
          "plastic": ("ShaderNodeBsdfPrincipled", "MULTI_GGX", 0.3,
                      {"Base Color": (0.5, 0.5, 0.5), "IOR": 1.6}),
          "ggx": ("ShaderNodeBsdfGlossy", "GGX", 0.3, {"Color": (0.7, 0.7, 0.9)})}


def _material(name, colour, kind="diffuse"):
    """A material: a Diffuse BSDF of ``colour``; a glossy one of :data:`GLOSSY`;
    ``textured``: the Diffuse BSDF's colour from a checker texture; ``emission``."""
    m = bpy.data.materials.new(name)
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if kind in GLOSSY:
        idname, dist, rough, inputs = GLOSSY[kind]
        node = nt.nodes.new(idname)
        node.distribution = dist
        node.inputs["Roughness"].default_value = rough
        for k, v in inputs.items():
            node.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) else v
    else:
        node = nt.nodes.new("ShaderNodeEmission" if kind == "emission"
                            else "ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = (*colour, 1.0)
    if kind == "textured":
        tex = nt.nodes.new("ShaderNodeTexChecker")
        nt.links.new(tex.outputs["Color"], node.inputs["Color"])
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return m


def _object(scene, name, bm, mat, smooth, index):
    me = bpy.data.meshes.new(name)
    for f in bm.faces:
        f.smooth = smooth
    bm.to_mesh(me)
    bm.free()
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    me.materials.append(mat)
    ob.pass_index = index
    return ob


def _world(scene, map_path, strength, rot_z):
    world = bpy.data.worlds.new("env")
    scene.world = world
    wt = world.node_tree
    wt.nodes.clear()
    env = wt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(map_path))
    bg, wo = wt.nodes.new("ShaderNodeBackground"), wt.nodes.new("ShaderNodeOutputWorld")
    bg.inputs["Strength"].default_value = strength
    wt.links.new(env.outputs["Color"], bg.inputs["Color"])
    wt.links.new(bg.outputs[0], wo.inputs["Surface"])
    if rot_z is not None:
        tc, mp = wt.nodes.new("ShaderNodeTexCoord"), wt.nodes.new("ShaderNodeMapping")
        mp.inputs["Rotation"].default_value = (0.0, 0.0, rot_z)
        wt.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
        wt.links.new(mp.outputs["Vector"], env.inputs["Vector"])


def _camera(scene, ortho, shift, fit):
    from mathutils import Matrix, Vector
    cam = bpy.data.cameras.new("cam")
    if ortho:
        cam.type, cam.ortho_scale = "ORTHO", 3.0
    cam.lens, cam.sensor_fit = 40.0, fit
    cam.shift_x, cam.shift_y = shift
    ob = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(ob)
    scene.camera = ob
    eye, target = Vector((0.6, -4.0, 1.7)), Vector((0.3, 0.0, 0.35))
    rot = (target - eye).to_track_quat("-Z", "Y").to_matrix().to_4x4()
    ob.matrix_world = Matrix.Translation(eye) @ rot


def build(path, map_path, *, sphere="diffuse", ortho=False, rot_z=None, strength=1.5,
          lamp=False, engine="CYCLES", shift=(0.0, 0.0), fit="AUTO", alone=False):
    """A .blend: the sphere (``sphere``: its material kind), a cube and the ground (not
    ``alone``), the camera, the map's world (Background ``strength``, a Mapping node's z
    rotation ``rot_z``)."""
    import bmesh
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=0.5)
    s = _object(sc, "sphere", bm, _material("s", DIFFUSE["sphere"], sphere), True, 1)
    s.location = (0.0, 0.0, 0.5)
    if not alone:
        bm = bmesh.new()
        bmesh.ops.create_cube(bm, size=0.6)
        c = _object(sc, "cube", bm, _material("c", DIFFUSE["cube"]), False, 2)
        c.location, c.rotation_euler = (1.0, -0.3, 0.3), (0.0, 0.0, 0.4)
        bm = bmesh.new()
        bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=4.0)
        _object(sc, "ground", bm, _material("g", DIFFUSE["ground"]), False, 3)
    _camera(sc, ortho, shift, fit)
    _world(sc, map_path, strength, rot_z)
    if lamp:
        light = bpy.data.objects.new("lamp", bpy.data.lights.new("lamp", "POINT"))
        sc.collection.objects.link(light)
    r, c = sc.render, sc.cycles
    r.engine = engine
    r.resolution_x, r.resolution_y, r.resolution_percentage = W, H, 100
    c.samples, c.max_bounces = 16, 0
    c.use_adaptive_sampling = c.use_denoising = False
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def render(path, out, *, world_only=False, spp=1):
    """Cycles' own passes of ``path`` at ``spp``, filter 0.01 px (each pixel at its centre);
    ``world_only``: the meshes hidden (the Combined pass is the map seen by the camera);
    with more than 1 spp the world is sampled (Manual, 64 px: the mean is unchanged)."""
    from envfit.renderers.cycles._render import _quiet_blender, _read_layers
    bpy.ops.wm.open_mainfile(filepath=str(path))
    sc = bpy.context.scene
    c, vl, fmt = sc.cycles, sc.view_layers[0], sc.render.image_settings
    # sample 0 is at the pixel's centre (init_from_camera.h), the others within 0.01 px of it
    # (Blender gives the box filter width 1 whatever its setting: sync.cpp, sync_film)
    c.samples, c.pixel_filter_type, c.filter_width = spp, "BLACKMAN_HARRIS", 0.01
    c.device = "CPU"
    sc.world.cycles.sampling_method = "NONE" if spp == 1 else "MANUAL"   # 1: no light sampled
    sc.world.cycles.sample_map_resolution = 64
    sc.render.threads_mode, sc.render.threads = "FIXED", 2
    for k in ("normal", "position", "object_index", "diffuse_color", "glossy_color"):
        setattr(vl, f"use_pass_{k}", True)
    for ob in sc.objects:
        ob.hide_render = world_only and ob.type == "MESH"
    fmt.media_type = "MULTI_LAYER_IMAGE"
    fmt.file_format, fmt.color_depth = "OPEN_EXR_MULTILAYER", "32"
    sc.render.filepath = str(out)
    with _quiet_blender():
        bpy.ops.render.render(write_still=True)
    return _read_layers(out)


def _centres():
    y, x = np.mgrid[0:H, 0:W]
    return np.column_stack([x.ravel() + 0.5, y.ravel() + 0.5])


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("cycles_frame")
    _map(d / "map.exr")
    return d


@pytest.mark.parametrize("ortho", [False, True])
def test_first_hits_are_cycles_own(work, ortho):
    """At every pixel centre: hit or miss and the object as Cycles' Object Index pass, the
    position (Position pass) to 1e-3 of the scene's size, the shading normal (Normal pass:
    the smooth sphere's interpolated normals, all facing the camera) to 5e-3 (the filter moves
    each sample up to 0.005 px), the albedo (Diffuse Color pass) exactly; at most 1 % of the
    pixels differ (a silhouette grazing a pixel's centre; none here)."""
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / f"hits{int(ortho)}.blend", work / "map.exr", ortho=ortho)
    passes = render(path, work / f"hits{int(ortho)}.exr")
    fs = read_scene(path)
    assert fs.size == (W, H) and [o.name for o in fs.occluders] == ["sphere", "cube", "ground"]
    assert [o.convex for o in fs.occluders] == [False, True, True]   # smooth: not convex
    h = fs.hits_at(_centres())
    index = passes["Object Index"][..., 0].ravel().round().astype(int)
    mine = np.where(h["kind"] == 1, h["shape"] + 1, 0)
    assert np.mean(mine == index) >= 0.99 and len(np.unique(index)) == 4
    ok = (mine == index) & (index > 0)
    assert np.abs(h["position"][ok] - passes["Position"].reshape(-1, 3)[ok]).max() < 1e-3 * 8
    assert np.abs(h["normal"][ok] - passes["Normal"].reshape(-1, 3)[ok]).max() < 5e-3
    assert np.allclose(h["albedo"][ok], passes["Diffuse Color"].reshape(-1, 3)[ok], atol=1e-6)
    _, d = fs.rays_at(_centres())                   # the geometric normals face the camera
    assert np.all(h["facing"][ok]) and np.all(np.einsum("ij,ij->i", h["geo_normal"][ok],
                                                         d[ok]) < 0)
    frames = h["tangent"][ok]                                        # orthonormal, rows s t n
    assert np.allclose(np.einsum("pij,pkj->pik", frames, frames), np.eye(3), atol=1e-9)
    # Blender's own ray cast (``Scene.ray_cast``) meets the same points
    from mathutils import Vector
    o, d = fs.rays_at(_centres())
    dg = bpy.context.evaluated_depsgraph_get()
    res = [bpy.context.scene.ray_cast(dg, Vector(a), Vector(b / np.linalg.norm(b)))
           for a, b in zip(o, d)]
    assert np.array_equal([r[0] for r in res], h["kind"] == 1)
    pos = np.array([tuple(r[1]) for r in res])[h["kind"] == 1]
    assert np.abs(pos - h["position"][h["kind"] == 1]).max() < 1e-5


@pytest.mark.parametrize("rot_z", [None, math.pi / 2])
def test_the_background_is_the_worlds_own(work, rot_z):
    """Where the camera sees the world (the meshes hidden): the map's radiance by the record's
    technique through ``envmap_to_world`` equals the Combined pass within float rounding —
    the map's orientation and rows, the Mapping node's rotation, the Background's Strength."""
    from envfit.renderers.cycles._frame_scene import read_scene
    tag = "plain" if rot_z is None else "rotated"
    path = build(work / f"world_{tag}.blend", work / "map.exr", rot_z=rot_z)
    comb = render(path, work / f"world_{tag}.exr", world_only=True)["Combined"][..., :3]
    fs = read_scene(path)
    assert fs.envmap_scale == 1.5 and fs.envmap_data.shape == (32, 64, 3)
    assert np.allclose(fs.envmap_to_world @ fs.envmap_to_world.T, np.eye(3), atol=1e-12)
    h = fs.hits_at(_centres())
    esc = h["kind"] == 0
    assert esc.sum() > 200
    c = comb.reshape(-1, 3)[esc]
    assert np.allclose(h["background"][esc], c, rtol=1e-3, atol=1e-5)
    assert np.ptp(c[:, 0] / c[:, 2]) > 0.05                 # the red ramp is seen: a real test


def test_a_glossy_albedo_is_cycles_glossy_color(work):
    """A coloured Multiscatter GGX Glossy BSDF: the hit's albedo (the colour times the
    multiscatter darkening at the view cosine of the closure's normal, raised for a valid
    reflection) against Cycles' Glossy Color pass (the closure's weight)."""
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / "glossy.blend", work / "map.exr", sphere="glossy")
    passes = render(path, work / "glossy.exr")
    fs = read_scene(path)
    assert [b.kind for b in fs.bsdfs] == ["glossy", "diffuse", "diffuse"]
    h = fs.hits_at(_centres())
    on = (h["shape"] == 0) & (passes["Object Index"][..., 0].ravel().round() == 1)
    assert on.sum() > 20
    col = passes["Glossy Color"].reshape(-1, 3)[on]
    assert np.allclose(h["albedo"][on], col, rtol=2e-3)
    assert np.ptp(col[:, 2] / np.array(DIFFUSE["sphere"])[2]) > 0.01   # darkening varies
    assert np.all(h["facing"][on])


def _reflectance(fs, h, sel, n=64):
    """∫ f cos dω_o at the hits ``sel`` by the FrameBsdf: its lobe's sample weight times its
    Fresnel at ω_i·m, over an n × n midpoint grid of the square, times the hit's albedo."""
    b = fs.bsdfs[0]
    t = (np.arange(n) + 0.5) / n
    u = np.column_stack([np.repeat(t, n), np.tile(t, n)])
    wi = np.repeat(h["wi"][sel], n * n, axis=0)
    s = b.lobe.sample(wi, np.tile(u, (len(sel), 1)))
    w = s.weight[:, None] * (1.0 if b.fresnel is None else b.fresnel(np.sum(wi * s.m, axis=1)))
    w = np.broadcast_to(w, (len(wi), 3))
    return w.reshape(len(sel), n * n, 3).mean(axis=1) * h["albedo"][sel]


@pytest.mark.parametrize("kind", ["glossy", "metal", "plastic", "ggx"])
def test_a_glossy_bsdf_reflects_as_cycles_renders_it(work, kind):
    """The sphere alone under a white map (direct light only): each pixel is ∫ f cos dω_o at
    its centre's hit; the FrameBsdf's (lobe × Fresnel × the hit's albedo, by its own sampler)
    against Cycles' render at 256 spp: a Multiscatter GGX Glossy BSDF in colour, the
    Principled BSDF's coloured F82 metal and its grey dielectric (two closures), a GGX Glossy
    BSDF. Pixels within 5 % (the render's noise), their mean within 1.5 % (measured: 0.1–1 %
    darker in Cycles, whose shadow rays meet the tessellated sphere below its smooth
    normals); the rim (cos θ_i < 0.3), where that grows, left out."""
    from envfit.maps import save_envmap
    from envfit.renderers.cycles._frame_scene import read_scene
    save_envmap(work / "white.exr", np.ones((32, 64, 3)))
    path = build(work / f"refl_{kind}.blend", work / "white.exr", sphere=kind, strength=1.0,
                 alone=True)
    img = render(path, work / f"refl_{kind}.exr", spp=256)["Combined"][..., :3].reshape(-1, 3)
    fs = read_scene(path)
    assert fs.bsdfs[0].kind == "glossy" and fs.bsdfs[0].lobes == (2 if kind == "plastic" else 1)
    h = fs.hits_at(_centres())
    d = fs.rays_at(_centres())[1]
    cos = -np.einsum("ij,ij->i", h["normal"], d) / np.linalg.norm(d, axis=1)
    sel = np.flatnonzero((h["shape"] == 0) & (cos > 0.3))
    assert len(sel) > 30
    ours = _reflectance(fs, h, sel)
    assert np.allclose(ours, img[sel], rtol=0.05, atol=0.01)
    assert abs(ours.mean() / img[sel].mean() - 1) < 0.015


@pytest.mark.parametrize("shift,fit,ortho", [((0.1, -0.05), "AUTO", False),
                                             ((0.0, 0.2), "VERTICAL", False),
                                             ((0.15, 0.0), "AUTO", True)])
def test_the_view_plane_is_blenders(work, shift, fit, ortho):
    """The camera rays at the film's corners against Blender's own ``Camera.view_frame``
    (shift, sensor fit, orthographic scale)."""
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / "view.blend", work / "map.exr", shift=shift, fit=fit, ortho=ortho)
    fs = read_scene(path)
    sc = bpy.context.scene
    cam = sc.camera
    m = np.array(cam.matrix_world)
    corners = np.array([tuple(v) for v in cam.data.view_frame(scene=sc)])   # TR BR BL TL
    o, d = fs.rays_at(np.array([[W, 0.0], [W, H], [0.0, H], [0.0, 0.0]]))
    if ortho:
        local = (o - m[:3, 3]) @ m[:3, :3]                   # camera space (unit axes)
        assert np.allclose(local[:, :2], corners[:, :2], atol=1e-6)
    else:
        local = d @ m[:3, :3]
        assert np.allclose(local[:, :2] / -local[:, 2:], corners[:, :2] / -corners[:, 2:],
                           atol=1e-6)


@pytest.mark.parametrize("change,words", [
    ({"lamp": True}, "light (lamp)"),
    ({"sphere": "textured"}, "textures are not read"),
    ({"sphere": "emission"}, "Emission"),
    ({"engine": "BLENDER_EEVEE"}, "BLENDER_EEVEE"),
])
def test_what_is_not_modelled_is_refused_in_one_line(work, change, words):
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / "refused.blend", work / "map.exr", **change)
    with pytest.raises(ParameterError) as e:
        read_scene(path)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_file_blender_cannot_read_is_refused_in_one_line(work):
    from envfit.renderers.cycles._frame_scene import read_scene
    for path, words in ((work / "missing.blend", "no such scene file"),
                        (work / "map.exr", "a Blender .blend file")):
        with pytest.raises(ParameterError) as e:
            read_scene(path)
        assert words in str(e.value) and "\n" not in str(e.value)
    bad = work / "bad.blend"
    bad.write_bytes(b"not a blend file")
    with pytest.raises(ParameterError, match="Blender cannot open it"):
        read_scene(bad)


def test_the_scene_settings_are_read(work):
    """Sampler, spp, filter (importance-sampled: a film warp), integrator depth, draws."""
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / "settings.blend", work / "map.exr")
    fs = read_scene(path)
    assert (fs.sampler, fs.spp, fs.integrator, fs.max_depth) == ("tabulated_sobol", 16,
                                                                  "path", 2)
    assert (fs.emitter_samples, fs.bsdf_samples, fs.draws) == (1, 1, (1, 2))
    assert fs.filter_name == "blackman_harris" and fs.filter_radius == 1.5
    assert fs.film_warp is not None and fs.notes == ()
    w = fs.filter_weights(np.array([0.0, 0.75, 1.5, 2.0]))
    assert w[0] == pytest.approx(1.0, abs=1e-6) and 0 < w[1] < 1 and w[3] == 0.0
    bpy.ops.wm.open_mainfile(filepath=str(path))
    c = bpy.context.scene.cycles
    c.max_bounces, c.use_adaptive_sampling, c.sampling_pattern = 4, True, "BLUE_NOISE"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    fs = read_scene(path)
    assert fs.sampler == "blue_noise" and fs.max_depth == 6
    assert any(n.startswith("adaptive sampling is on") for n in fs.notes)
    assert any("not the longer paths" in n for n in fs.notes)


def test_predict_frame_runs_the_net_model_on_a_blend(work, monkeypatch):
    """``predict_frame`` on a .blend: the reader is registered for the suffix and the model
    runs its net simulation over Cycles' own points (the Background's Strength 2 folded into
    the map: the converged image twice the Strength-1 one's)."""
    import envfit.frame._api as api
    from envfit.frame import READERS, predict_frame
    assert READERS[".blend"] == "cycles"
    ran = []

    def spy(*a, _f=api.pixel_mse_nets, **k):
        ran.append(1)
        return _f(*a, **k)
    monkeypatch.setattr(api, "pixel_mse_nets", spy)
    out = {}
    for strength in (1.0, 2.0):
        path = build(work / f"predict{strength:g}.blend", work / "map.exr", strength=strength)
        out[strength] = predict_frame(path, spp=(4,), level=3, max_pixels=48)
    p = out[2.0]
    assert ran and p.renderer == "cycles" and p.rows[0].rmse > 0
    assert p.mean_value == pytest.approx(2 * out[1.0].mean_value, rel=1e-9)
    assert p.rows[0].rmse == pytest.approx(2 * out[1.0].rows[0].rmse, rel=1e-9)


def test_two_lobes_pick_their_closure_by_the_requests_z(work):
    """The Principled BSDF at metallic 0 picks its closure by the BSDF request's third
    number: its lobe reads each closure on its own and that chance (``sample_lobe``,
    ``lobe_probability``), each with the mixture's weight f·cos/pdf; the frame's net model
    runs on it."""
    from envfit.frame import predict_frame
    from envfit.renderers.cycles._frame_scene import read_scene
    path = build(work / "plastic.blend", work / "map.exr", sphere="plastic", strength=1.0)
    lobe = read_scene(path).bsdfs[0].lobe
    wi = np.tile([0.6, 0.0, 0.8], (64, 1))
    u = np.random.default_rng(0).random((64, 2))
    p = lobe.lobe_probability(wi[:, 2])
    assert 0 < p[0] < 1
    a, b = lobe.sample_lobe(wi, u, 0), lobe.sample_lobe(wi, u, 1)
    assert np.all(a.specular) and not np.any(b.specular)
    assert np.allclose(a.weight, lobe.eval(wi, a.wo) / lobe.pdf(wi, a.wo))
    r = predict_frame(path, spp=(4, 16), level=3, max_pixels=48)
    assert r.rows[0].rmse > r.rows[1].rmse > 0 and r.mean_value > 0

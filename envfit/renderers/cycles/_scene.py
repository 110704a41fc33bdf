"""The bpy script of the scene envfit predicts for Cycles (:func:`cycles_snippet`): the
measurements' exact sphere, world, orthographic views and render settings
(:mod:`envfit.renderers.cycles._render`), as text a user pastes into Blender."""
from __future__ import annotations

from envfit.renderers._base import (SPHERE_VIEWS, SamplerSpec, StrategySetting,
                                           scene_comment, snippet_pixels)

__all__ = ["cycles_snippet"]

#: the bpy lines of the sphere's material: the white Diffuse BSDF (colour 1, roughness 0:
#: Lambertian) unless a microfacet BSDF replaces its node (:func:`_material`)
_MATERIAL = """mat = bpy.data.materials.new("sphere")
if mat.node_tree is None:
    mat.use_nodes = True
nt = mat.node_tree
nt.nodes.clear()
{node}nt.links.new(bsdf.outputs["BSDF"], nt.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
"""
_DIFFUSE = """bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
bsdf.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
bsdf.inputs["Roughness"].default_value = 0.0
"""
#: the bpy lines that build the measurements' exact sphere (:mod:`envfit.renderers.
#: _cycles`: one vertex → Mesh to Points of radius 1, which Cycles intersects as an analytic
#: sphere) with the material ``mat``
_SPHERE = """mesh = bpy.data.meshes.new("vertex")
mesh.from_pydata([(0.0, 0.0, 0.0)], [], [])
sphere = bpy.data.objects.new("sphere", mesh)
scene.collection.objects.link(sphere)
gn = bpy.data.node_groups.new("sphere points", "GeometryNodeTree")
gn.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
gn.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
gi, go = gn.nodes.new("NodeGroupInput"), gn.nodes.new("NodeGroupOutput")
m2p = gn.nodes.new("GeometryNodeMeshToPoints")
m2p.inputs["Radius"].default_value = 1.0
sm = gn.nodes.new("GeometryNodeSetMaterial")
sm.inputs["Material"].default_value = mat
gn.links.new(gi.outputs[0], m2p.inputs["Mesh"])
gn.links.new(m2p.outputs["Points"], sm.inputs["Geometry"])
gn.links.new(sm.outputs["Geometry"], go.inputs[0])
sphere.modifiers.new("points", "NODES").node_group = gn
"""

#: the orthographic camera of the measurements: ``ortho_scale`` 2 (the image covers
#: [-1, 1]²), at 3v looking along −v with image up u (world matrix columns u × v, u, v, 3v)
_CAMERA = """cam = bpy.data.objects.new("camera", bpy.data.cameras.new("ortho"))
cam.data.type = "ORTHO"
cam.data.ortho_scale = 2.0
cam.data.clip_start, cam.data.clip_end = 0.01, 100.0
scene.collection.objects.link(cam)
scene.camera = cam


def view(k):
    \"\"\"Point the camera along VIEWS[k] (camera at 3 v, image up u).\"\"\"
    v, u = VIEWS[k]
    r = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    cam.matrix_world = Matrix([[r[i], u[i], v[i], 3 * v[i]] for i in range(3)] + [[0, 0, 0, 1]])


view(0)
"""


def _material(microfacet) -> tuple[str, str]:
    """(the material's bpy lines, the BSDF in words) of ``microfacet`` = (name, α, the
    parameters set) or None (white diffuse): the node the measurements render
    (:func:`envfit.renderers.cycles._render.glossy_bsdf`) — the Glossy BSDF (colour 1,
    roughness √α: Cycles squares it; GGX, Beckmann or Multiscatter GGX) or the Principled
    BSDF (Multiscatter GGX, roughness √α, its inputs at Blender's defaults but those set)."""
    from envfit.renderers.cycles._bsdf import PRINCIPLED_PARAMS
    if microfacet is None:
        return _MATERIAL.format(node=_DIFFUSE), "white Diffuse BSDF (colour 1, roughness 0)"
    name, alpha = microfacet[0], float(microfacet[1])
    r = alpha ** 0.5
    if name == "principled":
        p = {**PRINCIPLED_PARAMS, **(microfacet[2] if len(microfacet) > 2 else {})}
        c, t = float(p["base_color"]), float(p["specular_tint"])
        node = (f'bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")\n'
                f'bsdf.distribution = "MULTI_GGX"\n'
                f'bsdf.inputs["Roughness"].default_value = {r:.6g}\n'
                f'bsdf.inputs["Base Color"].default_value = ({c:g}, {c:g}, {c:g}, 1.0)\n'
                f'bsdf.inputs["Metallic"].default_value = {float(p["metallic"]):g}\n'
                f'bsdf.inputs["IOR"].default_value = {float(p["ior"]):g}\n'
                f'bsdf.inputs["Specular IOR Level"].default_value = '
                f'{float(p["specular_ior_level"]):g}\n'
                f'bsdf.inputs["Specular Tint"].default_value = ({t:g}, {t:g}, {t:g}, 1.0)\n')
        words = ("Principled BSDF (Multiscatter GGX, roughness " + f"{r:.6g}, " + ", ".join(
            f"{k} {float(p[k]):g}" for k in PRINCIPLED_PARAMS if k != "roughness")
            + "; the node's defaults otherwise)")
        return _MATERIAL.format(node=node), words
    dist = {"ggx": "GGX", "beckmann": "BECKMANN", "multiggx": "MULTI_GGX"}[name]
    node = (f'bsdf = nt.nodes.new("ShaderNodeBsdfGlossy")\n'
            f'bsdf.distribution = "{dist}"\n'
            f'bsdf.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)\n'
            f'bsdf.inputs["Roughness"].default_value = {r:.6g}\n')
    return _MATERIAL.format(node=node), (f"white Glossy BSDF ({dist}, roughness {r:.6g}: "
                                         f"alpha {alpha:g})")


def _settings(n: int, spp: int, pattern: str) -> str:
    """The render settings of the measurements (:func:`envfit.renderers.cycles._render.
    _settings`): an n × n film, Blender's default pixel filter (Blackman–Harris 1.5 px, the
    record's ``pixel_filter``: the footprint the model takes), direct light only, no clamping,
    denoising or adaptive sampling, the light tree on, the pattern at ``spp``."""
    return (f"r, c = scene.render, scene.cycles\n"
            f'r.engine = "CYCLES"\n'
            f"r.resolution_x = r.resolution_y = {n}\n"
            f"r.resolution_percentage = 100\n"
            f"r.film_transparent = False\n"
            f'r.image_settings.file_format = "OPEN_EXR"\n'
            f'r.image_settings.color_depth = "32"\n'
            f'scene.view_settings.view_transform = "Standard"\n'
            f'c.device = "CPU"\n'
            f"c.samples = {spp}\n"
            f'c.sampling_pattern = "{pattern.upper()}"\n'
            f"c.use_adaptive_sampling = False\n"
            f"c.use_denoising = False\n"
            f"# Blender's default pixel filter, the footprint the model takes (--sphere-pixels)\n"
            f'c.pixel_filter_type = "BLACKMAN_HARRIS"\n'
            f"c.filter_width = 1.5\n"
            f"c.max_bounces = c.diffuse_bounces = 1\n"
            f"c.glossy_bounces = c.transmission_bounces = c.volume_bounces = 0\n"
            f"c.transparent_max_bounces = 0\n"
            f"c.sample_clamp_direct = c.sample_clamp_indirect = 0.0\n"
            f"c.use_light_tree = True\n")


def cycles_snippet(s: StrategySetting, spec: SamplerSpec, spp: int, *,
                   filename: str = "envmap.exr", sphere_pixels: int | None = None,
                   microfacet: tuple | None = None) -> str:
    """A bpy script of the scene envfit predicted, as the measurements build it
    (:mod:`envfit.renderers.cycles._render`): Blender's empty factory scene, the exact
    sphere with the white Diffuse BSDF (or ``microfacet``'s node, :func:`_material`), the
    world's Environment Texture (Linear) straight into
    the Background and its sampling for the strategy, an orthographic camera on each of the
    six :data:`SPHERE_VIEWS` (``view(k)``), a film of :func:`snippet_pixels` pixels with
    Blender's default Blackman–Harris filter of 1.5 px, direct light only (max bounces 1, diffuse 1, the rest 0: the one
    bounce off a convex sphere escapes to the world), no clamping, denoising or adaptive
    sampling, the light tree on, the pattern and spp (Sobol-Burley only in Cycles' debug UI:
    ``cycles/properties.py``: ``enum_sampling_pattern``)."""
    method = s.settings["world.cycles.sampling_method"]
    n = snippet_pixels(sphere_pixels)
    material, words = _material(microfacet)
    head = "\n".join(scene_comment(words, sphere_pixels,
                                   view_dependent=microfacet is not None,
                                   pixel_filter="Blackman-Harris 1.5 px pixel filter "
                                                "(Blender's default)"))
    views = ",\n         ".join(f"({v}, {u})" for v, u in SPHERE_VIEWS)
    debug = ("bpy.context.preferences.view.show_developer_ui = True\n"
             "bpy.context.preferences.experimental.use_cycles_debug = True\n"
             if spec.name == "sobol_burley" else "")
    return (f"import bpy\n"
            f"from mathutils import Matrix\n"
            f"{head}\n"
            f"# render view k (0..5, VIEWS: axis, image up): view(k); "
            f"bpy.ops.render.render(write_still=True)\n"
            f"VIEWS = [{views}]\n"
            f"bpy.ops.wm.read_factory_settings(use_empty=True)\n"
            f"{debug}"
            f"scene = bpy.context.scene\n"
            f"{material}{_SPHERE}"
            f'world = bpy.data.worlds.new("envmap")\n'
            f"scene.world = world\n"
            f"if world.node_tree is None:\n"
            f"    world.use_nodes = True\n"
            f"wt = world.node_tree\n"
            f"wt.nodes.clear()\n"
            f'env = wt.nodes.new("ShaderNodeTexEnvironment")\n'
            f"env.image = bpy.data.images.load({filename!r})\n"
            f'env.interpolation = "Linear"\n'
            f'env.projection = "EQUIRECTANGULAR"\n'
            f'bg = wt.nodes.new("ShaderNodeBackground")\n'
            f'bg.inputs["Strength"].default_value = 1.0\n'
            f'wt.links.new(env.outputs["Color"], bg.inputs["Color"])\n'
            f'wt.links.new(bg.outputs[0], wt.nodes.new("ShaderNodeOutputWorld").inputs["Surface"])\n'
            f'world.cycles.sampling_method = "{method}"\n'
            f"{_CAMERA}"
            f"{_settings(n, spp, spec.name)}")

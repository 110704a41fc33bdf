r"""A Blender ``.blend`` file read by Blender itself (PyPI ``bpy`` 5.0.1) into a
:class:`envfit.renderers._frame.FrameScene` for Cycles: the camera's rays and first hits at
any film position, the shapes as triangles for shadow rays, the world's environment map, and
the film, pixel filter, sampler and integrator settings.

What is read, and from where (Blender's Python API, ``bpy`` 5.0.1; Cycles = blender/cycles
@ v5.0.0, paths under ``src/``; Blender's own Cycles sync = blender/blender
``intern/cycles/blender/``):

* the file: ``bpy.ops.wm.open_mainfile`` (no scripts run), ``bpy.context.scene`` and its
  view layer; its evaluated geometry from ``evaluated_depsgraph_get`` after the viewport's
  settings are set to the render's in this session only (``hide_viewport`` := ``hide_render``
  of objects and collections, modifiers' ``show_viewport`` := ``show_render``, Subdivision and
  Multires ``levels`` := ``render_levels``, Simplify's render values), so that the triangles
  are the ones a render syncs (``blender/mesh.cpp``: ``create_mesh``, the mesh's corner
  triangles = ``Mesh.loop_triangles``);
* the film: ``render.resolution_x``/``_y`` × ``resolution_percentage``/100; the pixel filter
  ``scene.cycles.pixel_filter_type`` and ``filter_width`` (the box's width is 1 whatever the
  setting: ``blender/sync.cpp``, ``sync_film``), which Cycles *importance-samples*
  (``kernel/camera/camera.h``: ``camera_sample``; :mod:`._film`): its :class:`FilmWarp` and
  the filter function on the support the table spans (:data:`._film.FILTERS`);
* the sampler: ``scene.cycles.sampling_pattern`` (:data:`SAMPLING_PATTERNS`), the spp
  ``scene.cycles.samples`` (the view layer's ``samples`` where it overrides them);
* the integrator: path tracing. Blender's Max Bounces B becomes the kernel's B + 1
  (``scene/integrator.cpp``: ``Integrator::device_update``), and ``path_state_next``
  (``kernel/integrator/path_state.h``) ends a path at its next surface once the bounce count,
  or the diffuse or glossy one, reaches it; so B = 0 (or 0 diffuse and glossy bounces for the
  closures present) renders exactly one light sample (NEE) and one BSDF sample at the first
  hit, combined by the power heuristic, the BSDF ray counting only where it escapes to the
  world (``kernel/integrator/shade_surface.h``: ``integrate_surface_direct_light``,
  ``integrate_surface_bsdf_bssrdf_bounce``; ``shade_background.h``). :attr:`max_depth` is
  Mitsuba's path length for the same paths, B + 2 (2: direct lighting only); more bounces are
  noted, and their direct part is what is predicted;
* the world: its Cycles output's Background (a uniform Strength) fed by an Environment
  Texture (equirectangular, Linear), looked up at the ray direction, or through a Texture
  Coordinate (Generated, or Object without an object: the ray direction for the world,
  ``kernel/svm/tex_coord.h``; ``kernel/geom/shader_data.h``: ``shader_setup_from_background``)
  and Mapping nodes (``kernel/svm/mapping_util.h``: ``svm_mapping``; ``util/transform.h``:
  ``euler_to_transform``; the lookup normalises the vector: ``kernel/svm/image.h``,
  ``svm_node_tex_environment``). Its pixels are ``Image.pixels``, which Blender stores bottom
  row first (flipped here: row 0 the top, as :class:`~envfit.maps.EnvMap` holds a map); the
  world's sampling ``world.cycles.sampling_method``;
* shapes: every geometry object instance of the depsgraph visible to every ray type, its
  evaluated mesh's loop triangles in world space (``matrix_world``), flat or smooth per face
  (``use_smooth``: ``!sharp_face``) with the mesh's corner normals;
* materials: the object's one material, whose Cycles Material Output's Surface is a Diffuse
  BSDF (roughness 0: Lambert, ``kernel/svm/closure.h``, ``CLOSURE_BSDF_DIFFUSE_ID``), a
  Glossy BSDF (GGX, Beckmann, Multiscatter GGX, isotropic) or a Principled BSDF of metallic 0
  or 1 (no coat, sheen, transmission, subsurface, emission, thin film or anisotropy), every
  input a constant, as :func:`._bsdf.bsdf` builds them (:func:`_surface`);
* camera rays: Blender's camera parameters (``BKE_camera_params_compute_viewplane``, which
  ``Camera.view_frame`` draws) and Cycles' ``camera_sample_perspective`` /
  ``camera_sample_orthographic`` (``kernel/camera/camera.h``: the ray starts on the near-clip
  plane and ends at the far one), the camera's scale cleared as the sync clears it;
* first hits: Embree (the CPU BVH Cycles itself builds on) on the same triangles; the
  position from the barycentrics, the geometric normal (``kernel/geom/triangle.h``:
  ``triangle_normal``, flipped under a negative scale), the smooth normal
  (``triangle_smooth_normal``), both flipped to the camera's side
  (``kernel/geom/shader_data.h``: the backfacing test); a glossy closure's normal raised for
  a valid reflection (``kernel/closure/bsdf_util.h``: ``ensure_valid_specular_reflection``,
  on by default: ``material.cycles.use_bump_map_correction``); the tangent frame
  ``make_orthonormals`` of the closure's normal (:func:`._background.cycles_frame`, as
  ``sample_cos_hemisphere`` and ``bsdf_microfacet_sample`` take it); the albedo: the
  Diffuse or Glossy BSDF's colour (the closure's weight), for Multiscatter GGX times its
  darkening at the view cosine (``kernel/closure/bsdf_microfacet.h``:
  ``microfacet_ggx_preserve_energy``, F_ss the colour: the closure's weight, which Cycles'
  Glossy Color pass shows), 1 for the Principled BSDF (its colours are in its lobe and
  Fresnel); every hit faces the camera for a diffuse closure (Lambert reads no ω_i), for a
  glossy one where ω_i is above its normal (``bsdf_microfacet_eval``);
* an escaping camera ray: the world's texture at its direction by
  :class:`._background.CyclesBackground`'s lookup (times Strength × the film's Exposure).

Anything else is refused in one line (:class:`envfit.base.ParameterError`) before the
geometry is read. bpy holds one Blender session: reading a file replaces it (and changes the
viewport settings above in it, never in the file).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.renderers._frame import HIT_SURFACE, FrameBsdf, FrameScene, Occluder, TwoLobes

__all__ = ["read_scene", "SAMPLING_PATTERNS", "PIXEL_FILTERS", "ADAPTIVE_NOTE"]

#: Blender's ``scene.cycles.sampling_pattern`` → the record's sampler (*Automatic* renders a
#: final frame with blue noise: the record's ``blue_noise`` spec)
SAMPLING_PATTERNS = {"TABULATED_SOBOL": "tabulated_sobol", "BLUE_NOISE": "blue_noise",
                     "AUTOMATIC": "blue_noise", "SOBOL_BURLEY": "sobol_burley"}
#: Blender's ``scene.cycles.pixel_filter_type`` → :data:`._film.FILTERS`' name
PIXEL_FILTERS = {"BOX": "box", "GAUSSIAN": "gaussian", "BLACKMAN_HARRIS": "blackman_harris"}
#: the first words of the note a scene with adaptive sampling gets
ADAPTIVE_NOTE = "adaptive sampling is on"
#: object types Cycles renders as meshes (``to_mesh``); the refused ones, in words
_GEOMETRY = ("MESH", "CURVE", "SURFACE", "META", "FONT")
_REFUSED = {"LIGHT": "a light (lamp)", "POINTCLOUD": "a point cloud", "CURVES": "hair curves",
            "VOLUME": "a volume"}
#: a glossy lobe's tables this many levels finer than the diffuse ones, by α (the Mitsuba
#: reader's table, ``mitsuba3/_frame_scene.py``: ``_GLOSS_LEVELS``)
_GLOSS_LEVELS = ((0.05, 3), (0.15, 2), (1.0, 1))
#: the Glossy and Principled BSDF nodes' distributions → :func:`._bsdf.bsdf`'s names
_DISTRIBUTIONS = {"GGX": "ggx", "BECKMANN": "beckmann", "MULTI_GGX": "multiggx"}
#: Principled BSDF inputs that must be 0 (layers and effects not modelled)
_PRINCIPLED_ZERO = ("Subsurface Weight", "Transmission Weight", "Coat Weight", "Sheen Weight",
                    "Anisotropic", "Thin Film Thickness", "Emission Strength")
#: inputs a BSDF node may leave linked or set: none is read (hidden or ignored by Cycles)
_UNREAD = ("Weight",)


# ----------------------------------------------------------------------------- the file

def _open(bpy, path: Path):
    """The file's scene, opened by Blender (no scripts run), its output discarded."""
    from envfit.renderers.cycles._render import _quiet_blender
    if path.suffix.lower() != ".blend":
        raise ParameterError(f"{path}: Cycles' frame is read from a Blender .blend file")
    try:
        with _quiet_blender():
            bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False, use_scripts=False)
    except RuntimeError as exc:
        text = str(exc).strip().splitlines()
        raise ParameterError(f"{path}: Blender cannot open it: "
                             f"{text[0] if text else type(exc).__name__}") from None
    scene = bpy.context.scene
    if scene.render.engine != "CYCLES":
        raise ParameterError(f"the scene renders with {scene.render.engine}: the frame model "
                             f"predicts Cycles (Render Properties > Render Engine)")
    return scene


def _render_visibility(bpy, scene, view_layer) -> None:
    """The viewport's visibility, modifiers and subdivision set to the render's in this
    session, so that the evaluated depsgraph holds the geometry a render syncs."""
    r = scene.render
    for a, b in (("simplify_subdivision", "simplify_subdivision_render"),
                 ("simplify_child_particles", "simplify_child_particles_render")):
        setattr(r, a, getattr(r, b))
    for coll in bpy.data.collections:
        coll.hide_viewport = coll.hide_render
    stack = [view_layer.layer_collection]
    while stack:
        lc = stack.pop()
        lc.hide_viewport = False
        stack.extend(lc.children)
    for ob in scene.objects:
        ob.hide_viewport = ob.hide_render
        if ob.name in view_layer.objects:
            ob.hide_set(False, view_layer=view_layer)
        for mod in ob.modifiers:
            mod.show_viewport = mod.show_render
            if mod.type in ("SUBSURF", "MULTIRES"):
                mod.levels = mod.render_levels


# ----------------------------------------------------------------------------- film, sampler

def _filter_weight(kind: str, width: float, t) -> np.ndarray:
    """The 1-D weight at offsets ``t`` (pixels from the pixel's centre) of Cycles' filter
    ``kind`` of ``width``: :data:`._film.FILTERS`' function on the half-support
    ``filter_table`` integrates (Blackman–Harris ±w, Gaussian ±1.5 w, box ±w/2), 0 past it."""
    from envfit.renderers.cycles._film import FILTERS
    func, factor = FILTERS[kind]
    w = np.float32(width * factor)
    a = np.abs(np.asarray(t, dtype=np.float64))
    out = np.asarray(func(a.astype(np.float32), w), dtype=np.float64)
    return np.where(a <= float(w) / 2, np.broadcast_to(out, a.shape), 0.0)


def _film(scene) -> dict:
    """The film's size, filter name, radius, weights and warp (module docstring)."""
    from envfit.renderers.cycles._film import FILTERS, film_warp
    r, c = scene.render, scene.cycles
    size = (r.resolution_x * r.resolution_percentage // 100,
            r.resolution_y * r.resolution_percentage // 100)
    kind = PIXEL_FILTERS.get(c.pixel_filter_type)
    if kind is None:
        raise ParameterError(f"the pixel filter {c.pixel_filter_type} is not one of Cycles' "
                             f"{', '.join(PIXEL_FILTERS)}")
    # Blender's sync gives the box width 1 whatever the setting (``intern/cycles/blender/
    # sync.cpp``: ``BlenderSync::sync_film``)
    width = 1.0 if kind == "box" else float(c.filter_width)
    return {"size": size, "filter_name": kind,
            "filter_radius": width * FILTERS[kind][1] / 2.0,
            "filter_weights": functools.partial(_filter_weight, kind, width),
            "film_warp": film_warp(kind, width)}


def _sampler(scene, view_layer, notes: list) -> tuple[str, int]:
    """The record's sampler name and the spp; adaptive sampling and denoising noted."""
    c = scene.cycles
    name = SAMPLING_PATTERNS.get(c.sampling_pattern)
    if name is None:
        raise ParameterError(f"the sampling pattern {c.sampling_pattern} is not modelled: "
                             f"use {', '.join(SAMPLING_PATTERNS)}")
    if c.scrambling_distance != 1.0 or c.auto_scrambling_distance:
        raise ParameterError(f"Scrambling Distance {c.scrambling_distance:g} (or automatic): "
                             f"the sampler model reads Cycles' default, 1")
    if c.sample_offset or c.use_sample_subset:
        raise ParameterError("the render uses a sample offset or subset: the sampler model "
                             "starts at sample 0")
    if getattr(c, "use_guiding", False):
        raise ParameterError("path guiding is on: the frame model predicts Cycles' light and "
                             "BSDF sampling without guiding")
    spp = int(c.samples)
    if c.use_layer_samples != "IGNORE" and view_layer.samples > 0:     # Use, or Bounded
        spp = int(view_layer.samples if c.use_layer_samples == "USE"
                  else min(view_layer.samples, spp))
        notes.append(f"the view layer's samples give {spp} spp (the scene's: {c.samples})")
    if c.use_adaptive_sampling:
        notes.append(f"{ADAPTIVE_NOTE} (noise threshold {c.adaptive_threshold:g}, min samples "
                     f"{c.adaptive_min_samples}): this predicts every pixel at the full spp, a "
                     f"lower bound on the noise of pixels Cycles stops early")
    if c.use_denoising:
        notes.append("the denoiser is on: this predicts the noise before it (the Noisy Image)")
    if c.sample_clamp_direct > 0:
        notes.append(f"Clamp Direct {c.sample_clamp_direct:g} is on: clamping is not modelled")
    return name, spp


def _closure_kinds(surfaces) -> set:
    """The closure types (``diffuse``, ``glossy``) of the surfaces' BSDFs."""
    out = set()
    for s in surfaces:
        out |= {"diffuse", "glossy"} if s.bsdf.lobes == 2 else {s.bsdf.kind}
    return out


def _max_depth(scene, surfaces, notes: list) -> int:
    """Mitsuba's path length of the render's paths: B + 2, B the bounces after the first hit
    its closures get (module docstring); more than 0 noted."""
    c = scene.cycles
    per = {"diffuse": int(c.diffuse_bounces), "glossy": int(c.glossy_bounces)}
    kinds = _closure_kinds(surfaces)
    b = min(int(c.max_bounces), max((per[k] for k in kinds), default=0))
    if b > 0:
        notes.append(f"path tracing with {b} bounce(s) after the first hit (Max Bounces "
                     f"{c.max_bounces}, diffuse {c.diffuse_bounces}, glossy "
                     f"{c.glossy_bounces}): its direct lighting from the map at the first hit "
                     f"is predicted, not the longer paths (Max Bounces 0 renders just that)")
    return b + 2


# ----------------------------------------------------------------------------- world

def _nodes(datablock):
    """The material's or world's node tree where Cycles uses it (``use_nodes``, deprecated in
    Blender 5 but still read from older files), else None."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        used = getattr(datablock, "use_nodes", True)
    return datablock.node_tree if used else None


def _link(socket, where: str):
    """The link into ``socket`` through reroutes (None: unlinked); a muted link or node, or a
    node group, refused."""
    while socket.is_linked:
        link = socket.links[0]
        node = link.from_node
        if link.is_muted or node.mute:
            raise ParameterError(f"{where} has a muted node or link: unmute or remove it")
        if node.type == "REROUTE":
            socket = node.inputs[0]
            continue
        if node.type == "GROUP":
            raise ParameterError(f"{where} uses a node group: the frame model reads the nodes "
                                 f"themselves")
        return link
    return None


def _euler(rotation) -> np.ndarray:
    """Cycles' ``euler_to_transform`` (``util/transform.h``) as a 3 × 3 matrix: Rz Ry Rx."""
    x, y, z = (float(a) for a in rotation)
    cx, cy, cz, sx, sy, sz = (math.cos(x), math.cos(y), math.cos(z), math.sin(x),
                              math.sin(y), math.sin(z))
    return np.array([[cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz],
                     [cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz],
                     [-sy, cy * sx, cy * cx]])


def _lookup_matrix(socket, where: str) -> np.ndarray:
    """A with the texture looked up at A d for the world ray direction d (``svm_mapping``
    of each Mapping node, the Texture Coordinate's ray direction); anything else refused."""
    link = _link(socket, where)
    if link is None:
        return np.eye(3)
    node, out = link.from_node, link.from_socket.identifier
    if node.type == "TEX_COORD":
        if out == "Generated" or (out == "Object" and node.object is None):
            return np.eye(3)
        raise ParameterError(f"{where}: the Texture Coordinate's {out} output is not the ray "
                             f"direction (use Generated)")
    if node.type != "MAPPING":
        raise ParameterError(f"{where}: the Environment Texture's vector comes from a "
                             f"{node.name} node: the frame model reads Mapping nodes only")
    ins = {k: node.inputs[k] for k in ("Vector", "Location", "Rotation", "Scale")}
    if any(ins[k].is_linked for k in ("Location", "Rotation", "Scale")):
        raise ParameterError(f"{where}: the Mapping node's inputs must be constants")
    if not ins["Vector"].is_linked:
        raise ParameterError(f"{where}: the Mapping node's Vector is not connected (the map "
                             f"would be one colour): connect a Texture Coordinate's Generated")
    loc, scale = (np.array(ins[k].default_value, float) for k in ("Location", "Scale"))
    kind = node.vector_type
    if not (np.allclose(scale, scale[0], rtol=1e-6) and scale[0] > 0):
        raise ParameterError(f"{where}: the Mapping node's scale {scale.tolist()} is not "
                             f"uniform: the frame model reads a rotation")
    if kind in ("POINT", "TEXTURE") and np.any(loc != 0):
        raise ParameterError(f"{where}: the Mapping node moves the vector by {loc.tolist()}: "
                             f"a direction is not moved (set Location 0 or type Vector)")
    rot = _euler(ins["Rotation"].default_value)
    return (rot.T if kind == "TEXTURE" else rot) @ _lookup_matrix(ins["Vector"], where)


def _environment(world, where: str):
    """(Environment Texture node, Background strength, lookup matrix A) of the world's
    Cycles output; any other world refused."""
    nt = _nodes(world)
    out = nt.get_output_node("CYCLES") if nt is not None else None
    if out is None:
        raise ParameterError(f"{where} has no World Output: the frame model needs an "
                             f"Environment Texture world")
    if out.inputs["Volume"].is_linked:
        raise ParameterError(f"{where} has a volume: the frame model reads a surface world")
    link = _link(out.inputs["Surface"], where)
    if link is None or link.from_node.type != "BACKGROUND":
        raise ParameterError(f"{where}: its output is not a Background node fed by an "
                             f"Environment Texture (a plain colour, or other nodes)")
    bg = link.from_node
    if bg.inputs["Strength"].is_linked:
        raise ParameterError(f"{where}: the Background's Strength must be a constant")
    link = _link(bg.inputs["Color"], where)
    if (link is None or link.from_node.type != "TEX_ENVIRONMENT"
            or link.from_socket.identifier != "Color"):
        raise ParameterError(f"{where}: the Background's Color must be an Environment "
                             f"Texture's Color, connected directly")
    env = link.from_node
    if env.projection != "EQUIRECTANGULAR" or env.interpolation != "Linear":
        raise ParameterError(f"{where}: the Environment Texture is {env.projection}, "
                             f"{env.interpolation}: the frame model reads equirectangular, "
                             f"Linear (Blender's defaults)")
    tm = env.texture_mapping
    if (any(tm.translation) or any(tm.rotation) or tuple(tm.scale) != (1.0, 1.0, 1.0)
            or tm.use_min or tm.use_max
            or (tm.mapping_x, tm.mapping_y, tm.mapping_z) != ("X", "Y", "Z")):
        raise ParameterError(f"{where}: the Environment Texture's own Texture Mapping is set: "
                             f"use a Mapping node")
    return env, float(bg.inputs["Strength"].default_value), _lookup_matrix(env.inputs["Vector"],
                                                                          where)


def _pixels(image, where: str) -> np.ndarray:
    """The image's RGB (h, w, 3), row 0 the top (``Image.pixels`` is bottom row first)."""
    if image is None:
        raise ParameterError(f"{where}: the Environment Texture has no image")
    if image.source != "FILE":
        raise ParameterError(f"{where}: the image {image.name} is a {image.source}: the frame "
                             f"model reads one image file")
    w, h = (int(v) for v in image.size)
    if w == 0 or not image.has_data:
        raise ParameterError(f"{where}: Blender cannot load the image {image.filepath!r}")
    if not image.is_float:
        raise ParameterError(f"{where}: the image {image.name} is 8-bit: the frame model "
                             f"reads a float map (EXR, HDR)")
    if w != 2 * h:
        raise ParameterError(f"{where}: the image is {w}x{h}: an equirectangular map is twice "
                             f"as wide as high")
    buf = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    px = buf.reshape(h, w, image.channels)[::-1]
    rgb = px[..., :3] if image.channels >= 3 else np.repeat(px[..., :1], 3, axis=2)
    return np.ascontiguousarray(rgb, dtype=np.float64)


def _world(scene, notes: list) -> dict:
    """The map (h, w, 3), its rotation into Blender's world, its scale (Strength × the film's
    Exposure) and the light samples per spp (0 where the world is not sampled)."""
    from envfit.maps import EnvMap
    from envfit.renderers.cycles._background import CyclesBackground
    world = scene.world
    where = f"the world {world.name!r}" if world is not None else "the world"
    if world is None:
        raise ParameterError("the scene has no world: the frame model needs an Environment "
                             "Texture world")
    vis = world.cycles_visibility
    if not all((vis.camera, vis.diffuse, vis.glossy, vis.transmission)):
        raise ParameterError(f"{where} is hidden from some rays (Ray Visibility): the frame "
                             f"model reads a world every ray sees")
    env, strength, a = _environment(world, where)
    data = _pixels(env.image, where)
    scale = strength * float(scene.cycles.film_exposure)
    if scene.cycles.film_exposure != 1.0:
        notes.append(f"the film's Exposure {scene.cycles.film_exposure:g} is read as a scale "
                     f"on the map")
    method = world.cycles.sampling_method
    if method == "NONE":
        notes.append("the world's Sampling is None: no light samples; each spp is one BSDF "
                     "sample that escapes to the map")
    elif method == "MANUAL":
        notes.append(f"the world's Sampling is Manual ({world.cycles.sample_map_resolution} "
                     f"px): the model's importance map is Automatic's")
    if not np.allclose(a, np.eye(3)):
        notes.append("the map is looked up through a rotation: Cycles builds its importance "
                     "map on the world's grid, the model on the map's (the same for a turn "
                     "about z by whole cells)")
    try:
        tech = CyclesBackground(EnvMap(data), sampling="manual", map_resolution=2,
                                strength=scale)
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
    return {"envmap_data": data, "envmap_to_world": a.T @ tech.native_to_world.T,
            "envmap_scale": scale, "emitter_samples": 0 if method == "NONE" else 1,
            "technique": tech}


# ----------------------------------------------------------------------------- materials

@dataclass(frozen=True)
class _Surface:
    """One shape's material: its :class:`FrameBsdf`, the closure weight (the node's colour;
    1 where the BSDF holds it), Multiscatter GGX's per-channel darkening at a view cosine
    (:func:`_darkening`; None: none), and whether bump-map correction is on."""

    bsdf: FrameBsdf
    colour: np.ndarray
    darkening: object = None
    correction: bool = True

    def albedo(self, cos_i: np.ndarray) -> np.ndarray:
        """The hit's albedo (P, 3) at view cosines ``cos_i`` (module docstring)."""
        out = np.broadcast_to(self.colour, (len(cos_i), 3)).copy()
        if self.darkening is not None:
            out *= self.darkening(np.clip(cos_i, 0.0, 1.0))
        return out


def _rgb(socket) -> np.ndarray:
    return np.array(socket.default_value[:3], dtype=np.float64)


def _constant_inputs(node, where: str) -> dict:
    """The node's input values by name; any linked input refused."""
    for s in node.inputs:
        if s.is_linked and s.name not in _UNREAD and s.enabled:
            raise ParameterError(f"{where}: its {node.name} has a texture or node on "
                                 f"{s.name}: textures are not read from .blend yet")
    return {s.name: s for s in node.inputs}


def _darkening(alpha: float, fss) -> object:
    r"""Multiscatter GGX's per-channel darkening (1 + F_ms(1 − E)/E)·E at a view cosine
    (``kernel/closure/bsdf_microfacet.h``: ``microfacet_ggx_preserve_energy`` with the
    Fresnel average F_ss of each channel); None where every F_ss is 1."""
    from envfit.shading.microfacet import energy_scale
    fss = [float(f) for f in fss]
    if all(f == 1.0 for f in fss):
        return None
    kw = {"shadowing": "height_correlated", "vndf": "hemisphere_concentric"}

    def darkening(mu):
        white = energy_scale(alpha, mu, **kw)
        ok = white > 0
        return np.stack([np.where(ok, energy_scale(alpha, mu, fss=f, **kw)
                                  / np.where(ok, white, 1.0), 0.0) for f in fss], axis=-1)
    return darkening


def _alpha(roughness: float, where: str) -> float:
    """α = R² (``svm_node_closure_bsdf``: ``sqr(saturatef(roughness))``); a near-mirror
    refused."""
    alpha = min(max(float(roughness), 0.0), 1.0) ** 2
    if alpha < 1e-4:
        raise ParameterError(f"{where}: roughness {roughness:g} is a near-mirror (alpha < "
                             f"1e-4) the frame model's lobe tables do not resolve")
    return alpha


def _glossy(label: str, lobe, alpha: float, fresnel=None, lobes: int = 1) -> FrameBsdf:
    """A glossy :class:`FrameBsdf` of ``lobe`` (a two-lobe BSDF: ``lobes`` 2), its tables
    :data:`_GLOSS_LEVELS` finer by α."""
    extra = next(e for a, e in _GLOSS_LEVELS if alpha <= a)
    return FrameBsdf("glossy", f"{label}, alpha {alpha:g}",
                     lobe if lobes == 1 else TwoLobes(lobe), fresnel, extra, lobes=lobes)


def _principled(ins: dict, node, where: str, correction: bool) -> _Surface:
    """The Principled BSDF at metallic 1 (the F82-tint conductor: a white lobe, the Fresnel
    per channel, Multiscatter GGX's darkening per hit) or 0 (the specular and diffuse
    closures, grey; :func:`._bsdf.bsdf`)."""
    from envfit.renderers.cycles._bsdf import bsdf
    for k in _PRINCIPLED_ZERO + ("Diffuse Roughness",):
        if float(ins[k].default_value) != 0.0:
            raise ParameterError(f"{where}: the Principled BSDF's {k} is "
                                 f"{float(ins[k].default_value):g}: the frame model reads it "
                                 f"at 0")
    if float(ins["Alpha"].default_value) != 1.0:
        raise ParameterError(f"{where}: the Principled BSDF's Alpha is below 1 (transparent)")
    dist = _DISTRIBUTIONS.get(node.distribution)
    metallic = float(ins["Metallic"].default_value)
    if dist is None or metallic not in (0.0, 1.0):
        raise ParameterError(f"{where}: a Principled BSDF of distribution {node.distribution}"
                             f" and metallic {metallic:g}: the frame model reads GGX or "
                             f"Multiscatter GGX at metallic 0 or 1")
    alpha = _alpha(ins["Roughness"].default_value, where)
    base = np.clip(_rgb(ins["Base Color"]), 0.0, 1.0)
    tint = np.clip(_rgb(ins["Specular Tint"]), 0.0, 1.0)
    if metallic == 1.0:
        chans = [bsdf("principled", alpha, metallic=1.0, base_color=float(b),
                      specular_tint=float(t)) for b, t in zip(base, tint)]
        fresnel = None if np.all(base == 1.0) and np.all(tint == 1.0) else (
            lambda c: np.stack([ch.fresnel(c) for ch in chans], axis=-1))
        fss = [ch.f0 + (1.0 - ch.f0) / 21.0 - ch.f82_b / 126.0 for ch in chans]
        return _Surface(_glossy(f"principled metal ({dist})", bsdf(dist, alpha), alpha, fresnel),
                        np.ones(3), _darkening(alpha, fss) if dist == "multiggx" else None,
                        correction)
    if dist != "multiggx" or np.ptp(base) > 0 or np.ptp(tint) > 0:
        raise ParameterError(f"{where}: a Principled BSDF at metallic 0 is read with "
                             f"Multiscatter GGX and a grey Base Color and Specular Tint")
    try:
        lobe = bsdf("principled", alpha, metallic=0.0, base_color=float(base[0]),
                    specular_tint=float(tint[0]), ior=float(ins["IOR"].default_value),
                    specular_ior_level=float(ins["Specular IOR Level"].default_value))
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
    return _Surface(_glossy(f"principled ({lobe!r})", lobe, alpha, lobes=2), np.ones(3), None,
                    correction)


def _surface(mat, where: str) -> _Surface:
    """The material's :class:`_Surface`: one Diffuse, Glossy or Principled BSDF node straight
    into the Cycles Material Output, every input a constant (module docstring)."""
    from envfit.renderers.cycles._bsdf import bsdf
    nt = _nodes(mat)
    out = nt.get_output_node("CYCLES") if nt is not None else None
    if out is None:
        raise ParameterError(f"{where}: the material {mat.name!r} has no node tree or Material "
                             f"Output")
    if out.inputs["Volume"].is_linked or out.inputs["Displacement"].is_linked:
        raise ParameterError(f"{where}: the material {mat.name!r} has a volume or "
                             f"displacement: the frame model reads a surface")
    link = _link(out.inputs["Surface"], where)
    if link is None:
        raise ParameterError(f"{where}: the material {mat.name!r} has no surface shader")
    node = link.from_node
    kind = node.type  # the node type (the Glossy BSDF's bl_idname is Anisotropic's)
    if kind not in ("BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_PRINCIPLED"):
        raise ParameterError(f"{where}: its surface is a {node.name} node: the frame model "
                             f"reads one Diffuse, Glossy or Principled BSDF node (no emission, "
                             f"mixes or other shaders) so far")
    ins = _constant_inputs(node, where)
    correction = bool(mat.cycles.use_bump_map_correction)
    if kind == "BSDF_DIFFUSE":
        if float(ins["Roughness"].default_value) >= 1e-5:
            raise ParameterError(f"{where}: a Diffuse BSDF of roughness "
                                 f"{float(ins['Roughness'].default_value):g} is Oren–Nayar: "
                                 f"the frame model reads Lambert (roughness 0)")
        return _Surface(FrameBsdf("diffuse", "diffuse"), np.maximum(_rgb(ins["Color"]), 0.0))
    if kind == "BSDF_PRINCIPLED":
        return _principled(ins, node, where, correction)
    dist = _DISTRIBUTIONS.get(node.distribution)
    if dist is None or abs(float(ins["Anisotropy"].default_value)) > 1e-4:
        raise ParameterError(f"{where}: a Glossy BSDF of distribution {node.distribution}, "
                             f"anisotropy {float(ins['Anisotropy'].default_value):g}: the "
                             f"frame model reads isotropic GGX, Beckmann or Multiscatter GGX")
    alpha = _alpha(ins["Roughness"].default_value, where)
    colour = np.maximum(_rgb(ins["Color"]), 0.0)
    # Multiscatter GGX: the colour is the closure's weight and its constant Fresnel F_ss
    # (``svm_node_closure_bsdf``: ``bsdf_microfacet_setup_fresnel_constant``)
    return _Surface(_glossy(f"glossy ({dist})", bsdf(dist, alpha), alpha), colour,
                    _darkening(alpha, colour) if dist == "multiggx" else None, correction)


# ----------------------------------------------------------------------------- shapes

@dataclass(frozen=True)
class _Shape:
    """One object instance's triangles in world space: vertices (V, 3), faces (F, 3), the
    corner normals (F, 3, 3) (world, unit), which faces are smooth (F,), and the geometric
    normals' sign (−1 under a negative scale)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    corner_normals: np.ndarray
    smooth: np.ndarray
    sign: float


def _visible(ob, where: str) -> bool:
    """Whether the object is rendered (every ray type sees it); partial visibility, holdout
    and shadow catchers refused."""
    vis = [ob.visible_camera, ob.visible_shadow, ob.visible_diffuse, ob.visible_glossy,
           ob.visible_transmission]
    if not any(vis):
        return False
    if not all(vis) or ob.is_holdout or ob.is_shadow_catcher:
        raise ParameterError(f"{where} is hidden from some rays, a holdout or a shadow catcher:"
                             f" the frame model reads objects every ray sees")
    return True


def _mesh_arrays(mesh, matrix: np.ndarray) -> tuple:
    """(world vertices, faces, world corner normals per face, smooth, material indices) of an
    evaluated mesh's loop triangles."""
    mesh.calc_loop_triangles()
    nt, nl = len(mesh.loop_triangles), len(mesh.loops)
    co = np.empty(3 * len(mesh.vertices), np.float64)
    mesh.vertices.foreach_get("co", co)
    faces, loops = np.empty(3 * nt, np.int64), np.empty(3 * nt, np.int64)
    mesh.loop_triangles.foreach_get("vertices", faces)
    mesh.loop_triangles.foreach_get("loops", loops)
    smooth, mats = np.empty(nt, bool), np.empty(nt, np.int64)
    mesh.loop_triangles.foreach_get("use_smooth", smooth)
    mesh.loop_triangles.foreach_get("material_index", mats)
    cn = np.empty(3 * nl, np.float64)
    mesh.corner_normals.foreach_get("vector", cn)
    m3, t = matrix[:3, :3], matrix[:3, 3]
    v = co.reshape(-1, 3) @ m3.T + t
    n = cn.reshape(-1, 3) @ np.linalg.inv(m3)                      # the normal matrix
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return v, faces.reshape(-1, 3), n[loops.reshape(-1, 3)], smooth, mats


def _shape_material(ob, mats: np.ndarray, where: str):
    """The object's one material (its slots by the triangles' indices, clamped as Cycles'
    sync clamps them); none, or several, refused."""
    slots = ob.material_slots
    used = {slots[min(max(int(i), 0), len(slots) - 1)].material if len(slots) else None
            for i in np.unique(mats)}
    if len(used) != 1:
        raise ParameterError(f"{where} has {len(used)} materials: the frame model reads one "
                             f"material per object")
    mat = used.pop()
    if mat is None:
        raise ParameterError(f"{where} has no material: give it one (Cycles' default surface "
                             f"is not read)")
    return mat


def _rendered(depsgraph):
    """(instance, its object, "the object '…'") of every rendered geometry instance; a
    light, hair, point cloud or volume refused."""
    for inst in depsgraph.object_instances:
        ob = inst.object
        where = f"the object {ob.name!r}"
        if ob.type in _REFUSED:
            raise ParameterError(f"{where} is {_REFUSED[ob.type]}: the frame model predicts "
                                 f"lighting from the world's map only, on meshes")
        if ob.type in _GEOMETRY and _visible(ob, where):
            yield inst, ob, where


def _shapes(depsgraph, cache: dict) -> tuple[list, list]:
    """The rendered geometry instances as :class:`_Shape` and their :class:`_Surface`
    (``cache``: the materials' already read, by name)."""
    shapes, surfaces = [], []
    for inst, ob, where in _rendered(depsgraph):
        matrix = np.array(inst.matrix_world, dtype=np.float64)
        mesh = ob.to_mesh()
        try:
            v, f, cn, smooth, mats = _mesh_arrays(mesh, matrix)
        finally:
            ob.to_mesh_clear()
        if len(f) == 0:
            continue
        mat = _shape_material(ob, mats, where)
        if mat.name not in cache:
            cache[mat.name] = _surface(mat, where)
        name = ob.name + (f" (instance {len(shapes)})" if inst.is_instance else "")
        shapes.append(_Shape(name, v, f, cn, smooth,
                             float(np.sign(np.linalg.det(matrix[:3, :3])) or 1.0)))
        surfaces.append(cache[mat.name])
    if not shapes:
        raise ParameterError("the scene has no rendered mesh: the frame model needs a surface")
    return shapes, surfaces


def _convex(s: _Shape, eye: np.ndarray) -> bool:
    """Whether no ray leaving the shape's surface on the camera's side meets it again: a
    planar mesh whose shading normals are its plane's, or a closed convex flat-shaded one the
    camera sees from outside (a smooth mesh keeps its own triangles: a light direction above
    its shading normal may enter it, as in Cycles)."""
    v, f = s.vertices, s.faces
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ok = np.linalg.norm(e, axis=1) > 0
    if not np.any(ok):
        return False
    n = e[ok] / np.linalg.norm(e[ok], axis=1, keepdims=True)
    p = v[f[ok, 0]]
    tol = 1e-6 * (1.0 + np.abs(v).max())
    if np.all(np.abs((v - p[0]) @ n[0]) <= tol):                   # planar
        return bool(np.all(np.abs(np.abs(s.corner_normals[s.smooth] @ n[0]) - 1.0) < 1e-6))
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    if np.any(counts != 2) or np.any(s.smooth) or len(n) * len(v) > 1_000_000:
        return False
    side = np.einsum("fk,fvk->fv", n, v[None, :, :] - p[:, None, :])
    eye_side = np.einsum("fk,fk->f", n, eye - p)
    if np.all(side <= tol):                          # normals outwards: outside one face
        return bool(np.any(eye_side > tol))
    return bool(np.all(side >= -tol) and np.any(eye_side < -tol))


# ----------------------------------------------------------------------------- camera

def _viewplane(cam, render, size) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the camera's view plane at distance 1 (perspective) or in
    its plane (orthographic): ``BKE_camera_params_compute_viewplane`` (the sensor size by
    the camera's ``sensor_fit``, the fit by the pixel aspect, ``shift_x``/``shift_y`` in
    units of the fitted side)."""
    w, h = size
    xasp, yasp = float(render.pixel_aspect_x), float(render.pixel_aspect_y)
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if xasp * w >= yasp * h else "VERTICAL"
    sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
    pix = float(cam.ortho_scale) if cam.type == "ORTHO" else float(sensor) / float(cam.lens)
    ycor = yasp / xasp
    viewfac = w if fit == "HORIZONTAL" else ycor * h
    pix /= viewfac
    dx, dy = float(cam.shift_x) * viewfac, float(cam.shift_y) * viewfac
    return ((-0.5 * w + dx) * pix, (0.5 * w + dx) * pix,
            (-0.5 * ycor * h + dy) * pix, (0.5 * ycor * h + dy) * pix)


def _camera_params(scene, depsgraph, size, notes: list) -> dict:
    """The scene camera's rays as Cycles makes them (module docstring): its type, position,
    rotation (scale cleared), view plane and clip range; any other camera refused."""
    ob = scene.camera
    if ob is None:
        raise ParameterError("the scene has no camera")
    cam = ob.data
    if cam.type not in ("PERSP", "ORTHO"):
        raise ParameterError(f"the camera {ob.name!r} is {cam.type}: the frame model reads "
                             f"perspective and orthographic cameras")
    if cam.dof.use_dof:
        raise ParameterError(f"the camera {ob.name!r} has depth of field: the frame model "
                             f"reads a pinhole (Depth of Field off)")
    if scene.render.use_multiview:
        raise ParameterError("the scene renders stereo views: the frame model reads one")
    m = np.array(ob.evaluated_get(depsgraph).matrix_world, dtype=np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)             # transform_clear_scale
    if scene.render.use_motion_blur:
        notes.append("motion blur is on: the frame is read at its own time, without motion")
    return {"ortho": cam.type == "ORTHO", "position": m[:3, 3], "rotation": rot,
            "viewplane": _viewplane(cam, scene.render, size),
            "clip": (float(cam.clip_start), float(cam.clip_end)), "size": size}


def _valid_reflection(ng: np.ndarray, wi: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``ensure_valid_specular_reflection(Ng, I, N)`` (``kernel/closure/bsdf_util.h``), per
    row: N raised towards Ng just enough that the reflection of I lies above the surface."""
    def dot(a, b):
        return np.einsum("ij,ij->i", a, b)
    r = 2.0 * dot(n, wi)[:, None] * n - wi
    iz = dot(wi, ng)
    t = np.minimum(0.9 * iz, 0.01)
    x = n - dot(n, ng)[:, None] * ng
    ln = np.linalg.norm(x, axis=1, keepdims=True)
    x = np.where(ln > 0, x / np.where(ln > 0, ln, 1.0), n)
    ix = dot(wi, x)
    a = ix * ix + iz * iz
    b = 2.0 * (a + iz * t)
    c = (t + iz) ** 2
    disc = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        nz2 = np.where(ix < 0, 0.25 * (b + disc) / a, 0.25 * (b - disc) / a)
    lifted = (np.sqrt(np.maximum(1.0 - nz2, 0.0))[:, None] * x
              + np.sqrt(np.maximum(nz2, 0.0))[:, None] * ng)
    return np.where((dot(ng, r) >= t)[:, None], n, lifted)


def _embree_scene(shapes):
    """One Embree scene of every shape's triangles (geometry k = shape k)."""
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        raise ParameterError("the frame's first hits are cast with Embree: "
                             "pip install embreex") from None
    sc = rtcore_scene.EmbreeScene()
    for s in shapes:
        TriangleMesh(sc, np.ascontiguousarray(s.vertices, dtype=np.float32),
                     np.ascontiguousarray(s.faces, dtype=np.int32))
    return sc


def _empty_hits(p: int) -> dict:
    return {"kind": np.zeros(p, np.int8), "position": np.zeros((p, 3)),
            "normal": np.zeros((p, 3)), "geo_normal": np.zeros((p, 3)),
            "tangent": np.zeros((p, 3, 3)), "wi": np.zeros((p, 3)), "albedo": np.zeros((p, 3)),
            "facing": np.zeros(p, bool), "shape": np.full(p, -1, np.int64),
            "background": np.zeros((p, 3))}


class _Camera:
    """Camera rays and their first hits at film positions (module docstring): Cycles'
    camera, Embree on the rendered triangles, the shading of ``shade_surface``'s first hit."""

    def __init__(self, params: dict, shapes, surfaces, technique, rotation, transparent):
        self.p, self.shapes, self.surfaces = params, shapes, surfaces
        self.tech, self.rot, self.transparent = technique, rotation, transparent
        self._sc = None

    def rays(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Origins (P, 3) on the near-clip plane and directions (P, 3) with unit component
        along the camera's axis at film positions ``xy`` (P, 2) (pixels, x right, y down)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        (w, h), (x0, x1, y0, y1) = self.p["size"], self.p["viewplane"]
        rot, pos, near = self.p["rotation"], self.p["position"], self.p["clip"][0]
        px = x0 + xy[:, 0] / w * (x1 - x0)
        py = y1 - xy[:, 1] / h * (y1 - y0)
        axis = -rot[:, 2]
        if self.p["ortho"]:
            o = pos + np.column_stack([px, py, np.zeros(len(xy))]) @ rot.T + near * axis
            return o, np.broadcast_to(axis, o.shape).copy()
        d = np.column_stack([px, py, -np.ones(len(xy))]) @ rot.T
        return pos + near * d, d

    def hits(self, xy) -> dict:
        """The first hit of the camera ray at each film position ``xy`` (P, 2): the arrays of
        :attr:`~envfit.renderers._frame.FrameScene.hits_at`, shape (P, …)."""
        o, d = self.rays(xy)
        if len(d) == 0:
            return _empty_hits(0)
        length = np.linalg.norm(d, axis=1)
        d = d / length[:, None]
        near, far = self.p["clip"]
        tmax = (far - near) * (np.ones_like(length) if self.p["ortho"] else length)
        if self._sc is None:
            self._sc = _embree_scene(self.shapes)
        res = self._sc.run(np.ascontiguousarray(o, dtype=np.float32),
                           np.ascontiguousarray(d, dtype=np.float32),
                           dists=np.ascontiguousarray(tmax, dtype=np.float32), output=1)
        geom = np.asarray(res["geomID"], dtype=np.int64)
        out = _empty_hits(len(d))
        esc = geom < 0
        if np.any(esc) and not self.transparent:
            out["background"][esc] = self.tech.eval(d[esc] @ self.rot)
        for k in np.unique(geom[~esc]):
            sel = np.flatnonzero(geom == k)
            self._shade(int(k), sel, np.asarray(res["primID"])[sel].astype(np.int64),
                        np.column_stack([res["u"][sel], res["v"][sel]]).astype(np.float64),
                        d[sel], out)
        return out

    def _shade(self, k: int, sel, prim, uv, d, out: dict) -> None:
        """The hits ``sel`` on shape ``k`` (triangles ``prim``, barycentrics ``uv``)."""
        from envfit.renderers.cycles._background import cycles_frame
        s, surf = self.shapes[k], self.surfaces[k]
        tri = s.faces[prim]
        v0, v1, v2 = (s.vertices[tri[:, j]] for j in range(3))
        b = np.column_stack([1.0 - uv[:, 0] - uv[:, 1], uv])
        ng = s.sign * np.cross(v1 - v0, v2 - v0)
        ng /= np.linalg.norm(ng, axis=1, keepdims=True)
        ns = np.einsum("pj,pjk->pk", b, s.corner_normals[prim])
        ln = np.linalg.norm(ns, axis=1, keepdims=True)
        smooth = s.smooth[prim] & (ln[:, 0] > 0)
        n = np.where(smooth[:, None], ns / np.where(ln > 0, ln, 1.0), ng)
        wi = -d
        back = np.einsum("ij,ij->i", ng, wi) < 0
        ng[back], n[back] = -ng[back], -n[back]
        nb = n
        if surf.bsdf.kind == "glossy" and surf.correction and np.any(smooth):
            nb = np.where(smooth[:, None], _valid_reflection(ng, wi, n), n)
        frame = cycles_frame(nb)
        wl = np.einsum("pij,pj->pi", frame, wi)
        out["kind"][sel] = HIT_SURFACE
        out["position"][sel] = np.einsum("pj,pjk->pk", b, np.stack([v0, v1, v2], axis=1))
        out["normal"][sel], out["geo_normal"][sel] = n, ng
        out["tangent"][sel], out["wi"][sel], out["shape"][sel] = frame, wl, k
        out["facing"][sel] = True if surf.bsdf.kind == "diffuse" else wl[:, 2] > 0
        out["albedo"][sel] = surf.albedo(wl[:, 2])


# ----------------------------------------------------------------------------- the scene

def _settings_notes(scene, view_layer, notes: list) -> bool:
    """Settings the model reads as they are, noted; whether the film is transparent."""
    r = scene.render
    if r.use_border:
        notes.append("a render region (border) is set: the whole frame is predicted")
    if sum(vl.use for vl in scene.view_layers) > 1:
        notes.append(f"the scene renders several view layers: {view_layer.name!r} is read")
    if r.film_transparent:
        notes.append("the film is transparent: pixels that see the world are 0")
    return bool(r.film_transparent)


def _materials(depsgraph) -> dict:
    """Every rendered object's materials as :class:`_Surface` by name (and its type checked),
    refused before any mesh is built."""
    out: dict = {}
    for _, ob, where in _rendered(depsgraph):
        for slot in ob.material_slots:
            if slot.material is not None and slot.material.name not in out:
                out[slot.material.name] = _surface(slot.material, where)
    return out


def read_scene(path) -> FrameScene:
    """The :class:`~envfit.renderers._frame.FrameScene` of the Blender file ``path``, read by
    Blender (module docstring).

    Raises :class:`envfit.base.ParameterError` (one line) for a file Blender cannot open, a
    render engine other than Cycles, a world other than an Environment Texture, a light,
    a material other than one constant Diffuse, Glossy or Principled BSDF, a camera other
    than a perspective or orthographic pinhole, or a sampler setting the model does not
    read."""
    from envfit.renderers.cycles._render import import_bpy
    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"{path}: no such scene file")
    bpy = import_bpy()
    scene = _open(bpy, path)
    view_layer = bpy.context.view_layer
    notes: list = []
    film = _film(scene)
    sampler, spp = _sampler(scene, view_layer, notes)
    world = _world(scene, notes)
    transparent = _settings_notes(scene, view_layer, notes)
    _render_visibility(bpy, scene, view_layer)
    dg = bpy.context.evaluated_depsgraph_get()
    cam = _camera_params(scene, dg, film["size"], notes)
    shapes, surfaces = _shapes(dg, _materials(dg))
    depth = _max_depth(scene, surfaces, notes)
    camera = _Camera(cam, shapes, surfaces, world["technique"], world["envmap_to_world"],
                     transparent)
    occ = tuple(Occluder(s.name, s.vertices, s.faces, _convex(s, cam["position"]))
                for s in shapes)
    return FrameScene(
        path=str(path), renderer="cycles", size=tuple(film["size"]), occluders=occ,
        envmap_data=world["envmap_data"], envmap_to_world=world["envmap_to_world"],
        envmap_scale=world["envmap_scale"], sampler=sampler, spp=spp, integrator="path",
        emitter_samples=world["emitter_samples"], bsdf_samples=1, max_depth=depth,
        filter_name=film["filter_name"], filter_radius=film["filter_radius"],
        filter_weights=film["filter_weights"], hits_at=camera.hits, rays_at=camera.rays,
        notes=tuple(notes), bsdfs=tuple(s.bsdf for s in surfaces), draws=(1, 2),
        film_warp=film["film_warp"])

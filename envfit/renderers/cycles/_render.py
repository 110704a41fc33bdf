r"""Rendering the sphere of :mod:`._sphere` with Blender's Cycles through ``bpy`` (PyPI
``bpy`` 5.0.1: ``pip install 'envfit[cycles]'``), and its measured shading error.

The scene (built once per :class:`CyclesSphere`, from Blender's empty factory settings):

* **the sphere**: a point cloud of one point of radius 1 at the origin (a mesh vertex through
  the Geometry Nodes *Mesh to Points* node), which Cycles intersects as an exact analytic
  sphere (``kernel/geom/point_intersect.h``), so its normals are exact — not a tessellated
  mesh with interpolated normals. Material: the **Diffuse BSDF**, colour 1, roughness 0 —
  Lambertian (``kernel/closure/bsdf_diffuse.h``; Oren–Nayar only for roughness > 0), cosine
  sampling by the concentric map (``kernel/sample/mapping.h``: ``sample_cos_hemisphere``);
  or, with :attr:`CyclesOptions.bsdf`, the **Glossy BSDF** (:func:`glossy_bsdf`);
* **the world**: an *Environment Texture* (equirectangular, Linear interpolation) of the map
  written to a temporary EXR, wired straight to the Background as a user wires it (no
  Vector input: the lookup is at the world ray direction). Cycles' equirectangular lookup
  (``kernel/camera/projection.h``: ``direction_to_equirectangular_range``) puts direction
  (−sinθ cosφ, sinθ sinφ, cosθ) at the pixel of (θ, φ) (z up, centred grid;
  :func:`envfit.maps.convention` ``"blender"``); envfit's ``up="y"`` puts
  (sinθ sinφ, cosθ, −sinθ cosφ) there, so Cycles' world direction of envfit's w is the cyclic
  permutation (w_z, w_x, w_y). The six views of :data:`._sphere.VIEWS` are the same set under
  it, so the sphere's mean over them is what envfit predicts in its own frame (checked by
  rendering a map with one bright pixel). The world's importance map is built in that same
  world frame (``scene/light.cpp``: ``shade_background_pixels``), aligned with the texture's
  pixels — as it is in a user's scene: a remapped Vector (a Mapping node, a permutation)
  would sample one grid and look up another. World *Sampling*: ``AUTOMATIC`` for ``mis`` (one
  light sample + one BSDF sample per spp, power heuristic: ``kernel/integrator/
  shade_surface.h``), ``NONE`` for ``brdf``; emitter sampling alone exists only in debug
  builds (``map`` is refused);
* **light paths**: max bounces 1 (diffuse 1, others 0): the camera hit and its one bounce;
  with one convex sphere a bounce leaving it can only escape to the world, so this is direct
  lighting exactly (tested: more bounces give the same image); clamping off; denoising and
  adaptive sampling off; the light tree at its default (on); the **box** pixel filter of
  width 1 (or ``CyclesOptions.pixel_filter``: Blender's default is Blackman–Harris 1.5 px,
  ``_film``); the CPU device;
* **sampling pattern**: Tabulated Sobol (the factory startup scene's) or Blue Noise
  (:data:`PATTERNS`); a random seed per render (consecutive seeds are correlated: Cycles XORs
  the seed into each pixel's hash, ``kernel/sample/pattern.h``: ``path_rng_pixel_init``);
* six orthographic cameras, ``ortho_scale`` 2 (the image covers [−1, 1]²), at 3v looking
  along −v with the view's up: Blender's camera looks along its local −z with local +y up,
  so its world matrix has the columns (u × v, u, v, 3v).

bpy holds one global Blender session: one :class:`CyclesSphere` at a time (a new one resets
the session to the empty factory settings).
"""
from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.maps import EnvMap, save_envmap
from envfit.renderers._reference import ReferencePair, cached_reference, map_digest
from envfit.renderers._sphere import (VIEWS, SphereMeasurement, check_strategy,
                                              measurement, sphere_error, sphere_geometry,
                                              view_seeds)

__all__ = ["PATTERNS", "CYCLES_PATTERNS", "WORLD_SAMPLING", "CyclesOptions", "CyclesSphere",
           "import_bpy", "cycles_normals", "glossy_bsdf", "version", "open_sphere"]

#: envfit's pattern names → Cycles' ``sampling_pattern`` enum
PATTERNS = {"tabulated_sobol": "TABULATED_SOBOL", "blue_noise": "BLUE_NOISE",
            "automatic": "AUTOMATIC"}
CYCLES_PATTERNS = tuple(PATTERNS)
#: strategy → the world's ``cycles.sampling_method``
WORLD_SAMPLING = {"mis": "AUTOMATIC", "brdf": "NONE"}


def import_bpy():
    """The ``bpy`` module; :class:`ParameterError` (one line) if it is not installed."""
    try:
        with _quiet_blender():                  # bpy's import prints to stdout
            import bpy
    except ImportError:
        raise ParameterError("Blender's Cycles is not available: pip install bpy==5.0.1 "
                             "(or pip install 'envfit[cycles]')") from None
    return bpy


@dataclass(frozen=True)
class CyclesOptions:
    """Settings of the Cycles sphere renders.

    Attributes
    ----------
    resolution : pixels per side of each view.
    reference_spp : spp of each of the two reference renders (Tabulated Sobol, MIS).
    reference_seed : seed of the reference renders' seeds.
    threads : CPU threads (None: all cores).
    cache_dir : folder of the reference cache (None: no cache).
    max_bounces : light-path bounces (1: direct lighting; more only to check that it is).
    bsdf : None (the white Diffuse BSDF) or :func:`glossy_bsdf` (a white microfacet
        conductor: the Glossy BSDF node).
    pixel_filter : (Blender's ``pixel_filter_type``, ``filter_width``): the box of width 1
        (the lab's, default) or Blender's default ``("BLACKMAN_HARRIS", 1.5)``, ``GAUSSIAN``.
    """

    resolution: int = 64
    reference_spp: int = 4096
    reference_seed: int = 20241
    threads: int | None = None
    cache_dir: str | None = None
    max_bounces: int = 1
    bsdf: tuple | None = None
    pixel_filter: tuple = ("BOX", 1.0)

    def __post_init__(self):
        kind, width = self.pixel_filter
        if kind not in ("BOX", "GAUSSIAN", "BLACKMAN_HARRIS") or not float(width) > 0:
            raise ParameterError(f"pixel_filter must be (BOX | GAUSSIAN | BLACKMAN_HARRIS, "
                                 f"width > 0), got {self.pixel_filter!r}")
        if self.bsdf is not None and dict(self.bsdf).get("type") != "glossy":
            raise ParameterError("bsdf must be None (white diffuse) or glossy_bsdf(...)")
        for name, lo in (("resolution", 4), ("reference_spp", 1), ("max_bounces", 1)):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < lo:
                raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")


def glossy_bsdf(distribution: str = "ggx", alpha: float = 0.1, node: str = "glossy",
                base_color: float = 1.0, specular_tint: float = 1.0,
                **principled) -> tuple:
    """The sphere's BSDF for :attr:`CyclesOptions.bsdf`: the *Glossy BSDF* node, colour 1
    (Fresnel = 1: a white conductor), distribution ``GGX`` or ``Beckmann`` (single scattering),
    or ``multiggx``: *Multiscatter GGX*, the node's and the Principled BSDF's default (GGX
    times ``energy_scale``, ``_bsdf``), roughness √α (Cycles squares its
    roughness and sets no Fresnel for single-scatter GGX and Beckmann: ``src/kernel/svm/
    closure.h``, ``svm_node_closure_bsdf``, case ``CLOSURE_BSDF_MICROFACET_GGX_ID``:
    ``alpha_x = alpha_y = sqr(saturatef(roughness))``, then ``bsdf_microfacet_ggx_setup`` or
    ``bsdf_microfacet_beckmann_setup``; sampled by visible normals,
    ``src/kernel/closure/bsdf_microfacet.h``), as sorted (key, value) pairs.

    ``node="principled"``: the *Principled BSDF* node instead, Metallic 1, Base Color and
    Specular Tint white, its distribution GGX or Multiscatter GGX. Its metallic closure is the
    same microfacet BSDF with the F82-tint Fresnel (``closure.h``, ``CLOSURE_BSDF_PRINCIPLED_ID``:
    f0 = base colour, ``bsdf_microfacet_setup_fresnel_f82_tint``): F82 tint 1 sets b = 0, so
    F = Schlick(f0 = 1) = 1 and the multiscatter energy scale is the Glossy node's (Fss = 1);
    every other layer has weight 0 (1 − metallic, coat, sheen). So it renders the Glossy
    node's image (``tests/test_render_cycles.py``). ``base_color`` and ``specular_tint`` (grey,
    the Principled node only) set f0 and the tint of that Fresnel (Blender's defaults are 0.8
    and 1). ``principled``: the node's ``metallic`` (1 unless given: 0 is the node's default,
    the specular and diffuse closures of ``_bsdf``), ``ior`` and ``specular_ior_level``.

    >>> round(dict(glossy_bsdf("beckmann", 0.25))["roughness"], 12)
    0.5
    """
    if distribution not in ("ggx", "beckmann", "multiggx"):
        raise ParameterError(f"distribution must be ggx, beckmann or multiggx, got "
                             f"{distribution!r}")
    if node not in ("glossy", "principled") or (node == "principled"
                                                 and distribution == "beckmann"):
        raise ParameterError(f"node must be glossy, or principled with ggx or multiggx (the "
                             f"Principled BSDF has no Beckmann), got {node!r}")
    b = {"type": "glossy", "distribution": distribution, "alpha": float(alpha),
         "roughness": float(alpha) ** 0.5}
    if set(principled) - {"metallic", "ior", "specular_ior_level"} or (
            principled and node != "principled"):
        raise ParameterError(f"the Principled node's inputs here are metallic, ior and "
                             f"specular_ior_level (node=\"principled\"); got "
                             f"{sorted(principled)}")
    if node == "principled":                # the Glossy node's keys (and caches) unchanged
        b["node"] = node
        b.update({k: float(v) for k, v in (("base_color", base_color),
                                           ("specular_tint", specular_tint)) if v != 1.0})
        b.update({k: float(v) for k, v in principled.items()
                  if float(v) != {"metallic": 1.0, "ior": 1.5,
                                  "specular_ior_level": 0.5}[k]})
    elif (base_color, specular_tint) != (1.0, 1.0):
        raise ParameterError("base_color and specular_tint are the Principled node's "
                             "(node=\"principled\")")
    return tuple(sorted(b.items()))


def _use_nodes(datablock) -> None:
    """Give a material or world its node tree (``use_nodes``, deprecated in Blender 5 where
    new ones have it already, to be removed in 6)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        if getattr(datablock, "node_tree", None) is None or not datablock.use_nodes:
            datablock.use_nodes = True


def _material(bpy, bsdf=None):
    mat = bpy.data.materials.new("white diffuse" if bsdf is None else "white glossy")
    _use_nodes(mat)
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    colour = "Color"
    if bsdf is None:
        node = nt.nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Roughness"].default_value = 0.0
    else:
        b = dict(bsdf)
        principled = b.get("node") == "principled"
        node = nt.nodes.new("ShaderNodeBsdfPrincipled" if principled else "ShaderNodeBsdfGlossy")
        node.distribution = {"ggx": "GGX", "beckmann": "BECKMANN",
                             "multiggx": "MULTI_GGX"}[b["distribution"]]
        node.inputs["Roughness"].default_value = b["roughness"]
        if principled:
            node.inputs["Metallic"].default_value = b.get("metallic", 1.0)
            node.inputs["IOR"].default_value = b.get("ior", 1.5)
            node.inputs["Specular IOR Level"].default_value = b.get("specular_ior_level", 0.5)
            t = b.get("specular_tint", 1.0)
            node.inputs["Specular Tint"].default_value = (t, t, t, 1.0)
            colour = "Base Color"
    c = 1.0 if bsdf is None else dict(bsdf).get("base_color", 1.0)
    node.inputs[colour].default_value = (c, c, c, 1.0)
    nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    return mat


def _sphere_object(bpy, scene, mat):
    """One vertex at the origin → Mesh to Points (radius 1) → Set Material: an exact sphere."""
    me = bpy.data.meshes.new("vertex")
    me.from_pydata([(0.0, 0.0, 0.0)], [], [])
    ob = bpy.data.objects.new("sphere", me)
    scene.collection.objects.link(ob)
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
    ob.modifiers.new("points", "NODES").node_group = gn
    return ob


@contextlib.contextmanager
def _quiet_blender():
    """What Blender writes to file descriptor 1 from C (its render log, ``Saved: …``; "Unable
    to initialise audio" on import) discarded, so that stdout keeps only what envfit prints
    (``--json -``); a failed render still raises (``bpy.ops`` returns its error as a
    RuntimeError)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def _world(bpy, scene, map_path: str):
    """The Environment Texture world, looked up at the ray direction (module docstring)."""
    world = bpy.data.worlds.new("envmap")
    scene.world = world
    _use_nodes(world)
    wt = world.node_tree
    for n in list(wt.nodes):
        wt.nodes.remove(n)
    env = wt.nodes.new("ShaderNodeTexEnvironment")
    bg, wo = wt.nodes.new("ShaderNodeBackground"), wt.nodes.new("ShaderNodeOutputWorld")
    env.image = bpy.data.images.load(map_path)
    env.interpolation = "Linear"
    env.projection = "EQUIRECTANGULAR"
    wt.links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 1.0
    wt.links.new(bg.outputs[0], wo.inputs["Surface"])
    return world


def _settings(scene, options: CyclesOptions) -> None:
    r, c = scene.render, scene.cycles
    r.engine = "CYCLES"
    r.resolution_x = r.resolution_y = options.resolution
    r.resolution_percentage = 100
    r.threads_mode = "FIXED"
    r.threads = int(options.threads or os.cpu_count() or 1)
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.pixel_filter_type, c.filter_width = options.pixel_filter[0], float(options.pixel_filter[1])
    c.max_bounces = c.diffuse_bounces = options.max_bounces
    c.glossy_bounces = options.max_bounces if options.bsdf is not None else 0
    c.transmission_bounces = c.volume_bounces = 0
    c.transparent_max_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.use_animated_seed = False
    c.use_light_tree = True


def _camera(bpy, scene):
    cam = bpy.data.cameras.new("ortho")
    cam.type = "ORTHO"
    cam.ortho_scale = 2.0
    cam.clip_start, cam.clip_end = 0.01, 100.0
    ob = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(ob)
    scene.camera = ob
    return ob


def _view_matrix(view):
    from mathutils import Matrix
    r, u, v = (np.asarray(a, float) for a in (view.right, view.up, view.axis))
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = r, u, v, 3.0 * v
    return Matrix(m.tolist())


def _read_exr(path: Path, channels=None) -> np.ndarray:
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(path))
    spec = buf.spec()
    names = list(spec.channelnames)
    px = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)
    if channels and not all(c in names for c in channels):
        raise RuntimeError(f"{path}: no channels {channels} in {names}")
    idx = [names.index(c) for c in channels] if channels else [0, 1, 2]
    return px[..., idx]


def _sample_counts(value: np.ndarray, first: int) -> np.ndarray:
    """The samples each pixel took from the *Debug Sample Count* pass, which Cycles writes as
    count / N, N the samples of the render's longest pixel (``integrator/pass_accessor.cpp``:
    ``scale = 1 / num_samples``, the samples rendered, not the setting): N from the pixels that
    stop at the first test, ``first`` (the views' corners see one constant direction of the
    world and pass at once); checked to make every count a whole number."""
    v = np.asarray(value, dtype=np.float64)
    lo = float(v[v > 0].min())
    n = first / lo
    counts = v * n
    if not np.all(np.abs(counts - np.rint(counts)) < 0.02 * np.maximum(1.0, counts / 512)):
        raise RuntimeError("the sample count pass is not a whole number of samples at any "
                           "scale the first test gives")
    return np.rint(counts)


def _read_layers(path: Path) -> dict:
    """A multilayer EXR's passes {pass name: (H, W, channels)} (every subimage; channel names
    ``<view layer>.<pass>.<channel>``)."""
    import OpenImageIO as oiio
    out: dict = {}
    for k in range(oiio.ImageBuf(str(path)).nsubimages):
        buf = oiio.ImageBuf(str(path), k, 0)
        names = list(buf.spec().channelnames)
        px = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)
        for i, name in enumerate(names):
            layer = name.rsplit(".", 1)[0].split(".", 1)[-1]
            out.setdefault(layer, []).append(px[..., i])
    if not out:
        raise RuntimeError(f"{path}: no image")
    return {k: np.stack(v, axis=-1) for k, v in out.items()}


class CyclesSphere:
    """The sphere of :mod:`._sphere` in Cycles on one map (module docstring); a context
    manager (the temporary files are removed on exit)."""

    renderer = "cycles"

    def __init__(self, envmap: EnvMap, options: CyclesOptions | None = None):
        self.bpy = bpy = import_bpy()
        self.options = options or CyclesOptions()
        data = np.asarray(envmap.data, dtype=np.float32)
        if data.shape[2] == 1:
            data = np.repeat(data, 3, axis=2)
        elif data.shape[2] != 3:
            raise ParameterError(f"Cycles renders RGB maps; this one has {data.shape[2]} channels")
        self.envmap = EnvMap(data, up="y", name=envmap.name)
        self.digest = map_digest(self.envmap)
        self.geometry = sphere_geometry(self.options.resolution)
        self._dir = Path(tempfile.mkdtemp(prefix="envfit-cycles-"))
        path = save_envmap(self._dir / f"map-{self.digest[:16]}.exr", self.envmap)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        self.scene = bpy.context.scene
        _sphere_object(bpy, self.scene, _material(bpy, self.options.bsdf))
        self.world = _world(bpy, self.scene, str(path))
        self.camera = _camera(bpy, self.scene)
        _settings(self.scene, self.options)
        self.version = bpy.app.version_string

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        """Remove the temporary files."""
        shutil.rmtree(self._dir, ignore_errors=True)

    def _render_view(self, k: int, out: Path, channels=None) -> tuple[np.ndarray, float]:
        self.camera.matrix_world = _view_matrix(VIEWS[k])
        self.scene.render.filepath = str(out)
        t = time.perf_counter()
        with _quiet_blender():
            self.bpy.ops.render.render(write_still=True)
        secs = time.perf_counter() - t
        img = _read_exr(out, channels)
        out.unlink()
        return img, secs

    def render(self, strategy: str, pattern: str, spp: int, seed) -> tuple[np.ndarray, list]:
        """The six views (6, R, R, 3) and the seconds of each render (wall time of Cycles'
        render call, scene sync and the world's importance map included)."""
        if check_strategy(strategy) not in WORLD_SAMPLING:
            raise ParameterError("Cycles samples the world alone (no BSDF rays) only in debug "
                                 "builds: strategy must be 'mis' or 'brdf'")
        if pattern not in PATTERNS:
            raise ParameterError(f"Cycles sampling pattern must be one of "
                                 f"{', '.join(PATTERNS)}; got {pattern!r}")
        if not isinstance(spp, (int, np.integer)) or spp < 1:
            raise ParameterError(f"spp must be an integer >= 1, got {spp!r}")
        c = self.scene.cycles
        c.sampling_pattern = PATTERNS[pattern]
        c.samples = int(spp)
        self.world.cycles.sampling_method = WORLD_SAMPLING[strategy]
        images, secs = [], []
        for k, s in enumerate(view_seeds(seed)):
            c.seed = int(s)
            img, t = self._render_view(k, self._dir / f"view{k}.exr")
            images.append(img)
            secs.append(t)
        return np.stack(images), secs

    def render_adaptive(self, pattern: str, threshold: float, samples: int, seed, *,
                        min_samples: int = 0) -> tuple[np.ndarray, np.ndarray, list]:
        """The six views (6, R, R, 3) rendered with Cycles' adaptive sampling (MIS; Blender's
        ``use_adaptive_sampling``, ``adaptive_threshold``, ``adaptive_min_samples``,
        ``samples`` the most), the samples each pixel took (6, R, R) from Cycles' *Debug
        Sample Count* pass (its value × ``samples``), and the seconds of each view."""
        if pattern not in PATTERNS:
            raise ParameterError(f"Cycles sampling pattern must be one of "
                                 f"{', '.join(PATTERNS)}; got {pattern!r}")
        c, vl = self.scene.cycles, self.scene.view_layers[0]
        fmt = self.scene.render.image_settings
        c.sampling_pattern = PATTERNS[pattern]
        c.samples = int(samples)
        c.use_adaptive_sampling = True
        c.adaptive_threshold = float(threshold)
        c.adaptive_min_samples = int(min_samples)
        vl.cycles.pass_debug_sample_count = True
        if hasattr(fmt, "media_type"):                  # Blender 5: the layers are a media type
            fmt.media_type = "MULTI_LAYER_IMAGE"
        fmt.file_format = "OPEN_EXR_MULTILAYER"
        self.world.cycles.sampling_method = WORLD_SAMPLING["mis"]
        images, counts, secs = [], [], []
        from envfit.renderers.cycles._adaptive import CYCLES_ADAPTIVE
        first = int(CYCLES_ADAPTIVE.settings(threshold, int(samples), int(min_samples)).checks[0])
        try:
            for k, sd in enumerate(view_seeds(seed)):
                c.seed = int(sd)
                self.camera.matrix_world = _view_matrix(VIEWS[k])
                out = self._dir / f"adaptive{k}.exr"
                self.scene.render.filepath = str(out)
                t = time.perf_counter()
                with _quiet_blender():
                    self.bpy.ops.render.render(write_still=True)
                secs.append(time.perf_counter() - t)
                layers = _read_layers(out)
                out.unlink()
                images.append(layers["Combined"][..., :3])
                counts.append(_sample_counts(layers["Debug Sample Count"][..., 0], first))
        finally:
            c.use_adaptive_sampling = False
            vl.cycles.pass_debug_sample_count = False
            if hasattr(fmt, "media_type"):
                fmt.media_type = "IMAGE"
            fmt.file_format = "OPEN_EXR"
        return np.stack(images), np.stack(counts), secs

    def spp_used(self, pattern: str, spp: int) -> int:
        """The spp Cycles renders for ``spp`` asked: ``spp`` (no rounding, any pattern)."""
        return int(spp)

    def reference(self) -> ReferencePair:
        """Two reference renders (Tabulated Sobol, MIS, ``reference_spp``), cached."""
        o = self.options
        key = {"renderer": self.renderer, "version": self.version, "map": self.digest,
               "spp": o.reference_spp, "resolution": o.resolution, "seed": o.reference_seed,
               "strategy": "mis", "pattern": "tabulated_sobol", "bounces": o.max_bounces,
               "world": "native"}          # the texture at the ray direction (not permuted)
        if o.bsdf is not None:                  # the diffuse references' keys unchanged
            key["bsdf"] = dict(o.bsdf)
        if tuple(o.pixel_filter) != ("BOX", 1.0):     # the box renders' keys unchanged
            key["pixel_filter"] = list(o.pixel_filter)

        def render():
            rng = np.random.default_rng(o.reference_seed)
            a, ta = self.render("mis", "tabulated_sobol", o.reference_spp, rng)
            b, tb = self.render("mis", "tabulated_sobol", o.reference_spp, rng)
            return a, b, sum(ta) + sum(tb)

        return cached_reference(key, render, o.cache_dir)

    def measure(self, strategy: str, pattern: str, spp: int, *, seed=0,
                reference: ReferencePair | None = None) -> SphereMeasurement:
        """The measured RMSE over normals of one configuration against :meth:`reference`."""
        ref = self.reference() if reference is None else reference
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        imgs, secs = self.render(strategy, pattern, spp, rng)
        err = sphere_error(imgs, ref.a, ref.b, self.geometry, seed=rng)
        opts = {"world_sampling": WORLD_SAMPLING[strategy], "blender": self.version,
                "device": "CPU",
                "filter": f"{self.options.pixel_filter[0].lower()} "
                          f"{self.options.pixel_filter[1]:g} px", "light_tree": True,
                "max_bounces": self.options.max_bounces}
        return measurement(err, spp=spp, renderer=self.renderer, sampler=pattern,
                           strategy=strategy, reference_spp=self.options.reference_spp,
                           view_seconds=secs, resolution=self.options.resolution,
                           options=opts)

    def normals(self, spp: int = 16) -> np.ndarray:
        """World normals (6, R, R, 3) of the sphere per pixel, rendered by Cycles: the
        sphere's material swapped for an Emission of colour (N + 1)/2, N the Geometry node's
        normal (the camera sees the emission directly, so a pixel is the mean of (n + 1)/2
        over its footprint), for checking :func:`._sphere.view_normals`."""
        bpy, s = self.bpy, self.scene
        mat = bpy.data.materials.new("normal emission")
        _use_nodes(mat)
        nt = mat.node_tree
        for n in list(nt.nodes):
            nt.nodes.remove(n)
        geo, vm = nt.nodes.new("ShaderNodeNewGeometry"), nt.nodes.new("ShaderNodeVectorMath")
        em, out = nt.nodes.new("ShaderNodeEmission"), nt.nodes.new("ShaderNodeOutputMaterial")
        vm.operation = "MULTIPLY_ADD"
        vm.inputs[1].default_value = (0.5, 0.5, 0.5)
        vm.inputs[2].default_value = (0.5, 0.5, 0.5)
        nt.links.new(geo.outputs["Normal"], vm.inputs[0])
        nt.links.new(vm.outputs[0], em.inputs["Color"])
        em.inputs["Strength"].default_value = 1.0
        nt.links.new(em.outputs[0], out.inputs["Surface"])
        node = bpy.data.node_groups["sphere points"].nodes["Set Material"]
        white = node.inputs["Material"].default_value
        node.inputs["Material"].default_value = mat
        s.cycles.samples = int(spp)
        try:
            out = [self._render_view(k, self._dir / f"normal{k}.exr")[0]
                   for k in range(len(VIEWS))]
        finally:
            node.inputs["Material"].default_value = white
        return 2.0 * np.stack(out) - 1.0


def cycles_normals(resolution: int, spp: int = 16) -> np.ndarray:
    """World normals (6, R, R, 3) of the sphere per pixel of each view from Cycles' Normal
    pass (on a constant map)."""
    env = EnvMap(np.ones((4, 8, 3), np.float32))
    with CyclesSphere(env, CyclesOptions(resolution=int(resolution), reference_spp=1)) as r:
        return r.normals(spp)


# The harness protocol (``Renderer.harness``): what ``validate --renderer`` calls.

def version() -> str:
    """Blender's version (Cycles on the CPU); one-line ParameterError where bpy is not
    installed."""
    return f"Blender {'.'.join(str(v) for v in import_bpy().app.version)} (Cycles, CPU)"


def open_sphere(envmap, brdf: str | None, alpha: float | None, bsdf_params=None,
                **common) -> "CyclesSphere":
    """The sphere of envfit's measurement with ``brdf`` (None: white diffuse; ``principled``:
    the Principled BSDF with ``bsdf_params`` over Blender's node defaults (metallic 0, base
    colour 0.8, IOR 1.5, ...), Multiscatter GGX; else a Glossy BSDF, :func:`glossy_bsdf`) of roughness ``alpha``;
    ``common``: :class:`CyclesOptions`' resolution, reference_spp, cache_dir."""
    from envfit.renderers.cycles._bsdf import PRINCIPLED_PARAMS
    if brdf == "principled":
        p = {**PRINCIPLED_PARAMS, **(bsdf_params or {})}
        bsdf = glossy_bsdf("multiggx", alpha, node="principled", base_color=p["base_color"],
                           specular_tint=p["specular_tint"], metallic=p["metallic"],
                           ior=p["ior"], specular_ior_level=p["specular_ior_level"])
    else:
        bsdf = None if brdf is None else glossy_bsdf(brdf, alpha)
    return CyclesSphere(envmap, CyclesOptions(**common, bsdf=bsdf))

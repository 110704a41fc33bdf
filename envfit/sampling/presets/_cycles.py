r"""Cycles' world (background) light with an Environment Texture, its importance map and its
path-tracing direct light, in numpy.

Read from blender/cycles (the standalone mirror of Blender's ``intern/cycles``) at tag
``v5.0.0`` (``2eba41024174``; Blender 5.0 is what PyPI ``bpy`` 5.0.1 embeds), paths under
``src/``:

* ``scene/shader_nodes.cpp`` — ``EnvironmentTextureNode``: interpolation socket default
  ``INTERPOLATION_LINEAR``, ``image_params``: ``extension = EXTENSION_REPEAT``;
* ``kernel/device/cpu/image.h`` — ``interp_linear`` / ``interp_closest``: texel-centred
  (``x·width − 0.5``), ``EXTENSION_REPEAT`` wraps **both** axes periodically (so within half
  a texel of a pole the lookup blends the first and the last row of the file);
* ``kernel/camera/projection.h`` — ``direction_to_equirectangular``,
  ``equirectangular_to_direction`` (range (−2π, π, −π, π));
* ``scene/light.cpp`` — ``LightManager::device_update_background`` (the resolution rule),
  ``shade_background_pixels`` (cell centres), ``background_cdf`` (cell value =
  ``average(fabs(rgb))·sin θ(cell centre)``, conditional/marginal CDFs with the totals
  stored in the last entries);
* ``kernel/bake/bake.h`` — ``kernel_background_evaluate`` (the world shader at
  ``equirectangular_to_direction(u, v)``);
* ``kernel/light/background.h`` — ``background_map_sample`` (marginal by ``rand.y``,
  conditional by ``rand.x``, ``std::lower_bound``-style searches, ``inverse_lerp``),
  ``background_map_pdf``;
* ``kernel/sample/mapping.h`` — ``sample_cos_hemisphere``; ``util/math_float3.h`` —
  ``make_orthonormals``.

Orientation (``scene/image_oiio.cpp``: the file is loaded bottom row first, so file row i is
at :math:`v = 1 - (i+\frac12)/H`; :mod:`envfit.maps._conventions`, ``blender``): file pixel
(θ, φ) of envfit is at Blender's :math:`(-\sin\theta\cos\phi, \sin\theta\sin\phi,
\cos\theta)`, envfit's ``up="z"`` frame mirrored in x; :attr:`native_to_world` =
:math:`M_{up}\,\mathrm{diag}(-1, 1, 1)` (for ``up="y"`` a proper rotation: Blender
(x, y, z) = envfit (z, x, y)).
"""
from __future__ import annotations

import numba
import numpy as np

from envfit.base import ParameterError
from envfit.maps._latlong import local_to_world
from envfit.sampling.presets._base import (SPHERE_VIEWS, EnvmapTechnique, RendererPreset,
                                           SamplerSpec, StrategySetting, cosine_hemisphere,
                                           map_rgb, scene_comment, snippet_pixels)

__all__ = ["cycles_map_resolution", "CyclesBackground", "cycles_frame", "INTERPOLATIONS",
           "CYCLES"]

#: the Environment Texture interpolations implemented (Cycles' default is ``linear``)
INTERPOLATIONS = ("linear", "closest")


def cycles_map_resolution(image_size=None, *, sampling: str = "auto",
                          map_resolution: int = 1024, single_sun: bool = False):
    r"""The importance map's (res_x, res_y) as ``device_update_background`` sets it.

    ``sampling="manual"``: (R, R/2) with R = ``map_resolution`` (Blender's sync passes the
    world's *Map Resolution* only for *Manual*). ``"auto"`` (Blender passes 0): the largest
    Environment Texture size (``image_size`` = (width, height)), raised to at least
    4096 × 2048 — unless the world has exactly one Sky Texture sun (``single_sun``: at least
    512 × 256, sun guiding on); 1024 × 512 if still 0.

    >>> cycles_map_resolution((1024, 512)), cycles_map_resolution((8192, 4096))
    ((4096, 2048), (8192, 4096))
    >>> cycles_map_resolution((1024, 512), sampling="manual", map_resolution=1024)
    (1024, 512)
    """
    if sampling == "manual":
        r = int(map_resolution)
        if r < 2:
            raise ParameterError(f"map_resolution must be >= 2, got {map_resolution!r}")
        return r, r // 2
    if sampling != "auto":
        raise ParameterError(f"sampling must be 'auto' or 'manual', got {sampling!r}")
    w, h = (0, 0) if image_size is None else (int(image_size[0]), int(image_size[1]))
    floor = (512, 256) if single_sun else (4096, 2048)
    w, h = max(w, floor[0]), max(h, floor[1])
    return (w, h) if w > 0 and h > 0 else (1024, 512)


def _axis_linear(coord: np.ndarray, n: int):
    """Indices (i0, i1) and weight t of ``interp_linear`` along one periodic axis."""
    x = coord * n - 0.5
    i = np.floor(x).astype(np.int64)
    return i % n, (i + 1) % n, x - i


class CyclesBackground(EnvmapTechnique):
    r"""Cycles' world light with one Environment Texture (equirectangular, Background
    strength ``strength``) and world importance sampling on.

    **Radiance**: the texture at :math:`(u, v)` = ``direction_to_equirectangular(d)``,
    :math:`u = (\mathrm{atan2}(d_y, d_x) - \pi)/(-2\pi)`, :math:`v = 1 - \mathrm{acos}(d_z)/\pi`,
    ``linear`` (default): bilinear at :math:`(uW - \frac12, vH - \frac12)` with both axes
    periodic (``EXTENSION_REPEAT``), or ``closest``: pixel :math:`(\lfloor uW\rfloor,
    \lfloor vH\rfloor)`; Cycles' texture rows run bottom to top.

    **Importance map**: a res_x × res_y grid (:func:`cycles_map_resolution`; ``"auto"`` by
    default: at least 4096 × 2048), cell (x, y) =
    :math:`\frac13\sum_c|L_c(u_x, v_y)|\,\sin(\pi(y + \frac12)/\mathrm{res}_y)` with
    :math:`(u_x, v_y) = ((x + \frac12)/\mathrm{res}_x, (y + \frac12)/\mathrm{res}_y)` — the
    texture point-sampled at the cell centre, no floor.

    **Sampling** (``background_map_sample``): row = ``max(0, lower_bound(marginal, rand.y) −
    1)``, :math:`v = (i_v + d_v)/\mathrm{res}_y`; column likewise with ``rand.x``; pdf
    :math:`f_u f_v / (2\pi^2\sin(\pi v)\,T_u T_v)` with the **sampled** v's sin θ (0 where it
    vanishes).

    >>> from envfit.maps import EnvMap
    >>> t = CyclesBackground(EnvMap(np.full((4, 8, 3), 3.0)), sampling="manual", map_resolution=16)
    >>> d, p = t.sample([[0.3, 0.6]])
    >>> t.eval(d).round(6).tolist(), bool(np.allclose(t.pdf(d), p))
    ([[3.0, 3.0, 3.0]], True)
    """

    name = "cycles"
    renderer = "Cycles 5.0 world light"
    source = ("cycles @ 2eba41024174 (v5.0.0): src/scene/light.cpp {device_update_background, "
              "shade_background_pixels, background_cdf}; src/kernel/light/background.h "
              "{background_map_sample, background_map_pdf}; src/kernel/device/cpu/image.h "
              "interp_linear")

    def __init__(self, envmap, *, sampling: str = "auto", map_resolution: int = 1024,
                 interpolation: str = "linear", strength: float = 1.0):
        if interpolation not in INTERPOLATIONS:
            raise ParameterError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}; "
                                 f"got {interpolation!r}")
        rgb = map_rgb(envmap)
        self.texture = np.ascontiguousarray(rgb[::-1]).astype(np.float32)   # bottom row first
        self.interpolation = interpolation
        self.strength = float(strength)
        h, w = rgb.shape[:2]
        self.res_x, self.res_y = cycles_map_resolution((w, h), sampling=sampling,
                                                       map_resolution=map_resolution)
        self.native_to_world = local_to_world(getattr(envmap, "up", "y")) @ np.diag([-1.0, 1, 1])
        self._build()

    def _cell_values(self) -> np.ndarray:
        """The importance grid's cell values (res_y, res_x): RGB mean of :math:`|L|` at the cell
        centres (separable: u depends on x only, v on y only) times sin θ of the centre."""
        rx, ry = self.res_x, self.res_y
        u = (np.arange(rx) + 0.5) / rx
        v = (np.arange(ry) + 0.5) / ry
        acc = np.zeros((ry, rx), dtype=np.float32)
        tex = self.texture
        h, w = tex.shape[:2]
        if self.interpolation == "closest":
            iy, ix = np.floor(v * h).astype(np.int64) % h, np.floor(u * w).astype(np.int64) % w
            for c in range(3):
                acc += np.abs(tex[iy][:, ix, c])
        else:
            y0, y1, ty = _axis_linear(v, h)
            x0, x1, tx = _axis_linear(u, w)
            tx, ty = tx.astype(np.float32), ty.astype(np.float32)[:, None]
            for c in range(3):
                rows = tex[y0, :, c] * (1 - ty) + tex[y1, :, c] * ty        # (ry, W)
                acc += np.abs(rows[:, x0] * (1 - tx) + rows[:, x1] * tx)
        sin_t = np.sin(np.pi * (np.arange(ry) + 0.5) / ry)
        return (acc / 3.0 * self.strength).astype(np.float64) * sin_t[:, None]

    def _build(self) -> None:
        """``background_cdf`` and the marginal: CDFs normalised to 1, totals kept."""
        f = self._cell_values()
        rx, ry = self.res_x, self.res_y
        self.func = f
        self.row_total = f.sum(axis=1) / rx                                  # cdf_last_u.x
        cdf = np.concatenate([np.zeros((ry, 1)), np.cumsum(f, axis=1) / rx], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cdf = np.where(self.row_total[:, None] > 0, cdf / self.row_total[:, None], cdf)
        cdf[:, -1] = 1.0
        self.total = float(self.row_total.sum() / ry)                        # cdf_last_v.x
        marg = np.concatenate([[0.0], np.cumsum(self.row_total) / ry])
        if self.total > 0:
            marg = marg / self.total
        marg[-1] = 1.0
        self.marg_cdf = marg
        cdf += 2.0 * np.arange(ry)[:, None]          # rows 2 apart: one monotone table
        self._flat = cdf.ravel()
        if not self.total > 0:
            raise ParameterError("the world has no light to sample (all cells are 0)")

    def _texture(self, uv: np.ndarray) -> np.ndarray:
        tex = self.texture
        h, w = tex.shape[:2]
        if self.interpolation == "closest":
            iy = np.floor(uv[:, 1] * h).astype(np.int64) % h
            ix = np.floor(uv[:, 0] * w).astype(np.int64) % w
            return tex[iy, ix].astype(np.float64) * self.strength
        x0, x1, tx = _axis_linear(uv[:, 0], w)
        y0, y1, ty = _axis_linear(uv[:, 1], h)
        tx, ty = tx[:, None], ty[:, None]
        top = tex[y0, x0] * (1 - tx) + tex[y0, x1] * tx
        bot = tex[y1, x0] * (1 - tx) + tex[y1, x1] * tx
        return (top * (1 - ty) + bot * ty) * self.strength

    @staticmethod
    def _uv(d: np.ndarray) -> np.ndarray:
        """``direction_to_equirectangular``."""
        u = (np.arctan2(d[:, 1], d[:, 0]) - np.pi) / (-2.0 * np.pi)
        v = (np.arccos(np.clip(d[:, 2], -1.0, 1.0)) - np.pi) / (-np.pi)
        return np.column_stack([u, v])

    def _eval_native(self, d):
        return self._texture(self._uv(d))

    def _sample_native(self, rand):
        rx, ry = self.res_x, self.res_y
        first = np.searchsorted(self.marg_cdf[:ry], rand[:, 1], side="left")
        iv = np.maximum(0, first - 1)
        c0, c1 = self.marg_cdf[iv], self.marg_cdf[iv + 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            v = (iv + (rand[:, 1] - c0) / (c1 - c0)) / ry
        shifted = rand[:, 0] + 2.0 * iv
        first = np.minimum(np.searchsorted(self._flat, shifted, side="left") - iv * (rx + 1), rx)
        iu = np.maximum(0, first - 1)
        k = iv * (rx + 1) + iu
        c0, c1 = self._flat[k], self._flat[k + 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = (iu + (shifted - c0) / (c1 - c0)) / rx
        phi, theta = np.pi - 2.0 * np.pi * u, np.pi - np.pi * v
        st = np.sin(theta)
        d = np.column_stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)])
        return d, self._pdf_cells(iu, iv, np.sin(np.pi * v))

    def _pdf_cells(self, iu, iv, sin_theta):
        denom = 2.0 * np.pi ** 2 * sin_theta * self.row_total[iv] * self.total
        with np.errstate(invalid="ignore", divide="ignore"):
            pdf = self.func[iv, iu] * self.row_total[iv] / denom
        return np.where((sin_theta == 0) | (denom == 0), 0.0, pdf)

    def _pdf_native(self, d):
        uv = self._uv(d)
        iu = np.clip((uv[:, 0] * self.res_x).astype(np.int64), 0, self.res_x - 1)
        iv = np.clip((uv[:, 1] * self.res_y).astype(np.int64), 0, self.res_y - 1)
        return self._pdf_cells(iu, iv, np.sin(uv[:, 1] * np.pi))

    def bsdf_lookup(self, local: np.ndarray, frame: np.ndarray, fe: float,
                    fb: float) -> tuple[np.ndarray, np.ndarray]:
        r"""The radiance (P, 3) at the world directions ``local @ frame`` and the BSDF
        sample's power-heuristic weight (P,) with the sample fractions ``fe``, ``fb``
        (1 where ``fe`` is 0): :meth:`eval` and ``power_heuristic(cos/π, pdf, fb, fe)`` in
        one compiled pass (the renderer model's hot path; checked against them in the
        tests)."""
        out = np.empty((local.shape[0], 4))
        _cycles_lookup(np.ascontiguousarray(local, dtype=np.float64),
                       np.ascontiguousarray(frame, dtype=np.float64),
                       np.ascontiguousarray(self.native_to_world), self.texture,
                       self.strength, self.interpolation == "linear", self.func,
                       self.row_total, self.total, fe, fb, out)
        return out[:, :3], out[:, 3]


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _cycles_lookup(local, frame, to_native, tex, strength, linear, func, row_total, total,
                   fe, fb, out):  # pragma: no cover - numba
    """:meth:`CyclesBackground.bsdf_lookup`: ``_uv``, ``_texture`` and ``_pdf_native`` per
    point, in the same arithmetic."""
    h, w = tex.shape[0], tex.shape[1]
    ry, rx = func.shape[0], func.shape[1]
    for p in numba.prange(local.shape[0]):
        wx = local[p, 0] * frame[0, 0] + local[p, 1] * frame[1, 0] + local[p, 2] * frame[2, 0]
        wy = local[p, 0] * frame[0, 1] + local[p, 1] * frame[1, 1] + local[p, 2] * frame[2, 1]
        wz = local[p, 0] * frame[0, 2] + local[p, 1] * frame[1, 2] + local[p, 2] * frame[2, 2]
        x = wx * to_native[0, 0] + wy * to_native[1, 0] + wz * to_native[2, 0]
        y = wx * to_native[0, 1] + wy * to_native[1, 1] + wz * to_native[2, 1]
        z = wx * to_native[0, 2] + wy * to_native[1, 2] + wz * to_native[2, 2]
        u = (np.arctan2(y, x) - np.pi) / (-2.0 * np.pi)
        v = (np.arccos(min(max(z, -1.0), 1.0)) - np.pi) / (-np.pi)
        if linear:
            fx = u * w - 0.5
            fy = v * h - 0.5
            ix, iy = np.floor(fx), np.floor(fy)
            tx, ty = fx - ix, fy - iy
            x0, y0 = int(ix) % w, int(iy) % h
            x1, y1 = (x0 + 1) % w, (y0 + 1) % h
            for c in range(3):
                top = np.float64(tex[y0, x0, c]) * (1 - tx) + np.float64(tex[y0, x1, c]) * tx
                bot = np.float64(tex[y1, x0, c]) * (1 - tx) + np.float64(tex[y1, x1, c]) * tx
                out[p, c] = (top * (1 - ty) + bot * ty) * strength
        else:
            x0, y0 = int(np.floor(u * w)) % w, int(np.floor(v * h)) % h
            for c in range(3):
                out[p, c] = np.float64(tex[y0, x0, c]) * strength
        if fe == 0.0:
            out[p, 3] = 1.0
            continue
        iu = min(max(int(u * rx), 0), rx - 1)
        iv = min(max(int(v * ry), 0), ry - 1)
        st = np.sin(v * np.pi)
        denom = 2.0 * np.pi ** 2 * st * row_total[iv] * total
        pe = 0.0 if st == 0.0 or denom == 0.0 else func[iv, iu] * row_total[iv] / denom
        a = (fb * local[p, 2] / np.pi) ** 2
        b = (fe * pe) ** 2
        wgt = a / (a + b)
        out[p, 3] = wgt if np.isfinite(wgt) else 0.0


def cycles_frame(normals) -> np.ndarray:
    r"""Cycles' ``make_orthonormals(N)`` frame (K, 3, 3), rows (T, B, N):
    :math:`a = (N_z - N_y, N_x - N_z, N_y - N_x)` (= (1, 1, 1) × N), or
    :math:`(N_z - N_y, N_x + N_z, -N_y - N_x)` when :math:`N_x = N_y = N_z`;
    :math:`T = a/\lVert a\rVert`,
    B = N × T (``src/util/math_float3.h``), as ``sample_cos_hemisphere`` uses it."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    x, y, z = n[:, 0], n[:, 1], n[:, 2]
    same = (x == y) & (x == z)
    a = np.where(same[:, None], np.column_stack([z - y, x + z, -y - x]),
                 np.column_stack([z - y, x - z, y - x]))
    t = a / np.linalg.norm(a, axis=1)[:, None]
    return np.stack([t, np.cross(n, t), n], axis=1)


# ----------------------------------------------------------------------------- samplers

_C = "cycles @ 2eba4102 (v5.0.0) src/kernel/sample/"
SAMPLERS = {
    "tabulated_sobol": SamplerSpec(
        "tabulated_sobol", "owen", "independent", int,
        "per pixel and dimension: one of 256 fixed 4-D Owen-scrambled Sobol' tables "
        "(hash_shuffle_uint(dimension, 256, pixel seed)) and the sample index Owen-scrambled "
        "(nested_uniform_scramble, seeded per dimension and pixel): its high bits are constant "
        "for the pixel's first 2^m indices, so the N = 2^m points are one aligned block of N "
        "consecutive table entries - a (0, m, 2)-net in the light's (x, y) (checked by re-running "
        "Cycles' generator: bench/cycles_tabulated_sobol_nets.py) - from a finite set of "
        "scrambled nets; the pixel seed is hash_iqnt2d(x, y) ^ scene seed; scrambling "
        "distance 1 (default) adds no shift; spp unchanged. Blender 'TABULATED_SOBOL' "
        "('Classic'); the factory scene's pattern. " + _C + "tabulated_sobol.h", default=True),
    "blue_noise": SamplerSpec(
        "blue_noise", "owen", "independent", int,
        "one Sobol-Burley (Owen-scrambled) sequence shared by all pixels, pixel p using "
        "indices sample + p*N, p a base-4 Owen scramble of its Morton code; Blender "
        "'BLUE_NOISE' (and 'AUTOMATIC' for final renders); spp unchanged. " + _C + "pattern.h "
        "blue_noise_indexing"),
    "sobol_burley": SamplerSpec(
        "sobol_burley", "owen", "independent", int,
        "per pixel Owen-scrambled Sobol' (index shuffled, coordinates scrambled with seeds "
        "from the pixel hash and the dimension); debug UI only; spp unchanged. "
        + _C + "sobol_burley.h"),
}


# ----------------------------------------------------------------------------- integrator

_S = "src/kernel/integrator/shade_surface.h, src/kernel/light/sample.h "
STRATEGIES = {
    "map": StrategySetting(
        "map", False, "path", {}, 1, 0, "plain",
        "light-only (direct_light_sampling_type NEXT_EVENT_ESTIMATION) is read only under "
        "#ifdef WITH_CYCLES_DEBUG: release builds always combine. " + _S),
    "brdf": StrategySetting(
        "brdf", True, "path", {"world.cycles.sampling_method": "NONE"}, 0, 1, "plain",
        "World > Settings > Sampling 'None': the world is not a light, escaped BSDF rays get "
        "weight 1. " + _S),
    "mis": StrategySetting(
        "mis", True, "path", {"world.cycles.sampling_method": "AUTOMATIC"}, 1, 1, "plain",
        "one light (NEE) + one BSDF sample per spp, power_heuristic; importance map at "
        "max(image, 4096 x 2048) under Auto. " + _S),
}


#: the bpy lines that build the measurements' exact sphere (:mod:`envfit.measure.renderers.
#: _cycles`: one vertex → Mesh to Points of radius 1, which Cycles intersects as an analytic
#: sphere) with the white Diffuse BSDF (colour 1, roughness 0: Lambertian)
_SPHERE = """mat = bpy.data.materials.new("white diffuse")
if mat.node_tree is None:
    mat.use_nodes = True
nt = mat.node_tree
nt.nodes.clear()
bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
bsdf.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
bsdf.inputs["Roughness"].default_value = 0.0
nt.links.new(bsdf.outputs["BSDF"], nt.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
mesh = bpy.data.meshes.new("vertex")
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


def _settings(n: int, spp: int, pattern: str) -> str:
    """The render settings of the measurements (:func:`envfit.measure.renderers._cycles.
    _settings`): an n × n film, box filter of width 1, direct light only, no clamping,
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
            f'c.pixel_filter_type = "BOX"\n'
            f"c.filter_width = 1.0\n"
            f"c.max_bounces = c.diffuse_bounces = 1\n"
            f"c.glossy_bounces = c.transmission_bounces = c.volume_bounces = 0\n"
            f"c.transparent_max_bounces = 0\n"
            f"c.sample_clamp_direct = c.sample_clamp_indirect = 0.0\n"
            f"c.use_light_tree = True\n")


def _snippet(s: StrategySetting, spec: SamplerSpec, spp: int, *,
             filename: str = "envmap.exr", sphere_pixels: int | None = None) -> str:
    """A bpy script of the scene envfit predicted, as the measurements build it
    (:mod:`envfit.measure.renderers._cycles`): Blender's empty factory scene, the exact
    sphere with the white Diffuse BSDF, the world's Environment Texture (Linear) straight into
    the Background and its sampling for the strategy, an orthographic camera on each of the
    six :data:`SPHERE_VIEWS` (``view(k)``), a film of :func:`snippet_pixels` pixels with the
    box filter of width 1, direct light only (max bounces 1, diffuse 1, the rest 0: the one
    bounce off a convex sphere escapes to the world), no clamping, denoising or adaptive
    sampling, the light tree on, the pattern and spp (Sobol-Burley only in Cycles' debug UI:
    ``cycles/properties.py``: ``enum_sampling_pattern``)."""
    method = s.settings["world.cycles.sampling_method"]
    n = snippet_pixels(sphere_pixels)
    head = "\n".join(scene_comment("white Diffuse BSDF (colour 1, roughness 0)", sphere_pixels))
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
            f"{_SPHERE}"
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


def _technique(envmap, **options) -> CyclesBackground:
    return CyclesBackground(envmap, **options)


CYCLES = RendererPreset(
    name="cycles",
    renderer="Cycles 5.0 (blender/cycles @ 2eba41024174, v5.0.0), world light + path",
    technique=_technique,
    cosine=cosine_hemisphere,
    tangent_frame=cycles_frame,
    heuristic="power",
    strategies=STRATEGIES,
    samplers=SAMPLERS,
    snippet_fn=_snippet,
    source=("src/scene/light.cpp; src/kernel/light/background.h; src/kernel/sample/mapping.h "
            "sample_cos_hemisphere; src/kernel/sample/mis.h power_heuristic; "
            "src/kernel/sample/tabulated_sobol.h"),
)

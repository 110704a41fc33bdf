r"""A Mitsuba 3 scene file read by Mitsuba itself (``scalar_rgb``) into a
:class:`envfit.renderers._frame.FrameScene`: the first hit of each film point, the shapes as
triangles for shadow rays, the environment map, and the sensor's sampler, film and filter.

What is read, and from where (Mitsuba 3.9.1):

* camera rays: ``Sensor::sample_ray`` with the film position (x + ½…)/W, (y + ½…)/H (no
  aperture, time 0), as ``SamplingIntegrator::render_sample`` draws them
  (``src/render/integrator.cpp``);
* the first hit: ``Scene::ray_intersect``; its shading frame ``si.sh_frame`` (the BSDF's
  frame), geometric normal ``si.n``, the direction to the camera ``si.wi``, and the BSDF's
  diffuse reflectance ``BSDF::eval_diffuse_reflectance`` (textures evaluated by Mitsuba at
  ``si.uv``); for a ``roughconductor`` its specular reflectance there, as Mitsuba's own
  ``BSDF::eval`` towards the normal over the white lobe's value (``RoughConductor::eval``,
  ``src/bsdfs/roughconductor.cpp``: F·D·G/(4 cos θ_i) times ``specular_reflectance``);
* the BSDFs: ``diffuse``, and ``roughconductor`` (isotropic, visible-normal sampling: its
  ``distribution``, ``alpha``, ``eta`` and ``k`` from ``traverse``) as this folder's
  :func:`~envfit.renderers.mitsuba3._bsdf.bsdf` builds it (its Fresnel per RGB channel);
  ``principled`` with uniform parameters from ``traverse`` (a grey ``base_color``,
  ``roughness``, ``metallic``, ``specular``, ``spec_tint``, ``sheen``, ``sheen_tint``,
  ``flatness``; no clear coat, ``spec_trans`` or ``anisotropic``; the default sampling rates)
  as the same function builds it, its lobe choice modelled under ``independent`` only;
* an escaping camera ray: the environment emitter's ``eval`` of the escaped interaction, as
  ``DirectIntegrator::sample`` adds it (``src/integrators/direct.cpp``);
* shadow geometry: meshes' ``vertex_positions`` and ``faces`` (world space, as Mitsuba
  holds them after ``to_world``), a disk as a circumscribed 256-gon, a sphere tessellated from
  its ``to_world`` (an icosphere
  of 20 480 faces, inflated so that no facet cuts inside the true sphere);
* the map: the emitter's own ``data`` tensor (``src/emitters/envmap.cpp`` keeps the bitmap
  with a one-texel halo column on each side; the halo is dropped), its ``to_world`` and
  ``scale``;
* the filter: ``ReconstructionFilter::eval`` and ``radius`` (``src/rfilters/*.cpp``).

Only the ``diffuse``, ``roughconductor`` and ``principled`` BSDFs and one ``envmap`` emitter
are read;
anything else is refused in one line (:class:`envfit.base.ParameterError`) before any work.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.renderers._frame import HIT_SURFACE, FrameBsdf, FrameScene, Occluder, TwoLobes

__all__ = ["read_scene", "SAMPLER_CLASSES"]

#: Mitsuba's sampler classes → their plugin names
SAMPLER_CLASSES = {"IndependentSampler": "independent", "StratifiedSampler": "stratified",
                   "MultijitterSampler": "multijitter", "LowDiscrepancySampler": "ldsampler",
                   "OrthogonalSampler": "orthogonal"}
#: shapes whose own surface never shadows its points' outer side
_CONVEX = ("Sphere", "Rectangle", "Disk", "Cube")


def _class(obj) -> str:
    """The Mitsuba object's class name (its ``to_string`` up to the bracket)."""
    return str(obj).split("[", 1)[0].strip()


def _field(text: str, name: str, default=None):
    """The value of ``name = …`` in a Mitsuba ``to_string``."""
    m = re.search(rf"\b{name}\s*=\s*(-?[0-9]+)", text)
    return int(m.group(1)) if m else default


def _load(mi, path: Path):
    try:
        return mi.load_file(str(path))
    except Exception as exc:                      # Mitsuba's own parse/plugin errors
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ParameterError(f"{path}: Mitsuba cannot load the scene: {first}") from None


def _integrator(scene) -> tuple[str, int, int, int]:
    text = str(scene.integrator())
    cls = _class(scene.integrator())
    if cls == "DirectIntegrator":
        return "direct", _field(text, "emitter_samples", 1), _field(text, "bsdf_samples", 1), 2
    if cls == "PathIntegrator":
        return "path", 1, 1, _field(text, "max_depth", -1)
    raise ParameterError(f"the scene's integrator {cls} is not modelled: use direct or path "
                         f"(the frame model predicts direct lighting from the map)")


def _draws(integrator: str, ne: int, nb: int):
    """The sampler calls of the first emitter and BSDF 2-D draws (``direct`` with one sample
    of each, or ``path``), as the renderer's own strategy records place them
    (:mod:`._envmap`: ``_direct_draws``, ``_path_draws``); None otherwise."""
    from envfit.renderers.mitsuba3._envmap import _direct_draws, _path_draws
    if integrator == "path":
        return tuple(_path_draws()["calls"])
    if integrator == "direct" and ne == 1 and nb == 1:
        return tuple(_direct_draws(1)["calls"])
    return None


def _emitter(mi, scene):
    ems = list(scene.emitters())
    kinds = [_class(e) for e in ems]
    if kinds.count("EnvironmentMapEmitter") != 1 or len(ems) != 1:
        raise ParameterError(f"the frame model needs exactly one emitter, an envmap; the scene "
                             f"has {', '.join(kinds) or 'none'}")
    params = mi.traverse(scene)
    prefix = next(k[:-len(".data")] for k in params.keys()
                  if k.endswith(".data") and f"{k[:-len('.data')]}.scale" in params.keys())
    data = np.array(params[prefix + ".data"], dtype=np.float64)[:, 1:-1, :3]
    m = np.array(params[prefix + ".to_world"].matrix, dtype=np.float64)[:3, :3]
    return ems[0], data, m, float(params[prefix + ".scale"])


def _icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere: ``level`` subdivisions of the icosahedron (vertices on the sphere)."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
                  (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)],
                 dtype=np.float64)
    f = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9),
                  (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2),
                  (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
                  (8, 6, 7), (9, 8, 1)], dtype=np.int64)
    v /= np.linalg.norm(v, axis=1)[:, None]
    for _ in range(level):
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        key = np.sort(edges, axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        m = len(v) + inv.reshape(3, -1)                 # the midpoints of edges 01, 12, 20
        v = np.concatenate([v, mid])
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        ab, bc, ca = m[0], m[1], m[2]
        f = np.concatenate([np.column_stack(x) for x in
                            ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    return v, f


def _occluder(mi, params, shape, index: int) -> Occluder:
    cls = _class(shape)
    if shape.is_mesh():
        v = np.array(shape.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
        f = np.array(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        return Occluder(cls, v, f, cls in _CONVEX)
    if cls == "Sphere":
        key = next(k for k in params.keys() if k.endswith(".to_world")
                   and params[k] is not None and _sphere_match(params, k, shape))
        m = np.array(params[key].matrix, dtype=np.float64)
        v, f = _icosphere(5)
        # inflated so that every facet lies outside the true sphere (its centroid, the facet's
        # point nearest the centre for these near-equilateral facets, at radius ≥ 1): a
        # shadow is never missed through a facet; the sag of level 5 is ≈ 3·10⁻⁴ of the radius
        v = v / np.linalg.norm(v[f].mean(axis=1), axis=1).min() * (1.0 + 1e-6)
        return Occluder(cls, v @ m[:3, :3].T + m[:3, 3], f, True)
    if cls == "Disk":
        key = next(k for k in params.keys() if k.endswith(".to_world")
                   and params[k] is not None and _disk_match(params, k, shape))
        m = np.array(params[key].matrix, dtype=np.float64)
        n = 256                            # circumscribed: the polygon covers the disk
        t = 2 * np.pi * np.arange(n) / n
        rim = np.column_stack([np.cos(t), np.sin(t), np.zeros(n)]) / np.cos(np.pi / n)
        v = np.vstack([np.zeros((1, 3)), rim])
        f = np.column_stack([np.zeros(n, np.int64), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n])
        return Occluder(cls, v @ m[:3, :3].T + m[:3, 3], f, True)
    raise ParameterError(f"shape {index} ({cls}) cannot be made into triangles for shadow "
                         f"rays: use a mesh (obj, ply, rectangle, cube), a sphere or a disk")


def _disk_match(params, key, shape) -> bool:
    """Whether the ``to_world`` at ``key`` is this disk's: the unit disk in z = 0 mapped to
    its bounding box's centre and half-extents."""
    m = np.array(params[key].matrix, dtype=np.float64)
    bb = shape.bbox()
    c = (np.array(bb.min) + np.array(bb.max)) / 2
    r = (np.array(bb.max) - np.array(bb.min)) / 2
    half = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
    return bool(np.allclose(m[:3, 3], c, atol=1e-5 * (1 + abs(r).max()))
                and np.allclose(half, r, rtol=1e-3, atol=1e-5 * (1 + abs(r).max())))


def _sphere_match(params, key, shape) -> bool:
    """Whether the ``to_world`` at ``key`` is this sphere's (its bounding box agrees)."""
    m = np.array(params[key].matrix, dtype=np.float64)
    bb = shape.bbox()
    c = (np.array(bb.min) + np.array(bb.max)) / 2
    r = (np.array(bb.max) - np.array(bb.min)) / 2
    return bool(np.allclose(m[:3, 3], c, atol=1e-5 * (1 + abs(r).max()))
                and np.allclose(np.linalg.norm(m[:3, :3], axis=0), r, rtol=1e-4))


#: a glossy lobe's tables are this many levels finer than the diffuse ones, by its α: the
#: lobe must span enough cells of the BSDF technique's grid (chosen on the renders of
#: bench/frame_check.py's ``gloss`` scene)
_GLOSS_LEVELS = ((0.05, 3), (0.15, 2), (1.0, 1))


def _conductor(mi, b, where: str) -> FrameBsdf:
    """Mitsuba's ``roughconductor`` as a :class:`FrameBsdf` (``roughconductor.cpp``)."""
    from envfit.renderers.mitsuba3._bsdf import bsdf
    text = str(b)
    params = mi.traverse(b)
    if "alpha.value" not in params.keys():
        raise ParameterError(f"{where} has an anisotropic or textured roughness: the frame "
                             f"model reads an isotropic roughconductor (one alpha)")
    if not _field(text, "sample_visible", 1):
        raise ParameterError(f"{where} samples the full microfacet distribution "
                             f"(sample_visible false): the frame model reads visible-normal "
                             f"sampling, Mitsuba's default")
    dist = re.search(r"distribution\s*=\s*(\w+)", text).group(1)
    alpha = max(float(params["alpha.value"]), 1e-4)
    eta, k = (np.broadcast_to(np.atleast_1d(np.asarray(params[f"{x}.value"], dtype=np.float64)),
                              (3,)) for x in ("eta", "k"))
    lobe = bsdf(dist, alpha)
    white = bool(np.all(eta == 0.0) and np.all(k == 1.0))          # material "none": F = 1
    channels = [bsdf(dist, alpha, eta=float(e), k=float(kk)) for e, kk in zip(eta, k)]

    def fresnel(cos):
        return np.stack([c.fresnel(cos) for c in channels], axis=-1)

    extra = next(e for a, e in _GLOSS_LEVELS if alpha <= a)
    return FrameBsdf("glossy", f"roughconductor ({dist}, alpha {alpha:g})", lobe,
                     None if white else fresnel, extra)


#: ``principled``'s parameters that must be 0 (lobes or anisotropy the model does not have)
#: and its sampling rates that must be 1
_PRINCIPLED_ZERO = ("clearcoat", "spec_trans", "anisotropic")
_PRINCIPLED_RATES = ("main_specular_sampling_rate", "clearcoat_sampling_rate",
                     "diffuse_reflectance_sampling_rate")


def _principled(mi, b, where: str) -> FrameBsdf:
    """Mitsuba's ``principled`` as a :class:`FrameBsdf` (``principled.cpp``; the BSDF is
    :func:`~envfit.renderers.mitsuba3._bsdf.bsdf`'s): uniform parameters, a grey base colour,
    no clear coat, transmission or anisotropy, the default sampling rates."""
    from envfit.renderers.mitsuba3._bsdf import PRINCIPLED_PARAMS, PRINCIPLED_ROUGHNESS, bsdf
    params = mi.traverse(b)
    keys = set(params.keys())

    def value(name):
        if f"{name}.value" not in keys:
            raise ParameterError(f"{where} has a textured principled {name}: the frame model "
                                 f"reads uniform principled parameters")
        v = np.atleast_1d(np.asarray(params[f"{name}.value"], dtype=np.float64))
        if np.ptp(v) > 0:
            raise ParameterError(f"{where} has a coloured principled {name} {v.tolist()}: the "
                                 f"frame model reads a grey one")
        return float(v[0])

    for name in _PRINCIPLED_ZERO:
        if value(name) != 0.0:
            raise ParameterError(f"{where} has principled {name} {value(name):g}: the frame "
                                 f"model reads the diffuse and specular lobes only")
    for name in _PRINCIPLED_RATES:
        if float(params[name]) != 1.0:
            raise ParameterError(f"{where} sets principled {name}: the frame model reads the "
                                 f"default rates")
    if "specular" not in keys:
        raise ParameterError(f"{where} gives principled eta: the frame model reads specular")
    kw = {k: value(k) for k in PRINCIPLED_PARAMS if k not in ("roughness", "specular")}
    kw["specular"] = float(params["specular"])
    lobe = bsdf("principled", PRINCIPLED_ROUGHNESS.to_alpha(value("roughness")), **kw)
    extra = next(e for a, e in _GLOSS_LEVELS if lobe.alpha <= a)
    return FrameBsdf("glossy", f"principled ({lobe!r})", TwoLobes(lobe), None, extra,
                     lobes=2)


def _frame_bsdfs(mi, shapes) -> tuple:
    """Each shape's :class:`FrameBsdf`; a BSDF or emitter the model does not read is refused."""
    out = []
    for i, sh in enumerate(shapes):
        b = sh.bsdf()
        cls = _class(b)
        where = f"shape {i} ({_class(sh)})"
        if sh.emitter() is not None:
            raise ParameterError(f"{where} is an area emitter: the frame model "
                                 f"predicts lighting from the environment map only")
        if cls == "SmoothDiffuse":
            out.append(FrameBsdf("diffuse", "diffuse"))
        elif cls == "RoughConductor":
            out.append(_conductor(mi, b, where))
        elif str(b).startswith("Principled BSDF"):
            out.append(_principled(mi, b, where))
        else:
            raise ParameterError(f"{where} has the BSDF {cls}: the frame model reads the "
                                 f"diffuse, roughconductor and principled BSDFs only so far")
    return tuple(out)


class _Camera:
    """First hits of camera rays at film positions, by Mitsuba (``Sensor::sample_ray``,
    ``Scene::ray_intersect``)."""

    def __init__(self, mi, scene, sensor, emitter, bsdfs=()):
        self.mi, self.scene, self.sensor, self.emitter = mi, scene, sensor, emitter
        self.shapes = list(scene.shapes())
        self.bsdfs = bsdfs
        self.w, self.h = (int(x) for x in sensor.film().size())

    def _ray(self, x: float, y: float):
        mi = self.mi
        ray, _ = self.sensor.sample_ray(0.0, 0.5, mi.Point2f(x / self.w, y / self.h),
                                        mi.Point2f(0.5, 0.5))
        return ray

    def _index(self, shape) -> int:
        return next((i for i, s in enumerate(self.shapes) if s is shape), -1)

    def hits(self, xy: np.ndarray) -> dict:
        """The first hit of the camera ray at each film position ``xy`` (P, 2) in pixels
        (x right, y down): the arrays of :class:`~envfit.renderers._frame.FrameScene`,
        shape (P, …)."""
        p = len(xy)
        out = {"kind": np.zeros(p, np.int8), "position": np.zeros((p, 3)),
               "normal": np.zeros((p, 3)), "geo_normal": np.zeros((p, 3)),
               "tangent": np.zeros((p, 3, 3)), "wi": np.zeros((p, 3)),
               "albedo": np.zeros((p, 3)),
               "facing": np.zeros(p, bool), "shape": np.full(p, -1, np.int64),
               "background": np.zeros((p, 3))}
        up = self.mi.Vector3f(0.0, 0.0, 1.0)
        for k, (x, y) in enumerate(np.asarray(xy, dtype=np.float64).tolist()):
            ray = self._ray(x, y)
            si = self.scene.ray_intersect(ray)
            if not si.is_valid():
                out["background"][k] = tuple(self.emitter.eval(si))[:3]
                continue
            fr = si.sh_frame
            n, ng, d = tuple(fr.n), tuple(si.n), tuple(ray.d)
            if ng[0] * d[0] + ng[1] * d[1] + ng[2] * d[2] > 0:
                ng = (-ng[0], -ng[1], -ng[2])
            out["kind"][k] = HIT_SURFACE
            out["position"][k] = tuple(si.p)
            out["normal"][k] = n
            out["geo_normal"][k] = ng
            out["tangent"][k] = (tuple(fr.s), tuple(fr.t), n)
            out["facing"][k] = si.wi[2] > 0.0
            out["wi"][k] = tuple(si.wi)
            shape = out["shape"][k] = self._index(si.shape)
            if self._glossy(shape):
                if si.wi[2] > 0.0:                              # Mitsuba's eval to the normal
                    out["albedo"][k] = tuple(si.bsdf().eval(self.mi.BSDFContext(), si, up))[:3]
            else:
                out["albedo"][k] = tuple(si.bsdf().eval_diffuse_reflectance(si, True))[:3]
        self._specular(out)
        return out

    def _glossy(self, shape: int) -> bool:
        return 0 <= shape < len(self.bsdfs) and self.bsdfs[shape].kind == "glossy"

    def _specular(self, out: dict) -> None:
        """A glossy hit's specular reflectance (textures included): Mitsuba's ``eval``
        towards the normal (in ``albedo``) over the white lobe's there, times its Fresnel."""
        for shape in np.unique(out["shape"]):
            if not self._glossy(int(shape)):
                continue
            b = self.bsdfs[int(shape)]
            sel = np.flatnonzero((out["shape"] == shape) & (out["wi"][:, 2] > 0.0))
            wi = out["wi"][sel]
            wo = np.broadcast_to([0.0, 0.0, 1.0], wi.shape)
            m = wi + wo
            m /= np.linalg.norm(m, axis=1, keepdims=True)
            ref = b.lobe.eval(wi, wo)[:, None] * (
                b.fresnel(np.sum(wi * m, axis=1)) if b.fresnel is not None else 1.0)
            val = out["albedo"][sel]
            out["albedo"][sel] = np.where(ref > 0, val / np.where(ref > 0, ref, 1.0), 0.0)

    def rays(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The camera rays at film positions ``xy`` (P, 2): origins (P, 3) and directions
        (P, 3) divided by their component along the camera's axis."""
        axis = np.array(self.sensor.world_transform().matrix, dtype=np.float64)[:3, 2]
        axis /= np.linalg.norm(axis)
        org, dirs = np.zeros((len(xy), 3)), np.zeros((len(xy), 3))
        for k, (x, y) in enumerate(np.asarray(xy, dtype=np.float64).tolist()):
            ray = self._ray(x, y)
            org[k], dirs[k] = tuple(ray.o), tuple(ray.d)
        return org, dirs / (dirs @ axis)[:, None]


def read_scene(path) -> FrameScene:
    """The :class:`~envfit.renderers._frame.FrameScene` of the Mitsuba 3 scene file ``path``.

    Raises :class:`envfit.base.ParameterError` (one line) for a file Mitsuba cannot load, a
    scene without exactly one ``envmap`` emitter, a BSDF other than ``diffuse`` and an
    isotropic ``roughconductor`` with visible-normal sampling, an area
    emitter, or an integrator other than ``direct``/``path``."""
    from envfit.renderers.mitsuba3._render import import_mitsuba
    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"{path}: no such scene file")
    mi = import_mitsuba()
    scene = _load(mi, path)
    sensors = list(scene.sensors())
    if len(sensors) != 1:
        raise ParameterError(f"the scene has {len(sensors)} sensors: the frame model reads one")
    sensor = sensors[0]
    integ, ne, nb, depth = _integrator(scene)
    emitter, data, to_world, scale = _emitter(mi, scene)
    shapes = list(scene.shapes())
    bsdfs = _frame_bsdfs(mi, shapes)
    params = mi.traverse(scene)
    occ = tuple(_occluder(mi, params, s, i) for i, s in enumerate(shapes))
    sampler = sensor.sampler()
    cls = _class(sampler)
    if cls not in SAMPLER_CLASSES:
        raise ParameterError(f"the sampler {cls} is not one of Mitsuba's "
                             f"{', '.join(SAMPLER_CLASSES.values())}")
    if SAMPLER_CLASSES[cls] != "independent" and any(b.lobes > 1 for b in bsdfs):
        raise ParameterError(f"a principled BSDF under {SAMPLER_CLASSES[cls]}: the frame model "
                             f"predicts its lobe choice under the independent sampler so far")
    rf = sensor.film().rfilter()
    fname = _class(rf).replace("Filter", "").lower()
    radius = float(rf.radius())
    notes = []
    if integ == "path" and depth not in (2,):
        notes.append(f"path with max_depth {depth}: its direct lighting from the map is "
                     f"predicted, not the longer paths")
    cam = _Camera(mi, scene, sensor, emitter, bsdfs)
    draws = _draws(integ, ne, nb)
    return FrameScene(
        path=str(path), renderer="mitsuba3", size=tuple(int(x) for x in sensor.film().size()),
        occluders=occ, envmap_data=data, envmap_to_world=to_world,
        envmap_scale=scale, sampler=SAMPLER_CLASSES[cls], spp=int(sampler.sample_count()),
        integrator=integ, emitter_samples=ne, bsdf_samples=nb, max_depth=depth,
        filter_name=fname, filter_radius=radius,
        filter_weights=np.vectorize(lambda t: float(rf.eval(float(t))), otypes=[float]),
        hits_at=cam.hits, rays_at=cam.rays,
        notes=tuple(notes), bsdfs=bsdfs, draws=draws)

r"""pbrt-v4's image infinite light (``ImageInfiniteLight``) on an equal-area square map, its
``imgtool makeequiarea`` conversion of a lat-long map, and its ``path`` integrator, in numpy.

Read from mmp/pbrt-v4 at ``5f7a606806a4`` (no release tag):

* ``src/pbrt/util/math.cpp`` — ``EqualAreaSquareToSphere``, ``EqualAreaSphereToSquare``
  (Clarberg's octahedral equal-area map; the inverse with pbrt's 6th-degree minimax
  polynomial for :math:`\frac2\pi\arctan`), ``WrapEqualAreaSquare``;
* ``src/pbrt/lights.cpp`` / ``lights.h`` — ``ImageInfiniteLight::ImageInfiniteLight`` (the
  plain and the *compensated* distribution), ``SampleLi``, ``PDF_Li``, ``ImageLe``;
* ``src/pbrt/util/image.h`` — ``GetSamplingDistribution`` (pixel value = mean of its
  channels), ``LookupNearestChannel``, ``RemapPixelCoords`` (``WrapMode::OctahedralSphere``),
  ``BilerpChannel``;
* ``src/pbrt/util/sampling.h`` — ``PiecewiseConstant1D``, ``PiecewiseConstant2D``
  (``Sample``: rows by ``u[1]``, columns by ``u[0]``; ``PDF``), ``SampleCosineHemisphere``;
* ``src/pbrt/cmd/imgtool.cpp`` — ``makeequiarea``; ``src/pbrt/filters.h``/``filters.cpp``
  — ``GaussianFilter``, ``FilterSampler``;
* ``src/pbrt/cpu/integrators.cpp`` — ``PathIntegrator::SampleLd``/``Li``,
  ``SimplePathIntegrator::Li``; ``src/pbrt/lightsamplers.cpp`` — ``BVHLightSampler`` (an
  infinite light has no bounds, so with no other light the BVH is empty and
  ``pInfinite`` = 1).

Orientation: ``makeequiarea`` reads the lat-long file with pbrt-v3's convention,
:math:`\theta` = ``SphericalTheta(dir)`` = acos z, :math:`\phi` = ``SphericalPhi(dir)`` =
atan2(y, x) ∈ [0, 2π), looked up at :math:`(\phi/2\pi, \theta/\pi)` with texel-centred
bilinear ``Bilerp`` — envfit's *local* frame (``up="z"``) of the same file. So the light's
frame maps to envfit's world by :math:`M_{up}` (:func:`envfit.maps._latlong.local_to_world`);
with ``up="z"`` the two coincide. A user's own square equal-area image is taken in the light
frame (``up="z"``).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.base import ParameterError
from envfit.maps import local_to_world
from envfit.renderers._base import (SPHERE_VIEWS, DirectionSample, EnvmapTechnique,
                                           Renderer, SamplerSpec, StrategySetting,
                                           cosine_hemisphere, scene_comment, snippet_pixels,
                                           square_points)
from envfit.renderers.pbrt4._bsdf import ROUGHNESS, bsdf
from envfit.renderers.pbrt4._equal_area import (_ATAN_POLY, PiecewiseConstant2D,
                                                  equal_area_sphere_to_square,
                                                  equal_area_square_to_sphere, make_equal_area)

__all__ = ["Pbrt4ImageInfiniteLight", "pbrt_sphere_frame", "PBRT4"]

# ----------------------------------------------------------------------------- the light

def _octahedral_nearest(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``LookupNearestChannel(uv, c, WrapMode::OctahedralSphere)``: pixel
    (int(u·N), int(v·N)), remapped across the square's edges (``RemapPixelCoords``)."""
    ny, nx = img.shape[:2]
    x = (uv[:, 0] * nx).astype(np.int64)
    y = (uv[:, 1] * ny).astype(np.int64)
    flip = (x < 0) | (x >= nx)
    x = np.where(x < 0, -x, np.where(x >= nx, 2 * nx - 1 - x, x))
    y = np.where(flip, ny - 1 - y, y)
    flip = (y < 0) | (y >= ny)
    x = np.where(flip, nx - 1 - x, x)
    y = np.where(y < 0, -y, np.where(y >= ny, 2 * ny - 1 - y, y))
    return img[np.clip(y, 0, ny - 1), np.clip(x, 0, nx - 1)]


def _compensated(d: np.ndarray) -> np.ndarray:
    """The constructor's compensated function: max(v − mean, 0); all ones if all vanish."""
    c = np.maximum(d - d.mean(), 0.0)
    return c if np.any(c != 0) else np.ones_like(d)


class Pbrt4ImageInfiniteLight(EnvmapTechnique):
    r"""pbrt-v4's ``ImageInfiniteLight`` (``infinite`` light with ``filename``).

    **Image**: a square equal-area image, either the user's (``equal_area=``, (N, N, 3),
    in the light frame) or :func:`make_equal_area` of ``envmap`` (``resolution`` = N,
    default the lat-long width). A non-square image is refused, as pbrt refuses it.

    **Radiance** (``ImageLe``): the nearest pixel at :func:`equal_area_sphere_to_square`
    of the direction (``WrapMode::OctahedralSphere``), clamped at 0, times ``scale``.

    **Density**: :class:`PiecewiseConstant2D` over the pixels, value = the mean of the
    pixel's channels (``GetSamplingDistribution``), no sin θ (equal areas), no floor;
    ``compensated=True`` (default: what ``PathIntegrator`` samples and weights with,
    ``allowIncompletePDF = true``) uses max(v − mean, 0) instead (ones if all vanish); the
    ``simplepath`` integrator samples the plain one (``compensated=False``). Solid-angle pdf
    = mapPDF/(4π).

    >>> from envfit.maps import EnvMap
    >>> t = Pbrt4ImageInfiniteLight(equal_area=np.ones((4, 4, 3)), compensated=False)
    >>> d, p = t.sample([[0.3, 0.6]])
    >>> bool(np.isclose(p[0], 1 / (4 * np.pi))), t.eval(d).tolist()
    (True, [[1.0, 1.0, 1.0]])
    """

    name = "pbrt4"
    renderer = "pbrt-v4 ImageInfiniteLight"
    source = ("pbrt-v4 @ 5f7a606806a4: src/pbrt/lights.cpp ImageInfiniteLight::"
              "{ImageInfiniteLight, PDF_Li}; src/pbrt/lights.h ImageInfiniteLight::{SampleLi, "
              "ImageLe}; src/pbrt/util/math.cpp EqualArea*; src/pbrt/cmd/imgtool.cpp makeequiarea")

    def __init__(self, envmap=None, *, equal_area=None, resolution: int | None = None,
                 compensated: bool = True, scale: float = 1.0):
        if (envmap is None) == (equal_area is None):
            raise ParameterError("give either a lat-long envmap or an equal_area image")
        if equal_area is not None:
            img = np.asarray(equal_area, dtype=np.float64)
            img = img[:, :, None] if img.ndim == 2 else img
            self.native_to_world = np.eye(3)
        else:
            img = make_equal_area(envmap, resolution)
            self.native_to_world = local_to_world(getattr(envmap, "up", "y"))
        if img.ndim != 3 or img.shape[0] != img.shape[1] or not np.all(np.isfinite(img)):
            raise ParameterError(f"pbrt-v4 needs a finite square equal-area image; got shape "
                                 f"{img.shape} (it is unlikely to be an equal-area map)")
        self.image = np.repeat(img, 3, axis=2) if img.shape[2] == 1 else img[:, :, :3]
        self.scale = float(scale)
        self.compensated = bool(compensated)
        d = img.mean(axis=2)                      # GetChannels({x, y}).Average()
        self.plain = PiecewiseConstant2D(d)
        self.compensated_distribution = PiecewiseConstant2D(_compensated(d))
        self.distribution = self.compensated_distribution if compensated else self.plain

    def _eval_native(self, d):
        uv = equal_area_sphere_to_square(d)
        return np.maximum(_octahedral_nearest(self.image, uv), 0.0) * self.scale

    def _sample_native(self, u):
        uv, map_pdf = self.distribution.sample(u)
        return equal_area_square_to_sphere(uv), map_pdf / (4.0 * np.pi)

    def sample_radiance(self, u):
        """``SampleLi``: directions, pdf and the radiance ``ImageLe(uv)`` at the **sampled**
        uv (not re-derived from the direction, whose polynomial inverse can land in a
        neighbouring pixel within ~2e-6 of an edge)."""
        uv, map_pdf = self.distribution.sample(square_points(u))
        d = equal_area_square_to_sphere(uv) @ self.native_to_world.T
        le = np.maximum(_octahedral_nearest(self.image, uv), 0.0) * self.scale
        return DirectionSample(d, map_pdf / (4.0 * np.pi)), le

    def _pdf_native(self, d):
        return self.distribution.pdf(equal_area_sphere_to_square(d)) / (4.0 * np.pi)

    def bsdf_lookup(self, local: np.ndarray, frame: np.ndarray, fe: float,
                    fb: float) -> tuple[np.ndarray, np.ndarray]:
        r"""The radiance (P, 3) at the world directions ``local @ frame`` and the BSDF
        sample's power-heuristic weight (P,) with the sample fractions ``fe``, ``fb``
        (1 where ``fe`` is 0): :meth:`eval` and ``power_heuristic(cos/π, pdf, fb, fe)`` in
        one compiled pass (the renderer model's hot path; checked against them in the
        tests)."""
        return self._lookup(local, frame, None, fe, fb)

    def eval_pdf(self, dirs: np.ndarray, rows=None, skip=None) -> tuple[np.ndarray, np.ndarray]:
        """(radiance (P, 3), light pdf (P,)) at unit directions ``dirs`` (world, or local with
        the frame's ``rows``: world = local @ rows), 0 and 0 where ``skip`` ≤ 0:
        :meth:`eval` and :meth:`pdf` in one compiled pass (the microfacet model's hot path;
        checked against them in the tests)."""
        return self._lookup(dirs, np.eye(3) if rows is None else rows, skip, -1.0, 0.0)

    def _lookup(self, local, frame, skip, fe: float, fb: float):
        """:func:`_pbrt4_lookup`: the radiance and, with ``fe`` ≥ 0, the BSDF sample's weight,
        with ``fe`` < 0 the light's pdf."""
        out = np.empty((local.shape[0], 4))
        dist = self.distribution
        m = np.ascontiguousarray(np.asarray(frame, dtype=np.float64) @ self.native_to_world)
        skip = np.zeros(0) if skip is None else np.ascontiguousarray(skip, dtype=np.float64)
        _pbrt4_lookup(np.ascontiguousarray(local, dtype=np.float64), m,
                      np.ascontiguousarray(self.image, dtype=np.float64),
                      np.array(_ATAN_POLY[::-1]), dist.func,
                      np.array([self.scale, dist.integral, fe, fb]), skip, out)
        return out[:, :3], out[:, 3]


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _pbrt4_lookup(local, m, img, poly, func, consts, skip, out):  # pragma: no cover - numba
    """:meth:`Pbrt4ImageInfiniteLight.bsdf_lookup` at the native directions ``local @ m``:
    ``equal_area_sphere_to_square``, ``_octahedral_nearest`` and ``PiecewiseConstant2D.pdf``
    per point, in the same arithmetic (``poly``: the arctangent polynomial, highest degree
    first; ``consts``: scale, the distribution's integral, the fractions fe, fb; fe < 0:
    the pdf to ``out[:, 3]`` instead of the weight (:meth:`eval_pdf`), 0 and 0 where
    ``skip`` ≤ 0)."""
    scale, integral, fe, fb = consts[0], consts[1], consts[2], consts[3]
    ny, nx = img.shape[0], img.shape[1]
    fy, fx = func.shape[0], func.shape[1]
    for p in numba.prange(local.shape[0]):
        if skip.shape[0] > 0 and skip[p] <= 0.0:
            out[p, 0], out[p, 1], out[p, 2], out[p, 3] = 0.0, 0.0, 0.0, 0.0
            continue
        dx = local[p, 0] * m[0, 0] + local[p, 1] * m[1, 0] + local[p, 2] * m[2, 0]
        dy = local[p, 0] * m[0, 1] + local[p, 1] * m[1, 1] + local[p, 2] * m[2, 1]
        dz = local[p, 0] * m[0, 2] + local[p, 1] * m[1, 2] + local[p, 2] * m[2, 2]
        ax, ay, az = abs(dx), abs(dy), abs(dz)
        r = np.sqrt(max(1.0 - az, 0.0))
        a, b = max(ax, ay), min(ax, ay)
        b = 0.0 if a == 0.0 else b / a
        phi = 0.0
        for c in poly:
            phi = phi * b + c
        if ax < ay:
            phi = 1.0 - phi
        v = phi * r
        u = r - v
        if dz < 0:
            u, v = 1.0 - v, 1.0 - u
        u = np.copysign(u, dx)
        v = np.copysign(v, dy)
        u, v = 0.5 * (u + 1.0), 0.5 * (v + 1.0)
        x, y = int(u * nx), int(v * ny)
        if x < 0 or x >= nx:
            x = -x if x < 0 else 2 * nx - 1 - x
            y = ny - 1 - y
        if y < 0 or y >= ny:
            x = nx - 1 - x
            y = -y if y < 0 else 2 * ny - 1 - y
        x, y = min(max(x, 0), nx - 1), min(max(y, 0), ny - 1)
        for c in range(3):
            out[p, c] = max(img[y, x, c], 0.0) * scale
        if fe == 0.0:
            out[p, 3] = 1.0
            continue
        iu = min(max(int(u * fx), 0), fx - 1)
        iv = min(max(int(v * fy), 0), fy - 1)
        pe = func[iv, iu] / integral / (4.0 * np.pi) if integral > 0 else 0.0
        if fe < 0.0:
            out[p, 3] = pe
            continue
        aa = (fb * local[p, 2] / np.pi) ** 2
        bb = (fe * pe) ** 2
        wgt = aa / (aa + bb)
        out[p, 3] = wgt if np.isfinite(wgt) else 0.0


def pbrt_sphere_frame(normals) -> np.ndarray:
    r"""pbrt-v4's BSDF shading frame on a ``sphere`` shape (K, 3, 3), rows (x, y, n):
    ``Frame::FromXZ(Normalize(dpdu), n)`` (``src/pbrt/bsdf.h``, ``BSDF::BSDF``) with the
    sphere's :math:`\partial p/\partial u \propto (-n_y, n_x, 0)` in object space
    (``src/pbrt/shapes.h``, ``Sphere::InteractionFromIntersection``), y = n × x. Undefined at
    the poles n = ±z (pbrt's dpdu vanishes there; the x axis is returned)."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    x = np.column_stack([-n[:, 1], n[:, 0], np.zeros(len(n))])
    ln = np.linalg.norm(x, axis=1)
    x = np.where(ln[:, None] > 0, x / np.where(ln > 0, ln, 1.0)[:, None], [1.0, 0.0, 0.0])
    return np.stack([x, np.cross(n, x), n], axis=1)


# ----------------------------------------------------------------------------- samplers

def _floor_pow2(n: int) -> int:
    """``ZSobolSampler::SamplesPerPixel`` = 1 << Log2Int(spp) (a power of two, rounded down)."""
    return 1 << (int(n).bit_length() - 1)


def _grid(n: int) -> tuple[int, int]:
    """``StratifiedSampler::Create`` with ``--spp n``: y = the largest divisor d ≤ √n,
    x = n/d."""
    d = int(np.sqrt(n))
    while n % d:
        d -= 1
    return n // d, d



def pbrt_strata(n: int) -> tuple[int, int]:
    """pbrt-v4's ``StratifiedSampler::Create`` with spp ``n``: (x, y), y = the largest
    divisor of n at most √n, x = n/y (``src/pbrt/samplers.cpp``; ``samplers.h``:
    ``StratifiedSampler::Get2D``, ``(x + dx)/xPixelSamples``: x along u_0).

    >>> pbrt_strata(2048), pbrt_strata(7), pbrt_strata(16)
    ((64, 32), (7, 1), (4, 4))
    """
    d = math.isqrt(n)
    while n % d:
        d -= 1
    return n // d, d


def _xy_strata(n: int) -> tuple:
    """``stratified``'s x × y strata (:func:`pbrt_strata`: x = N/d, d the largest divisor
    ≤ √N): the ``jittered`` model's ``strata`` option."""
    return (("strata", pbrt_strata(n)),)

_P = "pbrt-v4 @ 5f7a6068 src/pbrt/samplers.h/.cpp "
SAMPLERS = {
    "zsobol": SamplerSpec(
        "zsobol", "owen", "independent", _floor_pow2,
        "Sobol' dims 0,1 at the pixel's Morton-ordered block of indices (base-4 digits "
        "permuted), FastOwen-scrambled with Hash(dimension, seed) - the scramble is shared by "
        "all pixels; spp -> 2^floor(log2 spp). " + _P + "ZSobolSampler", default=True),
    "paddedsobol": SamplerSpec(
        "paddedsobol", "owen", "independent", int,
        "per pixel and dimension an independently FastOwen-scrambled first-spp Sobol' net "
        "in a hashed order; spp unchanged (warns if not a power of two). "
        + _P + "PaddedSobolSampler::Get2D (PermutationElement(sampleIndex, samplesPerPixel): "
        "any spp is the net's first spp points)", prefix=True),
    "sobol": SamplerSpec(
        "sobol", "owen", "independent", int,
        "one global Sobol' sequence over the image, dimension-seeded FastOwen scramble "
        "shared by all pixels; spp unchanged. " + _P + "SobolSampler",
        unmodelled="a pixel's samples are a run of one image-wide Sobol' sequence "
        "(SobolIntervalToIndex), whose dimensions 2 and up are not a per-pixel net: rendered, "
        "its error measured 1.15-2.5x envfit's per-pixel Owen model (bench/pbrt4_check.py)"),
    "pmj02bn": SamplerSpec(
        "pmj02bn", "cp_shift", "independent", int,
        "precomputed pmj02bn sets, Cranley-Patterson rotated by BlueNoise(dimension, pixel); "
        "spp unchanged (warns unless a power of 4). " + _P + "PMJ02BNSampler"),
    "halton": SamplerSpec(
        "halton", "digit_permutation", "independent", int,
        "global Halton over the image, random digit permutations per dimension (seeded "
        "once); spp unchanged. " + _P + "HaltonSampler",
        unmodelled="a pixel's samples are a strided run of one image-wide Halton sequence "
        "with random digit permutations, a randomisation envfit has no exact model of"),
    "stratified": SamplerSpec(
        "stratified", "jittered", "independent", int,
        "x*y jittered strata (x = spp/d, y = d, d the largest divisor <= sqrt spp), the "
        "stratum of each sample index PermutationElement(index, spp, Hash(pixel, dimension, "
        "seed)); spp unchanged. " + _P + "StratifiedSampler", options=_xy_strata),
    "independent": SamplerSpec(
        "independent", "independent", "independent", int,
        "RNG Hash(pixel, seed) advanced to index*65536 + dimension; spp unchanged. "
        + _P + "IndependentSampler"),
}


# ----------------------------------------------------------------------------- integrator

_I = "src/pbrt/cpu/integrators.cpp "
STRATEGIES = {
    "map": StrategySetting(
        "map", True, "simplepath", {"maxdepth": 1, "samplelights": True, "samplebsdf": True},
        1, 0, "plain", "light sample without MIS (SampleLi, allowIncompletePDF = false: the "
        "plain distribution); escaped BSDF rays add nothing. " + _I + "SimplePathIntegrator::Li"),
    "brdf": StrategySetting(
        "brdf", True, "simplepath", {"maxdepth": 1, "samplelights": False, "samplebsdf": True},
        0, 1, "plain", "escaped BSDF rays add Le. " + _I + "SimplePathIntegrator::Li"),
    "mis": StrategySetting(
        "mis", True, "path", {"maxdepth": 1}, 1, 1, "compensated",
        "one light + one BSDF sample, PowerHeuristic(1, p_l, 1, p_b), the light sampled and "
        "weighted with the compensated distribution; the default bvh light sampler picks the "
        "infinite light with probability 1 when it is the only light (no bounded light: the "
        "BVH is empty). " + _I + "PathIntegrator::{Li, SampleLd}; src/pbrt/lightsamplers.cpp"),
}


def _transform_line(up: str) -> str:
    """``ConcatTransform`` (column-major 4×4) taking pbrt's light frame (= envfit's local
    frame of the lat-long file) to envfit's world frame of ``up``."""
    m = local_to_world(up)
    vals = [m[r, c] for c in range(3) for r in range(3)]
    cols = [vals[0:3] + [0], vals[3:6] + [0], vals[6:9] + [0], [0, 0, 0, 1]]
    flat = " ".join(f"{v:g}" for col in cols for v in col)
    return f"    ConcatTransform [ {flat} ]\n"


def _lookat(v, u) -> str:
    """``LookAt`` of one view of :data:`SPHERE_VIEWS`: eye 3v, the origin, up u."""
    return "LookAt " + "  ".join(" ".join(f"{c:g}" for c in w)
                                 for w in ([3 * c for c in v], (0, 0, 0), u))


def _snippet(s: StrategySetting, spec: SamplerSpec, spp: int, *,
             filename: str = "envmap.exr", up: str = "y", sphere_pixels: int | None = None) -> str:
    """pbrt-v4 scene lines of the scene envfit predicted, as the measurements' sphere
    (:data:`SPHERE_VIEWS`): the conversion command, ``LookAt`` from 3v at the origin (the
    view +z; the comment names the other five) and an ``orthographic`` camera whose screen
    window [-1, 1]² the unit sphere fills (``src/pbrt/cameras.cpp``:
    ``OrthographicCamera::Create``), an ``rgb`` film of :func:`snippet_pixels` pixels with
    the ``box`` filter (radius 0.5: one pixel, ``src/pbrt/filters.cpp``), the integrator
    for the strategy, the sampler at the spp it runs, the equal-area map as the infinite
    light, a sphere of radius 1 with the ``diffuse`` material of reflectance 1 (its default
    is 0.5: ``src/pbrt/materials.cpp``: ``DiffuseMaterial::Create``)."""
    eq = filename.rsplit(".", 1)[0] + "-equiarea.exr"
    opts = " ".join(f'"{"integer" if isinstance(v, int) and not isinstance(v, bool) else "bool"} '
                    f'{k}" [ {str(v).lower()} ]' for k, v in s.settings.items())
    if spec.name == "stratified":
        x, y = _grid(spp)
        samp = f'Sampler "stratified" "integer xsamples" [ {x} ] "integer ysamples" [ {y} ]'
    else:
        samp = f'Sampler "{spec.name}" "integer pixelsamples" [ {spp} ]'
    n = snippet_pixels(sphere_pixels)
    head = "\n".join(scene_comment("white diffuse (reflectance 1)", sphere_pixels))
    others = "\n".join(f"#   {_lookat(v, u)}" for v, u in SPHERE_VIEWS[:4] + SPHERE_VIEWS[5:])
    return (f"# imgtool makeequiarea {filename} --outfile {eq}\n"
            f"{head}\n"
            f"# the view +z below; the other five views: the same file with\n{others}\n"
            f"{_lookat(*SPHERE_VIEWS[4])}\n"
            f'Camera "orthographic" "float screenwindow" [ -1 1 -1 1 ]\n'
            f'Integrator "{s.integrator}" {opts}\n'
            f"{samp}\n"
            f'Film "rgb" "integer xresolution" [ {n} ] "integer yresolution" [ {n} ]\n'
            f'    "string filename" [ "sphere.exr" ]\n'
            f'PixelFilter "box" "float xradius" [ 0.5 ] "float yradius" [ 0.5 ]\n'
            f"WorldBegin\n"
            f"AttributeBegin\n{_transform_line(up)}"
            f'    LightSource "infinite" "string filename" [ "{eq}" ]\n'
            f"AttributeEnd\n"
            f'Material "diffuse" "rgb reflectance" [ 1 1 1 ]\n'
            f'Shape "sphere" "float radius" [ 1 ]\n')


def _technique(envmap=None, **options) -> Pbrt4ImageInfiniteLight:
    return Pbrt4ImageInfiniteLight(envmap, **options)


PBRT4 = Renderer(
    name="pbrt4",
    renderer="pbrt-v4 (mmp/pbrt-v4 @ 5f7a606806a4), infinite light + path/simplepath",
    technique=_technique,
    cosine=cosine_hemisphere,
    tangent_frame=pbrt_sphere_frame,
    heuristic="power",
    strategies=STRATEGIES,
    samplers=SAMPLERS,
    snippet_fn=_snippet,
    source=("src/pbrt/lights.cpp/.h ImageInfiniteLight; src/pbrt/util/sampling.h "
            "SampleCosineHemisphere, PowerHeuristic; src/pbrt/bxdfs.h DiffuseBxDF::Sample_f; "
            "src/pbrt/cpu/integrators.cpp; src/pbrt/samplers.h/.cpp"),
    display="pbrt-v4",
    negative_radiance=("pbrt-v4 clamps negative radiance to 0 (src/pbrt/lights.h: "
                       "ImageInfiniteLight::ImageLe, ClampZero) but samples the signed map's "
                       "|mean RGB| (src/pbrt/util/sampling.h: PiecewiseConstant1D takes abs)"),
    microfacet={"ggx": None},
    bsdf_fn=bsdf,
    roughness=ROUGHNESS,
    pixel_filter_note=("pbrt-v4's default filter is the gaussian (radius 1.5, sigma 0.5), "
                       "sampled by its FilterSampler with the weights f/pdf "
                       "(src/pbrt/filters.h: GaussianFilter::Sample): not modelled on the "
                       "sphere"),
    estimator_note=("pbrt-v4 renders spectrally, four wavelengths drawn per camera sample "
                    "(src/pbrt/cpu/integrators.cpp: RayIntegrator::EvaluatePixelSample, "
                    "SampleWavelengths): these predictions are its estimator's noise with the "
                    "wavelengths fixed (pbrt --disable-wavelength-jitter); its default "
                    "rendering adds wavelength noise (rendered, MIS measured 1.2-1.7x these "
                    "predictions: docs/validation.md, pbrt-v4 rendered)"),
)

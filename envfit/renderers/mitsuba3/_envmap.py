r"""Mitsuba 3's environment-map emitter (``envmap``) and ``direct`` integrator, in numpy.

Read from mitsuba-renderer/mitsuba3 at tag ``v3.9.1`` (``478e193a183c``, the PyPI release):

* ``src/emitters/envmap.cpp`` — ``EnvironmentMapEmitter`` (constructor, ``eval_spectrum``,
  ``rebuild_distribution``, ``sample_direction``, ``pdf_direction``, ``uv_to_direction``,
  ``direction_to_uv``, ``refresh_halo``, ``half_texel``);
* ``include/mitsuba/core/distr_2d.h`` — ``Hierarchical2D`` (constructor, ``sample``,
  ``eval``, ``Level::index``);
* ``include/mitsuba/core/warp.h`` — ``square_to_bilinear``, ``interval_to_linear``,
  ``square_to_cosine_hemisphere``;
* ``include/mitsuba/core/vector.h`` — ``coordinate_system`` (the shading frame ``Frame3f(n)``);
* ``src/integrators/direct.cpp`` — ``DirectIntegrator`` (counts, fractions, ``mis_weight``);
* ``src/samplers/*.cpp`` — ``set_sample_count``, ``next_2d`` of each sampler.

Native frame = envfit's ``up="y"`` frame: Mitsuba's ``uv_to_direction`` is
:math:`(\sin\phi\sin\theta, \cos\theta, -\cos\phi\sin\theta)` with :math:`\phi = 2\pi u`,
:math:`\theta = \pi v`, the OpenEXR orientation (emitter ``to_world`` = identity). For a
map with another ``up`` the technique's :attr:`native_to_world` is the emitter's
``to_world`` rotation :math:`M_{up} M_y^{T}`.
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError
from envfit.defaults import PLASTIC_SAMPLERS
from envfit.maps import local_to_world
from envfit.renderers._base import (SPHERE_VIEWS, EnvmapTechnique, Renderer,
                                           SamplerSpec, StrategySetting, cosine_hemisphere,
                                           map_rgb, scene_comment, snippet_pixels)
from envfit.renderers.mitsuba3._bsdf import (PRINCIPLED_PARAMS, PRINCIPLED_ROUGHNESS, ROUGHNESS,
                                             bsdf)
from envfit.renderers.mitsuba3._kensler import KENSLER_PERMUTATIONS, multijitter_shape

__all__ = ["Hierarchical2D", "Mitsuba3Envmap", "mitsuba_frame", "MITSUBA3", "LUMINANCE_RGB"]

#: Mitsuba's ``luminance(rgb)`` weights in RGB variants (``include/mitsuba/core/spectrum.h``)
LUMINANCE_RGB = np.array([0.212671, 0.715160, 0.072169])

#: ``dr::Epsilon<float>`` (2⁻²⁴): the floor of sin θ in ``uv_to_direction`` / ``pdf_direction``
_EPS32 = 2.0 ** -24


def _interval_to_linear(v0, v1, s):
    r"""``warp::interval_to_linear``: invert the CDF of the linear density v0 → v1 on [0, 1]
    (a square-root inversion), or the identity where :math:`|v_0 - v_1| \le 10^{-4}(v_0 + v_1)`."""
    lin = np.abs(v0 - v1) > 1e-4 * (v0 + v1)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (v0 - np.sqrt(np.maximum(v0 * v0 + (v1 * v1 - v0 * v0) * s, 0.0))) / (v0 - v1)
    return np.where(lin, x, s)


class Hierarchical2D:
    r"""Mitsuba 3's ``Hierarchical2D<Float, 0>``: a piecewise-bilinear density on a vertex
    grid and its hierarchical sample warping.

    ``data`` (ny, nx) are vertex values; the interpolant has (nx − 1) × (ny − 1) patches on
    [0, 1]², normalised so that the density integrates to 1 (the vertex values scaled by
    :math:`n_x' n_y' / \sum_{patches}\frac14(v_{00}+v_{10}+v_{01}+v_{11})`). Level 1 holds
    each patch's mean of its four corners, each level above sums 2 × 2 blocks of the one
    below, every level zero-padded to even sizes; there are
    :math:`\lceil\log_2 \max(n_x', n_y')\rceil` of them (``distr_2d.h``, constructor).

    :meth:`sample` descends from the coarsest level: in the 2 × 2 block under the current
    offset it picks the **row** with ``u[1]`` (from the two row sums ``r0 = v00 + v10``,
    ``r1 = v01 + v11``; ``u[1]·(r0 + r1) > r0`` → row 1), then the **column** with ``u[0]``
    (from the chosen row's two values), rescales both coordinates into the chosen quadrant,
    and doubles the offset; at the leaf patch ``square_to_bilinear`` inverts the linear
    marginal in y and then the linear conditional in x (``interval_to_linear``).
    """

    def __init__(self, data):
        v = np.asarray(data, dtype=np.float64)
        if v.ndim != 2 or min(v.shape) < 2:
            raise ParameterError("Hierarchical2D needs a vertex grid of at least 2 x 2")
        ny, nx = v.shape
        patches = 0.25 * (v[:-1, :-1] + v[:-1, 1:] + v[1:, :-1] + v[1:, 1:])
        total = float(patches.sum())
        if not (np.isfinite(total) and total > 0.0) or v.min() < 0.0:
            raise ParameterError("the map's sampling weights must be finite, >= 0 and not all 0")
        scale = (nx - 1) * (ny - 1) / total
        self.data = v * scale
        self.patch_counts = (nx - 1, ny - 1)
        max_level = int(np.ceil(np.log2(max(nx - 1, ny - 1)))) if max(nx, ny) > 2 else 0
        levels, cur = [], patches * scale
        for _ in range(max_level):
            cur = np.pad(cur, ((0, cur.shape[0] % 2), (0, cur.shape[1] % 2)))
            levels.append(cur)
            cur = cur[0::2, 0::2] + cur[0::2, 1::2] + cur[1::2, 0::2] + cur[1::2, 1::2]
        self.levels = levels                       # levels[0] = level 1 (patch means)

    def sample(self, u: np.ndarray):
        """Warped points (K, 2) in [0, 1]² and their density (K,) from uniform u (K, 2)."""
        s = np.clip(np.array(u, dtype=np.float64), 0.0, 1.0)
        k = s.shape[0]
        ox, oy = np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64)
        for lev in reversed(self.levels):
            ox, oy = 2 * ox, 2 * oy
            v00, v10 = lev[oy, ox], lev[oy, ox + 1]
            v01, v11 = lev[oy + 1, ox], lev[oy + 1, ox + 1]
            s = np.clip(s, 0.0, 1.0)
            r0, r1 = v00 + v10, v01 + v11
            sy = s[:, 1] * (r0 + r1)
            ym = sy > r0
            oy = oy + ym
            sy = np.where(ym, sy - r0, sy)
            dy = np.where(ym, r1, r0)
            c0, c1 = np.where(ym, v01, v00), np.where(ym, v11, v10)
            sx = s[:, 0] * dy
            xm = sx > c0
            sx = np.where(xm, sx - c0, sx)
            ox = ox + xm
            dx = np.where(xm, c1, c0)
            with np.errstate(invalid="ignore", divide="ignore"):
                s = np.column_stack([sx / dx, sy / dy])
        return self._leaf(s, ox, oy)

    def _leaf(self, s, ox, oy):
        """``square_to_bilinear`` in patch (ox, oy), mapped to [0, 1]²."""
        d = self.data
        v00, v10, v01, v11 = d[oy, ox], d[oy, ox + 1], d[oy + 1, ox], d[oy + 1, ox + 1]
        y = _interval_to_linear(v00 + v10, v01 + v11, s[:, 1])
        c0, c1 = v00 + (v01 - v00) * y, v10 + (v11 - v10) * y
        x = _interval_to_linear(c0, c1, s[:, 0])
        pdf = c0 + (c1 - c0) * x
        nx, ny = self.patch_counts
        return np.column_stack([(ox + x) / nx, (oy + y) / ny]), pdf

    def eval(self, pos: np.ndarray) -> np.ndarray:
        """The normalised density (K,) at points (K, 2) of [0, 1]² (``Hierarchical2D::eval``:
        clipped, the patch index clamped to the last patch, bilinear in the corners)."""
        nx, ny = self.patch_counts
        p = np.clip(np.asarray(pos, dtype=np.float64), 0.0, 1.0) * [nx, ny]
        ox = np.minimum(p[:, 0].astype(np.int64), nx - 1)
        oy = np.minimum(p[:, 1].astype(np.int64), ny - 1)
        fx, fy = p[:, 0] - ox, p[:, 1] - oy
        d = self.data
        top = d[oy, ox] + (d[oy, ox + 1] - d[oy, ox]) * fx
        bot = d[oy + 1, ox] + (d[oy + 1, ox + 1] - d[oy + 1, ox]) * fx
        return top + (bot - top) * fy


def _compensation_offset(lum: np.ndarray) -> float:
    """``rebuild_distribution``'s MIS-compensation offset: the mean luminance over the
    W × H real pixels, or 0 when mean − min ≤ 1 % of the mean (Karlík et al. 2019)."""
    offset = float(np.float32(lum.mean()))
    if offset - float(lum.min()) <= 0.01 * offset:
        return 0.0
    return offset


class Mitsuba3Envmap(EnvmapTechnique):
    r"""Mitsuba 3's ``envmap`` emitter on an envfit map (its pixels as the file's).

    **Radiance** (``eval_spectrum``, RGB variants): bilinear (``dr::Texture``,
    ``FilterMode::Linear``, ``WrapMode::Clamp``) on the W + 2 column storage whose halo
    columns copy the opposite edges: with :math:`u = \phi/2\pi` wrapped to [0, 1) and
    :math:`v = \theta/\pi` clipped, the lookup is at real column :math:`uW - \frac12`
    (texel-centred, periodic) and row :math:`v(H-1)` (align-corners: rows 0 and H − 1 on
    the poles, clamped), times ``scale``.

    **Density** (``rebuild_distribution``): the (W + 1) × H vertex grid, vertex (x, y) =
    :math:`\max(Y(x \bmod W, y) - o, 0)\,\sin(\pi y/(H-1))` with Y the Rec. 709 luminance
    (:data:`LUMINANCE_RGB`) and o the ``mis_compensation`` offset
    (:func:`_compensation_offset`, else 0), sampled by :class:`Hierarchical2D`.

    **Sampling** (``sample_direction``): ``uv = warp.sample(u)``, ``uv.x += ½/W``
    (``half_texel``), :math:`\theta = \pi v`, :math:`\phi = 2\pi u`, solid-angle pdf
    :math:`p_{uv}/(2\pi^2\max(\sin\theta, 2^{-24}))`.

    **Density at a direction** (``pdf_direction``): ``uv = direction_to_uv(d)``,
    ``uv.x −= ½/W``, ``uv −= floor(uv)``, :math:`p_{uv}(uv)/(2\pi^2 \sqrt{\max(d_x^2+d_z^2,
    2^{-48})})`.

    >>> from envfit.maps import EnvMap
    >>> t = Mitsuba3Envmap(EnvMap(np.full((4, 8, 3), 2.0)))
    >>> d, p = t.sample([[0.3, 0.6]])
    >>> bool(np.allclose(t.eval(d), 2.0)), bool(np.allclose(t.pdf(d), p))
    (True, True)
    """

    name = "mitsuba3"
    renderer = "Mitsuba 3.9.1 envmap"
    source = ("mitsuba3 @ 478e193a183c (v3.9.1): src/emitters/envmap.cpp "
              "EnvironmentMapEmitter::{eval_spectrum, rebuild_distribution, sample_direction, "
              "pdf_direction}; include/mitsuba/core/distr_2d.h Hierarchical2D::{sample, eval}")

    def __init__(self, envmap, *, mis_compensation: bool = False, scale: float = 1.0):
        rgb = map_rgb(envmap)
        h, w = rgb.shape[:2]
        if h < 3 or w < 2:
            raise ParameterError("Mitsuba's envmap needs at least 3 rows and 2 columns")
        self.rgb = rgb.astype(np.float32).astype(np.float64)       # Bitmap::convert(Float32)
        self.height, self.width = h, w
        self.scale = float(scale)
        self.mis_compensation = bool(mis_compensation)
        lum = np.float32(self.rgb @ LUMINANCE_RGB).astype(np.float64)
        self.offset = _compensation_offset(lum) if self.mis_compensation else 0.0
        sin_t = np.sin(np.arange(h) * (np.pi / (h - 1)))
        vert = np.maximum(lum - self.offset, 0.0) * sin_t[:, None]
        self.warp = Hierarchical2D(np.hstack([vert, vert[:, :1]]))         # (H, W + 1)
        self.native_to_world = local_to_world(getattr(envmap, "up", "y")) @ local_to_world("y").T

    def _uv(self, d: np.ndarray) -> np.ndarray:
        """``direction_to_uv``: (atan2(x, −z)/2π, acos(y)/π)."""
        return np.column_stack([np.arctan2(d[:, 0], -d[:, 2]) / (2.0 * np.pi),
                                np.arccos(np.clip(d[:, 1], -1.0, 1.0)) / np.pi])

    def _lookup(self, uv: np.ndarray) -> np.ndarray:
        """``eval_spectrum``: bilinear, texel-centred periodic φ, align-corners clamped θ."""
        h, w = self.height, self.width
        u = uv[:, 0] - np.floor(uv[:, 0])
        x = u * w + 0.5                           # storage coordinate (halo column 0)
        y = np.clip(uv[:, 1], 0.0, 1.0) * (h - 1)
        ix, iy = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
        fx, fy = (x - ix)[:, None], (y - iy)[:, None]
        c0, c1 = (ix - 1) % w, ix % w              # storage s ↔ real column (s − 1) mod W
        iy = np.minimum(iy, h - 1)
        iy1 = np.minimum(iy + 1, h - 1)
        img = self.rgb
        top = img[iy, c0] * (1 - fx) + img[iy, c1] * fx
        bot = img[iy1, c0] * (1 - fx) + img[iy1, c1] * fx
        return (top * (1 - fy) + bot * fy) * self.scale

    def _eval_native(self, d):
        return self._lookup(self._uv(d))

    def _sample_native(self, u):
        uv, pdf = self.warp.sample(u)
        uv[:, 0] += 0.5 / self.width
        theta, phi = np.pi * uv[:, 1], 2.0 * np.pi * uv[:, 0]
        st = np.sin(theta)
        d = np.column_stack([np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st])
        pdf = np.where(pdf > 0, pdf / np.maximum(st, _EPS32) / (2.0 * np.pi ** 2), 0.0)
        return d, pdf

    def _pdf_native(self, d):
        uv = self._uv(d)
        uv[:, 0] -= 0.5 / self.width
        uv -= np.floor(uv)
        inv_sin = 1.0 / np.sqrt(np.maximum(d[:, 0] ** 2 + d[:, 2] ** 2, _EPS32 ** 2))
        return self.warp.eval(uv) * inv_sin / (2.0 * np.pi ** 2)

    # The compiled fast path (``_compiled``: the same arithmetic, compared in the tests).

    def _texels(self) -> np.ndarray:
        """The texels times ``scale``, kept for the compiled lookups."""
        if getattr(self, "_scaled", None) is None:
            from envfit.renderers.mitsuba3._compiled import scaled_texels
            self._scaled = scaled_texels(self)
        return self._scaled

    def sample_table(self, u: np.ndarray):
        """(directions (P, 3), pdf (P,), radiance (P, 3)) of ``sample_direction`` at the
        square points ``u`` (P, 2), compiled."""
        from envfit.renderers.mitsuba3._compiled import sample_table
        return sample_table(self, np.ascontiguousarray(u, dtype=np.float64))

    def bsdf_lookup(self, local: np.ndarray, frame: np.ndarray, fe: float,
                    fb: float) -> tuple[np.ndarray, np.ndarray]:
        r"""The radiance (P, 3) at the world directions ``local @ frame`` and the BSDF
        sample's power-heuristic weight (P,) with the sample fractions ``fe``, ``fb``
        (``direct``'s ``mis_weight``), compiled."""
        from envfit.renderers.mitsuba3._compiled import bsdf_lookup
        return bsdf_lookup(self, local, frame, fe, fb, self._texels())

    def eval_pdf(self, dirs: np.ndarray, rows=None, skip=None) -> tuple[np.ndarray, np.ndarray]:
        """(radiance (P, 3), ``pdf_direction`` (P,)) at ``dirs``: world, or local with
        ``rows`` the local frame's axes as rows; 0 and 0 where ``skip`` (P,) is ≤ 0, compiled."""
        from envfit.renderers.mitsuba3._compiled import eval_pdf
        return eval_pdf(self, dirs, rows, skip, self._texels())


def mitsuba_frame(normals) -> np.ndarray:
    r"""Mitsuba's shading frame ``Frame3f(n)`` (K, 3, 3), rows (s, t, n):
    ``coordinate_system(n)`` (Duff et al., JCGT 6(1), 2017) with
    :math:`\sigma = \mathrm{sign}(n_z)` (+1 at 0), :math:`a = -1/(\sigma + n_z)`,
    :math:`b = n_x n_y a`: :math:`s = (1 + \sigma n_x^2 a, \sigma b, -\sigma n_x)`,
    :math:`t = (b, \sigma + n_y^2 a, -n_y)` (``include/mitsuba/core/vector.h``)."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    sg = np.where(n[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sg + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    s = np.column_stack([1.0 + sg * n[:, 0] ** 2 * a, sg * b, -sg * n[:, 0]])
    t = np.column_stack([b, sg + n[:, 1] ** 2 * a, -n[:, 1]])
    return np.stack([s, t, n], axis=1)


# ----------------------------------------------------------------------------- samplers

def _next_square(n: int) -> int:
    """``stratified``: r = the least integer with r² ≥ spp."""
    r = 1
    while r * r < n:
        r += 1
    return r * r


def _multijitter(n: int) -> int:
    """``multijitter``: ny = ⌊√spp⌋ (in float32), nx = ⌈spp/ny⌉, spp → nx·ny."""
    ny = int(np.sqrt(np.float32(n)))
    return ((n + ny - 1) // ny) * ny


def _ld(n: int) -> int:
    """``ldsampler``: res from 2, ``res = round_to_power_of_two(++res)`` while res² < spp."""
    r = 2
    while r * r < n:
        r = 1 << int(r).bit_length()            # next power of two above r
    return r * r


def _is_prime(x: int) -> bool:
    return all(x % i for i in range(2, x // 2 + 1))


def _orthogonal(n: int) -> int:
    """``orthogonal``: the least prime p ≥ 2 with p² ≥ spp, spp → p²."""
    p = 2
    while p * p < n or not _is_prime(p):
        p += 1
    return p * p


def _square_strata(n: int) -> tuple:
    """``stratified``'s r × r strata, r = √N (N already rounded to a square)."""
    return (("r", math.isqrt(n)),)


def _hashed_permutations(n: int) -> tuple:
    """``multijitter``'s nx × ny grid (N already rounded to nx·ny) and its permutations:
    Kensler's ``permute`` with Mitsuba's hashed seeds (:mod:`._kensler`)."""
    nx, ny = multijitter_shape(n)
    return (("nx", nx), ("ny", ny), ("permutations", KENSLER_PERMUTATIONS))


def _ldsampler_points(pixels: int, n: int, dims: int, seed: int) -> np.ndarray:
    """``ldsampler``'s points of ``pixels`` pixels of random scramble seeds, in its order
    (:mod:`._ldsampler`)."""
    from envfit.renderers.mitsuba3._ldsampler import ldsampler_points, pixel_scramble_seeds
    return ldsampler_points(pixel_scramble_seeds(pixels, seed), n, dims)


def _ldsampler_numbers(pixels: int, n: int, call: int, seed: int) -> np.ndarray:
    """``ldsampler``'s ``next_1d`` of call ``call`` for the pixels of
    :func:`_ldsampler_points` (the same seeds), in its order (:mod:`._ldsampler`)."""
    from envfit.renderers.mitsuba3._ldsampler import ldsampler_numbers, pixel_scramble_seeds
    return ldsampler_numbers(pixel_scramble_seeds(pixels, seed), n, call)


_M = "mitsuba3 @ 478e193a (v3.9.1) src/samplers/"
SAMPLERS = {
    "independent": SamplerSpec(
        "independent", "independent", "independent", int,
        "PCG32 per pixel, i.i.d. uniforms; no rounding; the sensor's default sampler "
        "(src/render/sensor.cpp). " + _M + "independent.cpp", default=True),
    "stratified": SamplerSpec(
        "stratified", "jittered", "independent", _next_square,
        "r x r jittered cells, the cell of each sample index permute_kensler(index, N, "
        "per-pixel seed + dimension), fresh PCG32 jitter; spp -> next square. "
        + _M + "stratified.cpp set_sample_count, next_2d", options=_square_strata),
    "multijitter": SamplerSpec(
        "multijitter", "cmj", "independent", _multijitter,
        "Kensler correlated multi-jittering nx x ny (ny = floor(sqrt spp)), permutation "
        "seeds per pixel and dimension, fresh jitter; spp -> nx*ny. "
        + _M + "multijitter.cpp set_sample_count, next_2d", options=_hashed_permutations),
    "ldsampler": SamplerSpec(
        "ldsampler", "digital_shift", "same_net_permuted", _ld,
        "(van der Corput, Sobol' 2) (0,2)-net XOR-scrambled by ONE per-pixel shift "
        "sample_tea_32(seed, 0x98bc51ab) for every 2-D dimension; each dimension only "
        "permutes the order (permute(index, N, seed + dimension)); next_1d is van der "
        "Corput XOR its own scramble sample_tea_32(seed, 0x48bc48eb), also in its own order "
        "(a lobe choice's number apart from the 2-D points); spp -> square of a power of two "
        "(min 4). " + _M + "ldsampler.cpp set_sample_count, next_1d, next_2d",
        film_points=_ldsampler_points, lobe_points=_ldsampler_numbers),
    "orthogonal": SamplerSpec(
        "orthogonal", "orthogonal", "joint_array", _orthogonal,
        "Bose orthogonal array (strength 2), CMJ-style permutations per pixel, fresh "
        "jitter; spp -> p^2, p the least prime >= 2 with p^2 >= spp. "
        + _M + "orthogonal.cpp set_sample_count, bose"),
}

# ----------------------------------------------------------------------------- integrator

_D = "src/integrators/direct.cpp DirectIntegrator"
_P = "src/integrators/path.cpp PathIntegrator"


def _direct_draws(emitter_samples: int) -> dict:
    """Where ``direct``'s first emitter and BSDF 2-D draws of one spp stand
    (:class:`~envfit.renderers.StrategySetting` ``dimensions``, ``calls``): the film position
    takes dimensions 0–1, call 0 (``src/render/integrator.cpp``:
    ``SamplingIntegrator::render_sample``, ``next_2d``; an orthographic sensor takes no
    aperture, time or wavelength sample), then ``direct.cpp`` draws ``next_2d`` per emitter
    sample, emitter samples first, and per BSDF sample ``bsdf->sample(ctx, si,
    sampler->next_1d(), sampler->next_2d())``, whose two arguments C++ may evaluate in either
    order: in the PyPI build (3.9.1) ``next_2d`` comes first (right to left;
    ``tests/test_randomisation_orthogonal.py`` records the BSDF's samples in a render), so the
    BSDF's 2-D draw starts at dimension 2 + 2·emitter_samples, call 1 + emitter_samples, and
    its lobe number (``next_1d``) is call 2 + emitter_samples."""
    return {"dimensions": (2, 2 + 2 * emitter_samples), "calls": (1, 1 + emitter_samples),
            "lobe_call": 2 + emitter_samples}


def _path_draws() -> dict:
    """Where ``path``'s emitter and BSDF 2-D draws of its first bounce stand: after the film's
    (dimensions 0–1, call 0), ``PathIntegrator::sample`` draws the emitter sample
    (``sample_emitter_direction(si, sampler->next_2d())``: dimensions 2–3, call 1), then, in
    two statements, ``sample_1 = next_1d()`` (dimension 4, call 2) and ``sample_2 =
    next_2d()`` (dimensions 5–6, call 3) for ``bsdf->eval_pdf_sample`` — the BSDF's 2-D draw
    one later than ``direct``'s (:func:`_direct_draws`), at an odd dimension; the lobe
    number is call 2."""
    return {"dimensions": (2, 5), "calls": (1, 3), "lobe_call": 2}


#: Mitsuba's ``path`` at its defaults (``max_depth`` −1, ``rr_depth`` 5, ``hide_emitters``
#: false): on envfit's sphere, alone and convex, every path ends at its first bounce — the
#: BSDF-sampled ray leaves the sphere and meets the map, weighted by the power heuristic
#: ``mis_weight(bsdf_pdf, em_pdf)``, as the emitter sample by ``mis_weight(ds.pdf,
#: bsdf_pdf)`` — so its estimate is ``direct``'s with one sample of each technique (whose
#: sample fractions ½, ½ cancel in the heuristic), but for where the BSDF's draw stands
#: (:func:`_path_draws`); Russian roulette starts at depth 5 and never plays.
STRATEGIES = {
    "map": StrategySetting("map", True, "direct", {"emitter_samples": 1, "bsdf_samples": 0},
                           1, 0, "plain", "emitter sampling only (bsdf fraction 0: weight 1); "
                           + _D, **_direct_draws(1)),
    "brdf": StrategySetting("brdf", True, "direct", {"emitter_samples": 0, "bsdf_samples": 1},
                            0, 1, "plain", "BSDF sampling only; " + _D, **_direct_draws(0)),
    "mis": StrategySetting("mis", True, "path", {}, 1, 1, "plain",
                           "Mitsuba's default integrator at its defaults: one emitter and one "
                           "BSDF sample per bounce, power heuristic; on the lone sphere only "
                           "the first bounce contributes; " + _P + "::sample",
                           **_path_draws()),
}


def _bsdf(microfacet) -> tuple[str, str, str]:
    """(XML, Python dict text, words) of the sphere's BSDF: white diffuse (reflectance 1: the
    plugin's default is 0.5), a white ``roughconductor`` (``material="none"``: Fresnel 1), a
    ``roughplastic`` with a GGX coat (its defaults otherwise: η 1.49, diffuse 0.5) or a
    ``principled`` (``microfacet`` = (name, α, the parameters set))."""
    if microfacet is None:
        return ('<bsdf type="diffuse"><rgb name="reflectance" value="1, 1, 1"/></bsdf>',
                '{"type": "diffuse", "reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}',
                "white diffuse (reflectance 1)")
    alpha = float(microfacet[1])
    if microfacet[0] == "principled":
        params = {"roughness": PRINCIPLED_ROUGHNESS.from_alpha(alpha),
                  **(microfacet[2] if len(microfacet) > 2 else {})}
        xml = "".join(f'<float name="{k}" value="{v:g}"/>' for k, v in params.items())
        py = ", ".join(f'"{k}": {v:g}' for k, v in params.items())
        return (f'<bsdf type="principled">{xml}</bsdf>', f'{{"type": "principled", {py}}}',
                "principled (" + ", ".join(f"{k} {v:g}" for k, v in params.items())
                + "; the plugin's defaults otherwise)")
    if microfacet[0] == "roughplastic":
        return (f'<bsdf type="roughplastic"><string name="distribution" value="ggx"/>'
                f'<float name="alpha" value="{alpha:g}"/></bsdf>',
                f'{{"type": "roughplastic", "distribution": "ggx", "alpha": {alpha:g}}}',
                f"roughplastic (GGX alpha {alpha:g}, eta 1.49, diffuse reflectance 0.5)")
    dist = microfacet[0]
    return (f'<bsdf type="roughconductor"><string name="distribution" value="{dist}"/>'
            f'<float name="alpha" value="{alpha:g}"/>'
            f'<string name="material" value="none"/></bsdf>',
            f'{{"type": "roughconductor", "distribution": "{dist}", '
            f'"alpha": {alpha:g}, "material": "none"}}',
            f"white roughconductor ({dist} alpha {alpha:g}, Fresnel 1)")


def _integrator_xml(s: StrategySetting) -> str:
    """The strategy's ``<integrator>`` element (its type and settings)."""
    if not s.settings:
        return f'  <integrator type="{s.integrator}"/>\n'
    items = "".join(f'    <integer name="{k}" value="{v}"/>\n' for k, v in s.settings.items())
    return f'  <integrator type="{s.integrator}">\n{items}  </integrator>\n'


def _integrator_py(s: StrategySetting) -> str:
    """The strategy's integrator as ``mi.load_dict`` text."""
    return "{" + ", ".join([f'"type": "{s.integrator}"']
                           + [f'"{k}": {v}' for k, v in s.settings.items()]) + "}"


def _xml(s: StrategySetting, sampler: str, spp: int, filename: str, comp: bool, bsdf: str,
         n: int) -> str:
    sensors = "".join(
        f'  <sensor type="orthographic">\n'
        f'    <transform name="to_world"><lookat origin="{3 * v[0]}, {3 * v[1]}, {3 * v[2]}" '
        f'target="0, 0, 0" up="{u[0]}, {u[1]}, {u[2]}"/></transform>\n'
        f'    <film type="hdrfilm"><integer name="width" value="{n}"/>'
        f'<integer name="height" value="{n}"/><rfilter type="box"/>'
        f'<string name="pixel_format" value="rgb"/></film>\n'
        f'    <sampler type="{sampler}">\n'
        f'      <integer name="sample_count" value="{spp}"/>\n'
        f'    </sampler>\n'
        f'  </sensor>\n' for v, u in SPHERE_VIEWS)
    return (f'<scene version="3.0.0">\n'
            f'{_integrator_xml(s)}{sensors}'
            f'  <emitter type="envmap">\n'
            f'    <string name="filename" value="{filename}"/>\n'
            f'    <boolean name="mis_compensation" value="{str(comp).lower()}"/>\n'
            f'  </emitter>\n'
            f'  <shape type="sphere">\n'
            f'    {bsdf}\n'
            f'  </shape>\n'
            f'</scene>\n')


def _snippet(s: StrategySetting, spec: SamplerSpec, spp: int, *, filename: str = "envmap.exr",
             mis_compensation: bool = False, form: str = "python",
             microfacet: tuple | None = None, sphere_pixels: int | None = None) -> str:
    """The scene envfit predicted, as the measurements render it
    (:mod:`envfit.renderers.mitsuba3._render`): a unit sphere at the origin with the BSDF
    (:func:`_bsdf`), the ``envmap`` of ``filename``, six ``orthographic`` sensors
    (:data:`SPHERE_VIEWS`: ``look_at`` from 3v, the image plane [-1, 1]², ``hdrfilm`` of
    :func:`snippet_pixels` pixels with the ``box`` filter), the sampler at the spp it runs in
    each, the strategy's integrator (``path`` at its defaults for ``mis``, ``direct`` with one
    technique's sample for ``map`` and ``brdf``: :data:`STRATEGIES`). ``form`` ``"python"``
    (a ``mi.load_dict`` call, commented; ``mi.render(scene, sensor=k)`` renders view k) or
    ``"xml"`` (scene XML for ``mi.load_string``)."""
    comp = bool(mis_compensation)
    bsdf_xml, bsdf_py, words = _bsdf(microfacet)
    n = snippet_pixels(sphere_pixels)
    if form == "xml":
        return _xml(s, spec.name, spp, filename, comp, bsdf_xml, n)
    if form != "python":
        raise ParameterError(f"form must be 'python' or 'xml', got {form!r}")
    head = "\n".join(scene_comment(words, sphere_pixels,
                                   view_dependent=microfacet is not None))
    views = ",\n         ".join(f"({v}, {u})" for v, u in SPHERE_VIEWS)
    return (f'import mitsuba as mi\n'
            f'mi.set_variant("scalar_rgb")\n'
            f'{head}\n'
            f'# render view k (0..5, in the order of VIEWS: axis, image up): '
            f'mi.render(scene, sensor=k)\n'
            f'VIEWS = [{views}]\n'
            f'scene = mi.load_dict({{\n'
            f'    "type": "scene",\n'
            f'    "integrator": {_integrator_py(s)},\n'
            f'    **{{f"sensor{{k}}": {{\n'
            f'        "type": "orthographic",\n'
            f'        "to_world": mi.ScalarTransform4f().look_at(\n'
            f'            origin=[3 * c for c in v], target=[0, 0, 0], up=list(u)),\n'
            f'        "film": {{"type": "hdrfilm", "width": {n}, "height": {n}, '
            f'"rfilter": {{"type": "box"}},\n'
            f'                 "pixel_format": "rgb"}},\n'
            f'        "sampler": {{"type": "{spec.name}", "sample_count": {spp}}}}}\n'
            f'        for k, (v, u) in enumerate(VIEWS)}},\n'
            f'    "emitter": {{"type": "envmap", "filename": {filename!r}, '
            f'"mis_compensation": {comp}}},\n'
            f'    "sphere": {{"type": "sphere", "bsdf": {bsdf_py}}},\n'
            f'}})\n')


def _technique(envmap, **options) -> Mitsuba3Envmap:
    return Mitsuba3Envmap(envmap, **options)


MITSUBA3 = Renderer(
    name="mitsuba3",
    renderer="Mitsuba 3.9.1 (mitsuba-renderer/mitsuba3 @ 478e193a183c), envmap + path (MIS) "
             "or direct (one technique)",
    technique=_technique,
    cosine=cosine_hemisphere,
    tangent_frame=mitsuba_frame,
    heuristic="power",
    strategies=STRATEGIES,
    samplers=SAMPLERS,
    snippet_fn=_snippet,
    source=("src/emitters/envmap.cpp; include/mitsuba/core/distr_2d.h Hierarchical2D; "
            "include/mitsuba/core/warp.h square_to_cosine_hemisphere; src/bsdfs/diffuse.cpp "
            "SmoothDiffuse::sample; src/integrators/path.cpp; src/integrators/direct.cpp; "
            "src/samplers/*.cpp"),
    display="Mitsuba 3",
    negative_radiance=("Mitsuba 3's envmap looks up the signed radiance but never samples a "
                       "texel of negative luminance (src/emitters/envmap.cpp: "
                       "rebuild_distribution, max(lum - offset, 0)), so its emitter samples "
                       "miss the negative light"),
    mis_compensation=True,
    microfacet={"ggx": None, "beckmann": None, "roughplastic": PLASTIC_SAMPLERS,
                "principled": PLASTIC_SAMPLERS},
    microfacet_why=dict.fromkeys(("roughplastic", "principled"),
                                 " (orthogonal pairs the lobe choice with the direction in an "
                                 "array)"),
    bsdf_fn=bsdf,
    roughness=ROUGHNESS,
    bsdf_roughness={"principled": PRINCIPLED_ROUGHNESS},
    bsdf_params={"principled": PRINCIPLED_PARAMS},
    render_samplers=("independent", "ldsampler"),
    harness="envfit.renderers.mitsuba3._render",
    pixel_filter_note=("Mitsuba's hdrfilm defaults to the gaussian filter (stddev 0.5, radius "
                       "2 px), which splats each sample into the pixels around it "
                       "(src/render/imageblock.cpp: ImageBlock::put): not modelled on the "
                       "sphere"),
)

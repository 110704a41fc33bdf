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

import math

import numba
import numpy as np

from envfit.base import ParameterError
from envfit.maps import local_to_world
from envfit.renderers._base import (EnvmapTechnique, Renderer, SamplerSpec,
                                           StrategySetting, cosine_hemisphere, map_rgb,
                                           power_heuristic)
from envfit.renderers.cycles._adaptive import CYCLES_ADAPTIVE
from envfit.renderers.cycles._bsdf import BSDF_NAMES, PRINCIPLED_PARAMS, ROUGHNESS, bsdf
from envfit.renderers.cycles._film import BLACKMAN_HARRIS
from envfit.renderers.cycles._patterns import BLUE_NOISE, film_points_of, lobe_points_of
from envfit.renderers.cycles._scene import cycles_snippet

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
        centres (separable: u depends on x only, v on y only) times sin θ of the centre
        (``linear``: :func:`_cell_values_kernel`, compiled)."""
        rx, ry = self.res_x, self.res_y
        tex = self.texture
        self._sin_rows = np.sin(np.pi * (np.arange(ry) + 0.5) / ry)
        if self.interpolation == "linear":
            out = np.empty((ry, rx))
            _cell_values_kernel(tex, self.strength, self._sin_rows, out)
            return out
        h, w = tex.shape[:2]
        iy = np.floor((np.arange(ry) + 0.5) / ry * h).astype(np.int64) % h
        ix = np.floor((np.arange(rx) + 0.5) / rx * w).astype(np.int64) % w
        acc = np.zeros((ry, rx), dtype=np.float32)
        for c in range(3):
            acc += np.abs(tex[iy][:, ix, c])
        return (acc / 3.0 * self.strength).astype(np.float64) * self._sin_rows[:, None]

    def _build(self) -> None:
        """``background_cdf`` and the marginal: CDFs normalised to 1, totals kept."""
        f = self._cell_values()
        rx, ry = self.res_x, self.res_y
        self.func = f
        self.row_total = f.sum(axis=1) / rx                                  # cdf_last_u.x
        flat = np.empty((ry, rx + 1))
        _row_cdfs(f, self.row_total, flat)
        self.total = float(self.row_total.sum() / ry)                        # cdf_last_v.x
        marg = np.concatenate([[0.0], np.cumsum(self.row_total) / ry])
        if self.total > 0:
            marg = marg / self.total
        marg[-1] = 1.0
        self.marg_cdf = marg
        self._flat = flat.ravel()                    # rows 2 apart: one monotone table
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

    def eval_pdf(self, dirs: np.ndarray, rows=None, skip=None) -> tuple[np.ndarray, np.ndarray]:
        """(radiance (P, 3), world-light pdf (P,)) at float64 unit directions ``dirs`` (world,
        or local with the frame's ``rows``: world = local @ rows), 0 and 0 where ``skip`` ≤ 0:
        :meth:`_eval_native` and :meth:`_pdf_native` in one compiled pass for the ``linear``
        texture (the renderer model's hot path; checked against them in the tests), the numpy
        methods for ``closest``."""
        rows = np.eye(3) if rows is None else np.asarray(rows, dtype=np.float64)
        if self.interpolation != "linear":
            d = np.asarray(dirs, dtype=np.float64) @ rows
            rad, pdf = self.eval_unit(d), self.pdf_unit(d)
            if skip is not None:
                off = np.asarray(skip) <= 0
                rad[off], pdf[off] = 0.0, 0.0
            return rad, pdf
        return self._lookup(dirs, rows, skip)

    def _lookup(self, dirs, rows, skip=None, fe: float = 0.0, fb: float = 0.0):
        """:func:`_eval_pdf_kernel`: (radiance, pdf), or with ``fe`` > 0 (radiance, the BSDF
        sample's power-heuristic weight with the fractions ``fe``, ``fb``)."""
        out = np.empty((len(dirs), 4))
        skip = np.zeros(0) if skip is None else np.ascontiguousarray(skip, dtype=np.float64)
        m = np.ascontiguousarray(rows @ self.native_to_world)
        _eval_pdf_kernel(np.ascontiguousarray(dirs, dtype=np.float64), m, self.texture,
                         self._sin_rows, self.row_total,
                         np.array([self.strength, self.total, self.res_x, self.res_y, fe, fb]),
                         skip, out)
        return out[:, :3], out[:, 3]

    def bsdf_lookup(self, local: np.ndarray, frame: np.ndarray, fe: float,
                    fb: float) -> tuple[np.ndarray, np.ndarray]:
        r"""The radiance (P, 3) at the world directions ``local @ frame`` and the BSDF
        sample's power-heuristic weight (P,) with the sample fractions ``fe``, ``fb`` (1
        where ``fe`` is 0): :meth:`eval_pdf` and ``power_heuristic(cos/π, pdf, fb, fe)``."""
        if self.interpolation != "linear":
            rad, pe = self.eval_pdf(local, frame)
            if fe == 0.0:
                return rad, np.ones(len(local))
            return rad, power_heuristic(local[:, 2] / np.pi, pe, fb, fe)
        rad, w = self._lookup(local, np.asarray(frame, dtype=np.float64), None, fe, fb)
        if fe == 0.0:
            return rad, np.ones(len(local))
        return rad, w


@numba.njit(cache=True)
def _periodic(coord, n):  # pragma: no cover - numba
    """:func:`_axis_linear` at one coordinate: (i0, i1, t) of ``interp_linear`` on a periodic
    axis of n texels."""
    x = coord * n - 0.5
    i = math.floor(x)
    i0 = int(i)
    if i0 < 0 or i0 >= n:            # rare (coord outside [1/2n, 1 - 1/2n)): the modulo
        i0 %= n
    i1 = i0 + 1 if i0 + 1 < n else 0
    return i0, i1, x - i


@numba.njit(cache=True)
def _cell_value(tex, iu, iv, rx, ry, strength, sin_rows):  # pragma: no cover - numba
    """:meth:`CyclesBackground._cell_values` (linear) of the one cell (iu, iv), its float32
    operations in the same order (so equal to the table bit for bit): read from the texture
    beside the direction's own texels rather than from the (res_y, res_x) float64 table,
    whose random reads (64 MB at 4096 × 2048) cost half the lookup's time."""
    h, w = tex.shape[0], tex.shape[1]
    x0, x1, tx = _periodic((iu + 0.5) / rx, w)
    y0, y1, ty = _periodic((iv + 0.5) / ry, h)
    one, tx32, ty32 = np.float32(1.0), np.float32(tx), np.float32(ty)
    acc = np.float32(0.0)
    for c in range(3):
        r0 = tex[y0, x0, c] * (one - ty32) + tex[y1, x0, c] * ty32
        r1 = tex[y0, x1, c] * (one - ty32) + tex[y1, x1, c] * ty32
        acc += abs(r0 * (one - tx32) + r1 * tx32)
    return np.float64(acc / np.float32(3.0) * np.float32(strength)) * sin_rows[iv]


@numba.njit(cache=True, parallel=True)
def _row_cdfs(f, row_total, out):  # pragma: no cover - numba
    """``background_cdf`` per row (parallel): the running sum of the row's cells / rx (in
    order, as ``np.cumsum``), normalised by the row's total where it is > 0, the last entry
    1, plus 2·row so that the rows make one monotone table."""
    ry, rx = f.shape
    for iv in numba.prange(ry):
        s = 0.0
        out[iv, 0] = 0.0 + 2.0 * iv
        for iu in range(rx):
            s += f[iv, iu]
            c = s / rx
            if row_total[iv] > 0:
                c = c / row_total[iv]
            out[iv, iu + 1] = c + 2.0 * iv
        out[iv, rx] = 1.0 + 2.0 * iv


@numba.njit(cache=True, parallel=True)
def _cell_values_kernel(tex, strength, sin_rows, out):  # pragma: no cover - numba
    """:meth:`CyclesBackground._cell_values` (linear) of every cell, rows in parallel:
    :func:`_cell_value` (the float32 operations of the numpy form: the bilinear rows, then
    across them; |·| summed over RGB, / 3, × strength, × sin θ)."""
    ry, rx = out.shape
    for iv in numba.prange(ry):
        for iu in range(rx):
            out[iv, iu] = _cell_value(tex, iu, iv, rx, ry, strength, sin_rows)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _eval_pdf_kernel(dirs, m, tex, sin_rows, row_total, consts, skip,
                     out):  # pragma: no cover - numba
    """:meth:`CyclesBackground.eval_pdf` (linear): ``_uv``, ``_texture`` and ``_pdf_native``
    per direction (``m`` = rows @ native_to_world; ``consts`` = strength, total, res_x,
    res_y, fe, fb), radiance to ``out[:, :3]``, pdf to ``out[:, 3]`` — or, with fe > 0, the
    BSDF sample's power-heuristic weight (``bsdf_lookup``; ``dirs`` local, z = cos θ); the
    cell's value by :func:`_cell_value`."""
    strength, total = consts[0], consts[1]
    rx, ry = int(consts[2]), int(consts[3])
    fe, fb = consts[4], consts[5]
    h, w = tex.shape[0], tex.shape[1]
    for p in numba.prange(dirs.shape[0]):
        if skip.shape[0] > 0 and skip[p] <= 0.0:
            out[p, 0], out[p, 1], out[p, 2], out[p, 3] = 0.0, 0.0, 0.0, 0.0
            continue
        x = dirs[p, 0] * m[0, 0] + dirs[p, 1] * m[1, 0] + dirs[p, 2] * m[2, 0]
        y = dirs[p, 0] * m[0, 1] + dirs[p, 1] * m[1, 1] + dirs[p, 2] * m[2, 1]
        z = dirs[p, 0] * m[0, 2] + dirs[p, 1] * m[1, 2] + dirs[p, 2] * m[2, 2]
        nrm = math.sqrt(x * x + y * y + z * z)
        x, y, z = x / nrm, y / nrm, z / nrm
        u = (math.atan2(y, x) - math.pi) / (-2.0 * math.pi)
        v = (math.acos(min(1.0, max(-1.0, z))) - math.pi) / (-math.pi)
        x0, x1, tx = _periodic(u, w)
        y0, y1, ty = _periodic(v, h)
        for c in range(3):
            top = tex[y0, x0, c] * (1 - tx) + tex[y0, x1, c] * tx
            bot = tex[y1, x0, c] * (1 - tx) + tex[y1, x1, c] * tx
            out[p, c] = (top * (1 - ty) + bot * ty) * strength
        iu = min(max(int(u * rx), 0), rx - 1)
        iv = min(max(int(v * ry), 0), ry - 1)
        st = math.sin(v * math.pi)
        denom = 2.0 * math.pi ** 2 * st * row_total[iv] * total
        if st == 0.0 or denom == 0.0:
            pdf = 0.0
        else:
            pdf = _cell_value(tex, iu, iv, rx, ry, strength, sin_rows) * row_total[iv] / denom
        if fe > 0.0:                       # power_heuristic(cos/π, pdf, fb, fe), 0 if not finite
            a = (fb * (dirs[p, 2] / math.pi)) ** 2
            e = (fe * pdf) ** 2
            wt = a / (a + e)
            out[p, 3] = wt if math.isfinite(wt) else 0.0
        else:
            out[p, 3] = pdf

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


def _blue_noise_options(n: int) -> tuple:
    """The ``shared_sequence`` randomisation's option: Cycles' blue-noise runs."""
    return (("points", BLUE_NOISE),)


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
        "('Classic'); the factory scene's pattern. " + _C + "tabulated_sobol.h", default=True,
        prefix=True, film_points=film_points_of("tabulated_sobol"),
        lobe_points=lobe_points_of("tabulated_sobol")),
    "blue_noise": SamplerSpec(
        "blue_noise", "shared_sequence", "independent", int,
        "one Sobol-Burley sequence shared by all pixels with fixed (seed 0) Owen scrambles, "
        "pixel p taking indices sample + p*N (N the render's samples), p a base-4 Owen "
        "scramble of its Morton code: a pixel differs from another only by the run it reads "
        "(drawn: _patterns.BlueNoiseRuns); Blender 'BLUE_NOISE' (= BLUE_NOISE_PURE, and "
        "'AUTOMATIC' for final renders: blender/sync.cpp sync_integrator); spp unchanged. "
        + _C + "pattern.h blue_noise_indexing, path_rng_pixel_init; sobol_burley.h",
        options=_blue_noise_options, film_points=film_points_of("blue_noise")),
    "sobol_burley": SamplerSpec(
        "sobol_burley", "owen", "independent", int,
        "per pixel Owen-scrambled Sobol' (index shuffled, coordinates scrambled with seeds "
        "from the pixel hash and the dimension); debug UI only; spp unchanged. "
        + _C + "sobol_burley.h", prefix=True,
        film_points=film_points_of("sobol_burley"), lobe_points=lobe_points_of("sobol_burley")),
}


# ----------------------------------------------------------------------------- integrator

_S = "src/kernel/integrator/shade_surface.h, src/kernel/light/sample.h "
#: the first hit's requests as planes of ``film_points``: the light's (x, y) 1, the BSDF's
#: (x, y) 2, and its z (the closure pick, ``surface_shader_bsdf_bssrdf_pick``) 3
_CALLS, _LOBE_CALL = (1, 2), 3
STRATEGIES = {
    "map": StrategySetting(
        "map", False, "path", {}, 1, 0, "plain",
        "light-only (direct_light_sampling_type NEXT_EVENT_ESTIMATION) is read only under "
        "#ifdef WITH_CYCLES_DEBUG: release builds always combine. " + _S),
    "brdf": StrategySetting(
        "brdf", True, "path", {"world.cycles.sampling_method": "NONE"}, 0, 1, "plain",
        "World > Settings > Sampling 'None': the world is not a light, escaped BSDF rays get "
        "weight 1. " + _S, calls=_CALLS, lobe_call=_LOBE_CALL),
    "mis": StrategySetting(
        "mis", True, "path", {"world.cycles.sampling_method": "AUTOMATIC"}, 1, 1, "plain",
        "one light (NEE) + one BSDF sample per spp, power_heuristic; importance map at "
        "max(image, 4096 x 2048) under Auto. " + _S, calls=_CALLS, lobe_call=_LOBE_CALL),
}


def _technique(envmap, **options) -> CyclesBackground:
    return CyclesBackground(envmap, **options)


CYCLES = Renderer(
    name="cycles",
    renderer=("Cycles 5.0 (blender/cycles @ 2eba41024174, v5.0.0; the files read are unchanged "
              "for this scene in v5.1.0 and main @ 97dbe6f57, 2026-07-13), world light + path; "
              "rendered with bpy 5.0.1 and 5.3.0"),
    technique=_technique,
    cosine=cosine_hemisphere,
    tangent_frame=cycles_frame,
    heuristic="power",
    strategies=STRATEGIES,
    samplers=SAMPLERS,
    snippet_fn=cycles_snippet,
    source=("src/scene/light.cpp; src/kernel/light/background.h; src/kernel/sample/mapping.h "
            "sample_cos_hemisphere; src/kernel/sample/mis.h power_heuristic; "
            "src/kernel/sample/tabulated_sobol.h"),
    display="Cycles",
    negative_radiance=("Cycles samples the world by |radiance| (src/scene/light.cpp: "
                       "background_cdf, average(fabs(rgb))), and no measurement checks the "
                       "model of a signed map"),
    microfacet={"ggx": None, "beckmann": None, "multiggx": None, "principled": None},
    bsdf_notes={"ggx": ("--brdf ggx is Cycles' single-scatter GGX (a Glossy BSDF set to GGX); "
                        "the Principled and Glossy BSDF nodes default to Multiscatter GGX: "
                        "--brdf multiggx")},
    bsdf_fn=bsdf,
    bsdf_names=BSDF_NAMES,
    roughness=ROUGHNESS,
    bsdf_params={"principled": PRINCIPLED_PARAMS},
    render_samplers=("tabulated_sobol", "blue_noise"),
    harness="envfit.renderers.cycles._render",
    adaptive=CYCLES_ADAPTIVE,
    pixel_filter=BLACKMAN_HARRIS,
)

r"""The warped integrands of a renderer preset's direct-light estimator on a white diffuse
surface, tabulated at the midpoints of a dyadic grid of the sample square.

For a normal n, albedo 1 and one 2-D sample u per technique (:mod:`envfit.sampling.presets`):

* the **map part** :math:`h_e(u) = w_e(\omega)\,L(\omega)\,\max(0, n\cdot\omega)/(\pi\,p_e(\omega))`
  at :math:`\omega = \mathrm{technique.sample}(u)`;
* the **BSDF part** :math:`h_b(u) = w_b(\omega)\,L(\omega)` at
  :math:`\omega = \mathrm{frame}_n(\mathrm{cosine}(u))` (the diffuse BSDF's weight
  :math:`f\cos/p = 1`),

with L the renderer's radiance lookup (``technique.eval``), :math:`p_e` its density
(``technique.pdf``), :math:`p_b = \cos/\pi` and w the preset's MIS weights with its sample
fractions (:meth:`~envfit.sampling.presets.RendererPreset.mis_weights`; 1 for a strategy with
one technique). Per channel (RGB).

The map part's :math:`\omega(u)`, :math:`L(\omega)/(\pi p_e)` and :math:`p_e` do not depend on
n: :class:`MapTable` computes them once per grid and every normal only takes a dot product
and a weight (:func:`map_values`). The BSDF part's local directions are fixed
(:class:`BsdfTable`); per normal they are turned into the world frame and looked up
(:func:`bsdf_values`) — for Mitsuba 3's ``envmap`` by a numba kernel that repeats
``eval_spectrum`` and ``pdf_direction`` (:func:`_mitsuba_lookup`, checked against the
technique's own numpy methods in the tests), for any other technique through its ``eval``
and ``pdf``.

The tables hold the integrand at the midpoints of the :math:`2^F \times 2^F` cells, axis 1 of
each array along ``u[:, 0]`` (the :class:`~envfit.predict.renderer.randomisation.DyadicGrid`
convention); :func:`cell_moments` aggregates them to the cell means of h and h² of a coarser
level, i.e. the midpoint rule on the fine level inside every coarse cell.

References: Mitsuba 3.9.1 ``src/integrators/direct.cpp`` (``DirectIntegrator::sample``),
``src/emitters/envmap.cpp``, ``src/bsdfs/diffuse.cpp``; E. Veach, PhD thesis (1997), §9.2.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from envfit.base import ParameterError

__all__ = ["MapTable", "BsdfTable", "map_values", "bsdf_values", "mis_parts", "cell_moments",
           "moment_pyramid", "midpoints"]

#: points per call of a technique's numpy methods (generic path)
_CHUNK = 1 << 18
_EPS32 = 2.0 ** -24


def midpoints(level: int) -> np.ndarray:
    """The midpoints (4^level, 2) of the 2^level × 2^level cells, row-major with ``u[:, 0]``
    the slow index (so that a reshape to (M, M) puts ``u[:, 0]`` on axis 0)."""
    m = 1 << int(level)
    c = (np.arange(m) + 0.5) / m
    u = np.empty((m, m, 2))
    u[..., 0] = c[:, None]
    u[..., 1] = c[None, :]
    return u.reshape(-1, 2)


@dataclass(frozen=True)
class MapTable:
    """The map part's normal-independent factors at the midpoints of level ``level``:
    directions (P, 3), :math:`L/(\\pi p_e)` (P, 3) and :math:`p_e` (P,) (0 where the
    technique's density is 0)."""

    level: int
    directions: np.ndarray
    base: np.ndarray
    pdf: np.ndarray

    @classmethod
    def build(cls, technique, level: int) -> "MapTable":
        """The table at the midpoints of level ``level``."""
        t = cls.at(technique, midpoints(level))
        return cls(int(level), t.directions, t.base, t.pdf)

    @classmethod
    def at(cls, technique, u: np.ndarray) -> "MapTable":
        """The table at the square points ``u`` (P, 2) (``level`` −1: no grid)."""
        if _is_mitsuba(technique):
            d, p, rad = _mitsuba_map_table(technique, u)
            with np.errstate(divide="ignore", invalid="ignore"):
                b = np.where(p[:, None] > 0, rad / (np.pi * p[:, None]), 0.0)
            return cls(-1, d, b, p)
        dirs, pdf, base = [], [], []
        for i in range(0, len(u), _CHUNK):
            s, rad = technique.sample_radiance(u[i:i + _CHUNK])
            p = np.asarray(s.pdf, dtype=np.float64)
            with np.errstate(divide="ignore", invalid="ignore"):
                b = np.where(p[:, None] > 0, rad / (np.pi * p[:, None]), 0.0)
            dirs.append(s.directions)
            pdf.append(p)
            base.append(b)
        return cls(-1, np.concatenate(dirs), np.concatenate(base), np.concatenate(pdf))


@dataclass(frozen=True)
class BsdfTable:
    """The BSDF part's local directions (P, 3) (normal +z) at the midpoints of level
    ``level``, by the preset's cosine map."""

    level: int
    local: np.ndarray

    @classmethod
    def build(cls, preset, level: int) -> "BsdfTable":
        """The table at the midpoints of level ``level``."""
        return cls(int(level), cls.at(preset, midpoints(level)).local)

    @classmethod
    def at(cls, preset, u: np.ndarray) -> "BsdfTable":
        """The table at the square points ``u`` (P, 2) (``level`` −1: no grid)."""
        return cls(-1, np.asarray(preset.cosine(u).directions))


@numba.njit(cache=True, parallel=True)
def _map_kernel(dirs, base, pdf, n, fe, fb, out_h, out_w):  # pragma: no cover - numba
    for p in numba.prange(dirs.shape[0]):
        c = n[0] * dirs[p, 0] + n[1] * dirs[p, 1] + n[2] * dirs[p, 2]
        if c <= 0.0 or pdf[p] <= 0.0:
            for k in range(3):
                out_h[p, k] = 0.0
            out_w[p] = 0.0
            continue
        for k in range(3):
            out_h[p, k] = base[p, k] * c
        a = (fe * pdf[p]) ** 2
        b = (fb * c / np.pi) ** 2
        out_w[p] = a / (a + b) if a + b > 0.0 else 0.0


def map_values(table: MapTable, normal, fractions) -> tuple[np.ndarray, np.ndarray]:
    r"""The map part at one normal: :math:`L\max(0, n\cdot\omega)/(\pi p_e)` (P, 3) and the
    power-heuristic MIS weight :math:`w_e` (P,) with the sample ``fractions`` (emitter,
    BSDF) — multiply them for :math:`h_e`."""
    n = np.ascontiguousarray(normal, dtype=np.float64)
    h = np.empty_like(table.base)
    w = np.empty_like(table.pdf)
    _map_kernel(table.directions, table.base, table.pdf, n, float(fractions[0]),
                float(fractions[1]), h, w)
    return h, w


@numba.njit(cache=True)
def _mitsuba_eval(x0, y0, z0, rgb, scale, warp, out, p):  # pragma: no cover - numba
    """Mitsuba 3 ``envmap`` at the native unit direction (x0, y0, z0): ``eval_spectrum``
    (bilinear, periodic texel-centred u, clamped align-corners v) written to ``out[p]``, and
    ``pdf_direction`` (``Hierarchical2D::eval`` of the half-texel shifted uv over
    :math:`2\\pi^2\\sin\\theta`) returned."""
    h, w = rgb.shape[0], rgb.shape[1]
    ny, nx = warp.shape[0] - 1, warp.shape[1] - 1
    uu = np.arctan2(x0, -z0) / (2.0 * np.pi)
    vv = np.arccos(min(1.0, max(-1.0, y0))) / np.pi
    u = uu - np.floor(uu)
    xs = u * w + 0.5
    ys = min(1.0, max(0.0, vv)) * (h - 1)
    ix, iy = int(np.floor(xs)), int(np.floor(ys))
    fx, fy = xs - ix, ys - iy
    c0, c1 = (ix - 1) % w, ix % w
    iy = min(iy, h - 1)
    iy1 = min(iy + 1, h - 1)
    for k in range(3):
        top = rgb[iy, c0, k] * (1 - fx) + rgb[iy, c1, k] * fx
        bot = rgb[iy1, c0, k] * (1 - fx) + rgb[iy1, c1, k] * fx
        out[p, k] = (top * (1 - fy) + bot * fy) * scale
    pu = uu - 0.5 / w
    pu -= np.floor(pu)
    pv = vv - np.floor(vv)
    inv_sin = 1.0 / np.sqrt(max(x0 * x0 + z0 * z0, _EPS32 * _EPS32))
    gx = min(1.0, max(0.0, pu)) * nx
    gy = min(1.0, max(0.0, pv)) * ny
    ox, oy = min(int(gx), nx - 1), min(int(gy), ny - 1)
    tx, ty = gx - ox, gy - oy
    t0 = warp[oy, ox] + (warp[oy, ox + 1] - warp[oy, ox]) * tx
    t1 = warp[oy + 1, ox] + (warp[oy + 1, ox + 1] - warp[oy + 1, ox]) * tx
    return (t0 + (t1 - t0) * ty) * inv_sin / (2.0 * np.pi ** 2)


@numba.njit(cache=True, parallel=True)
def _mitsuba_lookup(local, frame, to_native, rgb, warp, fractions,
                    out):  # pragma: no cover - numba
    """:func:`_mitsuba_eval` at ``local @ frame`` (radiance to ``out[:, :3]``, ``rgb``
    already scaled) and the BSDF's power-heuristic weight with ``fractions`` (emitter,
    BSDF) to ``out[:, 3]``."""
    fe, fb = fractions[0], fractions[1]
    for p in numba.prange(local.shape[0]):
        wd = np.empty(3)
        for k in range(3):
            wd[k] = local[p, 0] * frame[0, k] + local[p, 1] * frame[1, k] + local[p, 2] * frame[2, k]
        x0 = wd[0] * to_native[0, 0] + wd[1] * to_native[1, 0] + wd[2] * to_native[2, 0]
        y0 = wd[0] * to_native[0, 1] + wd[1] * to_native[1, 1] + wd[2] * to_native[2, 1]
        z0 = wd[0] * to_native[0, 2] + wd[1] * to_native[1, 2] + wd[2] * to_native[2, 2]
        nrm = np.sqrt(x0 * x0 + y0 * y0 + z0 * z0)
        pe = _mitsuba_eval(x0 / nrm, y0 / nrm, z0 / nrm, rgb, 1.0, warp, out, p)
        a = (fb * local[p, 2] / np.pi) ** 2
        b = (fe * pe) ** 2
        out[p, 3] = a / (a + b) if a + b > 0.0 else 0.0


@numba.njit(cache=True, error_model="numpy")
def _itl(v0, v1, s):  # pragma: no cover - numba
    """``warp::interval_to_linear`` (as ``_mitsuba3._interval_to_linear``)."""
    if abs(v0 - v1) > 1e-4 * (v0 + v1):
        return (v0 - np.sqrt(max(v0 * v0 + (v1 * v1 - v0 * v0) * s, 0.0))) / (v0 - v1)
    return s


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _mitsuba_sample(u, flat, layout, data, to_world, rgb, out):  # pragma: no cover - numba
    """Mitsuba 3 ``envmap`` ``sample_direction``: ``Hierarchical2D::sample`` (levels packed
    in ``flat``, finest first, ``layout`` = their offsets and widths), ``square_to_bilinear``
    in the leaf patch, the half texel; ``out[:, :3]`` the direction, ``out[:, 3]`` its
    solid-angle pdf, ``out[:, 4:]`` the radiance there (``rgb`` already scaled)."""
    offsets, widths = layout[0], layout[1]
    ny, nx = data.shape[0] - 1, data.shape[1] - 1
    w = rgb.shape[1]
    for p in numba.prange(u.shape[0]):
        s0, s1 = min(1.0, max(0.0, u[p, 0])), min(1.0, max(0.0, u[p, 1]))
        ox, oy = 0, 0
        for li in range(offsets.shape[0] - 1, -1, -1):
            ox, oy = 2 * ox, 2 * oy
            o, cw = offsets[li], widths[li]
            v00, v10 = flat[o + oy * cw + ox], flat[o + oy * cw + ox + 1]
            v01, v11 = flat[o + (oy + 1) * cw + ox], flat[o + (oy + 1) * cw + ox + 1]
            s0, s1 = min(1.0, max(0.0, s0)), min(1.0, max(0.0, s1))
            r0, r1 = v00 + v10, v01 + v11
            sy = s1 * (r0 + r1)
            dy, c0, c1 = r0, v00, v10
            if sy > r0:
                oy += 1
                sy -= r0
                dy, c0, c1 = r1, v01, v11
            sx = s0 * dy
            dx = c0
            if sx > c0:
                sx -= c0
                ox += 1
                dx = c1
            s0, s1 = sx / dx, sy / dy
        v00, v10, v01, v11 = data[oy, ox], data[oy, ox + 1], data[oy + 1, ox], data[oy + 1, ox + 1]
        y = _itl(v00 + v10, v01 + v11, s1)
        c0, c1 = v00 + (v01 - v00) * y, v10 + (v11 - v10) * y
        x = _itl(c0, c1, s0)
        pdf = c0 + (c1 - c0) * x
        uu = (ox + x) / nx + 0.5 / w
        theta, phi = np.pi * ((oy + y) / ny), 2.0 * np.pi * uu
        st = np.sin(theta)
        dn = (np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st)
        out[p, 3] = pdf / max(st, _EPS32) / (2.0 * np.pi ** 2) if pdf > 0 else 0.0
        for k in range(3):
            out[p, k] = to_world[k, 0] * dn[0] + to_world[k, 1] * dn[1] + to_world[k, 2] * dn[2]
        nrm = np.sqrt(dn[0] ** 2 + dn[1] ** 2 + dn[2] ** 2)
        _mitsuba_eval(dn[0] / nrm, dn[1] / nrm, dn[2] / nrm, rgb, 1.0, data, out[:, 4:], p)


def _mitsuba_map_table(technique, u):
    """(directions, pdf, radiance) of Mitsuba's ``sample_direction`` at square points u."""
    levels = technique.warp.levels
    flat = np.concatenate([lv.ravel() for lv in levels]) if levels else np.zeros(1)
    sizes = [lv.size for lv in levels]
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64) if levels \
        else np.zeros(0, np.int64)
    widths = np.array([lv.shape[1] for lv in levels], dtype=np.int64)
    out = np.empty((u.shape[0], 7))
    _mitsuba_sample(u, flat, np.stack([offsets, widths]), technique.warp.data,
                    np.ascontiguousarray(technique.native_to_world),
                    technique.rgb * float(technique.scale), out)
    return out[:, :3], out[:, 3], out[:, 4:]


def _is_mitsuba(technique) -> bool:
    return type(technique).__name__ == "Mitsuba3Envmap" and hasattr(technique, "warp")


def bsdf_values(technique, preset, table: BsdfTable, normal,
                fractions) -> tuple[np.ndarray, np.ndarray]:
    r"""The BSDF part at one normal: the radiance :math:`L(\omega)` (P, 3) at
    :math:`\omega = \mathrm{frame}_n(\mathrm{local})` and the MIS weight :math:`w_b` (P,) with
    the sample ``fractions`` (emitter, BSDF) — multiply them for :math:`h_b`."""
    n = np.asarray(normal, dtype=np.float64).reshape(1, 3)
    frame = np.ascontiguousarray(preset.tangent_frame(n)[0])
    fe, fb = float(fractions[0]), float(fractions[1])
    p = table.local.shape[0]
    if _is_mitsuba(technique) and preset.heuristic == "power":
        out = np.empty((p, 4))
        _mitsuba_lookup(table.local, frame, np.ascontiguousarray(technique.native_to_world),
                        technique.rgb * float(technique.scale), technique.warp.data,
                        np.array([fe, fb]), out)
        return out[:, :3], out[:, 3]
    lookup = getattr(technique, "bsdf_lookup", None)
    if lookup is not None and preset.heuristic == "power":
        return lookup(table.local, frame, fe, fb)
    rad, wts = [], []
    for i in range(0, p, _CHUNK):
        loc = table.local[i:i + _CHUNK]
        d = loc @ frame
        rad.append(technique.eval_unit(d))
        w = preset.mis_weights(technique.pdf_unit(d), loc[:, 2] / np.pi, "mis")[1] \
            if fe > 0 else np.ones(len(loc))
        wts.append(w)
    return np.concatenate(rad), np.concatenate(wts)


def mis_parts(h: np.ndarray, we: np.ndarray, rad: np.ndarray,
              wb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The weighted parts of MIS at one normal, in one compiled pass: :math:`w_e h_e`,
    :math:`w_b h_b` and their sum, from :func:`map_values` (h (P, C), w_e (P,)) and
    :func:`bsdf_values` (L (P, C), w_b (P,)).

    >>> e, b, t = mis_parts(np.ones((2, 1)), np.array([0.25, 1.0]), np.full((2, 1), 2.0),
    ...                     np.array([0.5, 0.0]))
    >>> e[:, 0].tolist(), b[:, 0].tolist(), t[:, 0].tolist()
    ([0.25, 1.0], [1.0, 0.0], [1.25, 1.0])
    """
    h, rad = np.asarray(h, np.float64), np.asarray(rad, np.float64)    # views are read as such
    out = np.empty((3,) + h.shape)
    _mis_parts_kernel(h, np.asarray(we, np.float64), rad, np.asarray(wb, np.float64), out)
    return out[0], out[1], out[2]


@numba.njit(cache=True, parallel=True)
def _mis_parts_kernel(h, we, rad, wb, out):  # pragma: no cover - numba
    for p in numba.prange(h.shape[0]):
        for c in range(h.shape[1]):
            e, b = h[p, c] * we[p], rad[p, c] * wb[p]
            out[0, p, c], out[1, p, c], out[2, p, c] = e, b, e + b


def cell_moments(values: np.ndarray, fine_level: int, level: int) -> tuple[np.ndarray, np.ndarray]:
    """The cell means of h and of h² (C, M, M), M = 2^level, from h at the midpoints of the
    fine level (P, C) (:func:`midpoints` order): each coarse cell is the mean over its
    :math:`4^{F-L}` fine midpoints."""
    if level > fine_level or level < 0:
        raise ParameterError(f"level {level} must be between 0 and the table's {fine_level}")
    mf, m = 1 << fine_level, 1 << level
    k = mf // m
    v = np.moveaxis(values.reshape(mf, mf, -1), -1, 0).reshape(-1, m, k, m, k)
    return v.mean(axis=(2, 4)), (v * v).mean(axis=(2, 4))


@numba.njit(cache=True, parallel=True)
def _halve(a, b, out_a, out_b):  # pragma: no cover - numba
    """The 2 × 2 block means of ``a`` and ``b`` (C, 2m, 2m) into ``out_a``, ``out_b``
    (C, m, m), rows in parallel."""
    chans, m = out_a.shape[0], out_a.shape[1]
    for r in numba.prange(chans * m):
        c, i = r // m, r % m
        for j in range(m):
            out_a[c, i, j] = 0.25 * ((a[c, 2 * i, 2 * j] + a[c, 2 * i, 2 * j + 1])
                                     + (a[c, 2 * i + 1, 2 * j] + a[c, 2 * i + 1, 2 * j + 1]))
            out_b[c, i, j] = 0.25 * ((b[c, 2 * i, 2 * j] + b[c, 2 * i, 2 * j + 1])
                                     + (b[c, 2 * i + 1, 2 * j] + b[c, 2 * i + 1, 2 * j + 1]))


@numba.njit(cache=True, parallel=True)
def _halve_values(v, out_a, out_b):  # pragma: no cover - numba
    """The 2 × 2 block means of h and of h² from the fine values ``v`` (2m, 2m, C) into
    ``out_a``, ``out_b`` (C, m, m): the first level of the pyramid without a channel-first
    copy of the fine table or its square."""
    chans, m = out_a.shape[0], out_a.shape[1]
    for r in numba.prange(chans * m):
        c, i = r // m, r % m
        for j in range(m):
            x0, x1 = v[2 * i, 2 * j, c], v[2 * i, 2 * j + 1, c]
            x2, x3 = v[2 * i + 1, 2 * j, c], v[2 * i + 1, 2 * j + 1, c]
            out_a[c, i, j] = 0.25 * ((x0 + x1) + (x2 + x3))
            out_b[c, i, j] = 0.25 * ((x0 * x0 + x1 * x1) + (x2 * x2 + x3 * x3))


def moment_pyramid(values: np.ndarray, fine_level: int, levels) -> dict:
    """:func:`cell_moments` at every level of ``levels`` at once: {level: (A, B)}, each level
    the 2 × 2 block means of the one below (one compiled pass per level over the fine
    values; :func:`cell_moments` is the tests' reference)."""
    levels = sorted(set(int(x) for x in levels))
    if not levels or levels[0] < 0 or levels[-1] > fine_level:
        raise ParameterError(f"levels must lie between 0 and the table's {fine_level}")
    mf = 1 << fine_level
    v = values.reshape(mf, mf, -1)
    if fine_level in levels or fine_level == 0:
        a = np.ascontiguousarray(np.moveaxis(v, -1, 0), dtype=np.float64)
        b = a * a
        start = fine_level
    else:
        m = mf // 2
        a, b = np.empty((v.shape[-1], m, m)), np.empty((v.shape[-1], m, m))
        _halve_values(np.ascontiguousarray(v, dtype=np.float64), a, b)
        start = fine_level - 1
    out = {}
    for lev in range(start, levels[0] - 1, -1):
        if lev < start:
            m = 1 << lev
            na, nb = np.empty((a.shape[0], m, m)), np.empty((a.shape[0], m, m))
            _halve(a, b, na, nb)
            a, b = na, nb
        if lev in levels:
            out[lev] = (a, b)
    return out

r"""The compiled (numba) fast path of Mitsuba 3's ``envmap`` (:class:`~.Mitsuba3Envmap`):
the same arithmetic as its numpy ``eval``, ``sample`` and ``pdf`` (which the tests compare it
with), for the renderer model's hot loops:

* :func:`sample_table` — ``sample_direction`` at many square points: direction, solid-angle
  pdf and the radiance there (``Hierarchical2D::sample``, ``square_to_bilinear``);
* :func:`bsdf_lookup` — ``eval`` at the BSDF samples of one normal and the power
  heuristic's weight (``direct``'s ``mis_weight``);
* :func:`eval_pdf` — ``eval`` and ``pdf_direction`` at many directions (the microfacet
  model's BSDF samples), skipping those of weight 0.

Source: mitsuba3 @ 478e193a183c (v3.9.1), ``src/emitters/envmap.cpp``: ``eval``,
``sample_direction``, ``pdf_direction``; ``include/mitsuba/core/warp.h``:
``Hierarchical2D``, ``interval_to_linear``; ``src/integrators/direct.cpp``: ``mis_weight``.
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["sample_table", "bsdf_lookup", "eval_pdf", "scaled_texels"]

_EPS32 = 2.0 ** -24


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


def sample_table(technique, u):
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


def bsdf_lookup(technique, local, frame, fe: float, fb: float, rgb=None):
    """(radiance (P, 3), the BSDF sample's power-heuristic weight (P,)) at the world
    directions ``local @ frame`` with the sample fractions ``fe``, ``fb``: one compiled pass
    of :func:`_mitsuba_eval` and Mitsuba's ``mis_weight``."""
    out = np.empty((local.shape[0], 4))
    _mitsuba_lookup(local, frame, np.ascontiguousarray(technique.native_to_world),
                    scaled_texels(technique) if rgb is None else rgb, technique.warp.data,
                    np.array([fe, fb]), out)
    return out[:, :3], out[:, 3]


@numba.njit(cache=True, parallel=True)
def _mitsuba_dirs(dirs, frame, to_native, rgb, warp, skip, rad, pdf):  # pragma: no cover - numba
    m = np.empty((3, 3))                    # local -> native: frame (rows t, b, n) @ to_native
    for i in range(3):
        for k in range(3):
            m[i, k] = frame[i, 0] * to_native[0, k] + frame[i, 1] * to_native[1, k] + frame[i, 2] * to_native[2, k]
    for p in numba.prange(dirs.shape[0]):
        if skip.shape[0] > 0 and skip[p] <= 0.0:
            rad[p, 0], rad[p, 1], rad[p, 2], pdf[p] = 0.0, 0.0, 0.0, 0.0
            continue
        x = dirs[p, 0] * m[0, 0] + dirs[p, 1] * m[1, 0] + dirs[p, 2] * m[2, 0]
        y = dirs[p, 0] * m[0, 1] + dirs[p, 1] * m[1, 1] + dirs[p, 2] * m[2, 1]
        z = dirs[p, 0] * m[0, 2] + dirs[p, 1] * m[1, 2] + dirs[p, 2] * m[2, 2]
        nrm = math.sqrt(x * x + y * y + z * z)
        pdf[p] = _mitsuba_eval(x / nrm, y / nrm, z / nrm, rgb, 1.0, warp, rad, p)


def eval_pdf(technique, dirs, rows=None, skip=None,
                     rgb=None) -> tuple[np.ndarray, np.ndarray]:
    """(radiance (P, 3), emitter pdf (P,)) of a ``Mitsuba3Envmap`` at directions ``dirs``:
    world, or local with ``rows`` the local frame's axes as rows (world = ``dirs @ rows``);
    0 and 0 where ``skip`` (P,) is ≤ 0 (a BSDF sample of weight 0). ``rgb``: the technique's
    texels times its scale, when the caller keeps them (:func:`scaled_texels`)."""
    rad, pdf = np.empty((len(dirs), 3)), np.empty(len(dirs))
    rows = np.eye(3) if rows is None else np.ascontiguousarray(rows, dtype=np.float64)
    skip = np.zeros(0) if skip is None else np.ascontiguousarray(skip, dtype=np.float64)
    _mitsuba_dirs(np.ascontiguousarray(dirs, dtype=np.float64), rows,
                  np.ascontiguousarray(technique.native_to_world),
                  scaled_texels(technique) if rgb is None else rgb, technique.warp.data, skip,
                  rad, pdf)
    return rad, pdf


def scaled_texels(technique) -> np.ndarray:
    """A ``Mitsuba3Envmap``'s texels times its scale (what :func:`eval_pdf` reads)."""
    return np.ascontiguousarray(technique.rgb * float(technique.scale))

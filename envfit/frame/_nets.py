r"""The frame's pixels under a sampler whose every dimension is one randomised net per pixel,
visited in an order of its own (Mitsuba's ``ldsampler``: pairing ``same_net_permuted``,
:attr:`envfit.renderers.SamplerSpec.film_points`).

Such a sampler's error is not MSE₁/N: its film position (call 0), its emitter sample and its
BSDF sample (the calls :attr:`~envfit.renderers._frame.FrameScene.draws`) are the same
scrambled (0, 2)-net in three orders, so the pixel's error depends on how the integrand varies
across the pixel and across each technique's sample square together. It is computed from the
sampler's own points: for pixel p with film cells c (G × G of them, each the renderer's first
hit at its midpoint with its techniques' tables :math:`T_{e,c}`, :math:`T_{b,c}` at the midpoints
of their grids, :func:`envfit.frame._model.surface_tables`), one render's pixel is

.. math::  F = \frac1N\sum_j \Big[T_{e,c(x_j)}(u_j) + T_{b,c(x_j)}(u'_j)\Big]

with :math:`x_j, u_j, u'_j` the points of sample j in the three calls (the box filter: every
sample in its own pixel), and its MSE :math:`E(F - I)^2`, I the tables' mean, is the mean
over R pixel scrambles (:func:`pixel_mse_nets`; the same R scrambles for every pixel, each
pixel's integrand its own). A cell where the camera sees the map holds the map's radiance (no
technique draws); a surface seen from behind, 0. G = S; 8 where a silhouette crosses the pixel
(:func:`envfit.frame._model.edge_pixels`; the renderer's first hits, their tables one level
coarser), and where the camera sees only the map (its radiance at camera directions
interpolated across the pixel, as the independent model's :func:`~envfit.frame._model.
_background` takes them).

The tables' level is one above the requested level and above log₄ N (:func:`net_level`: the
grid ≥ 4 × finer than the net's 1/N cells), and the answer is predicted to N = 4^(L−1)
(:func:`resolved`; past it the caller extrapolates at the last two counts' rate). The error from the integrand's variation above the grid is added as
:data:`ABOVE` × the tables' finest-shell power over N: the digital shift's dual net takes
≈ 1/N of the power above a grid, and that power is the finest shell's × 1/3 where each finer
shell holds a quarter of the one before (an integrand linear inside the cells; a jump's
shells halve instead, and 1/3 then underestimates it). On ``bench/frame_check.py``'s
``spheres_box`` scene under forest (300 sampled pixels, standard errors 3–5 %), the image RMSE
over the rendered one at 16, 64 and 256 spp: level 5 without this term 0.95, 0.91, 0.85, with
it 1.03, 1.04, 0.99; level 6 without it 0.90, 0.95, 0.97.

What this leaves out, and says (:data:`LIMITS`): the variation inside a film cell; the
simulation's own error (R scrambles per pixel, :func:`scrambles`).
"""
from __future__ import annotations

import numba
import numpy as np

from envfit.base import ParameterError
from envfit.frame._model import (FilmBlock, _lerp, _Techniques, edge_pixels,
                                 surface_tables)
from envfit.frame._visibility import Visibility
from envfit.renderers import HIT_SURFACE, FrameScene, get_renderer

__all__ = ["net_sampler", "pixel_mse_nets", "scrambles", "net_level", "resolved", "LIMITS",
           "film_span", "cell_weights"]

#: what the net model leaves out, as the prediction's note says it
LIMITS = ("each pixel's error from the sampler's own points over {r} of its scrambles ({filt}"
          "), the tables at level {level} (4^{level} points; predicted to {top} spp), "
          "the error above their grid from their finest shell; the film's variation inside "
          "a film cell is left out")
#: the share of an importance-sampled filter's samples allowed past the film square the
#: model tabulates (:func:`film_span`)
TAIL = 0.02
#: film cells per side where a silhouette crosses the pixel
_EDGE = 8
#: pixels per batch of tables (a batch under an importance-sampled filter: its pixels share
#: their cells, :func:`_shared`, so it takes a few rows of the film)
_PIXELS, _PIXELS_SHARED = 24, 192
#: the error above the tables' grid: this share of their finest shell's power, over N (the
#: power above a grid whose integrand is linear inside the cells of the grid one coarser is
#: 1/3 of the finest shell's, each finer shell holding a quarter of the one before)
ABOVE = 1.0 / 3.0


def net_sampler(fs: FrameScene):
    """The scene's sampler record if its error is modelled here (the renderer's own points
    per pixel: a net in Mitsuba's ``ldsampler`` orders, or any sampler of a renderer that
    importance-samples its filter and gives its points), else None; a scene it cannot model
    is refused in one line."""
    spec = get_renderer(fs.renderer).sampler(fs.sampler)
    if spec.film_points is None or (spec.pairing != "same_net_permuted"
                                    and fs.film_warp is None):
        return None
    if fs.filter_name != "box" and fs.film_warp is None:
        raise ParameterError(f"the scene's {fs.sampler} sampler is predicted with the box "
                             f"filter only so far (the film has {fs.filter_name}): its "
                             f"samples' splats to neighbouring pixels are not modelled")
    two = [b.name for b in fs.bsdfs if b.lobes > 1]
    if two and _lobe_call(fs) is None:
        raise ParameterError(f"{two[0]} picks one of two lobes per sample: its lobe choice "
                             f"under the {fs.sampler} sampler's own points is not in the frame "
                             f"model for {fs.renderer}")
    if fs.draws is None:
        raise ParameterError(f"the scene's integrator ({fs.integrator}, {fs.emitter_samples} "
                             f"emitter and {fs.bsdf_samples} BSDF samples) has no known "
                             f"order of {fs.sampler}'s dimensions")
    return spec


def _lobe_call(fs: FrameScene) -> int | None:
    """The sampler call whose first number picks a two-lobe BSDF's lobe (the record's
    ``lobe_call`` of its ``mis`` strategy), where the scene has such a BSDF whose lobe draws
    each lobe on its own (``sample_lobe``, ``lobe_probability``); else None."""
    two = [b for b in fs.bsdfs if b.lobes > 1]
    if not two:
        return None
    call = get_renderer(fs.renderer).strategy("mis").lobe_call
    ok = all(hasattr(b.lobe, "sample_lobe") and hasattr(b.lobe, "lobe_probability")
             for b in two)
    return call if ok else None


def scrambles(n: int) -> int:
    """R, the pixel scrambles simulated at N spp: 2^14/N within [16, 64]."""
    return int(min(64, max(16, (1 << 14) // int(n))))


def net_level(level: int, spps) -> int:
    """The tables' level for a net sampler at the largest of ``spps``: one above ``level``
    and above log₄ N (the grid 4 × finer than the net at least)."""
    top = max(int(n) for n in spps)
    return max(int(level) + 1, -(-(top.bit_length() - 1) // 2) + 1)


def resolved(level: int) -> int:
    """The largest spp the tables of ``level`` are trusted for: 4^(level − 1)."""
    return 4 ** (int(level) - 1)


def film_span(fs: FrameScene) -> tuple[float, float]:
    """(start, size): the film square a pixel's samples reach, in pixels from its corner per
    axis — the pixel (0, 1), or where an importance-sampled filter puts all but
    :data:`TAIL` of them (:attr:`~envfit.renderers._frame.FrameScene.film_warp`), rounded
    out to quarter pixels: Cycles' Blackman–Harris 1.5 px reaches ±1.5 px from the centre
    (its table spans twice the width), 98 % of its samples within ±0.93: (−0.5, 2). The rest
    count in the square's edge cells (:func:`_film` clamps them)."""
    if fs.film_warp is None:
        return 0.0, 1.0
    u = (np.arange(1 << 16) + 0.5) / (1 << 16)
    reach = float(np.quantile(np.abs(fs.film_warp.offset(u)), 1.0 - TAIL))
    e = np.ceil(max(0.0, reach - 0.5) * 4.0 - 1e-9) / 4.0
    return -e, 1.0 + 2.0 * e


def _film(fs: FrameScene, u: np.ndarray) -> np.ndarray:
    """The film numbers ``u`` in [0, 1) as positions in the :func:`film_span` square, in
    [0, 1) of its side (the filter's offset where the renderer importance-samples it)."""
    if fs.film_warp is None:
        return u
    lo, size = film_span(fs)
    return np.clip((fs.film_warp.offset(u) + 0.5 - lo) / size, 0.0, 1.0 - 1e-12)


def cell_weights(fs: FrameScene, g: int) -> np.ndarray:
    """The probability (g,) that a sample's film position falls in each of g equal cells of
    the :func:`film_span` side (1/g each for a uniform film; the filter's mass in each)."""
    if fs.film_warp is None:
        return np.full(int(g), 1.0 / int(g))
    u = (np.arange(1 << 16) + 0.5) / (1 << 16)
    c = np.minimum((_film(fs, u) * g).astype(np.int64), int(g) - 1)
    return np.bincount(c, minlength=int(g)) / float(len(u))


def _sky(block: FilmBlock, rows, tq: _Techniques, span=(0.0, 1.0)) -> dict:
    """Film cells on an :data:`_EDGE`² grid over the ``span`` square of the pixels ``rows``
    of ``block`` where the camera sees only the map: the map's radiance by the renderer's
    own technique at the camera directions interpolated from each pixel's corner rays."""
    g = _EDGE
    t = span[0] + span[1] * (np.arange(g) + 0.5) / g
    u, v = np.broadcast_arrays(t[None, :], t[:, None])
    d = _lerp(block.corners[rows], u, v).reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    h = {key: np.zeros((len(d),) + val.shape[3:], val.dtype)
         for key, val in block.hits.items()}
    h["shape"][:] = -1
    h["background"] = np.asarray(tq.tech.eval_unit(d @ tq.rot), dtype=np.float64)
    return h


def _cells(fs: FrameScene, block: FilmBlock, sel: np.ndarray, edges: np.ndarray,
           tq: _Techniques) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """The film cells of the block's pixels ``sel``: every pixel on a G × G grid over its
    :func:`film_span` (G = S, or ⌈S × span⌉ cells of about 1/S px under an importance-
    sampled filter; :data:`_EDGE` where ``edges`` — the renderer's first hits — or where the
    camera sees only the map — :func:`_sky`). Returns the cells' hits (flat arrays, one row
    per distinct cell, with ``edge``: on an edge grid of first hits) and, per (pixel, cell),
    its ``pixel`` (row in ``sel``), ``cell`` (row-major in its grid) and ``row`` in the hits:
    an importance-sampled filter's squares overlap, and neighbouring pixels read the same
    cells of one film grid (:func:`_shared`)."""
    s = block.side
    span = film_span(fs)
    sky = np.all(block.hits["kind"][sel] != HIT_SURFACE, axis=(1, 2)) & ~edges[sel]
    parts, meta = [], []
    plain = [k for k, i in enumerate(sel) if not edges[i] and not sky[k]]
    if plain and fs.film_warp is None:
        h = {key: v[sel[plain]].reshape((len(plain) * s * s,) + v.shape[3:])
             for key, v in block.hits.items()}
        parts.append(h)
        meta.append((np.repeat(plain, s * s), np.tile(np.arange(s * s), len(plain)), None,
                     False))
    elif plain:                                  # the filter's square, cells ≈ 1/S px
        h, pix, cell, row = _shared(fs, block.pixels[sel[plain]], s, span)
        parts.append(h)
        meta.append((np.asarray(plain)[pix], cell, row, False))
    g = _EDGE
    blue = np.flatnonzero(sky)
    if len(blue):
        parts.append(_sky(block, sel[blue], tq, span))
        meta.append((np.repeat(blue, g * g), np.tile(np.arange(g * g), len(blue)), None,
                     False))
    fine = [k for k, i in enumerate(sel) if edges[i]]
    if fine:
        parts.append(_grid_hits(fs, block.pixels[sel[fine]], g, span))
        meta.append((np.repeat(fine, g * g), np.tile(np.arange(g * g), len(fine)), None,
                     True))
    top, rows = 0, []
    for p, (_, _, row, edge) in zip(parts, meta):
        n = len(p["kind"])
        p["edge"] = np.full(n, edge)
        rows.append(top + (np.arange(n) if row is None else row))
        top += n
    h = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return (h, np.concatenate([m[0] for m in meta]), np.concatenate([m[1] for m in meta]),
            np.concatenate(rows))


def _shared(fs: FrameScene, pixels: np.ndarray, s: int, span) -> tuple:
    """The cells of ``pixels`` (P, 2) on the film's grid of 1/S px, each pixel's the w × w
    of its :func:`film_span` square (w = S × its side): the distinct cells' first hits and,
    per (pixel, cell), the pixel's index, the cell's row-major index in its square and the
    row of its hit. Where the square's start is not on that grid, each pixel its own cells."""
    w = int(np.ceil(s * span[1] - 1e-9))
    e = -span[0] * s
    local = np.arange(w)
    pix = np.repeat(np.arange(len(pixels)), w * w)
    cell = np.tile(np.arange(w * w), len(pixels))
    if abs(e - round(e)) > 1e-9:
        return _grid_hits(fs, pixels, w, span), pix, cell, np.arange(len(pix))
    gy = (pixels[:, 0, None] * s - round(e) + local[None, :])[:, :, None]
    gx = (pixels[:, 1, None] * s - round(e) + local[None, :])[:, None, :]
    keys = np.stack(np.broadcast_arrays(gy, gx), axis=-1).reshape(-1, 2)
    uniq, row = np.unique(keys, axis=0, return_inverse=True)
    h = fs.hits_at(np.column_stack([(uniq[:, 1] + 0.5) / s, (uniq[:, 0] + 0.5) / s]))
    return h, pix, cell, row.reshape(-1)


def _grid_hits(fs: FrameScene, pixels: np.ndarray, g: int, span) -> dict:
    """The renderer's first hits at the midpoints of a g × g grid over the ``span`` square
    of each of ``pixels`` (P, 2) (row, column), row-major per pixel."""
    t = span[0] + span[1] * (np.arange(g) + 0.5) / g
    yy, xx = np.meshgrid(t, t, indexing="ij")
    fx = (pixels[:, 1, None] + xx.ravel()[None, :]).ravel()
    fy = (pixels[:, 0, None] + yy.ravel()[None, :]).ravel()
    return fs.hits_at(np.column_stack([fx, fy]))


def _tables(fs: FrameScene, h: dict, fine: _Techniques, coarse: _Techniques,
            vis: Visibility):
    """Every cell's three tables, flat (T, 3), with each cell's (offset, side) per table
    (C, 3, 2) and its chance p (C,) of the BSDF's lobe 0: the map technique's table, the
    BSDF technique's for lobe 0 and for lobe 1 (the same table for a one-lobe BSDF, p = 1;
    :func:`~envfit.frame._model.surface_tables` with ``split``) on a surface that faces the
    camera (cells of an edge grid at ``coarse``'s level), the map's radiance (one entry, and
    a zero BSDF entry) where the camera sees the map, zeros elsewhere; and the shadow rays
    cast."""
    c = len(h["kind"])
    chunks, tabs, lobe_p = [], np.ones((c, 3, 2), np.int64), np.ones(c)
    const = np.zeros((c, 2, 3))
    const[:, 0] = np.where((h["kind"] != HIT_SURFACE)[:, None], h["background"], 0.0)
    chunks.append(const.reshape(-1, 3))
    tabs[:, 0, 0], tabs[:, 1, 0] = 2 * np.arange(c), 2 * np.arange(c) + 1
    tabs[:, 2, 0] = tabs[:, 1, 0]
    top = 2 * c
    rays = 0
    for tq, sel in ((fine, ~h["edge"]), (coarse, h["edge"])):
        sub = {k: v[sel] for k, v in h.items()}
        where = np.flatnonzero(sel)
        for b, e, (ga, gb, p), level, cast in surface_tables(sub, tq, vis, fs, split=True):
            m = 1 << level
            for part, tab in ((0, e), (1, ga), (2, gb)):
                sz = tab.shape[1]
                if part == 2 and gb is ga:
                    tabs[where[b], 2] = tabs[where[b], 1]
                    continue
                chunks.append(tab.reshape(-1, 3))
                tabs[where[b], part, 0] = top + sz * np.arange(len(b))
                tabs[where[b], part, 1] = m
                top += sz * len(b)
            lobe_p[where[b]] = p
            rays += cast
    return np.concatenate(chunks), tabs, lobe_p, rays


def _weights(fs: FrameScene, grid: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """The probability of each film cell (its pixel's grid side ``grid``, its row-major
    index ``cell``) that a sample falls in it (:func:`cell_weights` per axis)."""
    out = np.empty(len(cell))
    for g in np.unique(grid):
        w = cell_weights(fs, int(g))
        at = grid == g
        out[at] = w[cell[at] // g] * w[cell[at] % g]
    return out


@numba.njit(cache=True, inline="always")
def _entry(off, m, u0, u1):  # pragma: no cover - numba
    """The row of ``flat`` that a point (u0, u1) reads in an m × m table at ``off``."""
    return off + min(int(u0 * m), m - 1) * m + min(int(u1 * m), m - 1)


@numba.njit(cache=True, parallel=True)
def _squared_errors(flat, tabs, lobe_p, cellrow, pixels, points, means,
                    out):  # pragma: no cover - numba
    """out[k] = the mean over the scrambles r of (F − I)² (channels) of pixel k, whose cells
    on a ``pixels[k, 1]``² film grid are the rows ``cellrow[pixels[k, 0]]`` … of ``tabs``
    ((offset, side) of the map's table, lobe 0's and lobe 1's) and ``lobe_p`` (lobe 0's
    chance); ``points`` (4, R, N, 2): the film's, the emitter's, the BSDF's points and the
    lobe numbers (column 0)."""
    film, ue, ub, ul = points[0], points[1], points[2], points[3]
    nr, nn = film.shape[0], film.shape[1]
    for k in numba.prange(out.shape[0]):
        g = pixels[k, 1]
        a0 = a1 = a2 = 0.0
        for r in range(nr):
            f0 = f1 = f2 = 0.0
            for j in range(nn):
                cx = min(int(film[r, j, 0] * g), g - 1)
                cy = min(int(film[r, j, 1] * g), g - 1)
                c = cellrow[pixels[k, 0] + cy * g + cx]
                t = _entry(tabs[c, 0, 0], tabs[c, 0, 1], ue[r, j, 0], ue[r, j, 1])
                q = 1 if ul[r, j, 0] < lobe_p[c] else 2
                s = _entry(tabs[c, q, 0], tabs[c, q, 1], ub[r, j, 0], ub[r, j, 1])
                f0 += flat[t, 0] + flat[s, 0]
                f1 += flat[t, 1] + flat[s, 1]
                f2 += flat[t, 2] + flat[s, 2]
            d0, d1, d2 = f0 / nn - means[k, 0], f1 / nn - means[k, 1], f2 / nn - means[k, 2]
            a0 += d0 * d0
            a1 += d1 * d1
            a2 += d2 * d2
        out[k, 0], out[k, 1], out[k, 2] = a0 / nr, a1 / nr, a2 / nr


@numba.njit(cache=True, parallel=True)
def _table_stats(flat, offs, sides, means, shell):  # pragma: no cover - numba
    """Each cell's table mean and finest-shell power (the mean over its 2 × 2 blocks of their
    variance; 0 for a one-entry table), (C, 3) each."""
    for c in numba.prange(offs.shape[0]):
        m, o = sides[c], offs[c]
        for ch in range(3):
            s1 = 0.0
            s2 = 0.0
            b2 = 0.0
            for i in range(0, m, 2 if m > 1 else 1):
                for j in range(0, m, 2 if m > 1 else 1):
                    if m == 1:
                        v = flat[o, ch]
                        s1 += v
                        s2 += v * v
                        b2 += v * v
                        continue
                    bs = 0.0
                    for di in range(2):
                        for dj in range(2):
                            v = flat[o + (i + di) * m + j + dj, ch]
                            bs += v
                            s2 += v * v
                    s1 += bs
                    b2 += (bs / 4.0) ** 2
            cells = m * m
            means[c, ch] = s1 / cells
            shell[c, ch] = max(s2 / cells - b2 / (cells / 4.0 if m > 1 else 1.0), 0.0)


def pixel_mse_nets(fs: FrameScene, block: FilmBlock, targets, spps, level: int, seed: int,
                   bar=None, base: int | None = None) -> tuple[np.ndarray, dict, int, int]:
    """(converged value (K, 3), {N: MSE (K, 3)}, shadow rays, edge pixels) of the
    ``targets`` pixels (K, 2) of ``block`` at each runnable N of ``spps`` (module
    docstring); the tables at level ``level`` (edge cells one coarser), a glossy lobe's at
    ``base`` (the requested level) + its extra levels where that is finer."""
    spec = net_sampler(fs)
    tg = np.asarray(targets, dtype=np.int64).reshape(-1, 2)
    index = {(int(y), int(x)): i for i, (y, x) in enumerate(block.pixels)}
    sel = np.array([index[(int(y), int(x))] for y, x in tg], dtype=np.int64)
    vis = Visibility(fs.occluders)
    edges = edge_pixels(block, vis, span=film_span(fs))
    base = int(level) if base is None else int(base)
    fine = _Techniques(fs, int(level), gloss_base=base)
    coarse = _Techniques(fs, max(2, int(level) - 1), technique=fine.tech, gloss_base=base - 1)
    calls, lobe = fs.draws, _lobe_call(fs)
    dims = max(max(calls), lobe or 0) + 1
    points = {}
    for n in spps:
        pt = np.array(spec.film_points(scrambles(n), n, dims, seed))
        pt[:, :, 0] = _film(fs, pt[:, :, 0])
        if lobe is None:                        # one lobe everywhere: lobe numbers 0
            pt = np.concatenate([pt, np.zeros(pt.shape[:2] + (1, 2))], axis=2)
        points[n] = pt
    lobe = dims if lobe is None else lobe
    value = np.zeros((len(tg), 3))
    mse = {n: np.zeros((len(tg), 3)) for n in spps}
    rays = 0
    step = _PIXELS if fs.film_warp is None else _PIXELS_SHARED
    for lo in range(0, len(sel), step):
        part = sel[lo:lo + step]
        h, pix, cell, row = _cells(fs, block, part, edges, fine)
        flat, tabs, lobe_p, cast = _tables(fs, h, fine, coarse, vis)
        rays += cast
        order = np.lexsort((cell, pix))
        cellrow = np.ascontiguousarray(row[order], dtype=np.int64)
        counts = np.bincount(pix, minlength=len(part))
        first = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        grid = np.round(np.sqrt(counts)).astype(np.int64)
        weight = _weights(fs, grid[pix[order]], cell[order])[:, None]
        c = len(tabs)
        cell_mean, shell = np.zeros((c, 3)), np.zeros((c, 3))
        for p, share in ((0, 1.0), (1, lobe_p[:, None]), (2, 1.0 - lobe_p[:, None])):
            a, b = np.zeros((c, 3)), np.zeros((c, 3))
            _table_stats(flat, np.ascontiguousarray(tabs[:, p, 0]),
                         np.ascontiguousarray(tabs[:, p, 1]), a, b)
            cell_mean += share * a
            shell += share * b
        means = np.add.reduceat(cell_mean[cellrow] * weight, first, axis=0)
        above = np.add.reduceat(shell[cellrow] * weight, first, axis=0)
        value[lo:lo + len(part)] = means
        for n in spps:
            pt = points[n]
            out = np.zeros((len(part), 3))
            _squared_errors(flat, tabs, lobe_p, cellrow, np.column_stack([first, grid]),
                            np.ascontiguousarray(pt[:, :, [0, calls[0], calls[1], lobe]]
                                                 .transpose(2, 0, 1, 3)), means, out)
            mse[n][lo:lo + len(part)] = out + ABOVE * above / n
        if bar is not None:
            bar.update(len(part))
    return value, mse, rays, int(np.sum(edges[sel]))

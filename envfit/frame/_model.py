r"""The frame model: each pixel's predicted error under the renderer's estimator, with the
scene's shadows, materials and pixel filter.

**One film point.** At a film point x whose camera ray hits a surface at p with shading frame
(s, t, n) and the direction :math:`\omega_i` to the camera, one spp of the renderer's direct
estimator is (``direct`` with :math:`n_e` emitter and :math:`n_b` BSDF samples; ``path`` at
depth 2 is :math:`n_e = n_b = 1`)

.. math::  F(x) = \frac1{n_e}\sum_{i} h_e(x, u_i) + \frac1{n_b}\sum_k h_b(x, u'_k),

:math:`h_e = \frac{L(\omega)\,f(\omega_i, \omega)\cos^+\theta}{p_e(\omega)}\,
w_e(\omega)\,V(p, \omega)` at the map sample :math:`\omega(u)` and
:math:`h_b = L(\omega)\,\frac{f\cos\theta}{p_b}(\omega)\,w_b(\omega)\,V(p, \omega)` at
the BSDF's own sample, with the renderer's own technique, pdfs and power-heuristic weights
(:math:`w_e = (\tfrac{n_e}{n} p_e)^2/((\tfrac{n_e}{n} p_e)^2 + (\tfrac{n_b}{n} p_b)^2)`) and
the visibility V of :mod:`._visibility`. For a diffuse surface of albedo ρ, f = ρ/π and the BSDF
samples the cosine (as ``map_values`` and ``bsdf_values`` of
:mod:`envfit.predict.renderer._integrand_tables` tabulate them for the sphere); for a glossy
lobe (a rough conductor, :class:`~envfit.renderers._frame.FrameBsdf`) f·cos, :math:`p_b` and
the sample weight f·cos/:math:`p_b` are the renderer's lobe's (visible-normal sampling), times
its Fresnel per channel at :math:`\omega_i\cdot m` and the specular reflectance at the hit. Its
mean and variance over the samples,

.. math::  I(x) = E_u h_e + E_{u'} h_b,\qquad
           v(x) = \frac{\mathrm{Var}_u h_e}{n_e} + \frac{\mathrm{Var}_{u'} h_b}{n_b},

are the midpoint quadratures of the technique's own tables at level ``level`` (4^level
points each; a glossy lobe's at ``level`` + its ``level_extra``: the map technique's in the
map's sample square, the lobe's in its own). A camera ray that escapes sees the map:
:math:`I(x) = L`, :math:`v(x) = 0`.

**Film points.** Each pixel has S × S strata, each represented by its midpoint; where the
camera sees the map, a stratum's mean and the variance of I within it come from
⌈8/S⌉² directions (:func:`_background`). A pixel that a silhouette crosses
(:func:`edge_pixels`: camera rays at 8 × 8 positions meet more than one shape, or a shape and
the map) has each stratum from ⌈8/S⌉² sub-points (the renderer's own first hits, the
techniques one level coarser): their mean I, mean v, and the variance of I within the
stratum.

**One pixel.** With the ``independent`` sampler each of the N samples of pixel q lies uniformly
in q and every sample splats to pixel p with the filter's weight :math:`w(x - c_p)` (box: 1 in
its own pixel); the pixel is :math:`\hat I_p = \sum_j w_j F_j / \sum_j w_j` (Mitsuba's
``ImageBlock::put`` and ``develop``). To first order in 1/N (the delta method),

.. math::  \mathrm{MSE}_p = \frac{1}{N W_p^2}\sum_q\Big[\int_q w^2\big(v + (I - I_p)^2\big)dx
           - \Big(\int_q w\,(I - I_p)\,dx\Big)^2\Big],\quad
           W_p = \sum_q\int_q w\,dx,\; I_p = \frac1{W_p}\sum_q\int_q w\,I\,dx,

the integrals over each pixel taken at its S × S film points; :math:`I_p` is the converged
image (the preview this model draws). For the box filter this is
:math:`(\overline{v} + \mathrm{Var}_x I)/N` over the pixel.

Only the ``independent`` sampler is modelled for frames (its error is exactly 1/N in the
variance); the low-discrepancy samplers' rates on a shadowed integrand are not yet.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.base import progress_bar
from envfit.frame._visibility import Visibility
from envfit.maps import EnvMap
from envfit.predict.renderer import (BsdfTable, MapTable, compiled_layered,
                                     layered_eval_pdf, layered_sample, layered_views,
                                     midpoints)
from envfit.renderers import get_renderer
from envfit.renderers import HIT_SURFACE, FrameScene

__all__ = ["FilmBlock", "film_block", "PointMoments", "point_moments", "pixel_mse", "edge_pixels",
           "filter_weights", "filter_reach", "MODELLED_SAMPLERS"]

#: the samplers whose frame error is modelled
MODELLED_SAMPLERS = ("independent",)
#: film points per batch of shadow rays
_BATCH = 64
#: directions per side of a pixel where the camera sees the map
_SUB = 8


@dataclass(frozen=True)
class PointMoments:
    """Per film point (H, W, S, S, 3): the mean I(x) over its stratum, the per-spp
    variance v(x), and the variance of I within the stratum (``within``: computed where the
    camera sees the map, from :data:`_SUB` ² directions per stratum; 0 on surfaces)."""

    mean: np.ndarray
    var: np.ndarray
    within: np.ndarray
    rays: int
    edges: int = 0


def _offset(p: np.ndarray) -> np.ndarray:
    """The shadow rays' origin offsets along the geometric normal (B,)."""
    return 1e-4 * (1.0 + np.max(np.abs(p), axis=-1))


def _power(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The power heuristic a²/(a² + b²) (0 where both are 0)."""
    a2, b2 = a * a, b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(a2 + b2 > 0, a2 / (a2 + b2), 0.0)


class _Techniques:
    """The renderer's map technique and cosine sampling tabulated once at level ``level``,
    evaluated for a batch of film points (:meth:`parts`); ``technique``: one already built
    from this scene's map (its warp is not built again). A glossy lobe's tables are at
    :meth:`glossy_level`: ``gloss_base`` (default ``level``) plus the lobe's
    ``level_extra``, never coarser than ``level``."""

    def __init__(self, fs: FrameScene, level: int, technique=None,
                 gloss_base: int | None = None):
        rec = get_renderer(fs.renderer)
        self.rec, self.level = rec, int(level)
        self.gloss_base = self.level if gloss_base is None else int(gloss_base)
        # the radiance scale multiplies the texels (every renderer's importance map is
        # invariant to it; Mitsuba's scale and Cycles' Strength alike)
        data = fs.envmap_data if fs.envmap_scale == 1.0 else fs.envmap_data * fs.envmap_scale
        self.tech = technique if technique is not None else rec.technique(EnvMap(data))
        self.map = MapTable.build(self.tech, level)
        self.local = BsdfTable.build(rec, level).local
        self.rot = np.asarray(fs.envmap_to_world, dtype=np.float64)
        self.map_world = self.map.directions @ self.rot.T
        self._maps = {self.level: (self.map, self.map_world)}
        tot = fs.emitter_samples + fs.bsdf_samples
        self.fe, self.fb = fs.emitter_samples / tot, fs.bsdf_samples / tot

    def _eval_pdf(self, d: np.ndarray):
        f = getattr(self.tech, "eval_pdf", None)
        if f is not None:
            return f(np.ascontiguousarray(d))
        return self.tech.eval_unit(d), self.tech.pdf_unit(d)

    def parts(self, normals: np.ndarray):
        """For B normals (world): the map part's values without visibility (B, P, 3), the BSDF
        part's (B, P, 3), and both parts' world ray directions (P, 3) and (B, P, 3)."""
        n = normals @ self.rot                          # native frame: R^T n per row
        c = n @ self.map.directions.T                   # (B, P)
        pe = self.map.pdf[None, :]
        we = np.where((c > 0) & (pe > 0), _power(self.fe * pe, self.fb * np.maximum(c, 0)
                                                  / np.pi), 0.0)
        he = self.map.base[None] * (np.maximum(c, 0.0) * we)[..., None]
        frames = self.rec.tangent_frame(n)              # (B, 3, 3) rows s, t, n
        d = np.matmul(self.local, frames)                # (B, P, 3): local @ rows s, t, n
        rad, pdf = self._eval_pdf(d.reshape(-1, 3))
        wb = _power(self.fb * self.local[None, :, 2] / np.pi,
                    self.fe * np.asarray(pdf).reshape(d.shape[:2]))
        hb = np.asarray(rad).reshape(d.shape) * wb[..., None]
        return he, hb, self.map_world, d @ self.rot.T

    def glossy_level(self, bsdf) -> int:
        """The level of a glossy lobe's tables."""
        return max(self.level, self.gloss_base + int(bsdf.level_extra))

    def _map_at(self, level: int):
        """The map technique's table at ``level`` and its directions in world space."""
        if level not in self._maps:
            mt = MapTable.build(self.tech, level)
            self._maps[level] = (mt, mt.directions @ self.rot.T)
        return self._maps[level]

    def lobe_parts(self, tangent: np.ndarray, wi: np.ndarray, bsdf):
        r"""For B film points of a two-lobe :class:`~envfit.renderers._frame.FrameBsdf`
        whose lobe has ``sample_lobe(wi, u, lobe)`` and ``lobe_probability(cos)``: the map
        part (B, P, 3), the BSDF part's table of each lobe (B, Q, 3) — the directions drawn
        from lobe 0 or 1 with the mixture's weight f·cos/p and its MIS weight, as the
        renderer evaluates every closure at a sampled direction — their world directions
        ((P, 3); (B, Q, 3) each) and the chance p (B,) that the lobe number picks lobe 0."""
        he, _, world, _ = self.glossy_parts(tangent, wi, bsdf, bsdf_part=False)
        lvl = self.glossy_level(bsdf)
        u = midpoints(lvl)
        b, q = len(wi), len(u)
        fr = tangent @ self.rot
        wi_q = np.repeat(wi, q, axis=0)
        lay = _layered(bsdf)
        views = None if lay is None else layered_views(lay, wi)
        parts, dirs = [], []
        for lobe in (0, 1):
            if lay is not None:                     # compiled, one view at a time
                pick = 0.0 if lobe == 0 else float(np.nextafter(1.0, 0.0))
                wo, weight, pdf = (np.stack(x) for x in zip(*(
                    layered_sample(lay, wi[k], u, pick, views[k]) for k in range(b))))
            else:
                smp = bsdf.lobe.sample_lobe(wi_q, np.tile(u, (b, 1)), lobe)
                wo, weight, pdf = (smp.wo.reshape(b, q, 3), smp.weight.reshape(b, q),
                                   smp.pdf.reshape(b, q))
            d = np.matmul(wo, fr)
            rad, pdf_e = self._eval_pdf(d.reshape(-1, 3))
            wb = np.where(weight > 0, _power(self.fb * pdf,
                                             self.fe * np.asarray(pdf_e).reshape(b, q)), 0.0)
            parts.append(np.asarray(rad).reshape(b, q, 3) * (weight * wb)[..., None])
            dirs.append(d @ self.rot.T)
        return he, parts, world, dirs, bsdf.lobe.lobe_probability(wi[:, 2])

    def glossy_parts(self, tangent: np.ndarray, wi: np.ndarray, bsdf,
                     bsdf_part: bool = True):
        r"""For B film points of one glossy :class:`~envfit.renderers._frame.FrameBsdf`
        (their shading frames ``tangent`` (B, 3, 3), rows s, t, n, world; ``wi`` (B, 3) in
        them): the map part :math:`L f\cos\theta_o/p_e\; w_e` (B, P, 3), the lobe's part
        :math:`L\,(f\cos/p_b)\,w_b` (B, Q, 3), and their world directions (P, 3) and
        (B, Q, 3), both tables at the midpoints of level :meth:`glossy_level`
        (the map's sample square; the lobe's, drawn by its own ``sample``)."""
        lvl = self.glossy_level(bsdf)
        mt, world = self._map_at(lvl)
        fr = tangent @ self.rot                            # rows s, t, n in the map's frame
        loc = np.einsum("bkj,pj->bpk", fr, mt.directions)  # the map's directions, shading
        b, p = loc.shape[:2]
        wi_p, flat = np.repeat(wi, p, axis=0), loc.reshape(-1, 3)
        lay = _layered(bsdf)
        if lay is not None:                         # compiled, one view at a time
            views = layered_views(lay, wi)
            fcos, pb = (np.stack(x) for x in zip(*(
                layered_eval_pdf(lay, wi[k], mt.directions, fr[k], views[k])
                for k in range(b))))
        else:
            fcos = bsdf.lobe.eval(wi_p, flat).reshape(b, p)
            pb = bsdf.lobe.pdf(wi_p, flat).reshape(b, p)
        pe = mt.pdf[None, :]
        we = np.where((fcos > 0) & (pe > 0), _power(self.fe * pe, self.fb * pb), 0.0)
        he = np.pi * mt.base[None] * (fcos * we)[..., None]
        if bsdf.fresnel is not None:
            h = wi_p + flat
            h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-300)
            he = he * bsdf.fresnel(np.sum(wi_p * h, axis=1)).reshape(b, p, 3)
        if not bsdf_part:
            return he, None, world, None
        u = midpoints(lvl)
        q = len(u)
        wi_q = np.repeat(wi, q, axis=0)
        smp = bsdf.lobe.sample(wi_q, np.tile(u, (b, 1)))
        d = np.einsum("bqk,bkj->bqj", smp.wo.reshape(b, q, 3), fr)
        rad, pdf_e = self._eval_pdf(d.reshape(-1, 3))
        weight = smp.weight.reshape(b, q)
        wb = np.where(weight > 0, _power(self.fb * smp.pdf.reshape(b, q),
                                         self.fe * np.asarray(pdf_e).reshape(b, q)), 0.0)
        hb = np.asarray(rad).reshape(b, q, 3) * (weight * wb)[..., None]
        if bsdf.fresnel is not None:
            hb = hb * bsdf.fresnel(np.sum(wi_q * smp.m, axis=1)).reshape(b, q, 3)
        return he, hb, world, d @ self.rot.T


def _layered(bsdf):
    """The :class:`~envfit.shading.microfacet.AlbedoLayered` a two-lobe lobe holds as its
    ``bsdf`` where the compiled kernels repeat it (``compiled_layered``), else None."""
    lay = getattr(bsdf.lobe, "bsdf", None)
    return lay if bsdf.fresnel is None and lay is not None and compiled_layered(lay) else None


def _lerp(c: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of corner values ``c`` (…, 2, 2, 3) [corner row, corner column]
    at (u across, v down) (broadcast), shape (…, <u/v shape>, 3)."""
    ex = (Ellipsis,) + (None,) * u.ndim + (slice(None),)
    c00, c01, c10, c11 = c[..., 0, 0, :], c[..., 0, 1, :], c[..., 1, 0, :], c[..., 1, 1, :]
    uu, vv = u[..., None], v[..., None]
    return ((1 - uu) * (1 - vv) * c00[ex] + uu * (1 - vv) * c01[ex]
            + (1 - uu) * vv * c10[ex] + uu * vv * c11[ex])


def _background(block: "FilmBlock", tq: "_Techniques", idx: np.ndarray):
    """The map seen by the camera over each escaped film point's stratum: its mean and
    variance (E, 3) from f × f directions per stratum (f = ⌈:data:`_SUB`/S⌉), interpolated
    from the pixel's corner directions (:attr:`FilmBlock.corners`) and evaluated by the
    renderer's own technique; ``idx`` (E, 3): (block pixel, stratum row, stratum column)."""
    if len(idx) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    s = block.side
    f = max(1, -(-_SUB // s))
    t = (np.arange(f) + 0.5) / f
    k, i, j = idx.T
    u = (j[:, None, None] + t[None, None, :]) / s            # (E, 1, f) across the pixel
    v = (i[:, None, None] + t[None, :, None]) / s            # (E, f, 1) down the pixel
    u, v = np.broadcast_arrays(u, v)
    c = block.corners[k]                                      # (E, 2, 2, 3)
    d = ((1 - u) * (1 - v))[..., None] * c[:, None, None, 0, 0] \
        + (u * (1 - v))[..., None] * c[:, None, None, 0, 1] \
        + ((1 - u) * v)[..., None] * c[:, None, None, 1, 0] \
        + (u * v)[..., None] * c[:, None, None, 1, 1]
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    rad = np.asarray(tq.tech.eval_unit(d @ tq.rot)).reshape(len(idx), f * f, 3)
    return rad.mean(axis=1), rad.var(axis=1)


@dataclass(frozen=True)
class FilmBlock:
    """The film points of a set of pixels, S × S strata each, read by the renderer.

    ``pixels`` (F, 2) (row, column); ``hits`` the arrays of
    :attr:`~envfit.renderers._frame.FrameScene.hits_at` at the strata's midpoints, shape
    (F, S, S, …); ``origins`` and ``corners`` the camera rays at each pixel's corners,
    (F, 2, 2, 3) [corner row, corner column]."""

    pixels: np.ndarray
    side: int
    hits: dict
    origins: np.ndarray
    corners: np.ndarray


def film_block(fs: FrameScene, pixels, side: int) -> FilmBlock:
    """The :class:`FilmBlock` of ``pixels`` (F, 2) with ``side`` × ``side`` film points."""
    px = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    s = int(side)
    offs = (np.arange(s) + 0.5) / s
    fx = px[:, 1, None, None] + offs[None, None, :] + 0.0 * offs[None, :, None]
    fy = px[:, 0, None, None] + offs[None, :, None] + 0.0 * offs[None, None, :]
    flat = fs.hits_at(np.column_stack([fx.ravel(), fy.ravel()]))
    hits = {k: v.reshape((len(px), s, s) + v.shape[1:]) for k, v in flat.items()}
    cy = px[:, 0, None, None] + np.array([0, 1])[None, :, None]
    cx = px[:, 1, None, None] + np.array([0, 1])[None, None, :]
    cy, cx = np.broadcast_arrays(cy, cx)
    keys = np.column_stack([cx.ravel(), cy.ravel()])
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    org, dirs = fs.rays_at(uniq.astype(np.float64))
    inv = inv.reshape(-1)
    return FilmBlock(px, s, hits, org[inv].reshape(len(px), 2, 2, 3),
                     dirs[inv].reshape(len(px), 2, 2, 3))


def surface_tables(h: dict, tq: _Techniques, vis: Visibility, fs: FrameScene,
                   split: bool = False):
    """The techniques' tables with visibility of the flat film points ``h`` (the arrays of
    :attr:`FrameScene.hits_at`) that hit a surface facing the camera, in batches of one
    shape: yields (indices (B,), the map part (B, P, 3), the BSDF part (B, Q, 3), level of
    each, shadow rays cast) — the parts :math:`h_e`, :math:`h_b` of the module docstring at
    the midpoints of a 2^level × 2^level grid of each technique's sample square. With
    ``split``, the BSDF part is a tuple (lobe 0's table, lobe 1's, the chance p (B,) of lobe
    0) — for a one-lobe BSDF (its table, the same, 1) — as :meth:`_Techniques.lobe_parts`
    draws a two-lobe BSDF's."""
    idx = np.flatnonzero((h["kind"] == HIT_SURFACE) & h["facing"])
    idx = idx[np.argsort(h["shape"][idx], kind="stable")]           # one shape per batch
    batches = [b for s in np.unique(h["shape"][idx]) for sel in [idx[h["shape"][idx] == s]]
               for b in np.array_split(sel, max(1, -(-len(sel) // _BATCH)))]
    for b in batches:
        shape = int(h["shape"][b[0]])
        o = h["position"][b] + _offset(h["position"][b])[:, None] * h["geo_normal"][b]
        bsdf = fs.bsdfs[shape] if shape < len(fs.bsdfs) else None
        a = h["albedo"][b][:, None, :]
        if split and bsdf is not None and bsdf.lobes > 1:
            he, (ga, gb), de, (da, db), p = tq.lobe_parts(h["tangent"][b], h["wi"][b], bsdf)
            n = de.shape[0]
            ve = vis.visible(np.repeat(o, n, axis=0), np.tile(de, (len(b), 1)), shape)
            va, vb = (vis.visible(np.repeat(o, d.shape[1], axis=0), d.reshape(-1, 3), shape)
                      for d in (da, db))
            yield (b, he * ve.reshape(len(b), n)[..., None] * a,
                   (ga * va.reshape(len(b), -1)[..., None] * a,
                    gb * vb.reshape(len(b), -1)[..., None] * a, p),
                   tq.glossy_level(bsdf), ve.size + va.size + vb.size)
            continue
        if bsdf is not None and bsdf.kind == "glossy":
            he, hb, de, db = tq.glossy_parts(h["tangent"][b], h["wi"][b], bsdf)
            level = tq.glossy_level(bsdf)
        else:
            he, hb, de, db = tq.parts(h["normal"][b])
            level = tq.level
        p = de.shape[0]
        ve = vis.visible(np.repeat(o, p, axis=0), np.tile(de, (len(b), 1)), shape)
        vb = vis.visible(np.repeat(o, db.shape[1], axis=0), db.reshape(-1, 3), shape)
        g = hb * vb.reshape(len(b), -1)[..., None] * a
        yield (b, he * ve.reshape(len(b), p)[..., None] * a,
               (g, g, np.ones(len(b))) if split else g, level, ve.size + vb.size)


def _surface_moments(h: dict, tq: _Techniques, vis: Visibility, fs: FrameScene, bar):
    """I and v (P, 3) of flat film points ``h`` (the arrays of :attr:`FrameScene.hits_at`)
    that hit a surface facing the camera, 0 elsewhere; and the shadow rays cast."""
    ne, nb = fs.emitter_samples, fs.bsdf_samples
    p_all = len(h["kind"])
    mean, var = np.zeros((p_all, 3)), np.zeros((p_all, 3))
    rays = 0
    for b, e, g, _, cast in surface_tables(h, tq, vis, fs):
        mean[b] = e.mean(axis=1) + g.mean(axis=1)
        var[b] = (e.var(axis=1) / ne if ne else 0.0) + (g.var(axis=1) / nb if nb else 0.0)
        rays += cast
        bar.update(len(b))
    return mean, var, rays


def edge_pixels(block: FilmBlock, vis: Visibility, fine: int = _SUB,
                span: tuple = (0.0, 1.0)) -> np.ndarray:
    """Whether each pixel of ``block`` (F,) is crossed by a silhouette: its camera rays at
    ``fine`` × ``fine`` positions (interpolated from its corner rays, cast by Embree against
    the occluders) meet more than one shape, or a shape and the map. The S × S film points
    can miss such an edge. ``span`` (start, size): the film square its samples reach, in
    pixels from its corner (the pixel; wider for an importance-sampled filter)."""
    t = span[0] + span[1] * (np.arange(fine) + 0.5) / fine
    u, v = np.broadcast_arrays(t[None, :], t[:, None])
    out = np.zeros(len(block.pixels), bool)
    for lo in range(0, len(out), 256):
        sl = slice(lo, lo + 256)
        d = _lerp(block.corners[sl], u, v).reshape(-1, 3)
        d /= np.linalg.norm(d, axis=1)[:, None]
        o = _lerp(block.origins[sl], u, v).reshape(-1, 3)
        ids = vis.first_shape(o, d).reshape(-1, fine * fine)
        out[sl] = ids.min(axis=1) != ids.max(axis=1)
    return out


def _refine(fs: FrameScene, block: FilmBlock, vis: Visibility, sel: np.ndarray,
            tq: _Techniques, bar):
    """The strata of the block's pixels ``sel`` from r × r sub-points each (r = ⌈:data:`_SUB`
    /S⌉, the renderer's first hits, the techniques ``tq``): the strata's mean I, mean v and
    the variance of I within them, (E, S, S, 3) each; and the shadow rays cast."""
    s = block.side
    r = max(2, -(-_SUB // s))
    t = (np.arange(r) + 0.5) / r
    y, x = block.pixels[sel, 0], block.pixels[sel, 1]
    i, j, a, b = np.meshgrid(np.arange(s), np.arange(s), t, t, indexing="ij")
    fx = x[:, None] + ((j + b) / s).ravel()[None, :]
    fy = y[:, None] + ((i + a) / s).ravel()[None, :]
    h = fs.hits_at(np.column_stack([fx.ravel(), fy.ravel()]))
    m, v, rays = _surface_moments(h, tq, vis, fs, bar)
    esc = h["kind"] != HIT_SURFACE
    m[esc] = h["background"][esc]
    m = m.reshape(len(sel), s, s, r * r, 3)
    v = v.reshape(len(sel), s, s, r * r, 3)
    return m.mean(axis=3), v.mean(axis=3), m.var(axis=3), rays


def point_moments(fs: FrameScene, block: FilmBlock, level: int = 4, quiet: bool = True,
                  refine: bool = True) -> PointMoments:
    """I(x) and v(x) at every film point of ``block`` (module docstring), the techniques
    tabulated at level ``level``; with ``refine``, the strata of the pixels a silhouette
    crosses (:func:`edge_pixels`) from ⌈:data:`_SUB`/S⌉² sub-points each, at level
    ``level`` − 1. Arrays (F, S, S, 3)."""
    if not 2 <= int(level) <= 9:
        raise ParameterError(f"the frame model's level must be 2..9, got {level}")
    tq = _Techniques(fs, int(level))
    vis = Visibility(fs.occluders)
    shp = block.hits["kind"].shape
    flat = {k: v.reshape((-1,) + v.shape[3:]) for k, v in block.hits.items()}
    edges = np.flatnonzero(edge_pixels(block, vis)) if refine else np.zeros(0, int)
    r = max(2, -(-_SUB // block.side))
    todo = int(np.sum((flat["kind"] == HIT_SURFACE) & flat["facing"]))
    bar = progress_bar(todo + len(edges) * block.side ** 2 * r * r, desc="frame model",
                       quiet=quiet, unit="point")
    m, v, rays = _surface_moments(flat, tq, vis, fs, bar)
    mean, var = m.reshape(shp + (3,)), v.reshape(shp + (3,))
    within = np.zeros(shp + (3,))
    esc = block.hits["kind"] != HIT_SURFACE
    mean[esc], within[esc] = _background(block, tq, np.argwhere(esc))
    if len(edges):
        coarse = _Techniques(fs, max(2, int(level) - 1), technique=tq.tech)   # one warp
        em, ev, ew, more = _refine(fs, block, vis, edges, coarse, bar)
        mean[edges], var[edges], within[edges] = em, ev, ew
        rays += more
    bar.close()
    return PointMoments(mean, var, within, rays, len(edges))


def filter_weights(fs: FrameScene, side: int) -> dict:
    """The filter's weight at each film point of the pixel at offset (dy, dx) from a pixel:
    {(dy, dx): (S, S) weights}, separable as the renderer's ``ImageBlock`` evaluates them
    (box: the pixel's own points, weight 1)."""
    s = int(side)
    if fs.filter_name == "box":
        return {(0, 0): np.ones((s, s))}
    reach = int(np.ceil(fs.filter_radius - 0.5))
    c = (np.arange(s) + 0.5) / s - 0.5                 # film point offsets from its centre
    out = {}
    for dy in range(-reach, reach + 1):
        wy = fs.filter_weights(dy + c)
        for dx in range(-reach, reach + 1):
            w = np.outer(wy, fs.filter_weights(dx + c))
            if np.any(w != 0):
                out[dy, dx] = w
    return out


def pixel_mse(fs: FrameScene, block: FilmBlock, pm: PointMoments,
              targets) -> tuple[np.ndarray, np.ndarray]:
    """(converged value (K, 3), MSE at one spp (K, 3)) of the ``targets`` pixels (K, 2)
    (module docstring), whose filter reach lies in ``block``; the MSE at N spp is this
    over N."""
    tg = np.asarray(targets, dtype=np.int64).reshape(-1, 2)
    index = np.full((fs.height, fs.width), -1, dtype=np.int64)
    index[block.pixels[:, 0], block.pixels[:, 1]] = np.arange(len(block.pixels))
    wts = filter_weights(fs, block.side)
    a2 = block.side ** 2
    rows = {}
    for (dy, dx) in wts:
        qy, qx = tg[:, 0] + dy, tg[:, 1] + dx
        inside = (qy >= 0) & (qy < fs.height) & (qx >= 0) & (qx < fs.width)
        row = np.where(inside, index[np.clip(qy, 0, fs.height - 1),
                                     np.clip(qx, 0, fs.width - 1)], -1)
        if np.any(inside & (row < 0)):
            raise ValueError("a target pixel's filter reaches a pixel outside the block")
        rows[dy, dx] = (inside, np.maximum(row, 0))
    wsum = np.zeros(len(tg))
    isum = np.zeros((len(tg), 3))
    for key, wt in wts.items():
        inside, row = rows[key]
        wsum += inside * wt.sum() / a2
        isum += inside[:, None] * np.einsum("ij,kijc->kc", wt, pm.mean[row]) / a2
    ip = isum / wsum[:, None]
    acc = np.zeros((len(tg), 3))
    for key, wt in wts.items():
        inside, row = rows[key]
        dev = pm.mean[row] - ip[:, None, None, :]
        tot = pm.var[row] + pm.within[row] + dev * dev
        acc += inside[:, None] * (np.einsum("ij,kijc->kc", wt * wt, tot) / a2
                                  - (np.einsum("ij,kijc->kc", wt, dev) / a2) ** 2)
    return ip, np.clip(acc, 0.0, None) / (wsum * wsum)[:, None]


def filter_reach(fs: FrameScene) -> int:
    """How many pixels away a sample still weighs on a pixel (0 for the box filter, and
    where the renderer importance-samples its filter: :attr:`FrameScene.film_warp`)."""
    if fs.filter_name == "box" or fs.film_warp is not None:
        return 0
    return int(np.ceil(fs.filter_radius - 0.5))

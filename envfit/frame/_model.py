r"""The frame model: each pixel's predicted error under the renderer's estimator, with the
scene's shadows, materials and pixel filter.

**One film point.** At a film point x whose camera ray hits a diffuse surface of albedo ρ at p
with shading normal n, one spp of the renderer's direct estimator is (``direct`` with
:math:`n_e` emitter and :math:`n_b` BSDF samples; ``path`` at depth 2 is :math:`n_e = n_b = 1`)

.. math::  F(x) = \frac1{n_e}\sum_{i} h_e(x, u_i) + \frac1{n_b}\sum_k h_b(x, u'_k),

:math:`h_e = \rho\,\frac{L(\omega)\cos^+\theta}{\pi p_e(\omega)}\,w_e(\omega)\,V(p, \omega)` at
the map sample :math:`\omega(u)` and :math:`h_b = \rho\,L(\omega)\,w_b(\omega)\,V(p, \omega)`
at the cosine sample, with the renderer's own technique, pdfs and power-heuristic weights
(:mod:`envfit.predict.renderer._preset_integrand`: ``map_values``, ``bsdf_values``) and the
visibility V of :mod:`._visibility`. Its mean and variance over the samples,

.. math::  I(x) = E_u h_e + E_{u'} h_b,\qquad
           v(x) = \frac{\mathrm{Var}_u h_e}{n_e} + \frac{\mathrm{Var}_{u'} h_b}{n_b},

are the midpoint quadratures of the technique's own tables at level ``level`` (4^level
points each). A camera ray that escapes sees the map: :math:`I(x) = L`, :math:`v(x) = 0`.

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
from envfit.base._progress import progress_bar
from envfit.frame._visibility import Visibility
from envfit.maps import EnvMap
from envfit.predict.renderer._preset_integrand import (BsdfTable, MapTable, bsdf_values,
                                                       map_values)
from envfit.renderers import get_renderer
from envfit.renderers._frame import HIT_SURFACE, FrameScene

__all__ = ["PointMoments", "point_moments", "pixel_mse", "MODELLED_SAMPLERS"]

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
    evaluated for a batch of film points (:meth:`parts`)."""

    def __init__(self, fs: FrameScene, level: int):
        rec = get_renderer(fs.renderer)
        opts = {"scale": fs.envmap_scale} if fs.envmap_scale != 1.0 else {}
        self.rec, self.tech = rec, rec.technique(EnvMap(fs.envmap_data), **opts)
        self.map = MapTable.build(self.tech, level)
        self.local = BsdfTable.build(rec, level).local
        self.rot = np.asarray(fs.envmap_to_world, dtype=np.float64)
        self.map_world = self.map.directions @ self.rot.T
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
        d = np.einsum("pk,bkj->bpj", self.local, frames)
        rad, pdf = self._eval_pdf(d.reshape(-1, 3))
        wb = _power(self.fb * self.local[None, :, 2] / np.pi,
                    self.fe * np.asarray(pdf).reshape(d.shape[:2]))
        hb = np.asarray(rad).reshape(d.shape) * wb[..., None]
        return he, hb, self.map_world, d @ self.rot.T


def _background(fs: FrameScene, tq: "_Techniques", idx: np.ndarray):
    """The map seen by the camera over each escaped film point's stratum: its mean and
    variance (E, 3) from f × f directions per stratum (f = ⌈:data:`_SUB`/S⌉), interpolated
    from the pixel's corner directions (:attr:`FrameScene.corners`) and evaluated by the
    renderer's own technique."""
    if len(idx) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    s = fs.side
    f = max(1, -(-_SUB // s))
    t = (np.arange(f) + 0.5) / f
    y, x, i, j = idx.T
    u = (j[:, None, None] + t[None, None, :]) / s            # (E, 1, f) across the pixel
    v = (i[:, None, None] + t[None, :, None]) / s            # (E, f, 1) down the pixel
    c = fs.corners
    d = ((1 - u) * (1 - v))[..., None] * c[y, x][:, None, None] \
        + (u * (1 - v))[..., None] * c[y, x + 1][:, None, None] \
        + ((1 - u) * v)[..., None] * c[y + 1, x][:, None, None] \
        + (u * v)[..., None] * c[y + 1, x + 1][:, None, None]
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    rad = np.asarray(tq.tech.eval_unit(d @ tq.rot)).reshape(len(idx), f * f, 3)
    return rad.mean(axis=1), rad.var(axis=1)


def point_moments(fs: FrameScene, level: int = 5, quiet: bool = True) -> PointMoments:
    """I(x) and v(x) at every film point of ``fs`` (module docstring), the techniques
    tabulated at level ``level``."""
    if not 2 <= int(level) <= 9:
        raise ParameterError(f"the frame model's level must be 2..9, got {level}")
    tq = _Techniques(fs, int(level))
    vis = Visibility(fs.occluders)
    shp = fs.kind.shape
    mean = np.zeros(shp + (3,))
    var = np.zeros(shp + (3,))
    within = np.zeros(shp + (3,))
    esc = fs.kind != HIT_SURFACE
    mean[esc], within[esc] = _background(fs, tq, np.argwhere(esc))
    idx = np.argwhere((fs.kind == HIT_SURFACE) & fs.facing)
    idx = idx[np.argsort(fs.shape[tuple(idx.T)], kind="stable")]   # one shape per batch
    batches = [b for s in np.unique(fs.shape[tuple(idx.T)])
               for sel in [idx[fs.shape[tuple(idx.T)] == s]]
               for b in np.array_split(sel, max(1, -(-len(sel) // _BATCH)))]
    rays = 0
    bar = progress_bar(len(idx), desc="frame model", quiet=quiet, unit="point")
    for b in batches:
        k = tuple(b.T)
        shape = int(fs.shape[k][0])
        o = fs.position[k] + _offset(fs.position[k])[:, None] * fs.geo_normal[k]
        he, hb, de, db = tq.parts(fs.normal[k])
        p = de.shape[0]
        ve = vis.visible(np.repeat(o, p, axis=0), np.tile(de, (len(b), 1)), shape)
        vb = vis.visible(np.repeat(o, p, axis=0), db.reshape(-1, 3), shape)
        rays += ve.size + vb.size
        a = fs.albedo[k][:, None, :]
        e = he * ve.reshape(len(b), p)[..., None] * a
        h = hb * vb.reshape(len(b), p)[..., None] * a
        mean[k] = e.mean(axis=1) + h.mean(axis=1)
        var[k] = (e.var(axis=1) / fs.emitter_samples if fs.emitter_samples else 0.0) + \
                 (h.var(axis=1) / fs.bsdf_samples if fs.bsdf_samples else 0.0)
        bar.update(len(b))
    bar.close()
    return PointMoments(mean, var, within, rays)


def _weights(fs: FrameScene, reach: int):
    """The filter weight of each film point of the pixel at offset (dy, dx) from the pixel:
    {(dy, dx): (S, S) weights}, separable as the renderer's ``ImageBlock`` evaluates them."""
    s = fs.side
    c = (np.arange(s) + 0.5) / s - 0.5                 # film point offsets from its centre
    out = {}
    for dy in range(-reach, reach + 1):
        wy = fs.filter_weights(dy + c)
        for dx in range(-reach, reach + 1):
            wx = fs.filter_weights(dx + c)
            w = np.outer(wy, wx)
            if np.any(w != 0):
                out[dy, dx] = w
    return out


def _shifted(a: np.ndarray, dy: int, dx: int, fill=0.0) -> np.ndarray:
    """``a`` (H, W, …) moved so that out[y, x] = a[y + dy, x + dx] (``fill`` outside)."""
    out = np.full_like(a, fill)
    h, w = a.shape[:2]
    ys, yd = slice(max(dy, 0), h + min(dy, 0)), slice(max(-dy, 0), h + min(-dy, 0))
    xs, xd = slice(max(dx, 0), w + min(dx, 0)), slice(max(-dx, 0), w + min(-dx, 0))
    out[yd, xd] = a[ys, xs]
    return out


def pixel_mse(fs: FrameScene, pm: PointMoments) -> tuple[np.ndarray, np.ndarray]:
    """(converged image (H, W, 3), MSE at one spp (H, W, 3)) of every pixel (module
    docstring); the MSE at N spp is this over N."""
    if fs.filter_name == "box":
        wts = {(0, 0): np.ones((fs.side, fs.side))}
    else:
        wts = _weights(fs, int(np.ceil(fs.filter_radius - 0.5)))
    a2 = fs.side * fs.side
    h, w = fs.height, fs.width
    inside = np.ones((h, w, 1, 1))
    wsum = np.zeros((h, w))
    isum = np.zeros((h, w, 3))
    for (dy, dx), wt in wts.items():
        m = _shifted(inside, dy, dx)[..., 0, 0]
        wsum += m * wt.sum() / a2
        isum += np.einsum("ij,hwijc->hwc", wt, _shifted(pm.mean, dy, dx)) / a2
    ip = isum / wsum[..., None]
    acc = np.zeros((h, w, 3))
    for (dy, dx), wt in wts.items():
        mq = _shifted(pm.mean, dy, dx)
        vq = _shifted(pm.var + pm.within, dy, dx)
        m = _shifted(inside, dy, dx)[..., 0, 0][..., None]
        dev = mq - ip[:, :, None, None, :]
        acc += m * np.einsum("ij,hwijc->hwc", wt * wt, vq + dev * dev) / a2
        acc -= m * (np.einsum("ij,hwijc->hwc", wt, dev) / a2) ** 2
    return ip, np.clip(acc, 0.0, None) / (wsum * wsum)[..., None]

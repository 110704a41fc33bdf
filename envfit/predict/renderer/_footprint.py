r"""A rendered pixel's footprint: the normals a pixel of an orthographic sphere view spans,
and the variance its film position adds to a renderer's estimator.

A renderer's pixel estimate draws its film position p from two dimensions of its own, paired at
random with the techniques' (every sampler of the presets permutes or draws each dimension
pair independently), so one spp of technique t is :math:`g_t(p, u)`: the integrand at the
normal seen at p. With the ANOVA split :math:`g_t = \bar g_t(u) + a_t(p) + c_t(p, u)`
(:math:`\bar g_t` the mean over the footprint, a the pixel integral's deviation, c the
interaction), the main effect :math:`\bar g_t` is randomised as any table, and the MSE gains
:math:`\sum_t \mathrm{Var}\,c_t/N` for independent points (with :math:`\mathrm{Var}\,a/N`:
the exact :math:`(E_p\mathrm{Var}_u g + \mathrm{Var}_p E_u g)/N`) and
:math:`\sum_t \mathrm{Var}\,c_t/(N-1)` for randomly paired nets (each net sums c to about
zero, which makes the pairs' cross terms positive; a, integrated by the film's own net, is
left out) — :func:`footprint_term`. The footprint is sampled at side × side stratum midpoints
of the pixel (:func:`pixel_footprints`); the variances over them, Var a and Var c, are scaled
by J/(J − 1), J = side²: the midpoints of s × s strata see (1 − 1/s²) of the variance over
the pixel of a function linear across it (per axis (s² − 1)/(12 s²) against 1/12), so the
scaled values are exact for linear variation and converge as the side grows (on sun-gp-1.5,
GGX α = 0.3 at 1024 ``ldsampler`` spp, the unscaled term grew 1.254× from side 2 to 4, the
linear law's 1.25; scaled, the two agree to 0.3 %).

Used by :class:`~envfit.predict.renderer._preset_model.PresetModel` (a diffuse sphere R pixels
across, each normal in the view nearest it: :func:`nearest_views`) and
:class:`~envfit.predict.renderer._microfacet_model.MicrofacetModel` (per frame).
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

__all__ = ["pixel_footprints", "nearest_views", "FootprintSums", "with_variances",
           "footprint_term", "pixel_variance_scale"]

#: the parts each strategy draws (its streams) and the part whose mean over u is the pixel's
#: integral
_STREAMS = {"map": ("map",), "brdf": ("brdf",), "mis": ("mis_e", "mis_b")}
_TOTAL = {"map": "map", "brdf": "brdf", "mis": "mis_t"}


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _view_basis(views: np.ndarray):
    """(right, up) per view axis: those of :data:`envfit.measure.renderers.VIEWS` where the
    axis is one of theirs, else up = the unit part of z (or x) orthogonal to the axis and
    right = up × axis."""
    from envfit.measure.renderers import VIEWS
    axes = np.array([view.axis for view in VIEWS], dtype=np.float64)
    which = np.argmax(views @ axes.T, axis=1)
    known = np.all(np.abs(axes[which] - views) < 1e-9, axis=1)
    ref = np.where(np.abs(views[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    up = _unit(ref - np.sum(ref * views, axis=1, keepdims=True) * views)
    right = np.cross(up, views)
    right = np.where(known[:, None], np.array([v.right for v in VIEWS])[which], right)
    up = np.where(known[:, None], np.array([v.up for v in VIEWS])[which], up)
    return right, up


def pixel_footprints(normals, views, resolution: int, side: int = 2) -> np.ndarray:
    r"""The normals (K, side², 3) at side × side stratum midpoints of each frame's pixel: the
    pixel of an orthographic view of the unit sphere R pixels across (the image plane spans
    [-1, 1]², pixel side h = 2/R; :mod:`envfit.measure.renderers` renders R × R views) whose
    centre shows ``normals[k]`` from the view axis ``views[k]`` (the pixel's axes those of
    :data:`envfit.measure.renderers.VIEWS` for their axes, else :func:`_view_basis`). A
    sub-position (X + δx, Y + δy) shows the normal X'r + Y'u + √(1 − X'² − Y'²) v; off the disk
    it is pulled onto the rim.

    >>> from envfit.measure.renderers import VIEWS, sphere_geometry
    >>> from envfit.predict.renderer import pixel_frames
    >>> n, v, _ = pixel_frames(sphere_geometry(16), VIEWS, 8, seed=0)
    >>> f = pixel_footprints(n, v, 16, side=2)
    >>> f.shape, bool(np.allclose(f.mean(axis=1), n, atol=0.1))
    ((8, 4, 3), True)
    """
    n = _unit(np.asarray(normals, dtype=np.float64).reshape(-1, 3))
    v = _unit(np.asarray(views, dtype=np.float64).reshape(-1, 3))
    r, s = int(resolution), int(side)
    if r != resolution or r < 1 or s != side or s < 1:
        raise ParameterError(f"pixel_footprints: resolution and side must be integers >= 1, "
                             f"got {resolution!r}, {side!r}")
    if len(n) != len(v) or np.any(np.sum(n * v, axis=1) < 0):
        raise ParameterError("pixel_footprints: one view per normal, the normal facing it")
    right, up = _view_basis(v)
    h = 2.0 / r
    d = ((np.arange(s) + 0.5) / s - 0.5) * h
    dx, dy = (a.ravel() for a in np.meshgrid(d, d))
    x = np.sum(n * right, axis=1)[:, None] + dx
    y = np.sum(n * up, axis=1)[:, None] + dy
    rad = np.hypot(x, y)
    scale = np.where(rad > 1.0, 1.0 / np.where(rad > 0, rad, 1.0), 1.0)
    x, y = x * scale, y * scale
    z = np.sqrt(np.clip(1.0 - x * x - y * y, 0.0, None))
    return _unit(x[..., None] * right[:, None] + y[..., None] * up[:, None]
                 + z[..., None] * v[:, None])


def nearest_views(normals) -> np.ndarray:
    """The axis of the :data:`envfit.measure.renderers.VIEWS` view nearest each normal (K, 3):
    the view that keeps it in the sphere renders' ``cube`` layout."""
    from envfit.measure.renderers import VIEWS
    axes = np.array([view.axis for view in VIEWS], dtype=np.float64)
    n = _unit(np.asarray(normals, dtype=np.float64).reshape(-1, 3))
    return axes[np.argmax(n @ axes.T, axis=1)]


class FootprintSums:
    r"""Running sums of the tabulated parts over a footprint's normals (one dict of parts
    (P, C) per normal, :meth:`add`), and the parts they give (:meth:`parts`): the mean table
    of each part and its ``_var_c``, ``_var_a`` (module docstring). Running sums:
    :math:`\mathrm{Var}\,c = E g^2 - E_u \bar g^2 - \mathrm{Var}\,a`."""

    def __init__(self):
        self.s1, self.s2, self.means, self.count = {}, {}, {}, 0

    def add(self, parts: dict) -> None:
        """Add one footprint normal's parts."""
        for p, g in parts.items():
            self.s1[p] = self.s1.get(p, 0.0) + g
            self.s2[p] = self.s2.get(p, 0.0) + np.einsum("pc,pc->c", g, g) / len(g)
            self.means.setdefault(p, []).append(g.mean(axis=0))
        self.count += 1

    def parts(self) -> dict:
        """The mean tables, and ``_var_c`` and ``_var_a`` (dicts of (C,) per part)."""
        out = {p: s / self.count for p, s in self.s1.items()}
        return with_variances(out, {p: np.stack(m) for p, m in self.means.items()},
                              {p: s2 / self.count for p, s2 in self.s2.items()})


def with_variances(gbar: dict, means: dict, mean_sq: dict) -> dict:
    r"""``gbar`` (the footprint's mean table (P, C) per part) with ``_var_c`` and ``_var_a``
    added, from each footprint normal's table mean ``means`` (J, C) and the mean of g² over
    the normals and the table ``mean_sq`` (C,): :math:`\mathrm{Var}\,a` = the variance of
    the normals' means, :math:`\mathrm{Var}\,c = E g^2 - E_u \bar g^2 - \mathrm{Var}\,a`
    (clipped at 0), both over the J normals times :func:`pixel_variance_scale` (J) — the
    variances over the pixel (module docstring)."""
    k = pixel_variance_scale(len(next(iter(means.values()))))
    var_a = {p: np.var(means[p], axis=0) for p in gbar}
    var_c = {p: k * np.clip(mean_sq[p] - np.einsum("pc,pc->c", g, g) / len(g) - var_a[p], 0.0,
                            None) for p, g in gbar.items()}
    return {**gbar, "_var_c": var_c, "_var_a": {p: k * v for p, v in var_a.items()}}


def pixel_variance_scale(j: int) -> float:
    """J/(J − 1) (1 for J = 1): the variance over a pixel of a function linear across it,
    per unit of its variance over the midpoints of the pixel's J = s × s strata.

    >>> m = (np.arange(2) + 0.5) / 2                      # s = 2: the strata's midpoints
    >>> v = np.var(np.add.outer(m, m))                     # f = x + y at the 4 midpoints
    >>> float(v), bool(abs(pixel_variance_scale(4) * v - 2 / 12) < 1e-15)  # over the pixel: 2/12
    (0.125, True)
    """
    return j / (j - 1) if j > 1 else 1.0


def footprint_term(strategy: str, randomisation: str, n: int, vals: dict):
    """The MSE (C,) a pixel footprint adds to ``strategy``'s estimate of N points under
    ``randomisation`` (module docstring), from the parts' ``_var_c`` and ``_var_a``; 0 when
    ``vals`` has no footprint."""
    if "_var_c" not in vals:
        return 0.0
    c = sum(vals["_var_c"][t] for t in _STREAMS[strategy])
    if randomisation == "independent":
        return (c + vals["_var_a"][_TOTAL[strategy]]) / n
    return c / max(n - 1, 1)

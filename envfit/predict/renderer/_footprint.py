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
by J/(J − 1), J = side²: the midpoints of s × s strata see (1 − 1/s²) of the variance over the
pixel of a function linear across it (per axis (s² − 1)/(12 s²) against 1/12), so the scaled
values are exact for linear variation and converge as the side grows (on sun-gp-1.5, GGX α =
0.3 at 1024 spp of a digitally shifted net, the unscaled term grew 1.254× from side 2 to 4, the
linear law's 1.25; scaled, the two agree to 0.3 %).

A sampler whose dimensions are the pixel's one randomised net, each in an order of its own
(pairing ``same_net_permuted``), does not pair its dimensions at random: its orders may order
the film's points (dimension 0) and the first technique's alike. Its record's
``film_points`` (:attr:`envfit.renderers.SamplerSpec.film_points`) give its points in its
order; there the film's share is not
Var c/(N − 1) but E(F − I)² − E(F₀ − I)² over the sampler's own points (:class:`PairedFootprint`,
:func:`paired_extra`): F the pixel estimate with the integrand interpolated across the pixel
from the footprint's tables (:func:`film_weights`), F₀ the same samples of the mean table.

Used by :class:`~envfit.predict.renderer._diffuse_model.DiffuseModel` (a diffuse sphere R pixels
across, each normal in the view nearest it: :func:`nearest_views`) and
:class:`~envfit.predict.renderer._microfacet_model.MicrofacetModel` (per frame).
"""
from __future__ import annotations

import numba
import numpy as np

from envfit.base import ParameterError

__all__ = ["pixel_footprints", "nearest_views", "FootprintSums", "with_variances",
           "footprint_term", "pixel_variance_scale", "film_weights", "paired_extra",
           "PairedFootprint"]

#: the parts each strategy draws (its streams) and the part whose mean over u is the pixel's
#: integral
_STREAMS = {"map": ("map",), "brdf": ("brdf",), "mis": ("mis_e", "mis_b")}
_TOTAL = {"map": "map", "brdf": "brdf", "mis": "mis_t"}


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _view_basis(views: np.ndarray):
    """(right, up) per view axis: those of :data:`envfit.renderers.VIEWS` where the
    axis is one of theirs, else up = the unit part of z (or x) orthogonal to the axis and
    right = up × axis."""
    from envfit.renderers import VIEWS
    axes = np.array([view.axis for view in VIEWS], dtype=np.float64)
    which = np.argmax(views @ axes.T, axis=1)
    known = np.all(np.abs(axes[which] - views) < 1e-9, axis=1)
    ref = np.where(np.abs(views[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    up = _unit(ref - np.sum(ref * views, axis=1, keepdims=True) * views)
    right = np.cross(up, views)
    right = np.where(known[:, None], np.array([v.right for v in VIEWS])[which], right)
    up = np.where(known[:, None], np.array([v.up for v in VIEWS])[which], up)
    return right, up


def pixel_footprints(normals, views, resolution: int, side: int = 2,
                     film=None) -> np.ndarray:
    r"""The normals (K, side², 3) at side × side stratum midpoints of each frame's pixel
    (their film offsets from the pixel's centre those of ``film``, a renderer's
    :class:`~envfit.renderers.FilmWarp` — its importance-sampled pixel filter; None: the box,
    the midpoints of the pixel's strata): the
    pixel of an orthographic view of the unit sphere R pixels across (the image plane spans
    [-1, 1]², pixel side h = 2/R; :mod:`envfit.renderers` renders R × R views) whose
    centre shows ``normals[k]`` from the view axis ``views[k]`` (the pixel's axes those of
    :data:`envfit.renderers.VIEWS` for their axes, else :func:`_view_basis`). A
    sub-position (X + δx, Y + δy) shows the normal X'r + Y'u + √(1 − X'² − Y'²) v; off the disk
    it is pulled onto the rim.

    >>> from envfit.renderers import VIEWS, sphere_geometry
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
    d = (((np.arange(s) + 0.5) / s - 0.5) if film is None else film.midpoints(s)) * h
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
    """The axis of the :data:`envfit.renderers.VIEWS` view nearest each normal (K, 3):
    the view that keeps it in the sphere renders' ``cube`` layout."""
    from envfit.renderers import VIEWS
    axes = np.array([view.axis for view in VIEWS], dtype=np.float64)
    n = _unit(np.asarray(normals, dtype=np.float64).reshape(-1, 3))
    return axes[np.argmax(n @ axes.T, axis=1)]


class FootprintSums:
    r"""Running sums of the tabulated parts over a footprint's normals (one dict of parts
    (P, C) per normal, :meth:`add`), and the parts they give (:meth:`parts`): the mean table
    of each part and its ``_var_c``, ``_var_a`` (module docstring). Running sums:
    :math:`\mathrm{Var}\,c = E g^2 - E_u \bar g^2 - \mathrm{Var}\,a`. The parts named in
    ``keep`` are also kept per normal (``_normals``: (J, P, C) each) for
    :class:`PairedFootprint`."""

    def __init__(self, keep=(), scale: float | None = None):
        self.s1, self.s2, self.means, self.count = {}, {}, {}, 0
        self.keep = {p: [] for p in keep}
        self.scale = scale

    def add(self, parts: dict) -> None:
        """Add one footprint normal's parts."""
        for p, g in parts.items():
            self.s1[p] = self.s1.get(p, 0.0) + g
            self.s2[p] = self.s2.get(p, 0.0) + np.einsum("pc,pc->c", g, g) / len(g)
            self.means.setdefault(p, []).append(g.mean(axis=0))
            if p in self.keep:
                self.keep[p].append(g)
        self.count += 1

    def parts(self) -> dict:
        """The mean tables, and ``_var_c`` and ``_var_a`` (dicts of (C,) per part)."""
        out = {p: s / self.count for p, s in self.s1.items()}
        out = with_variances(out, {p: np.stack(m) for p, m in self.means.items()},
                             {p: s2 / self.count for p, s2 in self.s2.items()}, self.scale)
        if self.keep:
            out["_normals"] = {p: np.stack(g) for p, g in self.keep.items() if g}
        return out


def with_variances(gbar: dict, means: dict, mean_sq: dict, scale: float | None = None) -> dict:
    r"""``gbar`` (the footprint's mean table (P, C) per part) with ``_var_c`` and ``_var_a``
    added, from each footprint normal's table mean ``means`` (J, C) and the mean of g² over
    the normals and the table ``mean_sq`` (C,): :math:`\mathrm{Var}\,a` = the variance of
    the normals' means, :math:`\mathrm{Var}\,c = E g^2 - E_u \bar g^2 - \mathrm{Var}\,a`
    (clipped at 0), both over the J normals times ``scale`` (default
    :func:`pixel_variance_scale` (J), the box's; a film warp's
    :meth:`~envfit.renderers.FilmWarp.variance_scale`) — the variances over the pixel's
    filter (module docstring)."""
    k = pixel_variance_scale(len(next(iter(means.values())))) if scale is None else scale
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


def _axis_weights(x: np.ndarray, side: int) -> np.ndarray:
    """(…, side): per axis the piecewise-linear interpolation between the strata midpoints
    (i + ½)/side, extended linearly to the pixel's edges, each weight shifted to mean 1/side
    over [0, 1] (its mean by the midpoint rule on a grid whose cells the kinks bound: exact)."""
    def raw(t):
        w = np.zeros(t.shape + (side,))
        if side == 1:
            w[..., 0] = 1.0
            return w
        u = t * side - 0.5
        i0 = np.clip(np.floor(u), 0, side - 2).astype(np.int64)
        f = u - i0
        np.put_along_axis(w, i0[..., None], (1.0 - f)[..., None], axis=-1)
        np.put_along_axis(w, i0[..., None] + 1, f[..., None], axis=-1)
        return w
    grid = (np.arange(2 * side * 64) + 0.5) / (2 * side * 64)
    return raw(np.asarray(x, dtype=np.float64)) - raw(grid).mean(axis=0) + 1.0 / side


def film_weights(film, side: int) -> np.ndarray:
    r"""The weights (…, J) of a footprint's J = side² normals (:func:`pixel_footprints`:
    normal k = i_y·side + i_x, x along the view's right, y along its up) at film positions
    ``film`` (…, 2) in the pixel as ``film_points`` give them (x right, y down: the normal at
    (x, 1 − y)): the product of :func:`_axis_weights` — for side 2 the bilinear Lagrange
    basis on the strata midpoints, which spans the integrand's variation across the pixel
    exactly where it is linear (the J/(J − 1) of :func:`pixel_variance_scale`); each weight's
    mean over the pixel 1/J, so their mean table is the footprint's.

    >>> w = film_weights(np.array([[0.25, 0.75], [0.5, 0.5]]), 2)
    >>> w[0].round(12).tolist(), w[1].tolist()   # a stratum midpoint; the centre
    ([1.0, 0.0, 0.0, 0.0], [0.25, 0.25, 0.25, 0.25])
    """
    film = np.asarray(film, dtype=np.float64)
    s = int(side)
    wx, wy = _axis_weights(film[..., 0], s), _axis_weights(1.0 - film[..., 1], s)
    return (wy[..., :, None] * wx[..., None, :]).reshape(film.shape[:-1] + (s * s,))


def paired_extra(streams, weights) -> tuple[np.ndarray, np.ndarray]:
    r"""The MSE (C,) the film position adds to R simulated pixels of N samples, and its
    standard error: the mean over pixels of :math:`(F - I)^2 - (F_0 - I)^2 = D^2 + 2D(F_0 -
    I)`, :math:`D = F - F_0 = \frac1N\sum_j\sum_k (w_k(p_j) - \frac1J)\,g_k(u_j)`, where
    ``streams`` = [(tables (J, P, C): the part at each footprint normal, cells (R, N): each
    sample's table entry, the tables' mean (C,) or None)] (the techniques' streams, summed),
    ``weights`` (R, N, J) the film's (:func:`film_weights`), :math:`F_0` the samples of the
    mean table and I its mean.
    """
    r, n, j = weights.shape
    c = streams[0][0].shape[2]
    d, f0, total = np.zeros((r, c)), np.zeros((r, c)), 0.0
    w = np.ascontiguousarray(weights, dtype=np.float64)
    for tables, cells, mean in streams:
        _paired_sums(np.asarray(tables, dtype=np.float64),                  # strided: as is
                     np.ascontiguousarray(cells, dtype=np.int64), w, d, f0)
        total = total + (tables.mean(axis=(0, 1)) if mean is None else mean)
    d, f0 = d / n, f0 / (n * j)
    x = d * d + 2.0 * d * (f0 - total)                             # (R, C)
    return x.mean(axis=0), x.std(axis=0, ddof=1) / np.sqrt(r)


@numba.njit(cache=True, parallel=True)
def _paired_sums(tables, cells, weights, d, f0):  # pragma: no cover - numba
    """Add to each pixel's d (R, C) the sum of (w_k − 1/J) g_k over its samples and to f0
    the sum of g_k (:func:`paired_extra`)."""
    j, ch = tables.shape[0], tables.shape[2]
    for r in numba.prange(cells.shape[0]):
        for s in range(cells.shape[1]):
            p = cells[r, s]
            for k in range(j):
                wk = weights[r, s, k] - 1.0 / j
                for c in range(ch):
                    v = tables[k, p, c]
                    d[r, c] += wk * v
                    f0[r, c] += v


class PairedFootprint:
    r"""The film × technique pairing of a sampler at N spp over R pixels (module
    docstring), over the sampler's own points in its order (``film_points(pixels, n, dims,
    seed)``, :attr:`envfit.renderers.SamplerSpec.film_points`; dimension 0 the film's, then
    the emitter's and the BSDF's where the renderer's integrator draws them,
    :attr:`envfit.renderers.StrategySetting.calls`), ``dims`` dimensions of them, each
    pixel's scramble seed drawn at random.

    Examples
    --------
    An integrand 2x − ½ along the film's x only: the net's x are N strata's points shifted
    alike, so the error is 2(δ − ½)/N, δ uniform: MSE 1/(3N²).

    >>> from envfit.renderers import get_renderer
    >>> points = get_renderer("mitsuba3").sampler("ldsampler").film_points
    >>> pf = PairedFootprint(16, 4096, 0, points)
    >>> g = np.zeros((4, 16, 1)); g[1] = g[3] = 1.0          # the normals at x = ¾
    >>> mse, se = pf.extra({"map": g}, "map")
    >>> bool(abs(mse[0] - 1 / (3 * 16 ** 2)) < 3 * se[0])
    True
    """

    def __init__(self, n: int, pixels: int, seed: int, film_points, dims: int = 3,
                 lobe_points=None):
        self.n, self.seed = int(n), int(seed)
        self.points = film_points(pixels, self.n, int(dims), seed)
        self._lobe_points = lobe_points
        self._weights, self._cells, self._lobe = {}, {}, {}
        #: what a model derives from these pixels and keeps with them
        self.memo = {}

    def lobe_numbers(self, call: int | None = None) -> np.ndarray:
        """(R, N) each sample's 1-D number of a BSDF's lobe choice: with the sampler's
        ``lobe_points`` and the ``call`` that draws it, the sampler's own numbers in its order
        for these pixels (:attr:`envfit.renderers.SamplerSpec.lobe_points`); else one point in
        each of the N strata, one offset per pixel, the strata in a random order of the
        pixel's own, as :func:`~.randomisation.lobe_choice_mse` takes it."""
        exact = self._lobe_points is not None and call is not None
        key = call if exact else None
        if key not in self._lobe:
            r = self.points.shape[0]
            if exact:
                self._lobe[key] = self._lobe_points(r, self.n, int(call), self.seed)
            else:
                rng = np.random.default_rng([self.seed, self.n, 0x10BE])
                order = rng.permuted(np.broadcast_to(np.arange(self.n), (r, self.n)), axis=1)
                self._lobe[key] = (order + rng.random((r, 1))) / self.n
        return self._lobe[key]

    def weights(self, side: int) -> np.ndarray:
        """:func:`film_weights` of the film's points (R, N, side²)."""
        if side not in self._weights:
            self._weights[side] = film_weights(self.points[:, :, 0], side)
        return self._weights[side]

    def cells(self, dim: int, size: int, dtype=np.int64) -> np.ndarray:
        """Each sample's entry (R, N) of a table at the midpoints of a 2^L × 2^L grid of
        ``size`` = 4^L entries (u0 the slow index), in dimension ``dim``; as ``dtype`` (an
        integer type that holds ``size``, e.g. int32 for a compiled kernel's smaller reads),
        memoised per type."""
        key = (dim, size, np.dtype(dtype))
        if key not in self._cells:
            wide = self._cells.get((dim, size, np.dtype(np.int64)))
            if wide is None:
                m = 1 << (int(size).bit_length() - 1) // 2
                i = np.minimum((self.points[:, :, dim] * m).astype(np.int64), m - 1)
                wide = i[..., 0] * m + i[..., 1]
            self._cells[key] = np.ascontiguousarray(wide, dtype=dtype)
        return self._cells[key]

    def extra(self, tables: dict, strategy: str, calls: tuple[int, int] | None = None,
              means: dict | None = None):
        """:func:`paired_extra` of ``strategy``'s streams, ``tables`` {part: (J, P, C)}, the
        emitter's and the BSDF's samples in the dimensions ``calls`` (None: ``direct``'s with
        one sample of each technique, the only one's in dimension 1); ``means`` {part: the
        mean table (P, C)}, where the caller has them (the same mean, 4× less to read)."""
        if calls is None:
            dims = {"map": 1, "brdf": 1, "mis_e": 1, "mis_b": 2}
        else:
            dims = {"map": calls[0], "brdf": calls[1], "mis_e": calls[0], "mis_b": calls[1]}
        side = int(round(np.sqrt(len(next(iter(tables.values()))))))
        streams = [(tables[p], self.cells(dims[p], tables[p].shape[1]),
                    None if means is None else means[p].mean(axis=0))
                   for p in _STREAMS[strategy]]
        return paired_extra(streams, self.weights(side))

r"""Closed-form expected interpolation error of a Gaussian-process map (the kriging error).

Table 2 (Sec. 9.1) interpolates N samples of a map with the kernel :math:`K_s` (Eq. 14) and
scores the reconstruction at the pixel centres. When the map is a sample of a Gaussian
process (``data_gen``) the *expected* mean squared error over the process has a closed form.
With the node values :math:`g = (g(p_1), \dots, g(p_N))`, the truth :math:`t(x)` at pixel
centre x, the interpolation weights :math:`w(x) = K_s^{-1} k_s(X, x)` and a deterministic
offset c added to the map,

.. math::  E|t(x) - w(x)^T (g + c)|^2 = \mathrm{Var}\,t(x) - 2 w^T \mathrm{Cov}(g, t(x))
           + w^T \mathrm{Cov}(g, g)\, w + c^2 (1 - w^T 1)^2 ,

averaged over the pixels (per pixel, as Table 2's first table, and solid-angle weighted, as
its second). The covariances are those of the map *as synthesized and looked up*:

* **synthesis** (:func:`envfit.data_gen._gp.gaussian_process_map`): real SH coefficients
  :math:`f_{lm} \sim N(0, a_l^{(s_0)})` for :math:`l \le l_{max}` (default ``H_synth − 1``),
  nothing above, so the field's covariance is the truncated Legendre series
  :math:`k_0(t) = \sum_{l \le l_{max}} a_l \frac{2l+1}{4\pi} P_l(t)` (``lmax=None``: the full
  process, :math:`k_0 = K_{s_0}`, Eq. 14);
* **resize**: a map synthesized at ``factor × H`` rows and block-averaged to H rows with
  solid-angle weights (:meth:`envfit.maps._envmap.EnvMap.resized`): pixel covariances are the
  weighted sums of :math:`k_0` over the two blocks;
* **lookup**: the node sees the map's bilinear interpolant
  (:func:`envfit.maps._latlong.bilinear_lookup`), :math:`g(p) = \sum_q \beta_q(p) f_q` over
  four pixels (``lookup=False``: the node sees the field itself, :math:`g = f(p)`).

For ``lmax=None, lookup=False, factor=1, offset=0`` the weights of :math:`K_{s_0}` are the
best linear predictor of t(x) from g, so the expected MSE is minimal at :math:`s = s_0` for
every x and every N: any shift of the optimum comes from the band limit, the lookup, the
resize, the offset, or (measured on one map) the realization.

Cost: an N×N Cholesky per s and O(N² M) for M evaluation pixels (all of them, or the pixels of
``rows`` evenly spaced rows: a quadrature in latitude of the pixel average, exact in longitude).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from envfit.base import ParameterError
from envfit.base import progress
from envfit.maps import direction_to_pixel, pixel_angles, row_solid_angles
from envfit.theory import check_smoothness
from envfit.theory import kernel_from_distance2, sobolev_coefficients

__all__ = ["SynthesisModel", "KrigingCurve", "field_covariance", "bilinear_stencil",
           "expected_interpolation_mse", "expected_profiled_likelihood", "builtin_synthesis",
           "known_s_sentence"]

#: samples of t = u·v in [−1, 1] of the tabulated band-limited covariance (linear
#: interpolation: absolute error below 1e-6 at l_max = 255, where k_0(1) = 2.66)
_TABLE_POINTS = (1 << 19) + 1
#: largest synthesized height whose pixel covariance tables are made (the point table of
#: 8 H³ bytes, the map's of 16 H³ / factor³: 256 MiB at 256 rows)
MAX_SYNTH_HEIGHT = 256
#: evaluation pixels per block (bounds the N×M temporaries)
_BLOCK = 2048


def field_covariance(s0: float, lmax: int | None):
    r"""The covariance :math:`k_0` of the synthesized field as a function of the squared chord
    :math:`d^2 = |u - v|^2`: Eq. 14 for ``lmax=None``, else the Legendre partial sum
    :math:`\sum_{l\le l_{max}} a_l^{(s_0)} \frac{2l+1}{4\pi} P_l(1 - d^2/2)` (Eq. 8),
    tabulated on a uniform grid of :math:`t = 1 - d^2/2` and interpolated linearly.

    >>> k = field_covariance(1.5, None); round(float(k(0.0)), 6)       # 2^(2s-1)/s
    2.666667
    """
    s0 = check_smoothness(s0)
    if lmax is None:
        return lambda d2: kernel_from_distance2(s0, d2)
    L = int(lmax)
    if L < 0:
        raise ParameterError(f"lmax must be >= 0, got {lmax}")
    t = np.linspace(-1.0, 1.0, _TABLE_POINTS)         # a polynomial in t: uniform in t
    coef = sobolev_coefficients(s0, L) * (2 * np.arange(L + 1) + 1) / (4 * np.pi)
    p_prev, p = np.ones_like(t), t.copy()
    table = coef[0] * p_prev + (coef[1] * p if L >= 1 else 0.0)
    for l in range(1, L):
        p_prev, p = p, ((2 * l + 1) * t * p - l * p_prev) / (l + 1)
        table += coef[l + 1] * p
    slope = np.append(np.diff(table), 0.0)
    scale = (_TABLE_POINTS - 1) / 2.0

    def k0(d2):
        x = (2.0 - np.clip(np.asarray(d2, dtype=np.float64), 0.0, 4.0) * 0.5) * scale
        i = np.minimum(x.astype(np.int64), _TABLE_POINTS - 1)   # x = (t + 1) * scale
        return table[i] + (x - i) * slope[i]
    return k0


def bilinear_stencil(dirs: np.ndarray, height: int, *, up: str = "y"):
    """The four pixels (flat indices ``row * W + col``) and weights of the bilinear lookup
    of :func:`envfit.maps._latlong.bilinear_lookup` at ``dirs`` (N, 3): ``(idx, w)``, both
    (N, 4), with ``sum(w * img.ravel()[idx], axis=1) == bilinear_lookup(img, dirs)``
    (virtual rows beyond a pole read the edge row at φ + π, columns wrap)."""
    h = int(height)
    w = 2 * h
    row, col = direction_to_pixel(dirs, h, up=up)
    r0 = np.floor(row)
    a = row - r0
    r0 = r0.astype(np.int64)
    idx = np.empty((row.size, 4), np.int64)
    wt = np.empty((row.size, 4))
    for k, (r, fr) in enumerate(((r0, 1.0 - a), (r0 + 1, a))):
        virtual = (r < 0) | (r > h - 1)
        rr = np.clip(r, 0, h - 1)
        c = np.where(virtual, col + 0.5 * w, col)
        c0 = np.floor(c)
        fc = c - c0
        c0 = c0.astype(np.int64) % w
        idx[:, 2 * k], idx[:, 2 * k + 1] = rr * w + c0, rr * w + (c0 + 1) % w
        wt[:, 2 * k], wt[:, 2 * k + 1] = fr * (1.0 - fc), fr * fc
    return idx, wt


@dataclass(frozen=True)
class SynthesisModel:
    """How the map Table 2 reads was made, as far as its covariance is concerned.

    Attributes
    ----------
    s0 : smoothness of the process (covariance :math:`K_{s_0}`, Eq. 14)
    height : rows H of the map the nodes read (width 2H)
    lmax : band limit of the synthesis (``None``: the full, not band-limited process)
    factor : the map was synthesized at ``factor * height`` rows and block-averaged to H
    lookup : the nodes read the map's bilinear interpolant (False: the field itself)
    offset : constant added to the map (it is interpolated too)
    up : the map's up axis (where the pixel grid sits relative to the nodes)
    """
    s0: float
    height: int
    lmax: int | None
    factor: int = 1
    lookup: bool = True
    offset: float = 0.0
    up: str = "y"

    def __post_init__(self) -> None:
        check_smoothness(self.s0)
        for name in ("height", "factor"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ParameterError(f"{name} must be a positive integer, got {v!r}")
        if self.lookup and self.height * self.factor > MAX_SYNTH_HEIGHT:
            raise ParameterError(
                f"the closed form tabulates the pixel covariances of a map synthesized at "
                f"{self.height * self.factor} rows; at most {MAX_SYNTH_HEIGHT} rows "
                f"({16 * MAX_SYNTH_HEIGHT ** 3 // 2 ** 20} MiB table) are supported")
        if self.factor > 1 and not self.lookup:
            raise ParameterError("a block-averaged map is only seen through its pixels: "
                                 "lookup=False needs factor = 1")

    @classmethod
    def data_gen(cls, s0: float, synth_height: int, height: int | None = None,
                 **kw) -> "SynthesisModel":
        """``gaussian_process_map(s0, synth_height)`` (band limit ``synth_height − 1``), read
        at ``height`` rows (default: as synthesized; a divisor: block-averaged)."""
        h = int(synth_height if height is None else height)
        if synth_height % h:
            raise ParameterError(f"height {h} must divide the synthesized height {synth_height}")
        return cls(s0=s0, height=h, lmax=int(synth_height) - 1, factor=int(synth_height) // h,
                   **kw)

    def describe(self) -> str:
        band = "full process" if self.lmax is None else f"band-limited at l <= {self.lmax}"
        syn = f"{self.height * self.factor} rows" + (
            f", block-averaged to {self.height}" if self.factor > 1 else "")
        seen = "bilinear lookup" if self.lookup else "exact field values at the nodes"
        return f"GP s0={self.s0:g}, {band}, {syn}, {seen}"


@dataclass
class KrigingCurve:
    """Expected MSE against s at one N: per pixel (Table 2's first table) and solid-angle
    weighted (its second), with the parts of the per-pixel value."""
    model: SynthesisModel
    n: int
    s_values: list[float]
    mse_pixel: np.ndarray
    mse_solid_angle: np.ndarray
    variance: float                       # mean Var t(x), per pixel
    rows: int                             # evaluation rows used (of model.height)
    notes: list[str] = field(default_factory=list)

    @property
    def s_best(self) -> float:
        """The s of the grid with the lowest expected per-pixel MSE."""
        return float(self.s_values[int(np.argmin(self.mse_pixel))])

    @property
    def s_best_solid_angle(self) -> float:
        return float(self.s_values[int(np.argmin(self.mse_solid_angle))])

    def s_vertex(self, key: str = "mse_pixel") -> float:
        """The minimum of the parabola through the grid minimum and its two neighbours (the
        grid minimum itself at an end of the grid)."""
        y = getattr(self, key)
        s = np.asarray(self.s_values, dtype=np.float64)
        k = int(np.argmin(y))
        if k == 0 or k == s.size - 1:
            return float(s[k])
        c = np.polyfit(s[k - 1:k + 2], y[k - 1:k + 2], 2)
        return float(-c[1] / (2 * c[0])) if c[0] > 0 else float(s[k])


def _point_table(hf: int, k0) -> np.ndarray:
    """k0 between the pixel centres (R, C) and (R', C + Δ) of an hf-row grid, Δ in [0, hf]
    (the covariance is even in Δ and symmetric in (R, R')), shape (hf, hf, hf + 1)."""
    theta = np.pi * (np.arange(hf) + 0.5) / hf
    half = np.sin(np.pi * np.arange(hf + 1) / (2 * hf)) ** 2        # sin²(Δφ/2)
    out = np.empty((hf, hf, hf + 1))
    for r in range(hf):
        t2 = theta[r:]
        d2 = 4.0 * (np.sin(0.5 * (theta[r] - t2))[:, None] ** 2
                    + (np.sin(theta[r]) * np.sin(t2))[:, None] * half[None, :])
        out[r, r:] = out[r:, r] = k0(d2)
    return out


def _pixel_covariance_table(model: SynthesisModel, k0) -> np.ndarray:
    r"""T[r, r', Δc] = Cov(pixel (r, c), pixel (r', c + Δc)) of the map as read, (H, H, 2H).

    A pixel of a block-averaged map is :math:`\sum_{a,b} \omega_a f(\text{fine}(rF+a, cF+b))/F`
    with :math:`\omega_a` the fine rows' solid angles normalised in the block (EnvMap.resized):
    the point covariances of the fine grid summed over both blocks (columns: a triangle of
    weights (F − |δ|)/F² in the column offset δ)."""
    h, f = model.height, model.factor
    hf = h * f
    fine = _point_table(hf, k0)
    if f == 1:
        return np.concatenate([fine, fine[:, :, h - 1:0:-1]], axis=2)
    delta = np.arange(h + 1)[:, None] * f + np.arange(-f + 1, f)[None, :]   # fine Δ
    delta = np.abs(delta)
    delta = np.minimum(delta, 2 * hf - delta)                            # even, periodic
    tri = (f - np.abs(np.arange(-f + 1, f))) / f ** 2
    cols = fine[:, :, delta] @ tri                                       # (hf, hf, h + 1)
    om = row_solid_angles(hf, 2 * hf).reshape(h, f)
    om = om / om.sum(axis=1, keepdims=True)
    half = np.einsum("ra,rasbd,sb->rsd", om, cols.reshape(h, f, h, f, h + 1), om)
    return np.concatenate([half, half[:, :, h - 1:0:-1]], axis=2)


def _cov_pix(table: np.ndarray, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Cov(pixel qa, pixel qb) for broadcasting flat indices (row * W + col)."""
    w = table.shape[2]
    return table[qa // w, qb // w, (qb % w - qa % w) % w]


def _sq_dist(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """|u_i − v_j|² (M, N), from coordinate differences where the Gram form loses digits."""
    d2 = np.maximum(2.0 - 2.0 * (u @ v.T), 0.0)
    close = np.nonzero(d2 < 1e-6)
    if close[0].size:
        d2[close] = np.sum((u[close[0]] - v[close[1]]) ** 2, axis=-1)
    return d2


def _evaluation_rows(h: int, max_pixels: int | None) -> np.ndarray:
    """All rows, or ``max_pixels // 2H`` evenly spaced ones (at least one)."""
    if max_pixels is None or h * 2 * h <= max_pixels:
        return np.arange(h)
    k = max(1, int(max_pixels) // (2 * h))
    return np.unique(np.floor((np.arange(k) + 0.5) * h / k).astype(np.int64))


class _Setup:
    """What every s shares at one N: nodes, the node covariance G = Cov(g, g), the evaluation
    pixels and their weights, and a function giving Cov(g, t(x)) for a block of pixels."""

    def __init__(self, model: SynthesisModel, n: int, pointset: str, seed: int,
                 max_pixels: int | None):
        from envfit.fit._table2 import sample_directions
        from envfit.maps import pixel_directions
        h, w = model.height, 2 * model.height
        self.nodes = sample_directions(n, pointset=pointset, seed=seed, up=model.up)
        self.rows = _evaluation_rows(h, max_pixels)
        self.pix = (self.rows[:, None] * w + np.arange(w)[None, :]).ravel()
        self.dirs = pixel_directions(h, up=model.up).reshape(-1, 3)[self.pix]
        om = row_solid_angles(h, w)[self.rows]
        self.w_pixel = np.full(self.pix.size, 1.0 / self.pix.size)
        self.w_solid = np.repeat(om / (om.sum() * w), w)
        k0 = field_covariance(model.s0, model.lmax)
        self.lookup = model.lookup
        if model.lookup:
            self.table = _pixel_covariance_table(model, k0)
            self.idx, self.beta = bilinear_stencil(self.nodes, h, up=model.up)
            self.var = _cov_pix(self.table, self.pix, self.pix)
            r, c = np.divmod(self.idx, w)                               # (n, 4) rows, columns
            self.G = np.zeros((n, n))
            for a in range(4):
                for b in range(4):
                    cov = self.table[r[:, a, None], r[None, :, b], (c[None, :, b] - c[:, a, None]) % w]
                    self.G += self.beta[:, a, None] * self.beta[None, :, b] * cov
        else:
            self.k0 = k0
            self.var = np.full(self.pix.size, float(k0(0.0)))
            self.G = k0(_sq_dist(self.nodes, self.nodes))

    def cross(self, sl: slice) -> np.ndarray:
        """Cov(g(p_j), t(x)) for the evaluation pixels ``sl``, (N, m)."""
        if not self.lookup:
            return self.k0(_sq_dist(self.nodes, self.dirs[sl]))
        q = self.pix[sl]
        out = np.zeros((self.nodes.shape[0], q.size))
        for b in range(4):
            out += self.beta[:, b, None] * _cov_pix(self.table, self.idx[:, b, None], q[None, :])
        return out


def _expected_mse_at(setup: _Setup, s: float, offset: float) -> tuple[float, float]:
    """(per-pixel, solid-angle) expected MSE of the K_s interpolant (module doc)."""
    from envfit.theory import generalized_distance_kernel
    cf = cho_factor(generalized_distance_kernel(s, setup.nodes, setup.nodes), lower=True)
    acc_p = acc_s = 0.0
    for start in range(0, setup.pix.size, _BLOCK):
        sl = slice(start, min(start + _BLOCK, setup.pix.size))
        W = cho_solve(cf, generalized_distance_kernel(s, setup.nodes, setup.dirs[sl]))
        e2 = (setup.var[sl] - 2.0 * np.einsum("jx,jx->x", W, setup.cross(sl))
              + np.einsum("jx,jx->x", W, setup.G @ W)
              + offset ** 2 * (1.0 - W.sum(axis=0)) ** 2)
        acc_p += float(setup.w_pixel[sl] @ e2)
        acc_s += float(setup.w_solid[sl] @ e2)
    return acc_p, acc_s


def expected_interpolation_mse(model: SynthesisModel, s_values, n: int, *,
                               pointset: str = "sf", seed: int = 0,
                               max_pixels: int | None = 16384,
                               quiet: bool = True) -> KrigingCurve:
    r"""Expected MSE of Table 2's reconstruction of a GP map, for each s at N nodes.

    :math:`E|t(x) - I_s(g + c)(x)|^2` averaged over the map's pixels (module doc), with the
    nodes of :func:`envfit.fit._table2.sample_directions` (``pointset``, ``seed``, the map's
    ``up``). ``max_pixels``: evaluate on all pixels of evenly spaced rows, at most this many
    pixels (``None``: every pixel; the average over rows is then exact). ``quiet=False``
    shows a progress bar over ``s_values`` (one Cholesky factorisation of N × N each).

    >>> m = SynthesisModel(1.5, 8, lmax=None, lookup=False)
    >>> c = expected_interpolation_mse(m, [1.3, 1.5, 1.7], 40)
    >>> c.s_best
    1.5
    """
    from envfit.fit._table2 import check_grid
    s_values, _ = check_grid(s_values, [n])
    n = int(n)
    if n > model.height * 2 * model.height:
        raise ParameterError(f"N = {n} exceeds the {2 * model.height ** 2} pixels of the map")
    setup = _Setup(model, n, pointset, seed, max_pixels)
    res = np.array([_expected_mse_at(setup, s, float(model.offset))
                    for s in progress(s_values, desc=f"expected RMSE (N = {n})", unit="s",
                                      quiet=quiet)])
    return KrigingCurve(model=model, n=n, s_values=s_values, mse_pixel=res[:, 0],
                        mse_solid_angle=res[:, 1], variance=float(setup.w_pixel @ setup.var),
                        rows=int(setup.rows.size))


def builtin_synthesis(envmap) -> SynthesisModel | None:
    """The :class:`SynthesisModel` of the built-in map (:mod:`envfit.maps._default_map`) as
    loaded (its name records s0 and the synthesized height; a resize to a divisor of that
    height is a block average), with the map's solid-angle mean of channel 0 as the
    offset; ``None`` for any other map, a resize by a non-integer factor or a synthesis
    above :data:`MAX_SYNTH_HEIGHT` rows."""
    import re
    m = re.fullmatch(r"builtin:gp\(s0=([0-9.]+),height=([0-9]+),seed=[0-9]+\)",
                     getattr(envmap, "name", "") or "")
    if m is None:
        return None
    s0, synth_h = float(m.group(1)), int(m.group(2))
    if synth_h % envmap.height or synth_h > MAX_SYNTH_HEIGHT:
        return None
    offset = float(envmap.mean()[0])
    return SynthesisModel.data_gen(s0, synth_h, envmap.height, up=envmap.up, offset=offset)


def known_s_sentence(curve: KrigingCurve, measured_best: float, scale: str) -> str:
    """One sentence on what Table 2's best s on a map of known s0 means, true of the numbers:
    the closed-form expected optimum for this synthesis, lookup and N beside the measured one."""
    m = curve.model
    band = "the full process" if m.lmax is None else f"band-limited at l <= {m.lmax}"
    how = ", block-averaged to the map's rows" if m.factor > 1 else ""
    where = "" if scale == "linear" else " (computed on the linear scale)"
    best, vertex = curve.s_best, curve.s_vertex()
    if abs(best - m.s0) < 1e-9:
        expect = f"is lowest at s = {best:g} = s0 among these s"
    else:
        causes = [c for c, on in (("band limit", m.lmax is not None), ("resize", m.factor > 1),
                                  ("lookup", m.lookup)) if on]
        names = ", ".join(causes[:-1]) + (" and " if len(causes) > 1 else "") + causes[-1] \
            if causes else ""
        why = (f", because the {names} make the map smoother than K_s0 near "
               "its pixel scale" if best > m.s0 and causes else "")
        k = curve.s_values.index(best)
        vtx = (f" (parabola vertex {vertex:.2f})" if 0 < k < len(curve.s_values) - 1 else "")
        expect = (f"is lowest at s = {best:g} among these s{vtx}, "
                  f"not at s0 = {m.s0:g}{why}")
    on = "" if scale == "linear" else f" on the {scale} scale"
    agree = ("the same s" if abs(measured_best - best) < 1e-9
             else "a different s: the expectation is over all such maps, this is one of them")
    seen = "read by bilinear lookup" if m.lookup else "seen exactly at the nodes"
    return (f"Known s: this map is a GP sample of s0 = {m.s0:g} {band}{how}, {seen}; "
            f"for such maps the expected RMSE at N = {curve.n}{where} {expect}; "
            f"this map's lowest measured RMSE{on} is at s = {measured_best:g}, {agree}.")


def expected_profiled_likelihood(model: SynthesisModel, s_values, n: int, *,
                                 pointset: str = "sf", seed: int = 0) -> np.ndarray:
    r"""Expected negative profiled log-likelihood per sample of ``envfit fit``'s default
    criterion (kernel ``full``, samples by bilinear lookup) on maps of ``model``, per s.

    With G = Cov(g, g) the node covariance of the map as read and c its offset,
    :math:`E[g^T K_s^{-1} g] = \mathrm{tr}(K_s^{-1} G) + c^2\,1^T K_s^{-1} 1`, and to first
    order in 1/N (the quadratic form concentrates)

    .. math::  -E\ell(s)/N \approx \tfrac12\big(\log(E[g^T K_s^{-1} g]/N)
               + \log\det K_s / N + 1 + \log 2\pi\big),

    minimal where the likelihood fit converges for this synthesis and N (at s0 exactly for
    the full process seen exactly: the Kullback–Leibler divergence is zero there only).
    """
    from envfit.fit._table2 import check_grid
    from envfit.theory import generalized_distance_kernel
    s_values, _ = check_grid(s_values, [n])
    setup = _Setup(model, int(n), pointset, seed, max_pixels=1)
    one = np.ones(setup.nodes.shape[0])
    out = []
    for s in s_values:
        cf = cho_factor(generalized_distance_kernel(s, setup.nodes, setup.nodes), lower=True)
        quad = np.trace(cho_solve(cf, setup.G)) + model.offset ** 2 * (one @ cho_solve(cf, one))
        logdet = 2.0 * np.sum(np.log(np.diag(cf[0])))
        nn = one.size
        out.append(0.5 * (np.log(quad / nn) + logdet / nn + 1.0 + np.log(2 * np.pi)))
    return np.array(out)

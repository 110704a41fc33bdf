r"""pbrt-v4's equal-area sphere ↔ square maps, ``PiecewiseConstant2D`` and ``imgtool
makeequiarea`` (the lat-long → equal-area conversion), in numpy: the image side of
:mod:`envfit.renderers.pbrt4._light` (read from mmp/pbrt-v4 at ``5f7a606806a4``:
``src/pbrt/util/math.cpp``, ``src/pbrt/util/sampling.h``, ``src/pbrt/util/image.h``,
``src/pbrt/cmd/imgtool.cpp``, ``src/pbrt/filters.h``/``.cpp``).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.base import ParameterError
from envfit.renderers._base import map_rgb

__all__ = ["equal_area_square_to_sphere", "equal_area_sphere_to_square",
           "wrap_equal_area_square", "PiecewiseConstant2D", "make_equal_area",
           "gaussian_filter_offsets"]

#: pbrt's minimax coefficients of atan(x)·2/π on [0, 1] (``EqualAreaSphereToSquare``)
_ATAN_POLY = (0.406758566246788489601959989e-5, 0.636226545274016134946890922156,
              0.61572017898280213493197203466e-2, -0.247333733281268944196501420480,
              0.881770664775316294736387951347e-1, 0.419038818029165735901852432784e-1,
              -0.251390972343483509333252996350e-1)


def equal_area_square_to_sphere(p) -> np.ndarray:
    r"""``EqualAreaSquareToSphere``: points (K, 2) of [0, 1]² → unit vectors (K, 3).

    With :math:`u = 2p_x - 1`, :math:`v = 2p_y - 1`, signed distance
    :math:`s = 1 - (|u| + |v|)`, :math:`r = 1 - |s|`,
    :math:`\phi = \frac\pi4((|v| - |u|)/r + 1)` (π/4 at r = 0),
    :math:`z = \mathrm{sign}(s)(1 - r^2)` and :math:`(x, y) = (\pm\cos\phi, \pm\sin\phi)\,
    r\sqrt{2 - r^2}` with the signs of u and v. Area-preserving: the unit square's area 1
    maps to 4π.

    >>> (equal_area_square_to_sphere([[0.5, 0.5], [0.0, 0.0], [1.0, 0.5]]).round(12) + 0.0).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 2)
    u, v = 2.0 * p[:, 0] - 1.0, 2.0 * p[:, 1] - 1.0
    up, vp = np.abs(u), np.abs(v)
    sd = 1.0 - (up + vp)
    r = 1.0 - np.abs(sd)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(r == 0.0, 1.0, (vp - up) / r + 1.0) * (np.pi / 4.0)
    z = np.copysign(1.0 - r * r, sd)
    cos_phi = np.copysign(np.cos(phi), u)
    sin_phi = np.copysign(np.sin(phi), v)
    k = r * np.sqrt(np.maximum(2.0 - r * r, 0.0))
    return np.column_stack([cos_phi * k, sin_phi * k, z])


def equal_area_sphere_to_square(d) -> np.ndarray:
    r"""``EqualAreaSphereToSquare``: unit vectors (K, 3) → points (K, 2) of [0, 1]², with
    pbrt's polynomial approximation of :math:`\frac2\pi\arctan(b/a)` (max error ≈ 4e-6, as
    pbrt computes it), :math:`r = \sqrt{1 - |z|}`, the southern hemisphere mirrored.

    >>> equal_area_sphere_to_square([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]).round(5).tolist()
    [[0.5, 0.5], [1.0, 0.5]]
    """
    d = np.asarray(d, dtype=np.float64).reshape(-1, 3)
    x, y, z = np.abs(d[:, 0]), np.abs(d[:, 1]), np.abs(d[:, 2])
    r = np.sqrt(np.maximum(1.0 - z, 0.0))
    a, b = np.maximum(x, y), np.minimum(x, y)
    with np.errstate(invalid="ignore", divide="ignore"):
        b = np.where(a == 0.0, 0.0, b / a)
    phi = np.zeros_like(b)
    for c in reversed(_ATAN_POLY):                      # EvaluatePolynomial (Horner)
        phi = phi * b + c
    phi = np.where(x < y, 1.0 - phi, phi)
    v = phi * r
    u = r - v
    south = d[:, 2] < 0
    u, v = np.where(south, 1.0 - v, u), np.where(south, 1.0 - u, v)
    u, v = np.copysign(u, d[:, 0]), np.copysign(v, d[:, 1])
    return np.column_stack([0.5 * (u + 1.0), 0.5 * (v + 1.0)])


def wrap_equal_area_square(p) -> np.ndarray:
    """``WrapEqualAreaSquare``: points slightly outside [0, 1]² mirrored back (across u = 0
    or 1 with v → 1 − v, then across v = 0 or 1 with u → 1 − u), continuing the sphere."""
    p = np.array(p, dtype=np.float64).reshape(-1, 2)
    u, v = p[:, 0], p[:, 1]
    lo, hi = u < 0, u > 1
    u = np.where(lo, -u, np.where(hi, 2.0 - u, u))
    v = np.where(lo | hi, 1.0 - v, v)
    lo, hi = v < 0, v > 1
    v = np.where(lo, -v, np.where(hi, 2.0 - v, v))
    u = np.where(lo | hi, 1.0 - u, u)
    return np.column_stack([u, v])


class PiecewiseConstant2D:
    r"""pbrt-v4's ``PiecewiseConstant2D`` on a domain box: ``func`` (ny, nx), row v of the
    array is the conditional distribution over x (``pConditionalV[v]``), the marginal over
    rows holds each row's integral. ``|func|`` is used; an all-zero row (or the whole
    function) gets the uniform CDF. :meth:`sample` inverts the marginal with ``u[1]`` and
    the row's conditional with ``u[0]``, linearly inside the cell (``FindInterval``: the last
    CDF entry ≤ u, clamped to the cells); :meth:`pdf` is ``func[iv, iu] / Integral``.
    """

    def __init__(self, func, domain=((0.0, 0.0), (1.0, 1.0))):
        f = np.abs(np.asarray(func, dtype=np.float64))
        if f.ndim != 2 or f.size == 0 or not np.all(np.isfinite(f)):
            raise ParameterError("PiecewiseConstant2D needs a finite 2-D array")
        self.func = f
        (self.x0, self.y0), (self.x1, self.y1) = domain
        ny, nx = f.shape
        dx, dy = (self.x1 - self.x0) / nx, (self.y1 - self.y0) / ny
        self.row_int = f.sum(axis=1) * dx                          # conditional integrals
        self.cond_cdf = self._cdf(f * dx, self.row_int)
        self.integral = float(self.row_int.sum() * dy)             # marginal integral
        self.marg_cdf = self._cdf((self.row_int * dy)[None, :], np.array([self.integral]))[0]
        self._flat = (self.cond_cdf + 2.0 * np.arange(ny)[:, None]).ravel()

    @staticmethod
    def _cdf(cells: np.ndarray, totals: np.ndarray) -> np.ndarray:
        n = cells.shape[1]
        c = np.concatenate([np.zeros((cells.shape[0], 1)), np.cumsum(cells, axis=1)], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            c = np.where(totals[:, None] > 0, c / totals[:, None], np.arange(n + 1) / n)
        return c

    @staticmethod
    def _fraction(cdf, u, o):
        """``du`` of ``PiecewiseConstant1D::Sample``: (u − cdf[o])/(cdf[o+1] − cdf[o]) when
        the cell has mass, else u − cdf[o]."""
        c0, c1 = cdf[o], cdf[o + 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(c1 - c0 > 0, (u - c0) / (c1 - c0), u - c0)

    def sample(self, u):
        """Points (K, 2) in the domain and their pdf (K,) from u (K, 2) of [0, 1)²."""
        u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
        ny, nx = self.func.shape
        iv = np.clip(np.searchsorted(self.marg_cdf, u[:, 1], side="right") - 1, 0, ny - 1)
        fy = (iv + self._fraction(self.marg_cdf, u[:, 1], iv)) / ny
        row0 = iv * (nx + 1)
        shifted = u[:, 0] + 2.0 * iv             # rows stacked 2 apart: one monotone table
        iu = np.clip(np.searchsorted(self._flat, shifted, side="right") - 1 - row0, 0, nx - 1)
        fx = (iu + self._fraction(self._flat, shifted, row0 + iu)) / nx
        pts = np.column_stack([self.x0 + fx * (self.x1 - self.x0),
                               self.y0 + fy * (self.y1 - self.y0)])
        return pts, self._pdf_cells(iu, iv)

    def _pdf_cells(self, iu, iv):
        if self.integral > 0:
            return self.func[iv, iu] / self.integral
        return np.zeros(np.shape(iu))

    def pdf(self, p) -> np.ndarray:
        """``PiecewiseConstant2D::PDF`` (K,) at points (K, 2) of the domain."""
        p = np.asarray(p, dtype=np.float64).reshape(-1, 2)
        ny, nx = self.func.shape
        ox = (p[:, 0] - self.x0) / (self.x1 - self.x0)
        oy = (p[:, 1] - self.y0) / (self.y1 - self.y0)
        iu = np.clip((ox * nx).astype(np.int64), 0, nx - 1)
        iv = np.clip((oy * ny).astype(np.int64), 0, ny - 1)
        return self._pdf_cells(iu, iv)


# ----------------------------------------------------------------------------- makeequiarea

def _gaussian_table(radius: float = 1.5, sigma: float = 2.0) -> np.ndarray:
    r"""``FilterSampler``'s table of ``GaussianFilter(Vector2f(1.5, 1.5), 2)``: 32 entries per
    unit of radius (48 × 48), each :math:`\max(0, g(x) - g(r))\max(0, g(y) - g(r))` at the
    cell centre, :math:`g(x) = e^{-x^2/2\sigma^2}/\sqrt{2\pi\sigma^2}` (pbrt's ``FastExp`` is
    replaced by the exact exponential)."""
    n = int(32 * radius)
    c = -radius + (np.arange(n) + 0.5) / n * 2.0 * radius
    g = np.exp(-c * c / (2 * sigma ** 2)) / np.sqrt(2 * np.pi * sigma ** 2)
    gr = np.exp(-radius ** 2 / (2 * sigma ** 2)) / np.sqrt(2 * np.pi * sigma ** 2)
    f1 = np.maximum(0.0, g - gr)
    return np.outer(f1, f1)                                          # [y, x]


def gaussian_filter_offsets(sqrt_samples: int = 6):
    r"""The filter offsets (S², 2) and weights (S²,) of ``makeequiarea``, made deterministic:
    pbrt draws one jittered point per stratum of a 6 × 6 grid (``rng.Uniform``), envfit takes
    each stratum's **midpoint**, ((du + ½)/6, (dv + ½)/6), and maps it through the same
    ``GaussianFilter::Sample`` (``FilterSampler``: :class:`PiecewiseConstant2D` of
    :func:`_gaussian_table` on [−1.5, 1.5]²); weight = f(cell)/pdf (``FilterSample``).

    >>> off, w = gaussian_filter_offsets()
    >>> off.shape, bool(np.allclose(off.mean(axis=0), 0.0)), bool(np.allclose(w, w[0]))
    ((36, 2), True, True)
    """
    f = _gaussian_table()
    dist = PiecewiseConstant2D(f, domain=((-1.5, -1.5), (1.5, 1.5)))
    dv, du = np.meshgrid(np.arange(sqrt_samples), np.arange(sqrt_samples), indexing="ij")
    s2 = np.column_stack([(du.ravel() + 0.5) / sqrt_samples, (dv.ravel() + 0.5) / sqrt_samples])
    p, pdf = dist.sample(s2)
    n = f.shape[0]
    ix = np.clip(((p[:, 0] + 1.5) / 3.0 * n).astype(np.int64), 0, n - 1)
    iy = np.clip(((p[:, 1] + 1.5) / 3.0 * n).astype(np.int64), 0, n - 1)
    return p, f[iy, ix] / pdf


def make_equal_area(envmap, resolution: int | None = None) -> np.ndarray:
    r"""pbrt-v4's ``imgtool makeequiarea`` of a lat-long map: an N × N equal-area image
    (N = the lat-long width unless ``resolution``), pixel (u, v) (column, row) the filter-
    weighted mean of bilinear lat-long lookups at the equal-area points
    ``WrapEqualAreaSquare(((u + ½ + o_x)/N, (v + ½ + o_y)/N))`` for the 36 offsets of
    :func:`gaussian_filter_offsets` (pbrt jitters them; here stratum midpoints), each mapped
    by :func:`equal_area_square_to_sphere` to (φ/2π, θ/π) (``SphericalPhi``,
    ``SphericalTheta``) and looked up by ``Image::Bilerp`` with ``WrapMode2D(Repeat,
    Clamp)`` (texel-centred, φ periodic, θ clamped: no blending across a pole), clamped at
    0. Returns (N, N, 3) float64 (row 0 = the file's top). A compiled loop
    (:func:`_equal_area_kernel`): 2.5–3 s for N = 1024 on a loaded 2-core machine, where
    the numpy form (tests/oracles/pbrt_equiarea.py) took 9 s.

    >>> from envfit.maps import EnvMap
    >>> bool(np.allclose(make_equal_area(EnvMap(np.full((4, 8, 3), 0.5)), 6), 0.5))
    True
    """
    img = np.ascontiguousarray(map_rgb(envmap))
    n = int(resolution) if resolution is not None else img.shape[1]
    if n < 1:
        raise ParameterError(f"the equal-area resolution must be >= 1, got {resolution!r}")
    off, wt = gaussian_filter_offsets()
    return _equal_area_kernel(img, n, np.ascontiguousarray(off), wt)


@numba.njit(cache=True)
def _square_to_phi_theta(px: float, py: float):
    """``WrapEqualAreaSquare`` then ``EqualAreaSquareToSphere`` then (``SphericalPhi``,
    ``SphericalTheta``) of one point (the scalar form of the numpy functions above)."""
    if px < 0.0:
        px, py = -px, 1.0 - py
    elif px > 1.0:
        px, py = 2.0 - px, 1.0 - py
    if py < 0.0:
        px, py = 1.0 - px, -py
    elif py > 1.0:
        px, py = 1.0 - px, 2.0 - py
    u, v = 2.0 * px - 1.0, 2.0 * py - 1.0
    up, vp = abs(u), abs(v)
    sd = 1.0 - (up + vp)
    r = 1.0 - abs(sd)
    phi = (1.0 if r == 0.0 else (vp - up) / r + 1.0) * (math.pi / 4.0)
    z = math.copysign(1.0 - r * r, sd)
    k = r * math.sqrt(max(2.0 - r * r, 0.0))
    x, y = math.copysign(math.cos(phi), u) * k, math.copysign(math.sin(phi), v) * k
    ph = math.atan2(y, x)
    if ph < 0.0:
        ph += 2.0 * math.pi
    return ph, math.acos(min(max(z, -1.0), 1.0))


@numba.njit(cache=True)
def _equal_area_kernel(img, n, off, wt):
    """The loop of ``makeequiarea`` over output pixels and filter samples (see
    :func:`make_equal_area`); ``Bilerp`` with x periodic and y clamped."""
    h, w, nc = img.shape
    out = np.zeros((n, n, nc))
    wsum = wt.sum()
    for v in range(n):
        for u in range(n):
            for s in range(off.shape[0]):
                ph, th = _square_to_phi_theta((u + 0.5 + off[s, 0]) / n, (v + 0.5 + off[s, 1]) / n)
                fx, fy = ph / (2.0 * math.pi) * w - 0.5, th / math.pi * h - 0.5
                xi, yi = math.floor(fx), math.floor(fy)
                dx, dy = fx - xi, fy - yi
                x0, x1 = int(xi) % w, (int(xi) + 1) % w
                y0, y1 = min(max(int(yi), 0), h - 1), min(max(int(yi) + 1, 0), h - 1)
                for c in range(nc):
                    out[v, u, c] += wt[s] * ((1 - dx) * (1 - dy) * img[y0, x0, c]
                                             + dx * (1 - dy) * img[y0, x1, c]
                                             + (1 - dx) * dy * img[y1, x0, c]
                                             + dx * dy * img[y1, x1, c])
            for c in range(nc):
                out[v, u, c] = max(out[v, u, c] / wsum, 0.0)
    return out

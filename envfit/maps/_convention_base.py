r"""The machinery of a lat-long convention: the pixel :class:`Grid` of each axis, the
:class:`LatLongConvention` base class (direction ↔ pixel, the conversion to and from envfit's
grid) and :class:`NotLatLong` for renderers whose maps are not lat-long. The renderers'
conventions themselves, each with the source it was read from, and the registry
:data:`~envfit.maps._conventions.CONVENTIONS` are in :mod:`envfit.maps._conventions`.

Canonical form (see :mod:`envfit.maps._conventions` for the table of renderers):

.. math::  d_{world} = F\,(\sin\theta\cos\phi,\ \sin\theta\sin\phi,\ \cos\theta),\qquad
           \theta = \pi\,\frac{row + a_r}{H - b_r},\qquad \phi = 2\pi\,\frac{col + a_c}{W - b_c}.
"""
from __future__ import annotations

from typing import ClassVar, NamedTuple

import numpy as np

from envfit.base import ParameterError
from envfit.maps import _latlong as latlong
from envfit.maps._envmap import EnvMap

__all__ = ["Grid", "CENTRED", "ENDPOINTS", "EXACT_TOLERANCE", "LatLongConvention", "NotLatLong"]

#: an internal pixel centre this close (in pixels) to a pixel of the convention's grid
#: counts as "on the grid" (the exact permutation path)
EXACT_TOLERANCE = 1e-6


class Grid(NamedTuple):
    r"""A pixel grid along one axis: ``angle = span (index + offset) / (n − shrink)``.

    >>> float(CENTRED.angle(0, 4, np.pi) / np.pi), float(ENDPOINTS.angle(3, 4, np.pi) / np.pi)
    (0.125, 1.0)
    """

    offset: float
    shrink: int
    label: str

    def angle(self, index, n: int, span: float):
        """The angle of continuous pixel coordinate ``index`` on an axis of ``n`` pixels."""
        return span * (np.asarray(index, dtype=np.float64) + self.offset) / (n - self.shrink)

    def index(self, angle, n: int, span: float):
        """The continuous pixel coordinate of ``angle`` (inverse of :meth:`angle`)."""
        return np.asarray(angle, dtype=np.float64) * ((n - self.shrink) / span) - self.offset

    def period(self, n: int) -> int:
        """Distinct pixels around the axis (the last endpoint column repeats the first)."""
        return n - self.shrink


#: pixel centres at half-integers: θ = π(i+½)/H, φ = 2π(j+½)/W (envfit, pbrt-v3, Cycles)
CENTRED = Grid(0.5, 0, "centred")
#: first and last pixel on the ends: θ = π i/(H−1), φ = 2π j/(W−1) (OpenEXR, Mitsuba rows)
ENDPOINTS = Grid(0.0, 1, "endpoints")

_L_Y = latlong.local_to_world("y")


class LatLongConvention:
    r"""A renderer's lat-long convention (subclasses set the class attributes).

    Attributes
    ----------
    name, renderer : the CLI name and the renderer it describes
    frame : (3, 3) orthogonal ``F``: ``d_world = F (sinθ cosφ, sinθ sinφ, cosθ)``
    rows, cols : the :class:`Grid` of θ (over π, H rows) and of φ (over 2π, W columns)
    azimuth : ``(sign, offset, low)``: the renderer's own azimuth is
        ``φ_r = sign φ + offset`` wrapped into ``[low, low + 2π)`` (see :meth:`angles`)
    azimuth_label : how the renderer computes its azimuth, for messages
    source : where the formula was verified
    """

    name: ClassVar[str] = ""
    renderer: ClassVar[str] = ""
    frame: ClassVar[np.ndarray] = _L_Y
    rows: ClassVar[Grid] = CENTRED
    cols: ClassVar[Grid] = CENTRED
    azimuth: ClassVar[tuple[float, float, float]] = (1.0, 0.0, 0.0)
    azimuth_label: ClassVar[str] = "φ"
    source: ClassVar[str] = ""

    # ---------------------------------------------------------------- geometry
    @property
    def is_envfit_grid(self) -> bool:
        """Whether this is envfit's own layout (``--up y``): a map read with it is not
        converted."""
        return self.name == "envfit"

    @property
    def up(self) -> str:
        """The world axis of the convention's top row, ``"x"``, ``"y"`` or ``"z"`` (the
        internal map's ``up``)."""
        return "xyz"[int(np.argmax(np.abs(self.frame[:, 2])))]

    def pixel_to_direction(self, row, col, height: int, width: int | None = None) -> np.ndarray:
        r"""Unit world direction at continuous pixel coordinates of this convention.

        .. math::  d = F(\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta),\quad
                   \theta = \pi(row + a_r)/(H - b_r),\quad \phi = 2\pi(col + a_c)/(W - b_c).

        ``row`` and ``col`` broadcast; returns ``broadcast shape + (3,)``.

        >>> from envfit.maps import convention
        >>> convention("openexr").pixel_to_direction(0, 0, 4, 8).round(12) + 0.0   # top row: +y
        array([0., 1., 0.])
        """
        h, w = latlong._size(height, width)
        theta = self.rows.angle(row, h, np.pi)
        phi = self.cols.angle(col, w, 2.0 * np.pi)
        return latlong._local_dirs(theta, phi) @ self.frame.T

    def direction_to_pixel(self, dirs, height: int,
                           width: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        r"""Continuous pixel coordinates ``(row, col)`` of world directions (any nonzero length).

        With ``(x, y, z) = F^T d``: ``θ = atan2(√(x²+y²), z)``, ``φ = atan2(y, x)`` in
        ``[0, 2π)``, ``row = θ(H − b_r)/π − a_r``, ``col = φ(W − b_c)/(2π) − a_c``.

        >>> from envfit.maps import convention
        >>> r, c = convention("mitsuba3").direction_to_pixel([0.0, -1.0, 0.0], 5, 10)
        >>> float(r)                                     # −y: Mitsuba's last row, on the pole
        4.0
        """
        h, w = latlong._size(height, width)
        local = self._local(dirs)
        theta = np.arctan2(np.hypot(local[..., 0], local[..., 1]), local[..., 2])
        phi = np.mod(np.arctan2(local[..., 1], local[..., 0]), 2.0 * np.pi)
        phi = np.where(phi >= 2.0 * np.pi, 0.0, phi)          # mod can round up to 2π
        return self.rows.index(theta, h, np.pi), self.cols.index(phi, w, 2.0 * np.pi)

    def pixel_directions(self, height: int, width: int | None = None) -> np.ndarray:
        """World direction of every pixel of an ``H x W`` map in this convention, (H, W, 3).

        >>> from envfit.maps import convention
        >>> convention("blender").pixel_directions(4).shape
        (4, 8, 3)
        """
        h, w = latlong._size(height, width)
        return self.pixel_to_direction(np.arange(h)[:, None], np.arange(w)[None, :], h, w)

    def angles(self, dirs) -> tuple[np.ndarray, np.ndarray]:
        r"""The renderer's own angles of world directions, in radians: θ, the polar angle from
        its up axis, and its azimuth ``φ_r = sign·φ + offset`` in ``[low, low + 2π)``
        (:attr:`azimuth_label` says how the renderer computes it).

        >>> from envfit.maps import convention
        >>> t, p = convention("blender").angles([1.0, 0.0, 0.0])   # Cycles: atan2(y, x) = 0
        >>> round(float(t), 12), round(float(p), 12)
        (1.570796326795, 0.0)
        """
        local = self._local(dirs)
        theta = np.arctan2(np.hypot(local[..., 0], local[..., 1]), local[..., 2])
        sign, offset, low = self.azimuth
        phi = sign * np.arctan2(local[..., 1], local[..., 0]) + offset
        return theta, np.mod(phi - low, 2.0 * np.pi) + low

    def _local(self, dirs) -> np.ndarray:
        d = latlong._as_dirs(dirs)
        if not np.all(np.isfinite(d)):
            raise ParameterError("directions contain NaN or Inf")
        return d @ self.frame          # F^T d, as row vectors

    # ---------------------------------------------------------------- conversion
    def exact_indices(self, height: int, width: int | None = None):
        """``(rows, cols)`` integer arrays (H, W) such that internal pixel ``(i, j)`` is
        pixel ``(rows[i, j], cols[i, j])`` of the map in this convention, or None when the
        grids differ by more than a permutation or flip (then :meth:`to_internal` resamples).

        >>> from envfit.maps import convention
        >>> r, c = convention("blender").exact_indices(2)          # columns reversed, shifted
        >>> c[0].tolist()
        [1, 0, 3, 2]
        """
        h, w = latlong._size(height, width)
        row, col = self.direction_to_pixel(latlong.pixel_directions(h, w, up=self.up), h, w)
        ri, ci = np.rint(row), np.rint(col)
        if np.max(np.abs(row - ri)) > EXACT_TOLERANCE or np.max(np.abs(col - ci)) > EXACT_TOLERANCE:
            return None
        if ri.min() < 0 or ri.max() > h - 1:
            return None
        return ri.astype(np.int64), np.mod(ci.astype(np.int64), self.cols.period(w))

    def resample(self, image, height_out: int | None = None) -> np.ndarray:
        r"""The renderer's bilinear interpolant of ``image`` (H, W[, C], this convention)
        evaluated at envfit's pixel centres (same H unless ``height_out``), float64.

        Coordinates are :meth:`direction_to_pixel` of :func:`latlong.pixel_directions`
        (``up`` = :attr:`up`); values come from ``scipy.ndimage.map_coordinates(order=1)``
        on the image padded by one pixel: columns periodic (period ``W − b_c``), and, for
        a centred row grid, the rows beyond a pole continued across it (row −1 = row 0 at
        φ + π); an endpoint row grid needs no padding (its rows span [0, π]).

        >>> from envfit.maps import convention
        >>> img = np.arange(8.0).reshape(2, 4)
        >>> bool(np.allclose(convention("pbrt3").resample(img), img))     # identity grid
        True
        """
        from scipy.ndimage import map_coordinates

        img = np.asarray(image, dtype=np.float64)
        flat = img.ndim == 2
        img = img[:, :, None] if flat else img
        h, w = img.shape[:2]
        ho = h if height_out is None else int(height_out)
        row, col = self.direction_to_pixel(latlong.pixel_directions(ho, 2 * ho, up=self.up), h, w)
        period = self.cols.period(w)
        base = img[:, :period]
        shift = period // 2
        top = np.roll(base[:1], shift, axis=1) if self.rows is CENTRED else base[:1]
        bottom = np.roll(base[-1:], shift, axis=1) if self.rows is CENTRED else base[-1:]
        ext = np.concatenate([top, base, bottom], axis=0)
        ext = np.concatenate([ext[:, -1:], ext, ext[:, :1]], axis=1)
        coords = [row.ravel() + 1.0, np.mod(col.ravel(), period) + 1.0]
        out = np.stack([map_coordinates(ext[:, :, k], coords, order=1, mode="nearest",
                                        prefilter=False) for k in range(img.shape[2])], axis=-1)
        out = out.reshape(ho, 2 * ho, img.shape[2])
        return out[:, :, 0] if flat else out

    def to_internal(self, env, *, exact: bool | None = None) -> EnvMap:
        r"""The map ``env`` (an :class:`EnvMap` or an H x 2H [x C] array whose pixels are laid
        out in this convention) in envfit's convention, with ``up`` = :attr:`up`.

        ``exact=None``: permute pixels when :meth:`exact_indices` finds the grids equal up
        to a permutation or flip, else resample (:meth:`resample`); ``True``: permutation or
        :class:`ParameterError`; ``False``: always resample. A note says which was done.

        >>> from envfit.maps import convention
        >>> m = convention("blender").to_internal(np.arange(8.0).reshape(2, 4))
        >>> m.up, m.data[0, :, 0].tolist()
        ('z', [1.0, 0.0, 3.0, 2.0])
        """
        src = env if isinstance(env, EnvMap) else EnvMap(np.asarray(env))
        h, w = src.height, src.width
        idx = self.exact_indices(h, w) if exact is not False else None
        if exact and idx is None:
            raise ParameterError(f"the {self.name} grid is not envfit's up to a permutation; "
                                 "it can only be resampled")
        if idx is not None:
            data = src.data[idx[0], idx[1]]
            how = "pixels permuted exactly, no resampling"
        else:
            data = self.resample(src.data).astype(src.data.dtype)
            how = f"resampled bilinearly to envfit's pixel centres ({self.rows.label} rows, " \
                  f"{self.cols.label} columns)"
        notes = list(src.notes)
        if not self.is_envfit_grid:
            notes.append(f"read as a {self.renderer} lat-long map (+{self.up} up): {how}")
        return EnvMap(data, up=self.up, name=src.name, notes=notes)

    def from_internal(self, env: EnvMap) -> np.ndarray:
        r"""The pixels of an :class:`EnvMap` laid out in this convention, (H, W, C) float64:
        ``env.lookup`` (bilinear) at :meth:`pixel_directions`, which is bit-exact where the
        grids coincide (lookups at pixel centres are exact).

        >>> from envfit.maps import convention
        >>> e = EnvMap(np.random.default_rng(0).random((4, 8, 1)), up="z")
        >>> c = convention("blender")
        >>> bool(np.array_equal(c.to_internal(c.from_internal(e)).data, e.data))
        True
        """
        if not isinstance(env, EnvMap):
            raise ParameterError("from_internal needs an EnvMap (its up axis says where it is)")
        return env.lookup(self.pixel_directions(env.height, env.width))

    def describe(self) -> str:
        """One line: name, renderer, up axis, grids."""
        return (f"{self.name}: {self.renderer}, +{self.up} up, {self.rows.label} rows, "
                f"{self.cols.label} columns")

    def __repr__(self) -> str:
        return f"convention({self.name!r})"


class NotLatLong:
    """A renderer whose environment maps are not lat-long: every use raises
    :class:`ParameterError` with :attr:`reason` (one line)."""

    name: ClassVar[str] = ""
    renderer: ClassVar[str] = ""
    reason: ClassVar[str] = ""
    source: ClassVar[str] = ""
    is_envfit_grid: ClassVar[bool] = False

    def _refuse(self, *args, **kwargs):
        raise ParameterError(f"--convention {self.name}: {self.reason}")

    direction_to_pixel = pixel_to_direction = pixel_directions = angles = _refuse
    exact_indices = resample = to_internal = from_internal = _refuse

    def describe(self) -> str:
        return f"{self.name}: {self.renderer}: {self.reason}"

    def __repr__(self) -> str:
        return f"convention({self.name!r})"

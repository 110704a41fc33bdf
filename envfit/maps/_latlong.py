r"""The latitude-longitude (equirectangular) convention of envfit — the ONE place it is defined.

Convention
----------
* A map is an ``H x W x C`` array with ``W = 2H`` (the functions here accept any ``W``;
  :class:`envfit.maps._envmap.EnvMap` enforces 2:1). Row 0 is at the top and touches the *up* pole.
* Pixel ``(i, j)`` is the equal-angle cell whose **centre** has polar angle (measured from
  the up axis) and azimuth

  .. math::  \theta_i = \pi (i + \tfrac12) / H, \qquad \phi_j = 2\pi (j + \tfrac12) / W,

  i.e. half-integer centres: no row lies on a pole (unlike tools that put the first and last
  rows exactly on the poles; a map read with that other convention is shifted by half a pixel).
* Its exact solid angle is :math:`\Delta\phi\,(\cos\theta_{top} - \cos\theta_{bottom})` with
  :math:`\Delta\phi = 2\pi/W`, :math:`\theta_{top} = \pi i/H`, :math:`\theta_{bottom} = \pi(i+1)/H`;
  over the whole map they sum to :math:`4\pi`.
* Continuous pixel coordinates put pixel centres on integers:
  ``row = θ H/π − ½`` and ``col = φ W/(2π) − ½`` (``col`` wrapped to ``[−½, W−½)``).
* The *local frame* of a map is the standard spherical one, local z = up:

  .. math::  d_{local} = (\sin\theta\cos\phi,\ \sin\theta\sin\phi,\ \cos\theta).

  This is the frame of ducc0's spherical-harmonic transforms with geometry ``"F1"``
  (``θ_i = π(i+½)/H``) and ``phi0 = π/W``; ``data_gen/`` works in this frame only.
* *World* directions are ``d_world = M @ d_local`` with a fixed orthogonal matrix ``M``
  chosen by ``up`` (:func:`local_to_world`):

  ===== ============================================== ===========================
  up    world direction of (θ, φ)                      det M
  ===== ============================================== ===========================
  "y"   (sinθ sinφ,  cosθ,  −sinθ cosφ)  (OpenEXR)     −1
  "z"   (sinθ cosφ,  sinθ sinφ,  cosθ)   (identity)    +1
  "x"   (cosθ,  −sinθ cosφ,  sinθ sinφ)                −1
  ===== ============================================== ===========================

  ``up="y"`` (the default) reproduces OpenEXR's latitude-longitude orientation, the one
  most renderers use: ``+y`` up, the centre column (``φ = π``) looks along ``+z``, the left
  and right edges (``φ = 0, 2π``) along ``−z``, and ``φ = π/2`` along ``+x``. ``up="x"`` is
  the same relation with the world axes permuted cyclically: the up axis receives local z,
  the next axis cyclically (y after x, as z after y) receives −local x, and the previous one
  (z before x, as x before y) receives local y. The OpenEXR orientation is a reflection of
  the local frame, hence ``det M = −1``; this is irrelevant to anything that only evaluates
  the map at world directions, and local ↔ world is always ``M`` / ``M.T``.

Everything here is pure numpy, vectorised and float64.

Example
-------
>>> import numpy as np
>>> theta, phi = pixel_angles(4)
>>> np.allclose(theta, np.pi * (np.arange(4) + 0.5) / 4)
True
>>> bool(abs(pixel_solid_angles(4).sum() - 4 * np.pi) < 1e-12)
True
>>> d = pixel_directions(4)            # up="y": top row near +y
>>> bool(d[0, 0, 1] > 0.9)
True
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.defaults import UPS
from envfit.maps._lookup import lookup_rows

__all__ = [
    "UPS",
    "pixel_angles",
    "local_to_world",
    "pixel_directions",
    "row_solid_angles",
    "pixel_solid_angles",
    "direction_to_pixel",
    "pixel_to_direction",
    "bilinear_lookup",
]

# UPS, the accepted values of ``up`` (the world axis that row 0 of a map touches), is
# envfit.defaults', imported above

#: world = M @ local, local = (sinθ cosφ, sinθ sinφ, cosθ)
_LOCAL_TO_WORLD = {
    # world (x, y, z) = (local y, local z, −local x)  -> (sinθ sinφ, cosθ, −sinθ cosφ)
    "y": np.array([[0.0, 1.0, 0.0],
                   [0.0, 0.0, 1.0],
                   [-1.0, 0.0, 0.0]]),
    "z": np.eye(3),
    # world (x, y, z) = (local z, −local x, local y)  -> (cosθ, −sinθ cosφ, sinθ sinφ)
    "x": np.array([[0.0, 0.0, 1.0],
                   [-1.0, 0.0, 0.0],
                   [0.0, 1.0, 0.0]]),
}

#: directions per block in :func:`bilinear_lookup` (bounds its temporaries to a few tens of MB)
LOOKUP_BLOCK = 1 << 17

#: a continuous coordinate this close to an integer is snapped to it in :func:`bilinear_lookup`
#: (so that the lookup at a pixel centre returns the pixel value bit-exactly)
_SNAP = 1e-9



def _floor_and_fraction(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Integer part (as float) and fraction of continuous pixel coordinates, with fractions
    within ``_SNAP`` of 0 or 1 snapped, so that lookups at pixel centres are exact."""
    x0 = np.floor(x)
    f = x - x0
    snap = f > 1.0 - _SNAP
    if snap.any():
        x0 = np.where(snap, x0 + 1.0, x0)
        f = np.where(snap, 0.0, f)
    return x0, np.where(f < _SNAP, 0.0, f)

def _size(height, width=None) -> tuple[int, int]:
    """Validate ``height`` / ``width`` (positive integers; width defaults to ``2 * height``)."""
    try:
        h = int(height)
        w = 2 * h if width is None else int(width)
    except (TypeError, ValueError):
        raise ParameterError(f"map size must be integers, got height={height!r}, "
                             f"width={width!r}") from None
    if h != height or (width is not None and w != width):
        raise ParameterError(f"map size must be integers, got height={height!r}, width={width!r}")
    if h < 1 or w < 1:
        raise ParameterError(f"map size must be positive, got {w}x{h} (width x height)")
    return h, w


def pixel_angles(height: int, width: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""Polar angle of each row centre and azimuth of each column centre.

    .. math::  \theta_i = \pi (i + \tfrac12)/H,\quad i = 0..H-1;\qquad
               \phi_j = 2\pi (j + \tfrac12)/W,\quad j = 0..W-1.

    Returns ``(theta (H,), phi (W,))`` in radians, float64. ``width`` defaults to ``2*height``.

    >>> t, p = pixel_angles(2)
    >>> np.round(t / np.pi, 3).tolist(), np.round(p / np.pi, 3).tolist()
    ([0.25, 0.75], [0.25, 0.75, 1.25, 1.75])
    """
    h, w = _size(height, width)
    theta = np.pi * (np.arange(h, dtype=np.float64) + 0.5) / h
    phi = 2.0 * np.pi * (np.arange(w, dtype=np.float64) + 0.5) / w
    return theta, phi


def local_to_world(up: str = "y") -> np.ndarray:
    """The orthogonal 3x3 matrix ``M`` with ``world = M @ local`` for a map whose ``up`` axis is given.

    ``up`` is ``"y"`` (OpenEXR orientation, default), ``"z"`` (identity) or ``"x"``; see the
    module docstring for the full table. Raises :class:`ParameterError` for anything else.

    >>> local_to_world("y") @ np.array([0.0, 0.0, 1.0])   # local up -> world +y
    array([0., 1., 0.])
    """
    try:
        return _LOCAL_TO_WORLD[up].copy()
    except (KeyError, TypeError):
        raise ParameterError(f"up must be one of {', '.join(UPS)}; got {up!r}") from None


def _local_dirs(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), np.cos(theta)),
                    axis=-1)


def pixel_directions(height: int, width: int | None = None, *, up: str = "y") -> np.ndarray:
    r"""Unit world direction of every pixel centre, shape ``(H, W, 3)``, float64.

    ``d = M_up (\sin\theta_i\cos\phi_j, \sin\theta_i\sin\phi_j, \cos\theta_i)``; for
    ``up="y"`` this is OpenEXR's ``(sinθ sinφ, cosθ, −sinθ cosφ)``.

    >>> d = pixel_directions(8, up="z")
    >>> d.shape, bool(np.allclose(np.linalg.norm(d, axis=-1), 1))
    ((8, 16, 3), True)
    """
    theta, phi = pixel_angles(height, width)
    m = local_to_world(up)
    local = _local_dirs(theta[:, None], phi[None, :])
    return rows_times(local, m.T)


def row_solid_angles(height: int, width: int | None = None) -> np.ndarray:
    r"""Solid angle of ONE pixel of each row, shape ``(H,)`` (the row's total is ``W`` times it).

    .. math::  \Omega_i = \Delta\phi\,(\cos\theta_{top} - \cos\theta_{bottom})
               = 2\,\Delta\phi\,\sin(\Delta\theta/2)\,\sin\theta_i,
       \qquad \Delta\phi = 2\pi/W,\ \Delta\theta = \pi/H,

    the second (product) form avoids the cancellation of the difference of cosines.
    ``W * sum(Ω_i) = 4π`` to rounding.

    >>> om = row_solid_angles(3, 6)
    >>> bool(abs(6 * om.sum() - 4 * np.pi) < 1e-13)
    True
    """
    h, w = _size(height, width)
    theta, _ = pixel_angles(h, 1)
    dphi = 2.0 * np.pi / w
    return 2.0 * dphi * np.sin(0.5 * np.pi / h) * np.sin(theta)


def pixel_solid_angles(height: int, width: int | None = None) -> np.ndarray:
    """Solid angle of every pixel, shape ``(H, W)``; sums to ``4π`` (see :func:`row_solid_angles`).

    >>> om = pixel_solid_angles(16)
    >>> om.shape, bool(abs(om.sum() - 4 * np.pi) < 1e-12)
    ((16, 32), True)
    """
    h, w = _size(height, width)
    return np.repeat(row_solid_angles(h, w)[:, None], w, axis=1)


def rows_dot(d: np.ndarray, v) -> np.ndarray:
    """``d @ v`` for directions d (..., 3) and one vector v (3,), as three multiply-adds: a
    BLAS call with inner size 3 is memory bound anyway, and its thread pool can make it 5–10×
    slower on a loaded machine."""
    return d[..., 0] * v[0] + d[..., 1] * v[1] + d[..., 2] * v[2]


def rows_times(d: np.ndarray, m) -> np.ndarray:
    """``d @ m`` for directions d (..., 3) and a 3×3 matrix m, without BLAS (as :func:`rows_dot`).

    >>> d = np.array([[1.0, 2.0, 3.0]]); m = np.arange(9.0).reshape(3, 3)
    >>> bool(np.array_equal(rows_times(d, m), d @ m))
    True
    """
    return np.einsum("...j,jk->...k", d, np.asarray(m, dtype=np.float64))


def _as_dirs(dirs) -> np.ndarray:
    d = np.asarray(dirs, dtype=np.float64)
    if d.ndim == 0 or d.shape[-1] != 3:
        raise ParameterError(f"directions must have shape (..., 3); got {d.shape}")
    return d


def _dirs_to_rowcol(d: np.ndarray, h: int, w: int, m: np.ndarray):
    """(row, col) of world directions ``d`` (..., 3) (no validation)."""
    # local = M^T world; as row vectors: local = world @ M
    x = rows_dot(d, m[:, 0])
    y = rows_dot(d, m[:, 1])
    z = rows_dot(d, m[:, 2])
    theta = np.arctan2(np.hypot(x, y), z)          # accurate near the poles, any length
    phi = np.arctan2(y, x)                          # (−π, π]
    row = theta * (h / np.pi) - 0.5
    u = phi * (w / (2.0 * np.pi))
    u = np.where(u < 0.0, u + w, u)
    u = np.where(u >= w, u - w, u)                  # rounding can give exactly w
    return row, u - 0.5


def direction_to_pixel(dirs, height: int, width: int | None = None, *,
                       up: str = "y") -> tuple[np.ndarray, np.ndarray]:
    r"""Continuous pixel coordinates ``(row, col)`` of world directions (pixel centres are integers).

    With ``(θ, φ)`` the local spherical angles of ``M_up^T d`` (``d`` need not be unit length):

    .. math::  row = \theta H/\pi - \tfrac12 \in [-\tfrac12, H-\tfrac12],\qquad
               col = \phi W/(2\pi) - \tfrac12 \in [-\tfrac12, W-\tfrac12).

    ``dirs`` has shape ``(..., 3)``; the outputs have shape ``(...)``. The zero vector maps to
    the up pole (θ = 0, φ = 0). Non-finite directions raise :class:`ParameterError`.

    >>> r, c = direction_to_pixel(pixel_directions(4)[2, 5], 4)
    >>> round(float(r), 9), round(float(c), 9)
    (2.0, 5.0)
    """
    h, w = _size(height, width)
    d = _as_dirs(dirs)
    if not np.all(np.isfinite(d)):
        raise ParameterError("directions contain NaN or Inf")
    return _dirs_to_rowcol(d, h, w, local_to_world(up))


def pixel_to_direction(row, col, height: int, width: int | None = None, *,
                       up: str = "y") -> np.ndarray:
    r"""Unit world direction at continuous pixel coordinates (inverse of :func:`direction_to_pixel`).

    .. math::  \theta = \pi(row + \tfrac12)/H,\quad \phi = 2\pi(col + \tfrac12)/W,\quad
               d = M_{up}(\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta).

    ``row`` and ``col`` broadcast together and may be non-integer; a row beyond a pole
    (``row < −½``) continues over it along the great circle (the same point as row
    ``−1 − row`` at azimuth ``φ + π``). Returns shape ``broadcast(row, col).shape + (3,)``.

    >>> np.round(pixel_to_direction(-0.5, 0.0, 4, up="y"), 12) + 0.0   # the up pole
    array([0., 1., 0.])
    """
    h, w = _size(height, width)
    theta = np.pi * (np.asarray(row, dtype=np.float64) + 0.5) / h
    phi = 2.0 * np.pi * (np.asarray(col, dtype=np.float64) + 0.5) / w
    return rows_times(_local_dirs(theta, phi), local_to_world(up).T)


def _gather_row(flat: np.ndarray, rows: np.ndarray, cols: np.ndarray, h: int, w: int):
    """Linear interpolation in longitude along one (possibly virtual) row per direction.

    ``rows`` is in ``[-1, H]``: the virtual rows −1 and H are rows 0 and H−1 seen across the
    pole, i.e. at azimuth φ + π (column + W/2).
    """
    virtual_top = rows < 0
    virtual_bot = rows > h - 1
    virtual = virtual_top | virtual_bot
    r = np.where(virtual_top, 0, np.where(virtual_bot, h - 1, rows))
    c = np.where(virtual, cols + 0.5 * w, cols) if virtual.any() else cols
    c0, fc = _floor_and_fraction(c)
    c0 = c0.astype(np.int64) % w
    c1 = c0 + 1
    c1[c1 == w] = 0
    base = r * w
    v0 = np.take(flat, base + c0, axis=0).astype(np.float64, copy=False)
    v1 = np.take(flat, base + c1, axis=0).astype(np.float64, copy=False)
    return v0 + fc[:, None] * (v1 - v0)


def bilinear_lookup(image, dirs, *, up: str = "y") -> np.ndarray:
    r"""Evaluate a lat-long map at arbitrary world directions by bilinear interpolation.

    The map is treated as the function whose values at the pixel centres
    ``(row, col) = (i, j)`` are the pixels, interpolated bilinearly in the continuous pixel
    coordinates of :func:`direction_to_pixel`:

    .. math::  f = (1-a)(1-b) I_{r_0,c_0} + (1-a) b\, I_{r_0,c_0+1} + a(1-b) I_{r_0+1,c_0}
               + a b\, I_{r_0+1,c_0+1},

    ``r_0 = ⌊row⌋, a = row − r_0`` and likewise for columns, with columns wrapping around in
    longitude (column ``W`` is column 0). Near the poles (``row < 0`` or ``row > H−1``) the
    interpolation goes across the pole: the virtual row −1 is row 0 at azimuth ``φ + π``
    (column + W/2) and the virtual row ``H`` is row ``H−1`` at ``φ + π``. The interpolant is
    therefore continuous across the seam and along every great circle through a pole; it is
    exact at pixel centres (coordinates within 1e-9 px of an integer are snapped) and its
    error on a smooth function is O(h²), h = π/H. (At the pole point itself the value,
    ``(I_0(φ) + I_0(φ+π))/2``, depends on the meridian by O(h²); it is single-valued as a
    function of direction since the pole direction has φ = 0.)

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
    dirs : (..., 3) array of world directions (any nonzero length)
    up : the map's up axis (see :func:`local_to_world`)

    Returns
    -------
    float64 array of shape ``dirs.shape[:-1] + (C,)`` (``dirs.shape[:-1]`` for a 2-D image).
    One compiled pass per direction (:mod:`envfit.maps._lookup`), parallel over directions;
    the tests hold the same arithmetic in numpy (``tests/oracles/numpy_kernels.py``).

    >>> img = np.arange(8.0).reshape(2, 4)
    >>> bilinear_lookup(img, pixel_directions(2)).tolist() == img.tolist()
    True
    """
    img = np.asarray(image)
    if img.ndim not in (2, 3) or img.shape[0] < 1 or img.shape[1] < 1:
        raise ParameterError(f"image must have shape (H, W) or (H, W, C); got {img.shape}")
    if not np.issubdtype(img.dtype, np.floating):
        img = img.astype(np.float64)
    h, w = img.shape[:2]
    flat = img.reshape(h * w, -1)
    nch = flat.shape[1]
    d = _as_dirs(dirs)
    lead = d.shape[:-1]
    d = d.reshape(-1, 3)
    n = d.shape[0]
    if not np.all(np.isfinite(d)):
        raise ParameterError("directions contain NaN or Inf")
    out = lookup_rows(flat, d, local_to_world(up), h, w, _SNAP)
    if img.ndim == 2:
        return out.reshape(lead)
    return out.reshape(lead + (nch,))

r"""A self-check map: six small markers at the world axes ±x, ±y, ±z, each its own colour.

Given the world direction of every pixel (for the pixel grid of whichever renderer the map
is meant for), :func:`marker_map` renders

.. math::  f(d) = \sum_k a_k\, c_k\, \cos^2\!\Big(\frac{\pi\,\delta_k(d)}{2\rho}\Big)
           \,[\delta_k(d) < \rho], \qquad \delta_k(d) = \angle(d, e_k),

a smooth bump of angular radius ρ about each axis ``e_k`` with colour ``c_k`` and amplitude
``a_k`` (:data:`MARKERS`): the channel patterns are all different (+x red, −x cyan, +y green,
−y magenta, +z blue, −z yellow), and +x is ten times brighter than the others, so the map's
brightest direction is +x. Background 0. A renderer that reads the map in the convention it
was written for shows each marker at its axis; a wrong convention moves or mirrors them.

Pure numpy: the caller supplies the directions (``data_gen`` does not know pixel grids).

Example
-------
>>> import numpy as np
>>> f = marker_map(np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.6, 0.8]]), 0.1)
>>> f.tolist()
[[10.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
"""
from __future__ import annotations

import numpy as np

from envfit.data_gen._errors import SyntheticMapError

__all__ = ["MARKERS", "marker_map", "marker_for_colour"]

#: (label, world axis, colour pattern, amplitude) of each marker
MARKERS = (
    ("+x", (1.0, 0.0, 0.0), (1.0, 0.0, 0.0), 10.0),
    ("-x", (-1.0, 0.0, 0.0), (0.0, 1.0, 1.0), 1.0),
    ("+y", (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), 1.0),
    ("-y", (0.0, -1.0, 0.0), (1.0, 0.0, 1.0), 1.0),
    ("+z", (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), 1.0),
    ("-z", (0.0, 0.0, -1.0), (1.0, 1.0, 0.0), 1.0),
)


def marker_map(dirs, radius: float) -> np.ndarray:
    r"""The marker radiance at directions ``dirs`` (..., 3) (any nonzero length), (..., 3).

    ``radius`` ρ is the angular radius of each bump in radians, in ``(0, π/4]`` (so the
    bumps never overlap). The angle to an axis is ``atan2(|d × e|, d · e)``, accurate
    near the axis.

    >>> marker_map([0.0, 0.0, 1.0], 0.2).tolist()
    [0.0, 0.0, 1.0]
    """
    d = np.asarray(dirs, dtype=np.float64)
    if d.ndim == 0 or d.shape[-1] != 3 or not np.all(np.isfinite(d)):
        raise SyntheticMapError(f"directions must be finite with shape (..., 3); got {d.shape}")
    try:
        rho = float(radius)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"marker radius must be a number, got {radius!r}") from None
    if not 0.0 < rho <= np.pi / 4:
        raise SyntheticMapError(f"marker radius must be in (0, pi/4] radians, got {radius!r}")
    out = np.zeros(d.shape, dtype=np.float64)
    for _, axis, colour, amplitude in MARKERS:
        e = np.asarray(axis)
        delta = np.arctan2(np.linalg.norm(np.cross(d, e), axis=-1), d @ e)
        bump = np.where(delta < rho, np.cos(0.5 * np.pi * np.minimum(delta, rho) / rho) ** 2,
                        0.0)
        out += amplitude * bump[..., None] * np.asarray(colour)
    return out


def marker_for_colour(value, tol: float = 1e-6):
    """The label and axis of the marker whose colour pattern ``value`` (3,) shows (the
    channels above ``tol`` times its largest channel), or None for background / no match.

    >>> marker_for_colour([0.0, 0.3, 0.3])
    ('-x', (-1.0, 0.0, 0.0))
    """
    v = np.asarray(value, dtype=np.float64)
    top = float(v.max())
    if not top > 0:
        return None
    pattern = tuple(float(x) for x in (v > tol * top))
    for label, axis, colour, _ in MARKERS:
        if pattern == colour:
            return label, axis
    return None

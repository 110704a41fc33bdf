r"""Cycles' pixel filter as its source samples it (blender/cycles @ v5.0.0; unchanged on main
@ 97dbe6f57): the film position of a sample is *importance-sampled* from the filter, each
sample counting once in its own pixel (no splatting).

**The table** (``src/scene/film.cpp``: ``filter_func_box``, ``filter_func_gaussian``,
``filter_func_blackman_harris``, ``filter_table``; ``src/util/math_cdf.h``,
``math_cdf.cpp``: ``util_cdf_evaluate``, ``util_cdf_invert``). For Blender's *Pixel Filter*
of width w (``scene.cycles.pixel_filter_type``, ``filter_width``: Blackman–Harris, 1.5 px in
the factory startup file and in a new scene, checked with bpy 5.0.1) the filter function is
evaluated on half its support — Blackman–Harris on [0, w] (its width doubled), the Gaussian
on [0, 1.5 w], the box on [0, w/2] — at 1023 points, its cumulative sum normalised, and
inverted *symmetrically* into ``FILTER_TABLE_SIZE`` = 1024 entries: entry 511 ± i is
½(1 ± y_i), y_i the inverse at i/511 (the source's ``upper_bound`` index with the next
segment's slope), in pixels from the pixel's corner. Entry 1023 is never written and stays 0.

**The lookup** (``src/kernel/camera/camera.h``: ``camera_sample``;
``src/kernel/util/lookup_table.h``: ``lookup_table_read``): the film's 2-D request (u, v)
moves the raster position by table(u), table(v), each read at u·1023 with linear
interpolation — so for u above 1022/1023 the offset runs from the table's last written entry
back to 0 (a 1/1023 share of the samples; transcribed as is).

:func:`filter_table` computes the table in float32 as the source does; :data:`BLACKMAN_HARRIS`
is Blender's default as a :class:`~envfit.renderers.FilmWarp` (the offset from the
pixel's centre), which the renderer model's pixel footprint samples.

Example
-------
>>> t = filter_table("blackman_harris", 1.5)
>>> t.shape, float(t[511]), round(float(t[0]), 3), round(float(t[1022]), 3)
((1024,), 0.5, -1.0, 2.0)
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.renderers._film import FilmWarp

__all__ = ["FILTER_TABLE_SIZE", "FILTERS", "filter_table", "film_warp", "BLACKMAN_HARRIS"]

#: ``FILTER_TABLE_SIZE`` (``src/kernel/types.h``)
FILTER_TABLE_SIZE = 1024
_F = np.float32


def _box(v, width):
    return np.ones_like(v)


def _gaussian(v, width):
    v = v * _F(6.0 / width)
    return np.exp(_F(-2.0) * v * v)


def _blackman_harris(v, width):
    v = _F(2.0 * np.pi) * (v / _F(width) + _F(0.5))
    return (_F(0.35875) - _F(0.48829) * np.cos(v) + _F(0.14128) * np.cos(_F(2.0) * v)
            - _F(0.01168) * np.cos(_F(3.0) * v))


#: Blender's filter types → (the function, the factor ``filter_table`` scales the width by)
FILTERS = {"box": (_box, 1.0), "gaussian": (_gaussian, 3.0),
           "blackman_harris": (_blackman_harris, 2.0)}


def filter_table(kind: str, width: float) -> np.ndarray:
    """``filter_table(type, width)``: the 1024 film offsets (pixels from the pixel's corner,
    float32) the kernel interpolates (module docstring)."""
    if kind not in FILTERS:
        raise ParameterError(f"Cycles' pixel filter is one of {', '.join(FILTERS)}, got {kind!r}")
    if not np.isfinite(width) or width <= 0:
        raise ParameterError(f"the filter width must be > 0 pixels, got {width!r}")
    func, factor = FILTERS[kind]
    w = _F(width * factor)
    res = FILTER_TABLE_SIZE
    to = w * _F(0.5)
    # util_cdf_evaluate(res - 1, 0, to): cdf[0] = 0, cdf[i + 1] = cdf[i] + |f(x_i)|
    x = to * np.arange(res - 1, dtype=_F) / _F(res - 2)
    cdf = np.concatenate([[_F(0.0)], np.cumsum(np.abs(func(x, w)), dtype=_F)]).astype(_F)
    cdf = (cdf * (_F(1.0) / cdf[-1])).astype(_F)
    cdf[-1] = _F(1.0)
    # util_cdf_invert(res, 0, to, cdf, make_symmetric=true)
    half = (res - 1) // 2
    xs = np.arange(half + 1, dtype=_F) / _F(half)
    index = np.searchsorted(cdf, xs, side="right")                 # upper_bound
    inner = index < len(cdf) - 1
    i1 = np.minimum(index, len(cdf) - 2)
    with np.errstate(divide="ignore", invalid="ignore"):   # the last entry's t is 0
        t = np.where(inner, (xs - cdf[i1]) / (cdf[i1 + 1] - cdf[i1]), _F(0.0)).astype(_F)
    index = np.where(inner, index, len(cdf) - 1)
    y = ((index + t) / _F(res - 1)) * (_F(2.0) * to)
    table = np.zeros(res, dtype=_F)
    table[half + np.arange(half + 1)] = _F(0.5) * (_F(1.0) + y)
    table[half - np.arange(half + 1)] = _F(0.5) * (_F(1.0) - y)
    return table


def film_warp(kind: str = "blackman_harris", width: float = 1.5) -> FilmWarp:
    """Cycles' pixel filter ``kind`` of ``width`` pixels as the film warp the model samples:
    the offset from the pixel's centre of ``lookup_table_read`` at u (module docstring)."""
    return FilmWarp(f"{kind} {width:g} px (importance-sampled)",
                    tuple(float(v) - 0.5 for v in filter_table(kind, width)))


#: Blender's default pixel filter, Blackman–Harris 1.5 px
BLACKMAN_HARRIS = film_warp("blackman_harris", 1.5)

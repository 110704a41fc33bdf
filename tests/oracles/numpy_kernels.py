"""Numpy references of envfit's compiled kernels (the same arithmetic as array operations):
the lat-long bilinear lookup (:mod:`envfit.maps._lookup`) and the map sampler's warp and
pixel search (:mod:`envfit.sampling._sample_kernel`). tests/test_compiled_kernels.py checks
the kernels against them."""
from __future__ import annotations

import numpy as np

from envfit.maps import _latlong as latlong
from envfit.sampling._map_sampler import MapSampler

__all__ = ["bilinear_lookup_numpy", "sample_numpy", "pixel_of_numpy", "bsdf_lookup_numpy",
           "hemisphere_directions"]


def bilinear_lookup_numpy(flat: np.ndarray, d: np.ndarray, m: np.ndarray, h: int,
                          w: int) -> np.ndarray:
    """:func:`envfit.maps._latlong.bilinear_lookup` of the (H·W, C) table ``flat`` at finite
    directions d (N, 3) in numpy blocks of ``LOOKUP_BLOCK``: the reference the compiled
    kernel is tested against."""
    out = np.empty((d.shape[0], flat.shape[1]), dtype=np.float64)
    for s in range(0, d.shape[0], latlong.LOOKUP_BLOCK):
        row, col = latlong._dirs_to_rowcol(d[s:s + latlong.LOOKUP_BLOCK], h, w, m)
        r0, a = latlong._floor_and_fraction(row)
        r0 = r0.astype(np.int64)            # in [-1, H-1]
        top = latlong._gather_row(flat, r0, col, h, w)
        if np.any(a > 0.0):
            bot = latlong._gather_row(flat, r0 + 1, col, h, w)
            top += a[:, None] * (bot - top)
        out[s:s + latlong.LOOKUP_BLOCK] = top
    return out


def sample_numpy(sampler: MapSampler, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`MapSampler.sample` of checked points U (N, 2) in numpy (the compiled kernel's
    reference in the tests): searches in the stacked conditional table."""
    h, w = sampler.height, sampler.width
    i = np.clip(np.searchsorted(sampler._row_cdf, U[:, 0], side="right") - 1, 0, h - 1)
    lo = sampler._row_cdf[i]
    t = np.clip((U[:, 0] - lo) / np.maximum(sampler._row_cdf[i + 1] - lo, 1e-300), 0.0, 1.0)
    k = np.searchsorted(sampler._col_flat, U[:, 1] + i, side="right") - 1
    j = np.clip(k - i * (w + 1), 0, w - 1)
    c0 = sampler._col_cdf[i, j]
    s = np.clip((U[:, 1] - c0) / np.maximum(sampler._col_cdf[i, j + 1] - c0, 1e-300), 0.0, 1.0)
    return sampler.pixel_point(i, j, t, s), sampler.pixel_pdf[i, j]


def pixel_of_numpy(sampler: MapSampler, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`MapSampler.pixel_of` in numpy (the compiled kernel's reference in the tests)."""
    loc = latlong.rows_times(d, sampler._m)                            # rows: local = world M
    theta = np.arctan2(np.hypot(loc[..., 0], loc[..., 1]), loc[..., 2])
    phi = np.mod(np.arctan2(loc[..., 1], loc[..., 0]), 2.0 * np.pi)
    i = np.clip(np.floor(theta * (sampler.height / np.pi)).astype(np.int64), 0, sampler.height - 1)
    j = np.floor(phi * (sampler.width / (2.0 * np.pi))).astype(np.int64) % sampler.width
    return i, j


def bsdf_lookup_numpy(technique, local: np.ndarray, frame: np.ndarray, fe: float, fb: float):
    """A preset technique's ``bsdf_lookup`` by its numpy methods: the radiance ``eval`` at
    ``local @ frame`` and the BSDF sample's ``power_heuristic(cos/π, pdf, fb, fe)`` (1 where
    ``fe`` is 0)."""
    from envfit.renderers._base import power_heuristic
    d = local @ frame
    w = (power_heuristic(local[:, 2] / np.pi, technique.pdf(d), fb, fe) if fe > 0
         else np.ones(len(local)))
    return technique.eval(d), w


def hemisphere_directions(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` unit directions of the upper hemisphere (local frame, +z up), the first six
    the pole, the horizon's axes and two 37° tilts (a lookup's seams and edges)."""
    loc = rng.normal(size=(count, 3))
    loc[:, 2] = np.abs(loc[:, 2])
    loc[:6] = [[0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0.6, 0, 0.8], [0, -0.6, 0.8]]
    return loc / np.linalg.norm(loc, axis=1)[:, None]

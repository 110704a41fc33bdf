"""A numpy reference of pbrt-v4's ``imgtool makeequiarea`` (the array form of
:func:`envfit.renderers.pbrt4._equal_area.make_equal_area`'s compiled loop): the same
arithmetic in vectorised blocks. tests/test_presets_pbrt4.py checks the kernel against it."""
from __future__ import annotations

import numpy as np

from envfit.renderers import equal_area_square_to_sphere, wrap_equal_area_square
from envfit.renderers._base import map_rgb
from envfit.renderers.pbrt4._equal_area import gaussian_filter_offsets

__all__ = ["make_equal_area_numpy"]


def _bilerp_latlong(img: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``Image::Bilerp`` with ``WrapMode2D(Repeat, Clamp)``: texel-centred, x periodic,
    y clamped; ``p`` (K, 2) in [0, 1]², returns (K, C)."""
    h, w = img.shape[:2]
    x, y = p[:, 0] * w - 0.5, p[:, 1] * h - 0.5
    xi, yi = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    dx, dy = (x - xi)[:, None], (y - yi)[:, None]
    x0, x1 = xi % w, (xi + 1) % w
    y0, y1 = np.clip(yi, 0, h - 1), np.clip(yi + 1, 0, h - 1)
    return ((1 - dx) * (1 - dy) * img[y0, x0] + dx * (1 - dy) * img[y0, x1]
            + (1 - dx) * dy * img[y1, x0] + dx * dy * img[y1, x1])


def make_equal_area_numpy(envmap, n: int, rows_per_block: int = 32) -> np.ndarray:
    """makeequiarea of ``envmap`` at N = ``n``, row blocks of numpy arrays."""
    img = map_rgb(envmap)
    off, wt = gaussian_filter_offsets()
    out = np.empty((n, n, img.shape[2]))
    cols = np.arange(n) + 0.5
    for v0 in range(0, n, rows_per_block):
        rows = np.arange(v0, min(n, v0 + rows_per_block)) + 0.5
        px = (cols[None, :, None] + off[None, None, :, 0]) / n          # (1, N, S)
        py = (rows[:, None, None] + off[None, None, :, 1]) / n          # (R, 1, S)
        px, py = np.broadcast_arrays(px, py)
        sq = wrap_equal_area_square(np.column_stack([px.ravel(), py.ravel()]))
        d = equal_area_square_to_sphere(sq)
        phi = np.arctan2(d[:, 1], d[:, 0])
        phi = np.where(phi < 0, phi + 2 * np.pi, phi)
        theta = np.arccos(np.clip(d[:, 2], -1.0, 1.0))
        vals = _bilerp_latlong(img, np.column_stack([phi / (2 * np.pi), theta / np.pi]))
        vals = vals.reshape(len(rows), n, len(wt), -1)
        out[v0:v0 + len(rows)] = np.einsum("rnsc,s->rnc", vals, wt) / wt.sum()
    return np.maximum(out, 0.0)

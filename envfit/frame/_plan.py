r"""Which pixels the frame model predicts: every pixel of a frame up to ``max_pixels``, else
one pixel drawn at random in each cell of a grid of about ``max_pixels`` cells (stratified
sampling), each standing for its cell.

With one pixel per cell, the image's mean MSE is estimated by
:math:`\hat m = \sum_c a_c m_c / \sum_c a_c` (:math:`a_c` the cell's pixels), unbiased; its
standard error is bounded by the simple-random-sampling form
:math:`\sqrt{\sum_c a_c^2 (m_c - \hat m)^2} / \sum_c a_c` (stratification only lowers the
true error), which the prediction reports. The noise image is then the cells' grid, one value
per cell.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PixelPlan", "plan_pixels", "film_pixels"]


@dataclass(frozen=True)
class PixelPlan:
    """The pixels predicted: ``targets`` (K, 2) (row, column) in the grid's row-major order,
    ``weights`` (K,) the pixels each stands for, ``grid`` (rows, columns) of the noise image,
    ``exact`` (every pixel predicted)."""

    targets: np.ndarray
    weights: np.ndarray
    grid: tuple
    exact: bool

    def mean(self, values: np.ndarray) -> np.ndarray:
        """The image mean of per-target ``values`` (K, …)."""
        w = self.weights / self.weights.sum()
        return np.tensordot(w, values, axes=1)

    def standard_error(self, values: np.ndarray) -> float:
        """The bound on the standard error of :meth:`mean` of ``values`` (K,) (0 when
        exact)."""
        if self.exact:
            return 0.0
        m = float(self.mean(values))
        return float(math.sqrt(np.sum((self.weights * (values - m)) ** 2)) / self.weights.sum())

    def image(self, values: np.ndarray) -> np.ndarray:
        """Per-target ``values`` (K, …) laid out on the grid (rows, columns, …)."""
        return values.reshape(tuple(self.grid) + values.shape[1:])


def plan_pixels(size, max_pixels: int, seed: int = 0) -> PixelPlan:
    """The :class:`PixelPlan` of a W × H frame (``size`` = (W, H)) with at most about
    ``max_pixels`` predicted."""
    w, h = int(size[0]), int(size[1])
    if w * h <= max_pixels:
        yy, xx = np.mgrid[0:h, 0:w]
        return PixelPlan(np.column_stack([yy.ravel(), xx.ravel()]), np.ones(w * h), (h, w),
                         True)
    gx = min(w, max(1, round(math.sqrt(max_pixels * w / h))))
    gy = min(h, max(1, max_pixels // gx))
    ye = np.linspace(0, h, gy + 1).round().astype(np.int64)
    xe = np.linspace(0, w, gx + 1).round().astype(np.int64)
    rng = np.random.default_rng(seed)
    ys = rng.integers(ye[:-1], ye[1:])
    xs = rng.integers(xe[:-1], xe[1:], size=(gy, gx))
    yy = np.broadcast_to(ys[:, None], (gy, gx))
    area = np.diff(ye)[:, None] * np.diff(xe)[None, :]
    return PixelPlan(np.column_stack([yy.ravel(), xs.ravel()]), area.ravel().astype(float),
                     (gy, gx), False)


def film_pixels(targets: np.ndarray, reach: int, size) -> np.ndarray:
    """The pixels (F, 2) whose film points the targets' filter reaches (``reach`` pixels
    around each), inside the W × H frame."""
    w, h = int(size[0]), int(size[1])
    d = np.arange(-reach, reach + 1)
    dy, dx = np.meshgrid(d, d, indexing="ij")
    p = (targets[:, None, :] + np.stack([dy.ravel(), dx.ravel()], axis=1)[None]).reshape(-1, 2)
    p = p[(p[:, 0] >= 0) & (p[:, 0] < h) & (p[:, 1] >= 0) & (p[:, 1] < w)]
    return np.unique(p, axis=0)

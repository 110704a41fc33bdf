"""The frame model's picture: the converged image it implies beside its predicted noise."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure

__all__ = ["plot_frame"]


def _display(img: np.ndarray) -> np.ndarray:
    """``img`` (H, W, 3) for a screen: scaled so that its 99th percentile is 1, Reinhard's
    x/(1 + x) on twice that, then the sRGB-like gamma 1/2.2."""
    top = float(np.percentile(img, 99)) or 1.0
    x = 2.0 * np.clip(img, 0.0, None) / top
    return np.clip(x / (1.0 + x), 0.0, 1.0) ** (1 / 2.2)


def plot_frame(preview: np.ndarray, noise: np.ndarray, spp: int, path: str | Path,
               title: str = "") -> Path:
    """Save a PNG of ``preview`` (H, W, 3, the converged image) beside ``noise`` (H, W, the
    predicted per-pixel RMSE at ``spp``) as a heat map with its colour bar."""
    import matplotlib.pyplot as plt
    h, w = noise.shape
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 10.0 * h / (2 * w) + 1.0))
    axes[0].imshow(_display(preview), interpolation="nearest")
    axes[0].set_title("converged image (predicted)")
    im = axes[1].imshow(noise, cmap="inferno", interpolation="nearest")
    axes[1].set_title(f"predicted RMSE per pixel at {spp} spp")
    fig.colorbar(im, ax=axes[1], fraction=0.046, pad=0.04)
    for a in axes:
        a.set_xticks([])
        a.set_yticks([])
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)

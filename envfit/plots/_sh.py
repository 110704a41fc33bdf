"""The figure of ``envfit sh --out DIR`` (``sh.png``): what the exported SH coefficients look
like, and the ringing table.

:func:`plot_sh` takes plain data (no envfit computation here, layering): ``images`` with
``map`` and ``signal`` (H×W×3 display RGB in [0, 1], lat-long, top row = the up pole) and
``negative`` (H×W bool, where any channel of the signal is < 0), and ``data`` with ``title``,
``signal`` ("irradiance"/"radiance"), ``target``, ``rows`` (each ``L``, ``window``,
``predicted_relative_rmse``, ``negative_fraction`` and, after the check,
``measured_relative_rmse``, ``dense_negative_fraction``), ``choice`` (a row or None) and
``export`` (``L``, ``window``, ``predicted``, ``negative``).

Four panels: (a) the map, (b) the exported signal with its negative directions in magenta,
(c) predicted relative RMSE against L per window (measured: open markers; the target:
a horizontal line; the choice: a star), (d) the negative fraction against L per window
(dense check: open markers). Integer ticks on L.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure

__all__ = ["plot_sh", "WINDOW_STYLES"]

#: window → (colour, marker, line style)
WINDOW_STYLES = {"none": ("C0", "o", "-"), "hanning": ("C1", "s", "--"),
                 "lanczos": ("C2", "^", "-."), "sloan": ("C3", "D", ":")}


def _image(ax, rgb, title: str, mask=None) -> None:
    img = np.clip(np.asarray(rgb, dtype=float), 0.0, 1.0).copy()
    if mask is not None and np.any(mask):
        img[np.asarray(mask)] = (1.0, 0.0, 1.0)
    ax.imshow(img, aspect="equal", interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def _curves(ax, rows, key: str, check_key: str, log: bool) -> None:
    for name, (colour, marker, style) in WINDOW_STYLES.items():
        rs = [r for r in rows if r["window"] == name]
        if not rs:
            continue
        L = [r["L"] for r in rs]
        v = np.array([r[key] for r in rs], dtype=float)
        ax.plot(L, v, color=colour, marker=marker, linestyle=style, ms=5, label=name)
        c = [r.get(check_key) for r in rs]
        if all(x is not None for x in c):
            ax.plot(L, c, color=colour, marker=marker, mfc="none", ms=10, linestyle="none")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("L (SH degree)")


def plot_sh(images: dict, data: dict, path: str | Path) -> Path:
    """Write ``sh.png`` (module docstring) to ``path`` atomically; returns the path."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5))
    ex = data["export"]
    _image(axes[0, 0], images["map"], "(a) the map (display tone mapping)")
    neg = f"negative on {ex['negative']:.2%} (magenta)" if ex["negative"] > 0 \
        else "nowhere negative"
    _image(axes[0, 1], images["signal"],
           f"(b) {data['signal']} from the SH (L = {ex['L']}, {ex['window']}): {neg}",
           images.get("negative"))
    rows = data["rows"]
    ax = axes[1, 0]
    _curves(ax, rows, "predicted_relative_rmse", "measured_relative_rmse", log=True)
    ax.axhline(data["target"], color="k", lw=1.0, alpha=0.7)
    ax.text(min(r["L"] for r in rows), data["target"] * 1.1, f"target {data['target']:.3g}",
            fontsize=8)
    ch = data.get("choice")
    if ch:
        ax.plot([ch["L"]], [ch["predicted_relative_rmse"]], marker="*", color="k", ms=16,
                linestyle="none", label="choice")
    ax.set_ylabel(f"{data['signal']} RMSE / mean (open: measured)")
    ax.set_title("(c) predicted error per window", fontsize=9)
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    _curves(ax, rows, "negative_fraction", "dense_negative_fraction", log=False)
    ax.set_ylabel("share of directions < 0 (open: dense check)")
    ax.set_title(f"(d) where the truncated {data['signal']} goes negative", fontsize=9)
    ax.legend(fontsize=8)
    for a in axes[1]:
        a.xaxis.set_major_locator(MaxNLocator(integer=True))
        a.grid(alpha=0.3)
    fig.suptitle(data["title"], fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)

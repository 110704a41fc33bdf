r"""The preview figure of a map (``envfit info --out``, ``envfit synth --out``): the tone-mapped
lat-long image in the file's layout, its axes in the layout's angles, the bright sources
marked and listed.

:func:`plot_map_preview` takes a preview object with the attributes of
:class:`envfit.maps._preview.MapPreview` (plain data: the image, the affine maps
θ(row) and φ(col) in degrees, the sources with their ``position`` ``{col, row}``,
``radius_deg``, ``label()``) — plots import nothing above :mod:`envfit.base`. Pixel
``(row, col)`` is drawn centred at ``(col, row)`` (``extent`` = the pixel edges), so a
continuous pixel coordinate from a convention's ``direction_to_pixel`` lands where that
renderer looks the direction up. The θ ticks are at multiples of 30°, the azimuth ticks at
multiples of 45° of the unwrapped azimuth and labelled wrapped into the azimuth's range.
Written atomically (:func:`envfit.plots._save.save_figure`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure

__all__ = ["plot_map_preview", "angle_ticks"]


def angle_ticks(slope: float, intercept: float, n: int, step: float,
                low: float | None = None) -> tuple[np.ndarray, list[str]]:
    r"""Tick positions (pixel coordinates in [−½, n − ½]) where the angle
    ``slope·x + intercept`` is a multiple of ``step`` degrees, and their labels (wrapped into
    ``[low, low + 360)`` when ``low`` is given).

    >>> pos, lab = angle_ticks(-1.0, 180.0, 360, 90.0, low=-180.0)
    >>> pos.tolist(), lab
    ([0.0, 90.0, 180.0, 270.0], ['-180', '90', '0', '-90'])
    """
    ends = np.array([slope * -0.5 + intercept, slope * (n - 0.5) + intercept])
    k = np.arange(np.ceil(ends.min() / step - 1e-9), np.floor(ends.max() / step + 1e-9) + 1)
    angles = k * step
    pos = (angles - intercept) / slope
    order = np.argsort(pos)
    pos, angles = pos[order], angles[order]
    if low is not None:
        angles = np.mod(angles - low, 360.0) + low
    return pos + 0.0, [f"{a:g}" for a in np.round(angles, 6) + 0.0]


def _markers(ax, p) -> list:
    """Numbered circles of the sources' angular size, and the brightest pixel; legend handles."""
    from matplotlib.lines import Line2D
    handles = []
    px_per_deg = p.height / 180.0
    for s in p.sources:
        col, row = s.position["col"], s.position["row"]
        r = max(4.0, p.height / 40.0, s.radius_deg * px_per_deg * 1.6)   # pixels, visible
        ax.add_patch(_circle((col, row), r))
        dy = -r if row - r > 0 else r                              # below the ring at the top
        ax.annotate(str(s.rank), (col + r, row + dy), xytext=(2, 2), textcoords="offset points",
                    color="cyan", fontsize=9, weight="bold", annotation_clip=False)
        handles.append(Line2D([], [], marker="o", mfc="none", mec="cyan", ls="none",
                              label=s.label()))
    ax.plot([p.brightest[0]], [p.brightest[1]], marker="x", color="magenta", ms=7, mew=1.5,
            ls="none")
    handles.append(Line2D([], [], marker="x", color="magenta", ls="none",
                          label=f"brightest pixel (col {p.brightest[0]:.1f}, row {p.brightest[1]:.1f})"))
    return handles


def _circle(centre, radius_px):
    from matplotlib.patches import Circle
    return Circle(centre, radius_px, fill=False, ec="cyan", lw=1.4)


def plot_map_preview(p, path: str | Path) -> Path:
    """Write the preview ``p`` (module docstring) to ``path`` (PNG, atomic); returns the path."""
    import matplotlib.pyplot as plt
    w, h = p.width, p.height
    fig, ax = plt.subplots(figsize=(10.0, 5.0 + 0.22 * (len(p.sources) + 1)))
    ax.imshow(np.clip(p.image, 0.0, 1.0), origin="upper", interpolation="nearest",
              extent=(-0.5, w - 0.5, h - 0.5, -0.5))
    pos, lab = angle_ticks(*p.theta_of_row, h, 30.0)
    ax.set_yticks(pos, lab)
    pos, lab = angle_ticks(*p.phi_of_col, w, 45.0, low=p.phi_low)
    ax.set_xticks(pos, lab)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_ylabel(f"theta from +{p.up.upper()} (deg)")
    ax.set_xlabel(f"azimuth (deg): {p.azimuth_label}")
    handles = _markers(ax, p)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=8,
              frameon=False, title=(f"bright sources holding >= {100 * p.share:g} % of the power: "
                                    f"{len(p.sources)}"), title_fontsize=8)
    layout = p.layout if p.layout == p.renderer else f"{p.layout} ({p.renderer})"
    ax.set_title(f"{p.name or 'map'}: {w}×{h} lat-long, {layout} layout, +{p.up.upper()} up\n"
                 f"display tone mapping: exposure k = {p.exposure:.4g} (mean luminance -> 0.18), "
                 "sRGB", fontsize=9)
    return save_figure(fig, path)

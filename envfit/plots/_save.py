"""Atomic PNG saving for matplotlib figures."""
from __future__ import annotations

import io
from pathlib import Path

from envfit.base import atomic_write_bytes


def save_figure(fig, path: str | Path, *, dpi: int = 120) -> Path:
    """Save ``fig`` as PNG atomically and close it."""
    import matplotlib.pyplot as plt
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())

"""The frame's images as EXR files, written atomically (OpenImageIO)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.base import replace_via_temporary

__all__ = ["write_exr"]


def _write(tmp: str, path: Path, pixels: np.ndarray) -> None:
    import OpenImageIO as oiio
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(tmp)
    if out is None:
        raise ParameterError(f"{path}: cannot write this format: {oiio.geterror()}")
    spec = oiio.ImageSpec(w, h, c, "float")
    spec.channelnames = ("R", "G", "B") if c == 3 else ("Y",)
    spec.attribute("compression", "zip")
    ok = out.open(tmp, spec) and out.write_image(np.ascontiguousarray(pixels, np.float32))
    ok = out.close() and ok
    if not ok:
        raise OSError(f"{path}: write failed: {out.geterror() or oiio.geterror()}")


def write_exr(path, pixels) -> Path:
    """Write ``pixels`` (H, W) or (H, W, 3) as a float EXR at ``path``, atomically (the file
    is complete or absent); returns the path."""
    a = np.asarray(pixels, dtype=np.float32)
    a = a[..., None] if a.ndim == 2 else a
    p = Path(path)
    replace_via_temporary(p, lambda tmp: _write(str(tmp), p, a), suffix=p.suffix or ".exr")
    return p

r"""``predict_frame``: the predicted noise of a user's frame, read from the renderer's own
scene file, at each spp; the spp that meets a target; the noise image.

Steps: read the scene with the renderer (:mod:`envfit.renderers._frame`), each film point's
moments (:func:`._model.point_moments`), each pixel's MSE under the film's filter
(:func:`._model.pixel_mse`), then the image's RMSE and percentiles per spp.

The image RMSE is over all pixels and the three channels against the converged image:
:math:`\sqrt{\frac{1}{3HW}\sum_{p,c}\mathrm{MSE}_{p,c}(N)}`, and a pixel's RMSE is
:math:`\sqrt{\frac13\sum_c \mathrm{MSE}_{p,c}(N)}`; with the ``independent`` sampler both
fall exactly as :math:`N^{-1/2}`.
"""
from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.frame._model import MODELLED_SAMPLERS, pixel_mse, point_moments
from envfit.renderers import get_renderer

__all__ = ["FrameOptions", "FrameRow", "FramePrediction", "predict_frame", "READERS"]

#: scene file suffix → the renderer that reads it (its folder's ``_frame_scene.read_scene``)
READERS = {".xml": "mitsuba3"}
#: pixel percentiles reported per spp
PERCENTILES = (50, 90, 99)


@dataclass(frozen=True)
class FrameOptions:
    """What :func:`predict_frame` is asked.

    Attributes
    ----------
    spp : the sample counts to predict (default: the scene's own).
    target : an image RMSE to meet (absolute, the image's units), or
    target_relative : one relative to the converged image's mean value (default 0.01).
    percentile : meet the target at this percentile of the pixels' RMSE instead of the image
        RMSE (0 < q ≤ 100).
    side : film points per pixel side (S).
    level : the techniques' tables, 4^level points each.
    quiet : no progress bar.
    """

    spp: tuple = ()
    target: float | None = None
    target_relative: float | None = None
    percentile: float | None = None
    side: int = 2
    level: int = 4
    quiet: bool = True

    def __post_init__(self):
        for n in self.spp:
            if int(n) != n or n < 1:
                raise ParameterError(f"spp must be positive integers, got {n}")
        if self.target is not None and self.target_relative is not None:
            raise ParameterError("give target or target_relative, not both")
        for name in ("target", "target_relative"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a positive number, got {v}")
        if self.percentile is not None and not 0 < self.percentile <= 100:
            raise ParameterError(f"percentile must be in (0, 100], got {self.percentile}")
        if not 1 <= self.side <= 16:
            raise ParameterError(f"side must be 1..16, got {self.side}")
        if not 2 <= self.level <= 9:
            raise ParameterError(f"level must be 2..9, got {self.level}")


@dataclass(frozen=True)
class FrameRow:
    """One spp: the image RMSE, it relative to the image's mean, and pixel percentiles."""

    spp: int
    rmse: float
    relative: float
    percentiles: dict


@dataclass(frozen=True)
class FramePrediction:
    """What :func:`predict_frame` answers (see the module docstring for the definitions).

    ``preview`` is the converged image the model implies (H, W, 3); ``mse1`` the per-pixel
    MSE at one spp (H, W, 3); ``answer`` the smallest spp meeting the target (None without
    one); ``notes`` what the model assumed, as sentences."""

    scene: str
    renderer: str
    size: tuple
    sampler: str
    scene_spp: int
    integrator: str
    filter_name: str
    side: int
    level: int
    preview: np.ndarray = field(repr=False)
    mse1: np.ndarray = field(repr=False)
    rows: tuple
    target: float | None
    target_kind: str
    answer: int | None
    notes: tuple
    seconds: dict
    rays: int = 0

    @property
    def mean_value(self) -> float:
        """The converged image's mean over pixels and channels."""
        return float(self.preview.mean())

    def pixel_rmse(self, spp: int) -> np.ndarray:
        """Each pixel's predicted RMSE (H, W) at ``spp``."""
        return np.sqrt(self.mse1.mean(axis=2) / int(spp))

    def to_dict(self) -> dict:
        """The JSON form: ``predictions`` = [{"spp", "predicted_rmse", …}, …]."""
        return {"scene": self.scene, "renderer": self.renderer,
                "size": list(self.size), "sampler": self.sampler, "scene_spp": self.scene_spp,
                "integrator": self.integrator, "filter": self.filter_name,
                "film_points_per_side": self.side, "level": self.level,
                "mean_value": self.mean_value,
                "predictions": [{"spp": r.spp, "predicted_rmse": r.rmse,
                                 "relative_rmse": r.relative,
                                 "pixel_rmse_percentiles": {str(k): v for k, v in
                                                            r.percentiles.items()}}
                                for r in self.rows],
                "target": self.target, "target_kind": self.target_kind,
                "answer_spp": self.answer, "notes": list(self.notes),
                "seconds": self.seconds, "shadow_rays": self.rays}


def _reader(path: Path):
    name = READERS.get(path.suffix.lower())
    if name is None:
        raise ParameterError(f"{path}: a frame is read from a scene file "
                             f"({', '.join(READERS)}); this suffix is not one")
    rec = get_renderer(name)
    module = importlib.import_module(rec.harness.rsplit(".", 1)[0] + "._frame_scene")
    return module.read_scene


def _row(mse1: np.ndarray, n: int, mean: float) -> FrameRow:
    img = float(np.sqrt(mse1.mean() / n))
    pix = np.sqrt(mse1.mean(axis=2) / n)
    return FrameRow(int(n), img, img / mean if mean > 0 else math.inf,
                    {q: float(np.percentile(pix, q)) for q in PERCENTILES})


def _answer(mse1: np.ndarray, target: float, percentile) -> int:
    """The smallest N whose image RMSE (or the pixel percentile's) is ≤ target: exact, as
    the MSE is MSE₁/N."""
    m = float(mse1.mean()) if percentile is None else \
        float(np.percentile(np.sqrt(mse1.mean(axis=2)), percentile)) ** 2
    return max(1, math.ceil(m / (target * target) * (1 - 1e-12)))


def predict_frame(scene, options: FrameOptions | None = None, **kw) -> FramePrediction:
    """The predicted noise of the frame in the scene file ``scene`` (module docstring).

    Parameters
    ----------
    scene : path of the renderer's scene file (Mitsuba 3: ``.xml``).
    options : :class:`FrameOptions`, or its fields as keywords.

    Examples
    --------
    >>> p = predict_frame("scene.xml", spp=(16, 64))          # doctest: +SKIP
    >>> [(r.spp, round(r.rmse, 4)) for r in p.rows]            # doctest: +SKIP
    [(16, 0.0610), (64, 0.0305)]
    """
    opts = options or FrameOptions(**{k: (tuple(v) if k == "spp" else v) for k, v in kw.items()})
    path = Path(scene)
    read = _reader(path)
    t0 = time.perf_counter()
    fs = read(path, side=opts.side)
    if fs.sampler not in MODELLED_SAMPLERS:
        raise ParameterError(f"the scene's sampler is {fs.sampler}: the frame model predicts "
                             f"the {', '.join(MODELLED_SAMPLERS)} sampler so far")
    t1 = time.perf_counter()
    pm = point_moments(fs, opts.level, quiet=opts.quiet)
    preview, mse1 = pixel_mse(fs, pm)
    t2 = time.perf_counter()
    mean = float(preview.mean())
    spps = tuple(int(n) for n in opts.spp) or (fs.spp,)
    rows = tuple(_row(mse1, n, mean) for n in spps)
    if opts.target is not None:
        target, kind = float(opts.target), "absolute"
    else:
        rel = 0.01 if opts.target_relative is None else float(opts.target_relative)
        target, kind = rel * mean, f"relative {rel:g}"
    answer = _answer(mse1, target, opts.percentile) if target > 0 else None
    notes = list(fs.notes)
    notes.append(f"direct lighting from the map ({fs.integrator}); diffuse surfaces; "
                 f"{fs.side}×{fs.side} film points per pixel, "
                 f"{max(2, -(-8 // fs.side)) * fs.side} per side in the {pm.edges} pixels a "
                 f"silhouette crosses")
    return FramePrediction(
        str(path), fs.renderer, fs.size, fs.sampler, fs.spp, fs.integrator, fs.filter_name,
        fs.side, opts.level, preview, mse1, rows, target, kind, answer, tuple(notes),
        {"read": round(t1 - t0, 3), "model": round(t2 - t1, 3)}, pm.rays)

r"""The frame, not the sphere: the predicted noise of a user's scene before rendering it.

``predict_frame(SCENE)`` reads the renderer's own scene file with the renderer (camera, film
and filter, sampler, integrator, the environment map, shapes and materials), casts each film
point's shadow rays against the scene, and predicts every pixel's error under the renderer's
estimator: the image RMSE and pixel percentiles per spp, the spp that meets a target, and the
noise image.

Modules:

* :mod:`~envfit.frame._api` — :func:`predict_frame`, :class:`FrameOptions`,
  :class:`FramePrediction`: the steps and the result.
* :mod:`~envfit.frame._model` — each film point's mean and variance under the renderer's
  techniques with visibility, and each pixel's MSE under the film's filter.
* :mod:`~envfit.frame._nets` — each pixel's MSE under a sampler whose dimensions are one
  randomised net per pixel (Mitsuba's ``ldsampler``), simulated with its own points.
* :mod:`~envfit.frame._plan` — which pixels are predicted (all, or one per cell of a grid).
* :mod:`~envfit.frame._visibility` — shadow rays (Embree).

The scene is read by the renderer's folder (:mod:`envfit.renderers._frame`; the readers by
file suffix: :data:`READERS`); what each reads and refuses is in its folder.

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "predict_frame": "_api", "FrameOptions": "_api", "FramePrediction": "_api",
    "FrameRow": "_api", "READERS": "_api",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "write_exr": "_images",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

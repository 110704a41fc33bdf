r"""The renderer error prediction: the warped integrand's spectrum per technique, its tail
beyond the box, and the predictor of a renderer rule's RMSE.

Modules:

* :mod:`~envfit.predict.renderer._predictor` — Prediction of the renderer rules' RMSE
  (:class:`envfit.sampling.RendererRule`) from the map: the predictors ``random-variance``
  and ``warped-spectrum`` of :data:`envfit.predict.PREDICTORS`.
* :mod:`~envfit.predict.renderer._spectral_tail` — The error of a shifted point set from the
  warped integrand's power *above the box*, with the strips along the axes of frequency
  space resolved.
* :mod:`~envfit.predict.renderer._warped_spectrum` — The exact error of a Cranley–Patterson-
  shifted estimator from the spectrum of its *warped integrand*: the prediction of envfit
  for every renderer estimator (map importance sampling, BRDF sampling, MIS) driven by *any*
  point set, random or quasi-random.
* :mod:`~envfit.predict.renderer._preset_model` — a real renderer's noise on a white diffuse
  surface from its preset (its own estimator, its sampler's exact randomisation).
* :mod:`~envfit.predict.renderer._microfacet_model` — the same for a rough conductor (GGX,
  Beckmann), per frame (normal, view): view-dependent.
* :mod:`~envfit.predict.renderer._frames` — the frames it averages over: a render's pixels,
  or views in a band of polar angles.
* :mod:`~envfit.predict.renderer._footprint` — a rendered pixel's footprint: the normals it
  spans and the variance its film position adds.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {
    "renderer_model": "_predictor",
    "RENDERER_PREDICTORS": "_predictor", "RendererModel": "_predictor",
    "predict_random_variance": "_predictor", "predict_warped_spectrum": "_predictor",
    "renderer_predictor": "_predictor",
    "strip_tail": "_spectral_tail",
    "shifted_rmse": "_warped_spectrum", "WarpedSpectrum": "_warped_spectrum",
    "SpectrumInputs": "_warped_spectrum", "warped_integrand": "_warped_spectrum",
    "PresetModel": "_preset_model", "PresetModelOptions": "_preset_model",
    "PresetPrediction": "_preset_model",
    "MicrofacetModel": "_microfacet_model", "band_frames": "_frames",
    "pixel_frames": "_frames", "pixel_footprints": "_footprint",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

r"""envfit's own rules (the renderer rows of ``envfit advise`` and ``validate``), predicted
from the spectrum of each technique's *warped integrand*: its Fourier coefficients on a box,
the tail beyond it, the mean over uniform axes, and the predictors ``random-variance`` and
``warped-spectrum`` of :data:`envfit.predict.PREDICTORS`.

Modules:

* :mod:`~envfit.predict.warped._predictor` — Prediction of the renderer rules' RMSE
  (:class:`envfit.sampling.RendererRule`) from the map: the two predictors and the model
  (:class:`RendererModel`, :func:`renderer_model`).
* :mod:`~envfit.predict.warped._warped_spectrum` — The exact error of a Cranley–Patterson-
  shifted estimator from the spectrum of its *warped integrand*, for every estimator of
  envfit (map importance sampling, BRDF sampling, MIS) driven by *any* point set.
* :mod:`~envfit.predict.warped._techniques` — the estimators as sums of warped integrands;
  :mod:`~envfit.predict.warped._warped_integrand` — the integrand itself.
* :mod:`~envfit.predict.warped._box_spectra` — its coefficients on the box;
  :mod:`~envfit.predict.warped._spectral_tail` — its power above the box;
  :mod:`~envfit.predict.warped._prediction_sums` — the sums over frequency space.
* :mod:`~envfit.predict.warped._axis_mean`, :mod:`~envfit.predict.warped._axis_proposal` —
  the mean over uniform axes and its importance sample of axes;
  :mod:`~envfit.predict.warped._pixel_moments` — the integrands' variances by pixel
  quadrature; :mod:`~envfit.predict.warped._spectrum_inputs` — what one map's spectra share.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "renderer_model": "_predictor",
    "RENDERER_PREDICTORS": "_predictor", "RendererModel": "_predictor",
    "predict_random_variance": "_predictor", "predict_warped_spectrum": "_predictor",
    "renderer_predictor": "_predictor",
    "strip_tail": "_spectral_tail",
    "shifted_rmse": "_warped_spectrum", "WarpedSpectrum": "_warped_spectrum",
    "SpectrumInputs": "_warped_spectrum", "warped_integrand": "_warped_spectrum",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "SPECTRUM_FORMAT": "_warped_spectrum",
    "spectrum_nbytes": "_warped_spectrum",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

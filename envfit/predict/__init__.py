r"""Named predictors of a rule's shading error on a map: one module per predictor, each ``f(ctx:
PredictionContext, rule: Rule) -> Prediction``, registered in PREDICTORS and dispatched by
predict(); a rule is a :class:`QuadratureRule` (the paper's) or a :class:`RendererRule` (both
:class:`envfit.sampling.Rule`); the renderer rules' predictors (``random-variance``,
``warped-spectrum``) are in the sub-package :mod:`envfit.predict.warped`.

Modules:

* :mod:`~envfit.predict._bandlimited` — Prediction (b′), *band-limited*: the plain model made
  exact for what a lat-long map is.
* :mod:`~envfit.predict._context` — What a prediction is made from: a map
  (:class:`PredictionContext`), a rule (:class:`Rule`), and what it says
  (:class:`Prediction`).
* :mod:`~envfit.predict._plain` — Prediction (b), *plain*: :math:`\hat R = \hat\sigma\,E(\hat
  s)`.
* :mod:`~envfit.predict._registry` — The registry of predictors (as colour-science's method
  registries) and its dispatcher.
* :mod:`~envfit.predict._spectral` — Prediction (c), *spectral*: the map's own power per
  degree times the rule's error power — no model, no s, no σ: the exact mean over Haar-
  random rotations on this map.
* :mod:`~envfit.predict.warped` (sub-package) — envfit's own rules (its renderer rows): the
  warped integrand's spectrum per technique, its tail beyond the box, and the predictors of a
  renderer rule's RMSE.
* :mod:`~envfit.predict.renderer` (sub-package) — a real renderer's noise from its own
  estimator (its record in :mod:`envfit.renderers`) and its sampler's exact randomisation.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "predict_bandlimited": "_bandlimited",
    "Prediction": "_context", "PredictionContext": "_context", "reads": "_context",
    "Rule": "_context", "QuadratureRule": "_context", "RendererRule": "_context",
    "predict_plain": "_plain",
    "predict": "_registry", "Predictor": "_registry", "PREDICTORS": "_registry",
    "predictors_for": "_registry",
    "predict_rule": "_registry", "renderer_model": "warped", "RENDERER_PREDICTORS": "warped",
    "RendererModel": "warped", "WarpedSpectrum": "warped", "renderer_predictor": "warped",
    "predict_random_variance": "warped", "predict_warped_spectrum": "warped",
    "predict_spectral": "_spectral",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "SamplerRule": "_registry",
    "predict_many": "_registry",
    "spectral_truncation_curve": "_spectral",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

r"""Named predictors of a rule's shading error on a map (layer: beside :mod:`envfit.fit`).

One module per predictor, each ``f(ctx: PredictionContext, rule: Rule) -> Prediction``
(:mod:`envfit.predict.context`), registered by name in :data:`PREDICTORS` and dispatched by
:func:`predict`: ``plain`` (b) σ̂·E, ``bandlimited`` (b′) the band-limited model with the
lookup transfer and the mean term, ``spectral`` (c) the map's own spectrum.
"""
from .bandlimited import predict_bandlimited
from .context import Prediction, PredictionContext, Rule
from .plain import predict_plain
from .registry import PREDICTORS, Predictor, predict
from .spectral import predict_spectral

__all__ = ["PREDICTORS", "Predictor", "predict", "Prediction", "PredictionContext", "Rule",
           "predict_plain", "predict_bandlimited", "predict_spectral"]

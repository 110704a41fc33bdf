r"""The registry of predictors (as colour-science's method registries) and its dispatcher.

Every entry has the one signature ``f(ctx: PredictionContext, rule: Rule) -> Prediction``
and reads one kind of :class:`envfit.sampling.Rule` (its ``rule_type``, set by
:func:`envfit.predict._context.reads`):

===============  ====================================  ==============  ========================
name             function                              reads           formula
===============  ====================================  ==============  ========================
plain            :func:`predict_plain`                 QuadratureRule  (b) :math:`\hat\sigma
                                                                       E(\hat s)`
bandlimited      :func:`predict_bandlimited`           QuadratureRule  (b′) :math:`(\hat\sigma'^2
                                                                       \sum_{l\le H-1}
                                                                       a_l(\hat s')\tau_l e_l
                                                                       + (\sum w-1)^2
                                                                       \overline{m^2})^{1/2}`
spectral         :func:`predict_spectral`              QuadratureRule  (c) :math:`(\frac1C
                                                                       \sum_{c,l}\hat P_{l,c}
                                                                       e_l)^{1/2}`
random-variance  :func:`predict_random_variance`       RendererRule    :math:`(\sum_i
                                                                       V_i/n_i)^{1/2}`
warped-spectrum  :func:`predict_warped_spectrum`       RendererRule    :math:`(\sum_{k\ne0}
                                                                       |\sum_i\hat h_i(k)
                                                                       S_i(k)|^2)^{1/2}`
===============  ====================================  ==============  ========================

:func:`predict` is the one way to a prediction: ``envfit validate`` (its quadrature rules and
``--renderer``) and ``envfit advise`` (its quadrature rows and renderer rows) both call it.
"""
from __future__ import annotations

from typing import Callable

from envfit.base._errors import ParameterError

from envfit.predict._bandlimited import predict_bandlimited
from envfit.predict._context import Prediction, PredictionContext, Rule
from envfit.predict._plain import predict_plain
from envfit.predict._spectral import predict_spectral
from envfit.predict.warped._predictor import (predict_random_variance,
                                                predict_warped_spectrum, renderer_predictor)

__all__ = ["PREDICTORS", "Predictor", "predict", "predictors_for", "predict_rule"]

#: the signature every predictor has
Predictor = Callable[[PredictionContext, Rule], Prediction]

#: the predictors by name, in the order the report lists them
PREDICTORS: dict[str, Predictor] = {
    "plain": predict_plain,
    "bandlimited": predict_bandlimited,
    "spectral": predict_spectral,
    "random-variance": predict_random_variance,
    "warped-spectrum": predict_warped_spectrum,
}


def _reads(f: Predictor) -> type:
    """The kind of rule predictor ``f`` reads (any :class:`Rule` when it does not say)."""
    return getattr(f, "rule_type", Rule)


def predictors_for(rule_type: type) -> dict[str, Predictor]:
    """The predictors of :data:`PREDICTORS` that read a ``rule_type`` (in their order).

    >>> from envfit.sampling import QuadratureRule, RendererRule
    >>> list(predictors_for(QuadratureRule)), list(predictors_for(RendererRule))
    (['plain', 'bandlimited', 'spectral'], ['random-variance', 'warped-spectrum'])
    """
    return {k: f for k, f in PREDICTORS.items() if issubclass(rule_type, _reads(f))}


def predict(name: str, ctx: PredictionContext, rule: Rule) -> Prediction:
    """The prediction of the predictor ``name`` of :data:`PREDICTORS` for ``rule`` on ``ctx``.

    Raises
    ------
    envfit.base._errors.ParameterError
        for a name not in :data:`PREDICTORS` (the message lists the names), or a rule of a
        kind the predictor does not read.

    Examples
    --------
    >>> from envfit.sampling import QuadratureRule, RendererRule
    >>> predict("plain", PredictionContext(s=1.5, sigma=3.0), QuadratureRule(n=16, wce=0.5)).rmse
    1.5
    >>> predict("exact", PredictionContext(s=1.5, sigma=3.0), QuadratureRule(n=16))
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: unknown predictor 'exact'; choose from plain, bandlimited, spectral, random-variance, warped-spectrum
    >>> predict("plain", PredictionContext(s=1.5, sigma=3.0), RendererRule("map", "sf", 16))
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: predictor 'plain' reads a QuadratureRule, not a RendererRule
    """
    try:
        f = PREDICTORS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown predictor {name!r}; choose from "
                             f"{', '.join(PREDICTORS)}") from None
    if not isinstance(rule, _reads(f)):
        raise ParameterError(f"predictor {name!r} reads a {_reads(f).__name__}, not a "
                             f"{type(rule).__name__}")
    return f(ctx, rule)


def predict_rule(model, rule, *, seed: int = 0) -> Prediction:
    """Shorthand: :func:`predict` of :func:`~envfit.predict.renderer.renderer_predictor`
    (``rule``, a :class:`~envfit.sampling.RendererRule`) on a context holding ``model`` (a
    :class:`~envfit.predict.renderer.RendererModel`; ``seed``: the point seed, as
    :func:`envfit.sampling._rules.rule_points`)."""
    ctx = PredictionContext(renderer=model, point_seed=int(seed))
    return predict(renderer_predictor(rule), ctx, rule)

r"""The registry of predictors (as colour-science's method registries) and its dispatcher.

Every entry has the one signature ``f(ctx: PredictionContext, rule: Rule) -> Prediction``:

=============  ==========================  =============================================
name           function                    formula
=============  ==========================  =============================================
plain          :func:`predict_plain`       (b) :math:`\hat\sigma E(\hat s)`
bandlimited    :func:`predict_bandlimited` (b′) :math:`(\hat\sigma'^2\sum_{l\le H-1}
                                           a_l(\hat s')\tau_l e_l + (\sum w-1)^2
                                           \overline{m^2})^{1/2}`
spectral       :func:`predict_spectral`    (c) :math:`(\frac1C\sum_{c,l}\hat P_{l,c}e_l)^{1/2}`
=============  ==========================  =============================================
"""
from __future__ import annotations

from typing import Callable

from envfit.base._errors import ParameterError

from envfit.predict._bandlimited import predict_bandlimited
from envfit.predict._context import Prediction, PredictionContext, Rule
from envfit.predict._plain import predict_plain
from envfit.predict._spectral import predict_spectral

__all__ = ["PREDICTORS", "Predictor", "predict"]

#: the signature every predictor has
Predictor = Callable[[PredictionContext, Rule], Prediction]

#: the predictors by name, in the order the report lists them
PREDICTORS: dict[str, Predictor] = {
    "plain": predict_plain,
    "bandlimited": predict_bandlimited,
    "spectral": predict_spectral,
}


def predict(name: str, ctx: PredictionContext, rule: Rule) -> Prediction:
    """The prediction of the predictor ``name`` of :data:`PREDICTORS` for ``rule`` on ``ctx``.

    Raises
    ------
    envfit.base._errors.ParameterError
        for a name not in :data:`PREDICTORS` (the message lists the names).

    Examples
    --------
    >>> predict("plain", PredictionContext(s=1.5, sigma=3.0), Rule(n=16, wce=0.5)).rmse
    1.5
    >>> predict("exact", PredictionContext(s=1.5, sigma=3.0), Rule(n=16))
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: unknown predictor 'exact'; choose from plain, bandlimited, spectral
    """
    try:
        f = PREDICTORS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown predictor {name!r}; choose from "
                             f"{', '.join(PREDICTORS)}") from None
    return f(ctx, rule)

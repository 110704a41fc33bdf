r"""Prediction (b), *plain*: :math:`\hat R = \hat\sigma\,E(\hat s)`.

Under the Gaussian-process reading of the Sobolev model, f ~ GP(0, σ² K_gd^(s)), the error
of any linear rule is Gaussian with :math:`E_f[(\tilde I - I)^2] = \sigma^2 E(s)^2` (E is the
norm of the error's representer, Eq. 39 of Marques et al.), so σ̂·E uses no measured error.
"""
from __future__ import annotations

from envfit.predict._context import Prediction, PredictionContext, QuadratureRule, reads

__all__ = ["predict_plain"]


@reads(QuadratureRule)
def predict_plain(ctx: PredictionContext, rule: QuadratureRule) -> Prediction:
    r"""Prediction (b): the fitted σ̂ times the rule's worst-case error at ŝ,

    .. math:: \hat R = \hat\sigma\,E(\hat s), \qquad
              \hat\sigma = \Big(\frac1C\sum_c \hat\sigma_c^2\Big)^{1/2},

    E from Eq. 41 (:func:`envfit.theory._quadrature.worst_case_error`; for a truncation
    Eqs. 51–52). None when the rule's E is unknown.

    Parameters
    ----------
    ctx : :class:`PredictionContext`; uses ``sigma``.
    rule : :class:`~envfit.sampling.QuadratureRule`; uses ``wce``.

    Returns
    -------
    :class:`Prediction` with ``rmse`` = σ̂·E and ``wce`` = E.

    Examples
    --------
    >>> predict_plain(PredictionContext(s=1.5, sigma=2.0), QuadratureRule(n=16, wce=0.125)).rmse
    0.25
    """
    if rule.wce is None:
        return Prediction(name="plain", rmse=None, wce=None)
    ctx.need("sigma", who="plain")
    rmse = ctx.sigma * rule.wce
    return Prediction(name="plain", rmse=rmse, wce=rule.wce)

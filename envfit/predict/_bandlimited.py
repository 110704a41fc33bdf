r"""Prediction (b′), *band-limited*: the plain model made exact for what a lat-long map is.

(i) An H-row map holds no degree above H − 1, so the error spectrum (Eq. 42) is summed to
l = H − 1; (ii) a rule whose weights do not sum to 1 errs by :math:`\bar m(\sum_j w_j - 1)`
on the map's mean, for every axis; (iii) ŝ′, σ̂′ come from the likelihood of that same
band-limited model; (iv) the estimators integrate the bilinear interpolant, whose power at
degree l is the pixel field's times :math:`\tau_l`.
"""
from __future__ import annotations

import math

import numpy as np

from envfit.shading import band_e2, model_scatter

from envfit.predict._context import Prediction, PredictionContext, QuadratureRule, reads

__all__ = ["predict_bandlimited", "bandlimited_rmse"]


def bandlimited_rmse(sigma: float, e2_band: float, dev2: float = 0.0,
                     mean_sq: float = 0.0) -> float:
    r"""The combination of prediction (b′), :math:`(\hat\sigma'^2 E'^2 + (\sum_j w_j - 1)^2
    \overline{m^2})^{1/2}`, from its terms: ``e2_band`` :math:`E'^2`, ``dev2``
    :math:`(\sum_j w_j - 1)^2` (for a stochastic set: averaged over its realisations, as the
    advisor does), ``mean_sq`` :math:`\overline{m^2}`. The one formula that
    :func:`predict_bandlimited` and the advisor's N search use.

    >>> bandlimited_rmse(2.0, 0.25, 0.01, 9.0) == (4 * 0.25 + 0.01 * 9) ** 0.5
    True
    """
    return math.sqrt(max(sigma * sigma * e2_band + dev2 * mean_sq, 0.0))


@reads(QuadratureRule)
def predict_bandlimited(ctx: PredictionContext, rule: QuadratureRule) -> Prediction:
    r"""Prediction (b′): the band-limited model with the lookup transfer, plus the mean term,

    .. math:: \hat R^2 = \hat\sigma'^2 E'^2 + \Big(\sum_j w_j - 1\Big)^2\,\overline{m^2},
              \qquad E'^2 = \sum_{l\le H-1} a_l(\hat s')\,\tau_l\,e_l ,

    with :math:`a_l` the Sobolev coefficients (:func:`envfit.theory._sobolev.sobolev_coefficients`),
    :math:`e_l` the rule's error power (its first H degrees), :math:`\tau_l` the bilinear
    lookup's transfer and :math:`\overline{m^2}` the mean over channels of the squared
    solid-angle mean; :math:`E'^2` is :func:`envfit.shading._spectra.band_e2` of the context's
    :meth:`~PredictionContext.degree_weights` (a correctly rounded sum). A rule without
    ``error_power`` uses its ``wce_bandlimited``; one without weights (``weight_sum`` None, a
    truncation) has no mean term; one with ``weight_dev2`` (terms averaged over realisations)
    uses it for :math:`(\sum_j w_j - 1)^2`. Also returned: the one-map scatter
    (:func:`envfit.shading._spectra.model_scatter`, when the context has σ̂′ per channel).

    Parameters
    ----------
    ctx : :class:`PredictionContext`; uses ``s_bandlimited``, ``sigma_bandlimited``,
        ``sigma_bandlimited_channels``, ``band_lmax``, ``transfer``, ``mean_rms``.
    rule : :class:`~envfit.sampling.QuadratureRule`; uses ``error_power`` (or
        ``wce_bandlimited``), ``weight_sum`` and ``weight_dev2``.

    Returns
    -------
    :class:`Prediction` with ``rmse`` = R̂, ``wce`` = E′, ``mean_error`` =
    :math:`|\sum_j w_j - 1|(\overline{m^2})^{1/2}` and ``relative_sd``.

    Examples
    --------
    All the error in degree 1 (:math:`e_1 = 1`), no transfer: :math:`E'^2 = a_1(1.5)`;
    weights summing to 1.5 on a map of mean 0.2 add 0.1 in quadrature:

    >>> from envfit.theory._sobolev import sobolev_coefficients
    >>> a1 = sobolev_coefficients(1.5, 2)[1]
    >>> ctx = PredictionContext(s=1.5, sigma=1.0, s_bandlimited=1.5, sigma_bandlimited=0.5,
    ...                         sigma_bandlimited_channels=(0.5,), band_lmax=2, mean_rms=0.2)
    >>> p = predict_bandlimited(ctx, QuadratureRule(n=4, error_power=[0.0, 1.0, 0.0], weight_sum=1.5))
    >>> bool(abs(p.wce ** 2 - a1) < 1e-14), round(p.mean_error, 12)
    (True, 0.1)
    >>> bool(abs(p.rmse - (0.25 * a1 + 0.01) ** 0.5) < 1e-14)
    True
    """
    ctx.need("s_bandlimited", "sigma_bandlimited", "band_lmax", who="bandlimited")
    power, e2, wb = _band_terms(ctx, rule)
    me = None if rule.weight_sum is None else abs(rule.weight_sum - 1.0) * ctx.mean_rms
    rmse = None if e2 is None else bandlimited_rmse(ctx.sigma_bandlimited, e2,
                                                    _dev2(rule), ctx.mean_rms ** 2)
    scatter = None
    if power is not None and me is not None and len(ctx.sigma_bandlimited_channels):
        scatter = model_scatter(power, ctx.s_bandlimited, ctx.sigma_bandlimited_channels, me,
                                transfer=ctx.transfer)
    return Prediction(name="bandlimited", rmse=rmse, wce=wb, mean_error=me,
                      relative_sd=scatter)


def _band_terms(ctx: PredictionContext, rule: QuadratureRule):
    """(the rule's error power to H − 1, :math:`E'^2`, E′), None where unknown."""
    if rule.error_power is None:
        wb = rule.wce_bandlimited
        return None, None if wb is None else wb * wb, wb
    power = np.asarray(rule.error_power, dtype=np.float64)[:ctx.band_lmax + 1]
    e2 = band_e2(power, ctx.degree_weights())
    return power, e2, math.sqrt(e2)


def _dev2(rule: QuadratureRule) -> float:
    r""":math:`(\sum_j w_j - 1)^2` of the rule (its ``weight_dev2`` when given; 0 without
    weights)."""
    if rule.weight_dev2 is not None:
        return rule.weight_dev2
    return 0.0 if rule.weight_sum is None else (rule.weight_sum - 1.0) ** 2

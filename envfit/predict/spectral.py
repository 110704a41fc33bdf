r"""Prediction (c), *spectral*: the map's own power per degree times the rule's error power —
no model, no s, no σ: the exact mean over Haar-random rotations on this map."""
from __future__ import annotations

from envfit.shading.spectra import spectral_rmse

from .context import Prediction, PredictionContext, Rule

__all__ = ["predict_spectral"]


def predict_spectral(ctx: PredictionContext, rule: Rule) -> Prediction:
    r"""Prediction (c): the rule's RMSE on *this* map averaged over random rotations,

    .. math:: \hat R^2 = \frac1C\sum_c\sum_{l\le H-1} \hat P_{l,c}\, e_l ,

    :math:`\hat P_{l,c}` the realised power per degree of the map's bilinear interpolant
    (``ctx.map_power``), :math:`e_l` the rule's error power. Exact in expectation over
    Haar-random rotations (uniform axes, uniform twist) by Schur orthogonality of the Wigner
    D-matrices, for a map whose interpolant holds no degree above H − 1
    (:func:`envfit.shading.spectra.spectral_rmse`). Where (c) agrees with the measurement and
    (b′) does not, the map departs from the :math:`l^{-2s}` model.

    Parameters
    ----------
    ctx : :class:`PredictionContext`; uses ``map_power``.
    rule : :class:`Rule`; uses ``error_power``.

    Returns
    -------
    :class:`Prediction` with ``rmse`` = R̂ (None without ``error_power``).

    Examples
    --------
    >>> import numpy as np
    >>> ctx = PredictionContext(s=1.5, sigma=1.0, map_power=np.array([[5.0, 0.5], [7.0, 1.5]]))
    >>> predict_spectral(ctx, Rule(n=8, error_power=[0.0, 2.0])).rmse
    1.4142135623730951
    """
    ctx.need("map_power", who="spectral")
    rmse = None if rule.error_power is None else spectral_rmse(rule.error_power, ctx.map_power)
    return Prediction(name="spectral", rmse=rmse)

r"""Prediction (c), *spectral*: the map's own power per degree times the rule's error power —
no model, no s, no σ: the exact mean over Haar-random rotations on this map."""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.shading import spectral_rmse

from envfit.predict._context import Prediction, PredictionContext, QuadratureRule, reads

__all__ = ["predict_spectral", "spectral_truncation_curve"]


@reads(QuadratureRule)
def predict_spectral(ctx: PredictionContext, rule: QuadratureRule) -> Prediction:
    r"""Prediction (c): the rule's RMSE on *this* map averaged over random rotations,

    .. math:: \hat R^2 = \frac1C\sum_c\sum_{l\le H-1} \hat P_{l,c}\, e_l ,

    :math:`\hat P_{l,c}` the realised power per degree of the map's bilinear interpolant
    (``ctx.map_power``), :math:`e_l` the rule's error power. Exact in expectation over
    Haar-random rotations (uniform axes, uniform twist) by Schur orthogonality of the Wigner
    D-matrices, for a map whose interpolant holds no degree above H − 1
    (:func:`envfit.shading._spectra.spectral_rmse`). Where (c) agrees with the measurement and
    (b′) does not, the map departs from the :math:`l^{-2s}` model.

    Parameters
    ----------
    ctx : :class:`PredictionContext`; uses ``map_power``.
    rule : :class:`~envfit.sampling.QuadratureRule`; uses ``error_power``.

    Returns
    -------
    :class:`Prediction` with ``rmse`` = R̂ (None without ``error_power``).

    Examples
    --------
    >>> import numpy as np
    >>> ctx = PredictionContext(s=1.5, sigma=1.0, map_power=np.array([[5.0, 0.5], [7.0, 1.5]]))
    >>> predict_spectral(ctx, QuadratureRule(n=8, error_power=[0.0, 2.0])).rmse
    1.4142135623730951
    """
    ctx.need("map_power", who="spectral")
    rmse = None if rule.error_power is None else spectral_rmse(rule.error_power, ctx.map_power)
    return Prediction(name="spectral", rmse=rmse)


def spectral_truncation_curve(map_power, zonal, Lmax: int) -> np.ndarray:
    r"""Prediction (c) of SH truncation, RMSE(L) for L = 0…``Lmax``:

    .. math:: \hat R^2(L) = \frac1C\sum_c\sum_{l=L+1}^{L_P} \hat P_{l,c}\, b_l^2 ,

    :math:`\hat P_{l,c}` the map's realised power per degree (``map_power``, (C, L_P + 1),
    :func:`envfit.shading._spectra.map_degree_power`), :math:`b_l` the lobe's zonal
    coefficients (``zonal``, at least :math:`L_P + 1` of them). SH truncation at L keeps
    the degrees ≤ L of the map exactly, so its error on degree l is the whole degree-l part
    of the shading integral: by Funk–Hecke its error power is :math:`e_l = b_l^2` for l > L
    and 0 below (Eq. 52's bracket), and (c) (:func:`spectral_rmse`) becomes the sum above.
    The lobe is zonal, so the mean over uniform axes needs no twist: exact for the map's own
    coefficients to :math:`L_P` (the power above :math:`L_P` is left out).

    >>> spectral_truncation_curve([[9.0, 1.0, 4.0]], [1.0, 0.5, 0.25], 2).tolist()
    [0.7071067811865476, 0.5, 0.0]
    """
    P = np.atleast_2d(np.asarray(map_power, dtype=np.float64))
    lp = P.shape[1] - 1
    b = np.asarray(zonal, dtype=np.float64)[:lp + 1]
    if b.size != lp + 1:
        raise ParameterError(f"zonal needs {lp + 1} coefficients, got {b.size}")
    terms = P.mean(axis=0) * b * b
    tail = np.cumsum(terms[::-1])[::-1]                   # tail[k] = sum_{l >= k}
    curve = np.append(tail[1:], 0.0)                      # curve[L] = sum_{l > L}
    return np.sqrt(np.maximum(curve[:int(Lmax) + 1], 0.0))

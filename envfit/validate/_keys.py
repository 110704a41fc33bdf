r"""Where each predictor of :data:`envfit.predict.PREDICTORS` lands in the result of
``envfit validate`` (the keys the report, the plots and the JSON readers use).

Per rule, the :class:`envfit.predict.Prediction` fields of a predictor are stored as lists
over N under the keys of :data:`PREDICTION_KEYS`; the agreement statistics of its RMSE carry
the key's suffix after ``predicted_rmse`` (:func:`variant`): ``absolute["slope_range"]`` for
(b), ``["slope_range_refined"]`` for (b′), ``["slope_range_spectral"]`` for (c).
"""
from __future__ import annotations

__all__ = ["PREDICTION_KEYS", "prediction_keys", "rmse_key", "variant"]

#: result key of each Prediction field, per predictor
PREDICTION_KEYS: dict[str, dict[str, str]] = {
    "plain": {"rmse": "predicted_rmse"},
    "bandlimited": {"rmse": "predicted_rmse_refined", "wce": "predicted_wce_bandlimited",
                    "mean_error": "mean_error", "relative_sd": "model_scatter"},
    "spectral": {"rmse": "predicted_rmse_spectral"},
}


def prediction_keys(name: str) -> dict[str, str]:
    """The result keys of predictor ``name``'s fields (a predictor not in
    :data:`PREDICTION_KEYS` stores its RMSE as ``predicted_rmse_<name>``).

    >>> prediction_keys("spectral"), prediction_keys("exact")
    ({'rmse': 'predicted_rmse_spectral'}, {'rmse': 'predicted_rmse_exact'})
    """
    return PREDICTION_KEYS.get(name, {"rmse": f"predicted_rmse_{name}"})


def rmse_key(name: str) -> str:
    """The result key of predictor ``name``'s RMSE.

    >>> rmse_key("bandlimited")
    'predicted_rmse_refined'
    """
    return prediction_keys(name)["rmse"]


def variant(name: str) -> str:
    """The suffix of predictor ``name``'s agreement keys.

    >>> [variant(n) for n in ("plain", "bandlimited", "spectral")]
    ['', '_refined', '_spectral']
    """
    return rmse_key(name)[len("predicted_rmse"):]

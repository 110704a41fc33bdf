r"""The renderer model's own error: how far its predicted RMSE may lie from the model's exact
value, from the two things it samples.

* **Normals (frames).** The mean over the sphere is estimated from K importance-sampled
  normals, :math:`\hat M = \sum_a w_a m_a / \sum_a w_a`; its spread gives
  :func:`rmse_sampling_error` (the ratio estimator's variance, the normals treated as
  independent draws — the systematic draw is usually tighter, so this bounds it).
* **Randomisations.** Where the power above the grid is sampled over Q random shifts or
  scrambles (:mod:`envfit.predict.renderer.randomisation._shift_samples`), each normal's MSE
  carries a sampling error. The Q draws are the same at every normal, so the normals' errors
  are correlated: the error of :math:`\hat M` is the spread over the draws of the weighted
  sum over the normals (:func:`draws_error`).

The two are independent sources; :func:`model_error` adds them in quadrature and halves the
relative error of the MSE for the RMSE (delta method).

Reference: W. G. Cochran, *Sampling Techniques*, 3rd ed. (1977), eq. 6.9.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["rmse_sampling_error", "draws_error", "model_error", "larger_error",
           "larger_error_parts"]


def rmse_sampling_error(weights, mse) -> float | None:
    r"""The relative standard error of :math:`\sqrt{\hat M}`, :math:`\hat M = \sum w_i m_i /
    \sum w_i` the weighted mean of the frames' MSE :math:`m_i` (importance weights
    :math:`w_i`), from their spread: the ratio estimator's variance
    :math:`\frac{n}{n-1}\sum w_i^2 (m_i - \hat M)^2 / (\sum w_i)^2` (Cochran, *Sampling
    Techniques*, 3rd ed. (1977), eq. 6.9, the frames treated as independent draws; the
    systematic draw is usually tighter) halved for the square root (delta method); 0 where
    every frame's MSE is 0, None for fewer than two frames (no spread to measure).

    >>> round(rmse_sampling_error([1.0, 1.0, 1.0, 1.0], [1.0, 3.0, 1.0, 3.0]), 4)
    0.1443
    """
    w, m = np.asarray(weights, dtype=np.float64), np.asarray(mse, dtype=np.float64)
    keep = w > 0
    w, m = w[keep], m[keep]
    n, total = len(w), w.sum()
    if n < 2 or total <= 0:
        return None
    mean = float(w @ m / total)
    if mean <= 0:
        return 0.0
    var = n / (n - 1) * float(np.sum(w * w * (m - mean) ** 2)) / total ** 2
    return float(np.sqrt(var) / (2.0 * mean))


def draws_error(draws) -> float:
    r"""The standard error of the weighted mean over the normals of the sampled power above
    the grids, from its value per draw :math:`X_q = \sum_a w_a z_{a,q}` (module docstring;
    the same Q draws at every normal, so the normals' errors are combined draw by draw, with
    their correlation): :math:`\mathrm{sd}_q(X_q)/\sqrt Q`; 0 for fewer than two draws.

    >>> draws_error([1.0, 3.0])
    1.0
    """
    x = np.asarray(draws, dtype=np.float64)
    return float(x.std(ddof=1) / math.sqrt(len(x))) if len(x) > 1 else 0.0


def model_error(weights, mse, shift_se: float = 0.0, *, parts: bool = False):
    r"""The relative standard error of the predicted RMSE :math:`\sqrt{\hat M}`:
    :func:`rmse_sampling_error` of the normals and the sampled randomisations' standard error
    ``shift_se`` of :math:`\hat M` (:func:`draws_error`) relative to :math:`2\hat M`, in
    quadrature (None for one normal: its spread is unknown). With ``parts``: (that, (the
    normals' part, the randomisations' part)), the parts () for one normal.

    >>> round(model_error([0.5, 0.5], [1.0, 3.0], 0.2), 4)
    0.255
    >>> model_error([0.5, 0.5], [1.0, 3.0], 0.2, parts=True)[1]
    (0.25, 0.05)
    """
    normals = rmse_sampling_error(weights, mse)
    w = np.asarray(weights, dtype=np.float64)
    mean = float(w @ np.asarray(mse, dtype=np.float64)) / float(w.sum())
    shifts = float(shift_se) / (2.0 * mean) if mean > 0 else 0.0
    total = None if normals is None else math.hypot(normals, shifts)
    if not parts:
        return total
    return total, (() if normals is None else (normals, shifts))


def larger_error(a: float | None, b: float | None) -> float | None:
    """The larger of two model errors (None if either is unknown): a prediction between two
    anchors (a net's N between powers of two) is given the worse of theirs."""
    return None if a is None or b is None else max(a, b)


def larger_error_parts(lo, hi) -> tuple:
    """The larger of two predictions' model error parts, part by part (() if either is
    unknown).

    >>> larger_error_parts((0.02, 0.05), (0.03, 0.01))
    (0.03, 0.05)
    """
    if not lo or not hi:
        return ()
    return tuple(max(a, b) for a, b in zip(lo, hi))

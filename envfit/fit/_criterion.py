r"""The fit criterion at one s, for one map or for many maps sharing one factorisation.

For a fixed s the three criteria of :mod:`envfit.fit._smoothness` need, per map k with
samples :math:`f_k` (N × C_k) at the same N directions, only the factor of
:math:`K^{(s)}` (map-independent) and solves:

* ``likelihood``: :math:`\ell_k = \sum_c \ell_{kc}` of the profiled likelihood
  (:func:`envfit.sobolev._likelihood.profiled_log_likelihood`) on the centred samples,
  score :math:`-\ell_k/N`; channels constant at the samples are left out (σ̂ = 0);
* ``loo``: Rippa's closed-form residuals :math:`\alpha/\mathrm{diag}(K^{-1})` (the
  diagonal costs N³/3 once per s, shared by all maps), score the RMS residual;
* ``holdout``: each map's interpolant at its own held-out pixel centres, score the RMSE.

σ̂ (from the centred samples) is returned for every method, and, for the bootstrap
intervals of loo/holdout, the means of the per-item squared errors over the seeded
resamples (:func:`bootstrap_indices`). :func:`evaluate_criterion` is what the single-map fit
(:func:`envfit.fit._smoothness.fit_smoothness_samples`, one map) and the library fit's worker
task (:func:`envfit.batch._fit_tasks.criterion_task`, every map of a library) both call, so
their numbers agree to rounding.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from envfit.sobolev import bandlimited_log_likelihood
from envfit.sobolev import SobolevInterpolator

__all__ = ["N_BOOTSTRAP", "evaluate_criterion", "bootstrap_indices", "constant_columns"]

#: bootstrap resamples of the loo/holdout intervals
N_BOOTSTRAP = 400


def bootstrap_indices(m: int, *, seed: int, n_bootstrap: int) -> np.ndarray:
    """(n_bootstrap, m) item indices of the bootstrap resamples (seeded)."""
    return np.random.default_rng(seed).integers(0, m, size=(n_bootstrap, m))


def constant_columns(values: np.ndarray) -> np.ndarray:
    """Boolean (C,): the columns of ``values`` (N, C) constant at every sample."""
    values = np.asarray(values).reshape(len(values), -1)
    if not len(values):
        return np.ones(values.shape[1], dtype=bool)
    return ~(np.ptp(values, axis=0) > 0)


def evaluate_criterion(method: str, points: np.ndarray, values: np.ndarray, s: float, *,
                       widths: Sequence[int] | None = None, holdout: Sequence | None = None,
                       bootstrap: bool = False, seed: int = 0, n_bootstrap: int = N_BOOTSTRAP,
                       band_lmax: int | None = None) -> list[dict]:
    """The criterion ``method`` at ``s`` for every map, one factorisation for all.

    Parameters
    ----------
    method : ``"likelihood"``, ``"loo"`` or ``"holdout"``.
    points : (N, 3) sample directions, shared by the maps.
    values : (N, sum C_k) the maps' samples side by side.
    s : the smoothness.
    widths : the maps' channel counts C_k (default: one map, every column).
    holdout : per map ``(directions (m, 3), values (m, C_k))`` (``holdout`` only).
    bootstrap : also return ``boot``, the ``n_bootstrap`` resampled mean squared errors
        (loo/holdout; seeded by ``seed``, :func:`bootstrap_indices`).
    band_lmax : likelihood only: the kernel band-limited at that degree
        (:func:`envfit.sobolev._bandlimited.bandlimited_log_likelihood`) instead of K_gd.

    Returns
    -------
    list of dict
        Per map ``{"score", "sigma" (C_k floats), "boot" (list or None)}``.
    """
    values = np.asarray(values, dtype=np.float64).reshape(len(points), -1)
    widths = [values.shape[1]] if widths is None else [int(w) for w in widths]
    edges = np.cumsum([0, *widths])
    spans = list(zip(edges[:-1], edges[1:]))
    constant = constant_columns(values)
    centred = values - values.mean(axis=0, keepdims=True)
    if method == "likelihood":
        return _likelihood_scores(points, centred, s, band_lmax, constant, spans)
    interp = SobolevInterpolator(points, values, s, solver="cholesky")  # log det, LOO: dense
    sigma = np.where(constant, 0.0, np.atleast_1d(interp.log_likelihood_profiled(centred)[1]))
    out = []
    idx_cache: dict[int, np.ndarray] = {}
    for (a, b), (sq, channels) in zip(spans, _squared_errors(method, interp, spans, holdout)):
        boot = None
        if bootstrap:
            m = sq.shape[0]
            if m not in idx_cache:
                idx_cache[m] = bootstrap_indices(m, seed=seed, n_bootstrap=n_bootstrap)
            boot = [float(x) for x in sq[idx_cache[m]].mean(axis=1)]
        out.append({"score": float(np.sqrt(np.mean(sq) / channels)),
                    "sigma": [float(x) for x in sigma[a:b]], "boot": boot})
    return out


def _likelihood_scores(points, centred, s, band_lmax, constant, spans) -> list[dict]:
    r"""``likelihood``: per map :math:`-\sum_c \ell_{kc}/N` over its non-constant channels, and
    σ̂ (0 for the constant ones), by K_gd or the kernel band-limited at ``band_lmax``."""
    if band_lmax is not None:
        ll, sigma = bandlimited_log_likelihood(points, centred, s, band_lmax)
    else:
        ll, sigma = SobolevInterpolator(points, centred, s,
                                        solver="cholesky").log_likelihood_profiled()
    ll, sigma = np.atleast_1d(ll), np.where(constant, 0.0, np.atleast_1d(sigma))
    n = len(points)
    return [{"score": -float(np.sum(ll[a:b][~constant[a:b]])) / n,
             "sigma": [float(x) for x in sigma[a:b]], "boot": None} for a, b in spans]


def _squared_errors(method, interp, spans, holdout):
    """Per map ``(sq, C)``: the per-item squared errors summed over its C channels, Rippa's
    leave-one-out residuals (``loo``) or the errors at its held-out pixels (``holdout``)."""
    if method == "loo":
        e = interp.loo_residuals()
        for a, b in spans:
            yield np.sum(e[:, a:b] ** 2, axis=1), b - a
        return
    for k, (a, b) in enumerate(spans):
        hd, hv = holdout[k]
        hv = np.asarray(hv, dtype=np.float64).reshape(len(hd), -1)
        pred = np.asarray(interp.evaluate(hd, coefficients=interp.coefficients[:, a:b]))
        yield np.sum((pred.reshape(hv.shape) - hv) ** 2, axis=1), hv.shape[1]

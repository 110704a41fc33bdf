r"""Worker-side tasks of a library fit: sample a map; evaluate the fit criterion at one s for
many maps with one factorisation.

For a fixed s, the three criteria of :mod:`envfit.fit.smoothness` need, per map k with samples
:math:`f_k` (N x C_k), only the factor of :math:`K^{(s)}` (map-independent) and solves:

* likelihood: :math:`\ell_k = -\tfrac12 \sum_c (N\log\hat\sigma_{kc}^2 + \log\det K + N(1+\log 2\pi))`,
  :math:`\hat\sigma_{kc}^2 = f_{kc}^T K^{-1} f_{kc}/N` on the centred samples; score
  :math:`-\ell_k/N`;
* loo: Rippa's residuals :math:`\alpha/\mathrm{diag}(K^{-1})`; ``diag(K^{-1})`` costs
  N^3/3 once per s, shared by all maps;
* holdout: each map's interpolant at its own held-out pixel centres.

So one task factorises :math:`K^{(s)}` once and returns every map's score, σ̂ (from the
centred samples, for all methods) and, for the bootstrap intervals of loo/holdout, the
means of the per-item squared errors over the seeded resamples
(:func:`envfit.fit.smoothness.bootstrap_indices`): exactly the numbers the single-map
:func:`envfit.fit.smoothness.fit_smoothness_samples` computes, to rounding.
"""
from __future__ import annotations

import time

import numpy as np

from envfit.fit.smoothness import bootstrap_indices, holdout_pixels
from envfit.kernels.interpolation import SobolevInterpolator
from envfit.batch.tasks import SweepSpec, load_scaled
from envfit.maps.mapsource import MapSource

__all__ = ["fit_sample_task", "criterion_task", "N_BOOTSTRAP"]

#: bootstrap resamples (as :func:`envfit.fit.smoothness.fit_smoothness_samples`)
N_BOOTSTRAP = 400


def fit_sample_task(source: MapSource, spec: SweepSpec, n: int, n_holdout: int | None) -> dict:
    """Load one map, put it on the scale, sample it at the N points (and, for ``holdout``,
    draw its held-out pixels as :func:`envfit.fit.smoothness.fit_smoothness` does)."""
    scaled, sc = load_scaled(source, spec)
    c = scaled.channels
    res = {"values": np.ascontiguousarray(scaled.lookup(spec.points(n)).reshape(n, c)),
           "height": scaled.height, "width": scaled.width, "channels": c,
           "scale_description": sc.describe(), "holdout": None}
    if n_holdout is not None:
        res["holdout"] = holdout_pixels(scaled, n_holdout, seed=spec.seed)
    return res


def criterion_task(spec: SweepSpec, method: str, s: float, n: int, payload: dict,
                   bootstrap: bool) -> dict:
    """The criterion at ``s`` for every map in ``payload`` (one factorisation).

    ``payload``: ``values`` (N, sum C_k), ``widths`` [C_k], ``holdout`` [(dirs, values)] or
    None. Returns ``{"maps": [{"score", "sigma", "boot"}...], "seconds"}``; ``boot`` (the
    n_bootstrap resampled mean squared errors) only for loo/holdout with ``bootstrap``.
    """
    t0 = time.perf_counter()
    values = payload["values"]
    widths = payload["widths"]
    edges = np.cumsum([0, *widths])
    centred = values - values.mean(axis=0, keepdims=True)
    points = spec.points(n)
    if method == "likelihood":
        interp = SobolevInterpolator(points, centred, s)
        ll, sigma = interp.log_likelihood_profiled()
    else:
        interp = SobolevInterpolator(points, values, s)
        ll = None
        sigma = interp.log_likelihood_profiled(centred)[1]
        e = interp.loo_residuals() if method == "loo" else None
    out = []
    idx_cache: dict[int, np.ndarray] = {}
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        cell = {"sigma": [float(x) for x in sigma[a:b]], "boot": None}
        if method == "likelihood":
            cell["score"] = -float(np.sum(ll[a:b])) / n
            out.append(cell)
            continue
        if method == "loo":
            ek = e[:, a:b]
            sq = np.sum(ek * ek, axis=1)
            cell["score"] = float(np.sqrt(np.mean(sq) / (b - a)))
        else:
            hd, hv = payload["holdout"][k]
            pred = np.asarray(interp.evaluate(hd, coefficients=interp.coefficients[:, a:b]))
            pred = pred.reshape(hv.shape)
            sq = np.sum((pred - hv) ** 2, axis=1)
            cell["score"] = float(np.sqrt(np.mean(sq) / hv.shape[1]))
        if bootstrap:
            m = sq.shape[0]
            if m not in idx_cache:
                idx_cache[m] = bootstrap_indices(m, seed=spec.seed, n_bootstrap=N_BOOTSTRAP)
            cell["boot"] = [float(x) for x in sq[idx_cache[m]].mean(axis=1)]
        out.append(cell)
    return {"maps": out, "seconds": time.perf_counter() - t0}

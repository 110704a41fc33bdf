r"""Worker-side tasks of a library fit: sample a map; evaluate the fit criterion at one s for
many maps with one factorisation.

For a fixed s the criterion needs only the factor of :math:`K^{(s)}` (map-independent) and
solves, so one task factorises :math:`K^{(s)}` once and returns every map's score, σ̂ and,
for loo/holdout, the bootstrap means (:func:`envfit.fit._criterion.evaluate_criterion`, the
function the single-map :func:`envfit.fit._smoothness.fit_smoothness_samples` calls with one
map: the same numbers, to rounding).
"""
from __future__ import annotations

import time

import numpy as np

from envfit.fit import N_BOOTSTRAP, evaluate_criterion
from envfit.fit import holdout_pixels
from envfit.batch._tasks import SweepSpec, load_scaled
from envfit.maps import MapSource

__all__ = ["fit_sample_task", "criterion_task", "N_BOOTSTRAP"]


def fit_sample_task(source: MapSource, spec: SweepSpec, n: int, n_holdout: int | None) -> dict:
    """Load one map, put it on the scale, sample it at the N points (and, for ``holdout``,
    draw its held-out pixels as :func:`envfit.fit._smoothness.fit_smoothness` does)."""
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
    """The criterion at ``s`` for every map in ``payload`` (one factorisation;
    :func:`envfit.fit._criterion.evaluate_criterion`).

    ``payload``: ``values`` (N, sum C_k), ``widths`` [C_k], ``holdout`` [(dirs, values)] or
    None. Returns ``{"maps": [{"score", "sigma", "boot"}...], "seconds"}``; ``boot`` (the
    n_bootstrap resampled mean squared errors) only for loo/holdout with ``bootstrap``.
    """
    t0 = time.perf_counter()
    cells = evaluate_criterion(method, spec.points(n), payload["values"], s,
                               widths=payload["widths"], holdout=payload["holdout"],
                               bootstrap=bootstrap, seed=spec.seed, n_bootstrap=N_BOOTSTRAP)
    return {"maps": cells, "seconds": time.perf_counter() - t0}

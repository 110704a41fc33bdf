"""The advisor: smallest N per rule and smallest SH/HSH degree for a target error,
with its on-disk cache.

Modules, in the order of the pipeline (:func:`envfit.advisor.advise.advise_with`):

* :mod:`~envfit.advisor.options` — :class:`~envfit.advisor.options.AdviseOptions`, the
  parameters by role, checked in one place, and their defaults;
* :mod:`~envfit.advisor.model` — the map on its scale, the target, the band-limited fit of
  s' and σ' and the lookup transfer τ (cached);
* :mod:`~envfit.advisor.prediction` — a rule's map-independent terms and the prediction (b');
* :mod:`~envfit.advisor.search` — doubling and bisection for the smallest N, the L search;
* :mod:`~envfit.advisor.result` — :class:`~envfit.advisor.result.Advice`, its rows and the
  recommendation;
* :mod:`~envfit.advisor.check` — the measured RMSE of ``check=True``;
* :mod:`~envfit.advisor.advise` — the pipeline, :func:`~envfit.advisor.advise.advise`;
* :mod:`~envfit.advisor.cache` — the JSON cache of fits, τ and curve points.
"""

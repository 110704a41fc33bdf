r"""The advisor: smallest N per rule and smallest SH/HSH degree for a target error, with its on-
disk cache.

Modules:

* :mod:`~envfit.advisor._advise` — The advisor: how many samples, or which SH/HSH degree, for
  this map, this BRDF and a target error?
* :mod:`~envfit.advisor._budget` — The advisor's memory and time plan, made before any work:
  every stage's predicted peak from the map size, N, L and the options, against the
  machine's memory budget (:func:`envfit.base._resources.memory_budget_bytes`); a map too big
  for it is downsampled to what the predictions need, or the run is refused in one line
  naming an option that fits.
* :mod:`~envfit.advisor._cache` — The on-disk cache of ``envfit advise``: fitted (s, σ̂) and
  lookup transfer per map, and worst-case-error curves.
* :mod:`~envfit.advisor._check` — The advisor's ``check=True`` (``envfit advise --check``):
  the RMSE measured on the map at each reached row's chosen N or L, beside the prediction.
* :mod:`~envfit.advisor._choice` — Which prediction sizes a row: (b′) "bandlimited" or (c)
  "spectral", and the warning when they disagree.
* :mod:`~envfit.advisor._model` — The map's side of the advisor's prediction: the map on its
  scale, the absolute target, the band-limited fit of s' and σ', the bilinear lookup's
  transfer τ_l and :math:`a_l(s')\tau_l`, and the realised power per degree :math:`\hat
  P_{l,c}` of the map's bilinear interpolant to :math:`L_\mathrm{tail} = 2H - 1`
  (:func:`spectral_lmax`) for prediction (c), with the fit, τ and :math:`\hat P` cached
  (:mod:`envfit.advisor._cache`).
* :mod:`~envfit.advisor._options` — What the advisor is asked: :class:`AdviseOptions`, its
  parameters grouped by role and checked in one place, and their defaults.
* :mod:`~envfit.advisor._prediction` — The advisor's prediction of one rule's RMS shading
  error on a map, from map-independent terms.
* :mod:`~envfit.advisor._preset` — Advice in a renderer's own terms (``--renderer``): the
  spp its sampler must run for the target, with its integrator's settings and scene text
  (:func:`advise_preset`, :class:`PresetAdvice`); its options in
  :mod:`~envfit.advisor._preset_options` (:class:`PresetAdviseOptions`) and its cached
  search in :mod:`~envfit.advisor._preset_search`.
* :mod:`~envfit.advisor._rule_rows` — The advisor's renderer rows: how many samples per
  shading point for BRDF sampling, map importance sampling, MIS and the source split, with a
  given point set, for the target error.
* :mod:`~envfit.advisor._rule_rows_cache` — The advisor's cache of the renderer model: each
  warped spectrum stored and read back exactly, the missing ones computed.
* :mod:`~envfit.advisor._result` — What the advisor answers: :class:`Advice`, its rows
  (:class:`AdviceRow`, one rule each), their order, the recommended row and the
  recommendation line.
* :mod:`~envfit.advisor._search` — The advisor's searches: the smallest N of a quadrature
  rule (doubling, then bisection) and the smallest SH/HSH degree L, each giving one
  :class:`~envfit.advisor._result.AdviceRow`.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {
    "advise_with": "_advise",
    "advise_preset": "_preset", "PresetAdvice": "_preset",
    "PresetAdviseOptions": "_preset_options",
    "AdviseOptions": "_options",
    "Advice": "_result",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

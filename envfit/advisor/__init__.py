r"""The advisor: smallest N per rule and smallest SH/HSH degree for a target error, with its on-
disk cache.

One pipeline, by what is asked: :func:`advise_with` (``envfit advise``) takes the options of
envfit's own rules (:class:`AdviseOptions`) or of a renderer's own terms
(:class:`RendererAdviseOptions`, ``--renderer``), and both run the same steps — the options
checked in one place → the model → the search → a result dataclass (:class:`Advice`,
:class:`RendererAdvice`). Every prediction goes through the predictor registry
(:data:`envfit.predict.PREDICTORS`).

Modules, by step:

* Entry point: :mod:`~envfit.advisor._advise` — :func:`advise_with`, dispatching on the
  options, and :func:`advise`, the keyword form for envfit's rules.
* Options: :mod:`~envfit.advisor._options` — :class:`AdviseOptions`, envfit's rules' parameters
  grouped by role and checked in one place, and their defaults;
  :mod:`~envfit.advisor._renderer_options` — :class:`RendererAdviseOptions`, a renderer's
  (its sampler, strategies, model resolution, target), checked before any work.
* Model: :mod:`~envfit.advisor._model` — the map's side of the prediction of envfit's rules:
  the map on its scale, the absolute target, the band-limited fit of s' and σ', the bilinear
  lookup's transfer τ_l and the realised power per degree :math:`\hat P_{l,c}` to
  :math:`L_\mathrm{tail} = 2H - 1` (:func:`spectral_lmax`), cached;
  :mod:`~envfit.advisor._prediction` — one rule's prediction from map-independent terms;
  :mod:`~envfit.advisor._choice` — which prediction sizes a row ((b′) or (c));
  :mod:`~envfit.advisor._renderer_model` — a renderer's noise model on the map, asked through
  the registry's ``renderer`` predictor, its cells cached.
* Search: :mod:`~envfit.advisor._search` — the smallest N of a quadrature rule (doubling, then
  bisection) and the smallest SH/HSH degree L; :mod:`~envfit.advisor._rule_rows` — envfit's
  renderer rows (BRDF sampling, map importance sampling, MIS, the source split with a point
  set), with their spectra's cache :mod:`~envfit.advisor._rule_rows_cache`;
  :mod:`~envfit.advisor._renderer_search` — the smallest spp a renderer's sampler runs per
  strategy; :mod:`~envfit.advisor._renderer_sizing` — that model sized to its own error.
* Result: :mod:`~envfit.advisor._result` — :class:`Advice`, its rows (one rule each), their
  order and the recommendation line; :mod:`~envfit.advisor._renderer_advice` —
  :class:`RendererAdvice` (the spp per strategy, the integrator's settings, the scene text)
  and the renderer pipeline :func:`~envfit.advisor._renderer_advice.advise_renderer_map`;
  :mod:`~envfit.advisor._renderer_adaptive` — :func:`advise_adaptive`: a renderer's adaptive
  sampling at a noise threshold, and the threshold that meets the target.
* Shared: :mod:`~envfit.advisor._budget` — the memory and time plan before any work (a map
  too big is downsampled, or the run refused in one line naming an option that fits);
  :mod:`~envfit.advisor._cache` — the on-disk cache (fits, transfers, wce curves, renderer
  cells); :mod:`~envfit.advisor._check` — ``check=True``: the RMSE measured at each reached
  row's N or L beside the prediction.

The former names ``PresetAdvice``, ``PresetAdviseOptions`` and ``advise_preset`` (the
keyword form of the renderer pipeline) still resolve, as aliases outside ``__all__``.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "advise_with": "_advise",
    "AdviseOptions": "_options", "RendererAdviseOptions": "_renderer_options",
    "Advice": "_result", "RendererAdvice": "_renderer_advice",
    "advise_adaptive": "_renderer_adaptive", "AdaptiveAdvice": "_renderer_adaptive",
    # the former names, kept as aliases
    "advise_preset": "_renderer_advice", "PresetAdvice": "_renderer_advice",
    "PresetAdviseOptions": "_renderer_options",
}

#: the former names: they resolve, but the supported names are the new ones
_FORMER = ("advise_preset", "PresetAdvice", "PresetAdviseOptions")

__all__ = sorted(k for k in _LAZY if k not in _FORMER)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "cache_write_problem": "_cache",
    "check_adaptive": "_renderer_adaptive",
    "BASES": "_options",
    "MAX_AXES": "_options",
    "MAX_SEEDS": "_options",
    "MAX_SPECTRUM_AXES": "_options",
    "SIZED_RANDOMISATIONS": "_renderer_options",
    "default_cache_dir": "_cache",
    "renderer_plan": "_budget",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

r"""How a renderer draws: the map sampler (pdf ∝ luminance × solid angle) and its compiled warp,
BRDF sampling and MIS, the bright-source split, the sampling techniques' second-moment
proxies, and renderer rules (strategy, point set, N). The renderers (Mitsuba 3, pbrt-v4,
Cycles, envfit) are the package :mod:`envfit.renderers`, one folder each.

Modules:

* ``_sample_kernel`` (private) — The compiled inverse-CDF warp of
  :meth:`envfit.sampling._map_sampler.MapSampler.sample`.
* :mod:`~envfit.sampling._importance` — The estimators renderers use for the shading
  integral: map importance sampling, BRDF (lobe) sampling and Veach's multiple importance
  sampling of the two.
* :mod:`~envfit.sampling._map_sampler` — Importance sampling of a lat-long map
  (:class:`MapSampler`): pdf ∝ luminance × solid angle.
* :mod:`~envfit.sampling._proxies` — Proxies of the second moments of the renderer's sampling
  techniques, per axis.
* :mod:`~envfit.sampling._rules` — Rules: what a shading estimate integrates with — one
  concept, two kinds (the paper's quadrature rule, the renderer's strategy + point set + N).
* :mod:`~envfit.sampling._source_split` — Bright sources of a map (the sun, lamps) and the source
  / rest split of the shading estimators.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "brdf_sampling_estimates": "_importance", "ESTIMATORS": "_importance",
    "HEURISTICS": "_importance", "map_is_estimates": "_importance", "mis_estimates": "_importance",
    "MapSampler": "_map_sampler",
    "proxy_second_moments": "_proxies",
    "QuadratureRule": "_rules", "RendererRule": "_rules", "Rule": "_rules",
    "rule_points": "_rules", "STRATEGIES": "_rules",
    "split_estimates": "_source_split", "split_map": "_source_split", "SplitResult": "_source_split",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "bilinear_cell_average": "_map_sampler",
    "square_samples": "_map_sampler",
    "brdf_pdf": "_importance",
    "normalised_moments": "_proxies",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

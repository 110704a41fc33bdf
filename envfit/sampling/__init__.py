r"""How a renderer draws: the map sampler (pdf ∝ luminance × solid angle) and its compiled warp,
BRDF sampling and MIS, the bright-source split, the sampling techniques' second-moment
proxies, and renderer rules (strategy, point set, N). Renderer presets will live here.

Modules:

* ``_sample_kernel`` (private) — The compiled inverse-CDF warp of
  :meth:`envfit.sampling.map_sampler.MapSampler.sample`.
* :mod:`~envfit.sampling.importance` — The estimators renderers use for the shading
  integral: map importance sampling, BRDF (lobe) sampling and Veach's multiple importance
  sampling of the two.
* :mod:`~envfit.sampling.map_sampler` — Importance sampling of a lat-long map
  (:class:`MapSampler`): pdf ∝ luminance × solid angle.
* :mod:`~envfit.sampling.proxies` — Proxies of the second moments of the renderer's sampling
  techniques, per axis.
* :mod:`~envfit.sampling.rules` — Renderer sampling rules — a strategy, a point set and N —
  the renderer's choice.
* :mod:`~envfit.sampling.sources` — Bright sources of a map (the sun, lamps) and the source
  / rest split of the shading estimators.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base.lazy import lazy_exports

_LAZY = {
    "brdf_sampling_estimates": "importance", "ESTIMATORS": "importance",
    "HEURISTICS": "importance", "map_is_estimates": "importance", "mis_estimates": "importance",
    "MapSampler": "map_sampler",
    "proxy_second_moments": "proxies",
    "RendererRule": "rules", "rule_points": "rules", "STRATEGIES": "rules",
    "split_estimates": "sources", "split_map": "sources", "SplitResult": "sources",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

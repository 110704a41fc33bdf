r"""Microfacet BSDFs as renderers shade them (issue 25): GGX and Beckmann distributions, Smith
shadowing-masking (separable: Mitsuba 3; height-correlated: pbrt-v4, Cycles), visible-normal
sampling step for step as each renderer does it, conductor Fresnel, the rough conductor BSDF
(eval, pdf and sample sharing one warp) and the ground truth of its shading integral on a map.

Modules:

* :mod:`~envfit.shading.microfacet._distributions` — D, Λ, G1, separable and height-correlated
  G, the density of visible normals.
* :mod:`~envfit.shading.microfacet._vndf` — visible-normal sampling: Mitsuba 3, pbrt-v4, Cycles.
* :mod:`~envfit.shading.microfacet._fresnel` — conductor Fresnel (Mitsuba's and pbrt-v4's forms).
* :mod:`~envfit.shading.microfacet._conductor` — :class:`Conductor`, roughness conventions,
  Cycles' Multiscatter GGX (its energy scale).
* :mod:`~envfit.shading.microfacet._plastic` — :class:`RoughPlastic` (Mitsuba 3 ``roughplastic``).
* :mod:`~envfit.shading.microfacet._ground_truth` — the shading integral's ground truth with
  its resolution rule.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "ALPHA_RANGE": "_distributions", "DISTRIBUTIONS": "_distributions",
    "MicrofacetDistribution": "_distributions",
    "concentric_disk": "_vndf", "polar_disk": "_vndf", "sample_visible_normals": "_vndf",
    "fr_complex": "_fresnel", "fresnel_conductor": "_fresnel",
    "BSDFSample": "_conductor", "Conductor": "_conductor", "MICROFACET_RENDERERS": "_conductor",
    "roughness_to_alpha": "_conductor", "alpha_to_roughness": "_conductor",
    "roughness_range": "_conductor", "roughness_words": "_conductor", "ROUGHNESS_UNITS": "_conductor",
    "ROUGHNESS_RTOL": "_conductor", "ROUGHNESS_RULES": "_conductor",
    "PlasticSample": "_plastic", "RoughPlastic": "_plastic",
    "energy_scale": "_conductor", "multiscatter_or_conductor": "_conductor",
    "GroundTruthOptions": "_ground_truth", "MicrofacetShading": "_ground_truth",
    "microfacet_shading_integral": "_ground_truth",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

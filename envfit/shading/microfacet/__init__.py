r"""Microfacet BSDFs as techniques (issue 25): GGX and Beckmann distributions, Smith
shadowing-masking in its separable and height-correlated forms, three visible-normal warps,
two conductor Fresnel forms and the F82-tint one, multiple scattering as an energy scale, the
rough conductor, rough plastic, principled and albedo-layered BSDFs (eval, pdf and sample sharing one warp)
and the ground truth of a BSDF's shading integral on a map.

Each technique is named by what it is, never by a renderer: which renderer shades its BSDFs
by which techniques, with which roughness convention, read from which source, is its folder's
(``envfit/renderers/<name>/_bsdf.py``), and its record builds the BSDF
(:meth:`envfit.renderers.Renderer.bsdf`, :attr:`envfit.renderers.Renderer.roughness`).

Modules:

* :mod:`~envfit.shading.microfacet._distributions` — D, Λ, G1, separable and height-correlated
  G, the density of visible normals.
* :mod:`~envfit.shading.microfacet._vndf` — the visible-normal warps :data:`VNDF_WARPS`.
* :mod:`~envfit.shading.microfacet._fresnel` — the conductor Fresnel forms
  :data:`FRESNEL_FORMS`.
* :mod:`~envfit.shading.microfacet._conductor` — :class:`Conductor` (its shadowing form,
  :data:`SHADOWINGS`; its warp; its Fresnel form; multiple scattering or not).
* :mod:`~envfit.shading.microfacet._multiscatter` — the energy scale 1/E of a white GGX
  lobe, E its own single-scatter albedo table.
* :mod:`~envfit.shading.microfacet._plastic` — :class:`RoughPlastic`, a rough dielectric
  coating over a Lambertian base with rough-interface transmittance tables.
* :mod:`~envfit.shading.microfacet._principled` — :class:`Principled`, the principled
  ("Disney") BSDF's diffuse-with-retro-reflection and GGX specular lobes, the Fresnel a
  blend of the dielectric's and a metal's.
* :mod:`~envfit.shading.microfacet._layered` — :class:`AlbedoLayered`, a GGX dielectric layer
  over a Lambertian base weighted by what the layer's estimated albedo leaves, the lobes
  picked in proportion to their albedos.
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
    "VNDF_WARPS": "_vndf",
    "FRESNEL_FORMS": "_fresnel", "fr_complex": "_fresnel", "fresnel_conductor": "_fresnel",
    "BSDFSample": "_conductor", "Conductor": "_conductor", "SHADOWINGS": "_conductor",
    "albedo_table": "_multiscatter", "energy_scale": "_multiscatter",
    "PlasticSample": "_plastic", "RoughPlastic": "_plastic",
    "Principled": "_principled",
    "AlbedoLayered": "_layered", "blend_factor": "_layered", "blend_factor_table": "_layered",
    "f0_of_ior": "_layered", "ior_of_f0": "_layered",
    "GroundTruthOptions": "_ground_truth", "MicrofacetShading": "_ground_truth",
    "microfacet_shading_integral": "_ground_truth",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

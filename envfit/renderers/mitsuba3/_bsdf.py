r"""Mitsuba 3's microfacet BSDFs as envfit builds them (:func:`bsdf`, the record's
:meth:`~envfit.renderers.Renderer.bsdf`) from the techniques of
:mod:`envfit.shading.microfacet`, and its roughness convention (:data:`ROUGHNESS`).

**roughconductor** (``src/bsdfs/roughconductor.cpp``: ``RoughConductor::eval``, ``pdf``,
``sample``) — :class:`~envfit.shading.microfacet.Conductor` with

* separable shadowing-masking (``shadowing="separable"``): eval = F D G1(ω_i)G1(ω_o)/(4 cos θ_i),
  pdf = D G1(ω_i)/(4 cos θ_i), the sample weight ``distr.smith_g1(bs.wo, m)`` times F
  (``RoughConductor::sample``); ``include/mitsuba/render/microfacet.h``:
  ``MicrofacetDistribution::eval`` (D, GGX or Beckmann), ``smith_g1`` (χ⁺; Beckmann's
  rational :math:`(3.535a + 2.181a^2)/(1 + 2.276a + 2.577a^2)`), ``G`` (the product),
  ``pdf``;
* the ``slope_space`` visible-normal warp (``MicrofacetDistribution::sample`` with
  ``sample_visible``, ``sample_visible_11``): GGX from the concentric disk point
  (``include/mitsuba/core/warp.h``: ``square_to_uniform_disk_concentric``, Dave Cline's
  branch-reduced form), Beckmann by Jakob's inversion with three Newton steps; the compiled
  model's variant 0;
* the ``moeller`` Fresnel form with η + ik (``include/mitsuba/render/fresnel.h``:
  ``fresnel_conductor``, "modified from *Optics* by K.D. Moeller"); the plugin's default
  ``material`` "none" is (η, k) = (0, 1), F ≡ 1 (its "100% reflective mirror"): envfit's white
  conductor, no η, k;
* α the plugin's own ``alpha`` (:data:`ROUGHNESS`: R = α), clamped to ≥ 1e-4 as the
  distribution does.

**roughplastic** (``src/bsdfs/roughplastic.cpp``: ``RoughPlastic::RoughPlastic``,
``parameters_changed``, ``eval``, ``pdf``, ``sample``, ``lerp_gather``) —
:class:`~envfit.shading.microfacet.RoughPlastic` with the ``slope_space`` warp: the tables of
``parameters_changed`` (``m_external_transmittance`` at ``MI_ROUGH_TRANSMITTANCE_RES`` = 64
cosines by ``eval_transmittance(distr, wi, η)``, ``m_internal_reflectance`` by
``eval_reflectance(distr, wi, 1/η)``: ``include/mitsuba/render/microfacet.h``, their
Gauss–Legendre nodes ``quad::gauss_legendre`` in float32), ``lerp_gather`` for T,
``MicrofacetDistribution::eval``'s zero below D cos θ ≤ 1e-20, the dielectric Fresnel and
refraction (``include/mitsuba/render/fresnel.h``: ``fresnel``, ``refract``), the specular lobe
picked by ``sample1`` < ``prob_specular`` (``sampled_component`` 0, the sampler's ``next_1d``)
with ``m_specular_sampling_weight``, the diffuse lobe by ``square_to_cosine_hemisphere``
(``warp.h``), ``sample_visible`` false by ``MicrofacetDistribution::sample`` of D(m) cos θ_m.
The plugin's defaults are the class's (``distribution`` beckmann, ``alpha`` 0.1, ``int_ior``
polypropylene 1.49, ``ext_ior`` air 1.000277, ``diffuse_reflectance`` 0.5, ``nonlinear``
false, ``sample_visible`` true); envfit's advice asks for a GGX coat.
"""
from __future__ import annotations

from envfit.renderers._roughness import RoughnessConvention

__all__ = ["ROUGHNESS", "bsdf"]

#: Mitsuba 3's roughness: the plugins' ``alpha`` itself
ROUGHNESS = RoughnessConvention(rule="alpha = R", units="Mitsuba 3's alpha",
                                alpha_of=lambda r: r, roughness_of=lambda a: a)


def bsdf(name: str, alpha: float, **params):
    """``roughconductor`` (``name`` ``ggx`` or ``beckmann``; ``params`` ``eta``, ``k``) or
    ``roughplastic`` (a GGX coat unless ``params`` say ``distribution``; the others its
    :class:`~envfit.shading.microfacet.RoughPlastic` keywords) of microfacet α.

    >>> bsdf("beckmann", 0.2)          # doctest: +NORMALIZE_WHITESPACE
    Conductor('beckmann', 0.2, shadowing='separable', vndf='slope_space', fresnel='moeller',
              eta=None, k=None)
    """
    from envfit.shading.microfacet import Conductor, RoughPlastic
    if name == "roughplastic":
        return RoughPlastic(params.pop("distribution", "ggx"), alpha, vndf="slope_space",
                            **params)
    return Conductor(name, alpha, shadowing="separable", vndf="slope_space", fresnel="moeller",
                     **params)

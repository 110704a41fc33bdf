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

**principled** (``src/bsdfs/principled.cpp``: ``Principled::Principled``, ``sample``, ``eval``,
``pdf``; ``src/bsdfs/principledhelpers.h``: ``calc_dist_params``, ``principled_fresnel``,
``calc_schlick``, ``schlick_R0_eta``, ``schlick_weight``, ``mac_mic_compatibility``; unchanged
from v3.9.1 to the repository's head of 2026-08-08) —
:class:`~envfit.shading.microfacet.Principled`: the plugin's defaults (``base_color`` 0.5,
``roughness`` 0.5, ``specular`` 0.5, so η = 2/(1 − √(0.08·0.5)) − 1 = 1.5, the rest 0);
α = max(0.001, roughness²) (:data:`PRINCIPLED_ROUGHNESS`), isotropic GGX sampled by visible
normals (``MicrofacetDistribution(GGX, ax, ay)``, ``sample_visible`` true: the
``slope_space`` warp), separable G (``MicrofacetDistribution::G``); without clear coat and
specular transmission the lobe probabilities are the specular's 1 and the diffuse's
1 − metallic, normalised, and ``sample1`` < p_d picks the diffuse lobe (``sampled_component``
0), else the specular (3). Clear coat, ``spec_trans`` and ``anisotropic`` (further lobes, a
transmission, two roughnesses) are not modelled: ``bsdf`` refuses them. Checked against the
plugin itself (``tests/test_principled.py``: eval, pdf, sample to float32 rounding).
"""
from __future__ import annotations

import math

from envfit.base import ParameterError
from envfit.renderers._roughness import RoughnessConvention

__all__ = ["PRINCIPLED_PARAMS", "PRINCIPLED_ROUGHNESS", "ROUGHNESS", "bsdf"]

#: Mitsuba 3's roughness: the plugins' ``alpha`` itself
ROUGHNESS = RoughnessConvention(rule="alpha = R", units="Mitsuba 3's alpha",
                                alpha_of=lambda r: r, roughness_of=lambda a: a)
#: ``principled``'s roughness: alpha = max(0.001, roughness²) (``calc_dist_params``)
PRINCIPLED_ROUGHNESS = RoughnessConvention(
    rule="alpha = R^2", units="the roughness R of Mitsuba 3's principled, alpha = R^2",
    alpha_of=lambda r: max(0.001, r * r), roughness_of=math.sqrt)
#: ``principled``'s parameters envfit models, with the plugin's defaults (a grey
#: ``base_color``; ``specular`` sets η)
PRINCIPLED_PARAMS = {"roughness": 0.5, "base_color": 0.5, "metallic": 0.0, "specular": 0.5,
                     "spec_tint": 0.0, "sheen": 0.0, "sheen_tint": 0.0, "flatness": 0.0}


def bsdf(name: str, alpha: float, **params):
    """``roughconductor`` (``name`` ``ggx`` or ``beckmann``; ``params`` ``eta``, ``k``),
    ``roughplastic`` (a GGX coat unless ``params`` say ``distribution``; the others its
    :class:`~envfit.shading.microfacet.RoughPlastic` keywords) or ``principled`` (``params``
    among :data:`PRINCIPLED_PARAMS`; its roughness √α) of microfacet α.

    >>> bsdf("beckmann", 0.2)          # doctest: +NORMALIZE_WHITESPACE
    Conductor('beckmann', 0.2, shadowing='separable', vndf='slope_space', fresnel='moeller',
              eta=None, k=None)
    """
    from envfit.shading.microfacet import Conductor, Principled, RoughPlastic
    if name == "principled":
        unknown = sorted(set(params) - set(PRINCIPLED_PARAMS) | ({"roughness"} & set(params)))
        if unknown:
            raise ParameterError(f"Mitsuba 3's principled: {', '.join(unknown)} is not a "
                                 f"parameter envfit models (roughness is --roughness; the others: "
                                 f"{', '.join(k for k in PRINCIPLED_PARAMS if k != 'roughness')}; "
                                 f"clearcoat, spec_trans and anisotropic are not modelled)")
        return Principled(math.sqrt(alpha), **params)
    if name == "roughplastic":
        return RoughPlastic(params.pop("distribution", "ggx"), alpha, vndf="slope_space",
                            **params)
    return Conductor(name, alpha, shadowing="separable", vndf="slope_space", fresnel="moeller",
                     **params)

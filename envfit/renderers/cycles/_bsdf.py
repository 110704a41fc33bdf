r"""Cycles' microfacet BSDFs as envfit builds them (:func:`bsdf`, the record's
:meth:`~envfit.renderers.Renderer.bsdf`) from the techniques of
:mod:`envfit.shading.microfacet`, and its roughness convention (:data:`ROUGHNESS`).

**The microfacet reflection closure** (the Glossy BSDF set to GGX or Beckmann, and the
Principled BSDF's metallic lobe; ``src/kernel/closure/bsdf_microfacet.h``:
``bsdf_microfacet_eval``, ``bsdf_microfacet_sample``) —
:class:`~envfit.shading.microfacet.Conductor` with

* GGX or Beckmann (``bsdf_D``; Beckmann's Λ by ``bsdf_lambda_from_sqr_alpha_tan_n``, the
  rational fit of Walter et al.);
* height-correlated shadowing-masking (``shadowing="height_correlated"``: ``bsdf_G``):
  eval = F D/(4 cos θ_i (1 + Λ_i + Λ_o)), pdf = D/(4 cos θ_i (1 + Λ_i)), the sample weight
  F (1 + Λ_i)/(1 + Λ_i + Λ_o);
* the ``hemisphere_concentric`` visible-normal warp: GGX by ``microfacet_ggx_sample_vndf``
  (Heitz 2018 in the hemisphere configuration, the concentric disk point
  ``sample_uniform_disk`` of ``src/kernel/sample/mapping.h``, m_z ≥ 0), Beckmann by
  ``microfacet_beckmann_sample_vndf`` (the OSL reformulation of Jakob's routine: a
  closed-form start, up to three safeguarded Newton/bisection steps). Cycles evaluates erf
  and erf⁻¹ there by fast approximations (``fast_erff``, ``fast_ierff``); envfit uses the
  exact functions, so its Beckmann normals differ from Cycles' by those approximations'
  error. The compiled model's variant 2;
* white (F = 1): Cycles sets no Fresnel for single-scatter GGX and Beckmann
  (``src/kernel/svm/closure.h``); a coloured conductor (η + ik) is given the ``moeller`` form,
  which is not read from Cycles;
* roughness R with α = R² (:data:`ROUGHNESS`: the Principled BSDF, ``src/kernel/svm/
  closure.h``: ``alpha_x = sqr(roughness)``; the Glossy BSDF squares its roughness too, so
  envfit's harness sets roughness √α, ``_render.glossy_bsdf``).

**Multiscatter GGX** (``multiggx``: the default distribution of Blender's Principled BSDF and
Glossy BSDF nodes) — the single-scatter GGX above with ``multiscatter=True``: Cycles 5.0
(``bsdf_microfacet.h``: ``microfacet_ggx_preserve_energy``; ``svm/closure.h``: the Glossy
BSDF with ``CLOSURE_BSDF_MICROFACET_MULTI_GGX_ID`` and the Principled metallic component)
multiplies eval and sample weight by 1/E(√α, μ_i), E its GGX albedo table ``table_ggx_E``
(``src/app/cycles_precompute.cpp``: ``precompute_ggx_E``, the mean of the sample weight over
2²³ Sobol' points on 32 × 32 nodes, clamped to [0, 1]) read by ``lookup_table_read_2D``
(``src/kernel/util/lookup_table.h``: linear in μ between rows, linear in r within a row,
indices truncated). envfit computes that table itself
(:func:`~envfit.shading.microfacet.albedo_table` of this conductor's techniques); its values
and Cycles' own agree at the nodes read to 5 × 10⁻⁴. For a white metal (base colour and
specular tint 1: F82-tint Fresnel ≡ 1, so the multi-bounce Fresnel term is 1) the scale is the
whole change; ``tests/test_render_cycles.py`` renders a white Multiscatter GGX sphere under a
constant map: 1 at every view.
"""
from __future__ import annotations

import math

from envfit.renderers._roughness import RoughnessConvention

__all__ = ["ROUGHNESS", "bsdf", "BSDF_NAMES"]

#: Cycles' roughness R (the Principled BSDF's): α = R²
ROUGHNESS = RoughnessConvention(rule="alpha = R^2", units="Cycles' roughness R, alpha = R^2",
                                alpha_of=lambda r: r * r, roughness_of=math.sqrt)

#: the ``--brdf`` names in Cycles' words (the record's ``bsdf_names``)
BSDF_NAMES = {"multiggx": "Multiscatter GGX (the Principled and Glossy BSDF nodes' default)"}


def bsdf(name: str, alpha: float, **params):
    """The microfacet reflection closure (``name`` ``ggx`` or ``beckmann``; ``params``
    ``eta``, ``k``) or Multiscatter GGX (``multiggx``, white) of microfacet α.

    >>> bsdf("multiggx", 0.2).multiscatter, bsdf("ggx", 0.2).vndf
    (True, 'hemisphere_concentric')
    """
    from envfit.shading.microfacet import Conductor
    technique = {"shadowing": "height_correlated", "vndf": "hemisphere_concentric"}
    if name == "multiggx":
        return Conductor("ggx", alpha, **technique, multiscatter=True, **params)
    return Conductor(name, alpha, **technique, fresnel="moeller", **params)

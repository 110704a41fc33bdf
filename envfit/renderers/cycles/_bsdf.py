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

**The Principled BSDF with metallic 1** (``principled``; ``src/kernel/svm/closure.h``, case
``CLOSURE_BSDF_PRINCIPLED_ID``: the metallic component; ``src/kernel/closure/bsdf_util.h``:
``fresnel_f82``, ``fresnel_f82tint_B``, ``fresnel_f82_Fss``; ``bsdf_microfacet.h``:
``bsdf_microfacet_setup_fresnel_f82_tint``, ``microfacet_ggx_preserve_energy``) — the
Multiscatter GGX closure above with the F82-tint Fresnel of f0 = min(base colour, 1) and the
tint min(specular tint, 1) at cos θ = ω_i·H, its energy scale 1 + F_ms(1 − E)/E with
F_ss = mix(f0, 1, 1/21) − b/126 and E_avg the 32-node ``table_ggx_Eavg`` (``precompute_ggx_E``
times 2μ averaged over μ), which envfit computes by quadrature
(:func:`~envfit.shading.microfacet._multiscatter.average_albedo`). Every other layer has
weight 1 − metallic = 0, so it is the closure's only one. Blender's node defaults
(:data:`PRINCIPLED_PARAMS`, read from bpy 5.0.1: Base Color 0.8, Metallic 0, Roughness 0.5,
IOR 1.5, Specular IOR Level 0.5, Specular Tint 1, distribution Multiscatter GGX) have
metallic 0 — the next paragraph.

**The Principled BSDF with metallic 0** (``principled``, the node's default; ``closure.h``,
case ``CLOSURE_BSDF_PRINCIPLED_ID``: the specular and diffuse components, transmission,
coat, sheen and subsurface at their default weight 0) — two closures, in this order
(:class:`~envfit.shading.microfacet.AlbedoLayered`):

* the *specular* closure: a GGX reflection closure (``bsdf_microfacet_ggx_setup``) of
  η = IOR (or, with Specular IOR Level ℓ ≠ 0.5, f₀ = F₀(IOR)·2ℓ and η = ``ior_from_F0(f₀)``)
  with the generalized-Schlick Fresnel in its "real Fresnel" mode (``exponent = −η``:
  ``generalized_schlick_fresnel``, F = mix(f₀·tint, 1, sat(inverse_lerp(F₀(η), 1,
  ``fresnel_dielectric``(ω_i·H, η))))), Multiscatter GGX's energy scale with
  F_ss = mix(f₀, 1, sat(inverse_lerp(F₀, 1, ``fresnel_dielectric_Fss(η)``)))
  (``bsdf_microfacet_setup_fresnel_generalized_schlick``, ``microfacet_ggx_preserve_energy``:
  the darkening (1 + F_ms(1 − E)/E)·E goes into the closure's weight and sample weight), and
  the sample weight times the albedo estimate mix(f₀, 1, S) (``bsdf_microfacet_estimate_albedo``:
  S from the 16³ table ``table_ggx_gen_schlick_ior_s`` at (√α, μ, √((η − 1)/(η + 1))),
  ``lookup_table_read_3D``; precomputed by ``precompute_ggx_gen_schlick_s`` in
  ``src/app/cycles_precompute.cpp`` as the mean of eval.x/eval.y over 2²⁰ Sobol' points:
  envfit's quadrature, :func:`~envfit.shading.microfacet.blend_factor_table`, agrees with
  the table in ``src/scene/shader.tables`` to 4 × 10⁻⁴ at every node with √α ≥ 1/15);
* the *diffuse* closure (``bsdf_diffuse_setup``: Lambert, ``bsdf_diffuse.h``) of weight
  base colour × ``closure_layering_weight(albedo, weight)`` = c·sat(1 − a), a the specular
  closure's ``bsdf_albedo`` (its weight times the same estimate: equal to its sample weight).

``surface_shader_bsdf_bssrdf_pick`` (``src/kernel/integrator/surface_shader.h``) picks a
closure in proportion to the sample weights by the *third coordinate* of the BSDF's 3-D
request (rescaled for the closure; reflection closures read only the first two);
``surface_shader_bsdf_eval`` and ``_surface_shader_bsdf_eval_mis`` sum every closure's eval
and take the sample-weighted mixture of their pdfs (the lobe choice's mixture). Metallic
strictly between 0 and 1 (three closures) is refused in one line.
"""
from __future__ import annotations

import math

from envfit.renderers._roughness import RoughnessConvention

__all__ = ["ROUGHNESS", "bsdf", "BSDF_NAMES", "PRINCIPLED_PARAMS"]

#: Cycles' roughness R (the Principled BSDF's): α = R²
ROUGHNESS = RoughnessConvention(rule="alpha = R^2", units="Cycles' roughness R, alpha = R^2",
                                alpha_of=lambda r: r * r, roughness_of=math.sqrt)

#: the ``--brdf`` names in Cycles' words (the record's ``bsdf_names``)
BSDF_NAMES = {"multiggx": "Multiscatter GGX (the Principled and Glossy BSDF nodes' default)",
              "principled": "Principled BSDF"}
#: the Principled BSDF node's inputs envfit models, with their defaults (bpy 5.0.1; grey
#: colours)
PRINCIPLED_PARAMS = {"roughness": 0.5, "base_color": 0.8, "metallic": 0.0,
                     "specular_tint": 1.0, "ior": 1.5, "specular_ior_level": 0.5}


def bsdf(name: str, alpha: float, **params):
    """The microfacet reflection closure (``name`` ``ggx`` or ``beckmann``; ``params``
    ``eta``, ``k``), Multiscatter GGX (``multiggx``, white) or the Principled BSDF with
    metallic 0 or 1 (``principled``; ``params`` among :data:`PRINCIPLED_PARAMS`) of
    microfacet α.

    >>> bsdf("multiggx", 0.2).multiscatter, bsdf("ggx", 0.2).vndf
    (True, 'hemisphere_concentric')
    """
    from envfit.shading.microfacet import Conductor
    technique = {"shadowing": "height_correlated", "vndf": "hemisphere_concentric"}
    if name == "multiggx":
        return Conductor("ggx", alpha, **technique, multiscatter=True, **params)
    if name == "principled":
        return _principled_metal(alpha, technique, params)
    return Conductor(name, alpha, **technique, fresnel="moeller", **params)


def _principled_metal(alpha: float, technique: dict, params: dict):
    """The Principled BSDF (module docstring): its metallic closure at metallic 1, its
    specular and diffuse closures at metallic 0; one line for a parameter envfit does not
    model or a metallic between."""
    from envfit.base import ParameterError
    from envfit.shading.microfacet import Conductor
    unknown = sorted(set(params) - set(PRINCIPLED_PARAMS) | ({"roughness"} & set(params)))
    if unknown:
        raise ParameterError(f"Cycles' Principled BSDF: {', '.join(unknown)} is not an input "
                             f"envfit models (roughness is --roughness; the others: "
                             f"{', '.join(k for k in PRINCIPLED_PARAMS if k != 'roughness')})")
    p = {**PRINCIPLED_PARAMS, **{k: float(v) for k, v in params.items()}}
    if p["metallic"] == 0.0:
        return _principled_dielectric(alpha, p)
    if p["metallic"] != 1.0:
        raise ParameterError(f"Cycles' Principled BSDF with metallic {p['metallic']:g}: a "
                             f"metallic closure beside the specular and diffuse ones (three "
                             f"closures) is not modelled; --bsdf-param metallic=0 (the node's "
                             f"default) or metallic=1 predicts it")
    return Conductor("ggx", alpha, **technique, f0=min(max(p["base_color"], 0.0), 1.0),
                     f82_tint=min(max(p["specular_tint"], 0.0), 1.0), multiscatter=True)


def _principled_dielectric(alpha: float, p: dict):
    """The Principled BSDF's specular and diffuse closures at metallic 0 (module docstring):
    η and f₀ from IOR, Specular IOR Level and Specular Tint as ``svm_node_closure_bsdf``
    computes them."""
    from envfit.base import ParameterError
    from envfit.shading.microfacet import AlbedoLayered, f0_of_ior, ior_of_f0
    ior, level = p["ior"], max(p["specular_ior_level"], 0.0)
    if not ior > 1.0:
        raise ParameterError(f"Cycles' Principled BSDF with IOR {ior:g}: envfit models IOR > 1 "
                             f"(a specular layer over the base)")
    f0, eta = f0_of_ior(ior), ior
    if level != 0.5:
        f0 *= 2.0 * level
        eta = ior_of_f0(f0)
    if eta == 1.0:
        raise ParameterError("Cycles' Principled BSDF with Specular IOR Level 0 has no "
                             "specular closure: a diffuse BSDF, not this model")
    tint = max(p["specular_tint"], 0.0)
    return AlbedoLayered(alpha, base_color=min(max(p["base_color"], 0.0), 1.0), eta=eta,
                         f0=min(max(f0 * tint, 0.0), 1.0))

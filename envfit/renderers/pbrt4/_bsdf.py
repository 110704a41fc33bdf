r"""pbrt-v4's microfacet BSDF as envfit builds it (:func:`bsdf`, the record's
:meth:`~envfit.renderers.Renderer.bsdf`) from the techniques of
:mod:`envfit.shading.microfacet`, and its roughness convention (:data:`ROUGHNESS`).

**conductor** (``src/pbrt/bxdfs.h``: ``ConductorBxDF::f``, ``PDF``, ``Sample_f``; pbrt's
``wo`` is the view, envfit's ``wi``) — :class:`~envfit.shading.microfacet.Conductor` with

* the Trowbridge–Reitz (GGX) distribution only (``src/pbrt/util/scattering.h``:
  ``TrowbridgeReitzDistribution::D``, ``Lambda``);
* height-correlated shadowing-masking (``shadowing="height_correlated"``:
  ``TrowbridgeReitzDistribution::G``, ``G1``): eval = ``f`` times ``AbsDot(wi, n)`` =
  F D/(4 cos θ_i (1 + Λ_i + Λ_o)), pdf = D/(4 cos θ_i (1 + Λ_i)) (``PDF``: ``D(wo, wm)``),
  the sample weight F (1 + Λ_i)/(1 + Λ_i + Λ_o) (``Sample_f``);
* the ``hemisphere_polar`` visible-normal warp (``TrowbridgeReitzDistribution::Sample_wm``:
  Heitz 2018 in the hemisphere configuration, ``SampleUniformDiskPolar`` of
  ``src/pbrt/util/sampling.h``, m_z ≥ 1e-6); the compiled model's variant 1;
* the ``complex`` Fresnel form with η + ik (``scattering.h``: ``FrComplex``);
* roughness R with α = √R (:data:`ROUGHNESS`: ``remaproughness`` true by default,
  ``TrowbridgeReitzDistribution::RoughnessToAlpha``), α ≥ 1e-4 as the distribution clamps it.
"""
from __future__ import annotations

import math

from envfit.base import ParameterError
from envfit.renderers._roughness import RoughnessConvention

__all__ = ["ROUGHNESS", "bsdf"]

#: pbrt-v4's roughness R: α = √R (``remaproughness``, its default)
ROUGHNESS = RoughnessConvention(rule="alpha = sqrt(R)",
                                units="pbrt-v4's roughness R, alpha = sqrt(R)",
                                alpha_of=math.sqrt, roughness_of=lambda a: a * a)


def bsdf(name: str, alpha: float, **params):
    """The ``conductor`` (``name`` ``ggx``: pbrt-v4 has no other distribution; ``params``
    ``eta``, ``k``) of microfacet α.

    >>> bsdf("ggx", 0.2).vndf
    'hemisphere_polar'
    """
    from envfit.shading.microfacet import Conductor
    if name != "ggx":
        raise ParameterError("pbrt-v4's conductor has only the GGX (Trowbridge-Reitz) "
                             f"distribution, got {name!r}")
    return Conductor(name, alpha, shadowing="height_correlated", vndf="hemisphere_polar",
                     fresnel="complex", **params)

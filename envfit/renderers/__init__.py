r"""The renderers envfit predicts — Mitsuba 3, pbrt-v4, Cycles and envfit's own rules — one
folder each, holding everything envfit knows of that renderer, read from its source
(file:function @ commit in every docstring).

A renderer (:class:`Renderer`, from :func:`get_renderer` / :data:`RENDERERS`) holds the
renderer's environment-map technique (radiance lookup, sampling warp and density as the
renderer builds them: :class:`Mitsuba3Envmap`, :class:`Pbrt4ImageInfiniteLight`,
:class:`CyclesBackground`, :class:`EnvfitMapTechnique`), its cosine BSDF sampling map and
tangent frame, its MIS heuristic, the integrator settings per strategy (``map``, ``brdf``,
``mis``; which of them the renderer can render), its microfacet BSDFs built from the
techniques of :mod:`envfit.shading.microfacet` (:meth:`Renderer.bsdf`) and its roughness
convention (:attr:`Renderer.roughness`), its samplers by their own names with the
spp each runs and a randomisation tag (:data:`RANDOMISATIONS`), the scene text a user
pastes (:meth:`Renderer.snippet`), and where the renderer installs here, the harness that
renders envfit's measurement with it (:class:`Mitsuba3Sphere`, :class:`CyclesSphere`).

Which coordinate of the square sample drives what (each as the renderer's source does it):

=========  ==============================================  ===================================
renderer   ``u[:, 0]``                                     ``u[:, 1]``
=========  ==============================================  ===================================
mitsuba3   column (φ) at each 2 × 2 level, then x in the   row (θ) at each level, first; then
           leaf patch (``Hierarchical2D::sample``)          y in the leaf patch
pbrt4      column of the equal-area square (conditional)   row of the square (marginal)
cycles     ``rand.x``: column / u (φ) (conditional)         ``rand.y``: row / v (θ) (marginal)
envfit     row (θ) (marginal, :class:`MapSampler`)          column (φ)
=========  ==============================================  ===================================

Folders and modules:

* ``_base`` — the renderer record and its technique protocol, the sampler and strategy
  records (a sampler's variant of a randomisation — its strata, its hashed permutations'
  :class:`PermutationLaw` — is an option value its record gives the exact model), the
  concentric cosine map, the power and balance heuristics.
* ``_registry`` — :data:`RENDERERS`, :func:`get_renderer`: one line per renderer.
* ``_roughness`` — a renderer's roughness convention (:class:`RoughnessConvention`: its
  roughness R → the microfacet α, its range and words).
* ``_sphere`` — renderer-independent measurement: a white sphere rendered from six
  orthographic views, each pixel kept in the view nearest its normal and weighted 1/(n·v),
  so the weighted pixels sample normals uniformly; the RMSE with the reference's own
  variance subtracted and its bootstrap interval (:class:`SphereMeasurement`).
* ``_reference`` — the high-spp reference renders, cached on disk (verified, atomic).
* ``mitsuba3/`` — Mitsuba 3.9.1: ``_envmap`` (``envmap``: ``Hierarchical2D`` warp of a
  bilinear density, and ``direct``), ``_kensler`` (``multijitter``'s hashed permutations and
  grid), ``_bsdf`` (``roughconductor``, ``roughplastic``, α itself), ``_render`` (the
  renders, ``scalar_rgb``).
* ``pbrt4/`` — pbrt-v4: ``_light`` (``ImageInfiniteLight``, equal-area square image,
  compensated ``PiecewiseConstant2D``), ``_equal_area`` (``imgtool makeequiarea``),
  ``_bsdf`` (the GGX ``conductor``, α = √R).
* ``cycles/`` — Cycles 5.0: ``_background`` (the world light, importance map at ≥ 4096 ×
  2048 under Auto), ``_bsdf`` (the microfacet closure and Multiscatter GGX, α = R²),
  ``_scene`` (the scene text), ``_render`` (the renders through ``bpy``).
* ``envfit/`` — envfit's own MapSampler, lobe sampling and balance MIS.

Adding a renderer is a folder holding its record and one line in ``_registry``.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules (nor Mitsuba, nor bpy).

Example
-------
>>> from envfit.renderers import get_renderer
>>> r = get_renderer("mitsuba3")
>>> r.sampler("ldsampler").spp(32), r.sampler("multijitter").spp(32)
(64, 35)
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "RANDOMISATIONS": "_base", "PAIRINGS": "_base", "STRATEGY_NAMES": "_base",
    "DirectionSample": "_base", "EnvmapTechnique": "_base", "PermutationLaw": "_base",
    "Renderer": "_base", "FilmWarp": "_film", "BOX_FILTER": "_film", "film_of": "_film",
    "SamplerSpec": "_base", "StrategySetting": "_base", "concentric_disk": "_base",
    "cosine_hemisphere": "_base", "power_heuristic": "_base", "balance_heuristic": "_base",
    "Hierarchical2D": "mitsuba3._envmap", "Mitsuba3Envmap": "mitsuba3._envmap",
    "mitsuba_frame": "mitsuba3._envmap",
    "KENSLER_PERMUTATIONS": "mitsuba3._kensler", "multijitter_shape": "mitsuba3._kensler",
    "permute_kensler": "mitsuba3._kensler",
    "Pbrt4ImageInfiniteLight": "pbrt4._light", "pbrt_sphere_frame": "pbrt4._light",
    "pbrt_strata": "pbrt4._light",
    "equal_area_square_to_sphere": "pbrt4._equal_area",
    "equal_area_sphere_to_square": "pbrt4._equal_area",
    "wrap_equal_area_square": "pbrt4._equal_area", "PiecewiseConstant2D": "pbrt4._equal_area",
    "make_equal_area": "pbrt4._equal_area",
    "CyclesBackground": "cycles._background", "cycles_map_resolution": "cycles._background",
    "cycles_frame": "cycles._background",
    "EnvfitMapTechnique": "envfit._technique",
    "RENDERERS": "_registry", "get_renderer": "_registry", "renderer_names": "_registry",
    "RoughnessConvention": "_roughness", "ROUGHNESS_RTOL": "_roughness",
    "BOOTSTRAP_RESAMPLES": "_sphere", "SphereError": "_sphere", "SphereGeometry": "_sphere",
    "SphereMeasurement": "_sphere", "SphereView": "_sphere", "VIEWS": "_sphere",
    "sphere_error": "_sphere", "sphere_geometry": "_sphere", "sphere_mean": "_sphere",
    "view_normals": "_sphere", "view_seeds": "_sphere", "LAYOUTS": "_sphere",
    "ReferencePair": "_reference", "cached_reference": "_reference", "map_digest": "_reference",
    "MITSUBA_SAMPLERS": "mitsuba3._render", "Mitsuba3Options": "mitsuba3._render",
    "Mitsuba3Sphere": "mitsuba3._render", "mitsuba_normals": "mitsuba3._render",
    "roughconductor_bsdf": "mitsuba3._render", "roughplastic_bsdf": "mitsuba3._render",
    "principled_bsdf": "mitsuba3._render",
    "glossy_bsdf": "cycles._render",
    "CYCLES_PATTERNS": "cycles._render", "CyclesOptions": "cycles._render",
    "CyclesSphere": "cycles._render", "cycles_normals": "cycles._render",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "FrameScene": "_frame",
    "FrameBsdf": "_frame",
    "TwoLobes": "_frame",
    "HIT_SURFACE": "_frame",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

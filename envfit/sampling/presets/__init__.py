r"""Renderer presets of the environment-map estimator: Mitsuba 3, pbrt-v4, Cycles and envfit
itself, each read from the renderer's source (file:function @ commit in every docstring).

A preset (:class:`RendererPreset`, from :func:`preset` / :data:`PRESETS`) holds the
renderer's environment-map technique (radiance lookup, sampling warp and density as the
renderer builds them: :class:`Mitsuba3Envmap`, :class:`Pbrt4ImageInfiniteLight`,
:class:`CyclesBackground`, :class:`EnvfitMapTechnique`), its cosine BSDF sampling map and
tangent frame, its MIS heuristic, the integrator settings per strategy (``map``, ``brdf``,
``mis``; which of them the renderer can render), its samplers by their own names with the
spp each runs and a randomisation tag (:data:`RANDOMISATIONS`), and the scene text a user
pastes (:meth:`RendererPreset.snippet`).

Which coordinate of the square sample drives what (each as the renderer's source does it):

=========  ==============================================  ===================================
preset     ``u[:, 0]``                                     ``u[:, 1]``
=========  ==============================================  ===================================
mitsuba3   column (φ) at each 2 × 2 level, then x in the   row (θ) at each level, first; then
           leaf patch (``Hierarchical2D::sample``)          y in the leaf patch
pbrt4      column of the equal-area square (conditional)   row of the square (marginal)
cycles     ``rand.x``: column / u (φ) (conditional)         ``rand.y``: row / v (θ) (marginal)
envfit     row (θ) (marginal, :class:`MapSampler`)          column (φ)
=========  ==============================================  ===================================

Modules:

* ``_base`` — the technique protocol, the preset and sampler records, the concentric
  cosine map, the power and balance heuristics.
* ``_mitsuba3`` — Mitsuba 3.9.1 ``envmap`` (``Hierarchical2D`` warp of a bilinear density)
  and ``direct``.
* ``_pbrt4`` / ``_pbrt4_image`` — pbrt-v4 ``ImageInfiniteLight`` (equal-area square image,
  compensated ``PiecewiseConstant2D``) and ``imgtool makeequiarea``.
* ``_cycles`` — Cycles 5.0 world light (importance map at ≥ 4096 × 2048 under Auto).
* ``_envfit`` — envfit's own MapSampler, lobe sampling and balance MIS.
* ``_registry`` — :data:`PRESETS`, :func:`preset`.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.

Example
-------
>>> from envfit.sampling.presets import preset
>>> p = preset("mitsuba3")
>>> p.sampler("ldsampler").spp(32), p.sampler("multijitter").spp(32)
(64, 35)
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {
    "RANDOMISATIONS": "_base", "PAIRINGS": "_base", "STRATEGY_NAMES": "_base",
    "DirectionSample": "_base", "EnvmapTechnique": "_base", "RendererPreset": "_base",
    "SamplerSpec": "_base", "StrategySetting": "_base", "concentric_disk": "_base",
    "cosine_hemisphere": "_base", "power_heuristic": "_base", "balance_heuristic": "_base",
    "Hierarchical2D": "_mitsuba3", "Mitsuba3Envmap": "_mitsuba3", "mitsuba_frame": "_mitsuba3",
    "Pbrt4ImageInfiniteLight": "_pbrt4", "pbrt_sphere_frame": "_pbrt4",
    "equal_area_square_to_sphere": "_pbrt4_image", "equal_area_sphere_to_square": "_pbrt4_image",
    "wrap_equal_area_square": "_pbrt4_image", "PiecewiseConstant2D": "_pbrt4_image",
    "make_equal_area": "_pbrt4_image",
    "CyclesBackground": "_cycles", "cycles_map_resolution": "_cycles", "cycles_frame": "_cycles",
    "EnvfitMapTechnique": "_envfit",
    "PRESETS": "_registry", "preset": "_registry", "preset_names": "_registry",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

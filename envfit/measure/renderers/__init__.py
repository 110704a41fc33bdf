r"""Measuring a real renderer's shading error: a white diffuse sphere rendered from six
orthographic views, each pixel kept in the view nearest its normal and weighted 1/(n·v), so
the weighted pixels sample normals uniformly — the RMSE over uniform axes that envfit
predicts (issue 24; ``/work/shared/notes/real-renderers.md`` in the project's notes).

Modules (private):

* ``_sphere`` — renderer-independent: the six views, per-pixel normals and weights, the RMSE
  with the reference's own variance subtracted and its bootstrap interval
  (:class:`SphereMeasurement`).
* ``_reference`` — the high-spp reference renders, cached on disk (verified, atomic).
* ``_mitsuba3`` — the renders with Mitsuba 3 (``scalar_rgb``): :class:`Mitsuba3Sphere`.
* ``_cycles`` — the renders with Blender's Cycles through ``bpy``: :class:`CyclesSphere`.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules (nor Mitsuba, nor bpy).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {
    "BOOTSTRAP_RESAMPLES": "_sphere", "SphereError": "_sphere", "SphereGeometry": "_sphere",
    "SphereMeasurement": "_sphere", "SphereView": "_sphere", "VIEWS": "_sphere",
    "sphere_error": "_sphere", "sphere_geometry": "_sphere", "sphere_mean": "_sphere",
    "view_normals": "_sphere", "view_seeds": "_sphere", "LAYOUTS": "_sphere",
    "ReferencePair": "_reference", "cached_reference": "_reference", "map_digest": "_reference",
    "MITSUBA_SAMPLERS": "_mitsuba3", "Mitsuba3Options": "_mitsuba3",
    "Mitsuba3Sphere": "_mitsuba3", "mitsuba_normals": "_mitsuba3",
    "roughconductor_bsdf": "_mitsuba3", "roughplastic_bsdf": "_mitsuba3",
    "glossy_bsdf": "_cycles",
    "CYCLES_PATTERNS": "_cycles", "CyclesOptions": "_cycles", "CyclesSphere": "_cycles",
    "cycles_normals": "_cycles",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

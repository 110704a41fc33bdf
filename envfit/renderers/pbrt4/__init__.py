"""pbrt-v4 (mmp/pbrt-v4 @ 5f7a606806a4), as envfit reads it from its source: everything envfit
assumes pbrt-v4 does, and where each assumption is held (nothing rendered: it is not
built here).

* **Emitter** — ``ImageInfiniteLight`` on the equal-area square of ``imgtool
  makeequiarea`` (``_equal_area``): :class:`Pbrt4ImageInfiniteLight` in ``_light`` with its
  compensated ``PiecewiseConstant2D`` and a compiled ``eval_pdf`` / ``bsdf_lookup``.
* **Integrators** — ``simplepath`` for one technique, ``path`` for MIS, power heuristic
  (the record's strategies).
* **Samplers** — ``zsobol`` (default), ``paddedsobol``, ``sobol``, ``pmj02bn``, ``halton``,
  ``stratified`` (x × y strata), ``independent`` (``_light.SAMPLERS``).
* **BSDFs** — white ``diffuse`` (:func:`pbrt_sphere_frame`); the conductor with the
  Trowbridge–Reitz (GGX) distribution only, height-correlated G, roughness R and α = √R
  (:class:`envfit.shading.microfacet.Conductor` ``renderer="pbrt4"``, ``_vndf``'s
  ``_sample_pbrt``).
* **Scene text** — the scene lines and the conversion command (``_light._snippet``).

The folder's record is :data:`PBRT4` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {"PBRT4": "_light"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

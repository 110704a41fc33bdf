"""Mitsuba 3 (3.9.1, ``scalar_rgb``; mitsuba-renderer/mitsuba3 @ 478e193a183c), as envfit reads
it from its source: everything envfit assumes Mitsuba does, and where each assumption is
held.

* **Emitter** ``envmap`` — :class:`Mitsuba3Envmap` in ``_envmap``: bilinear radiance,
  the ``Hierarchical2D`` warp of the luminance × sin θ vertex grid (``mis_compensation``
  optional), ``sample_direction`` / ``pdf_direction``; its compiled form (same arithmetic)
  in ``_compiled`` (``sample_table``, ``bsdf_lookup``, ``eval_pdf``).
* **Integrators** — ``path`` at its defaults for MIS (Mitsuba's default integrator: one
  emitter and one BSDF sample per bounce, power heuristic; on the lone sphere only the first
  bounce plays) and ``direct`` with one technique's sample for emitter-only and BSDF-only
  sampling (the record's strategies, ``_envmap.STRATEGIES``); where each draws its samples
  among the sampler's dimensions (``_envmap._path_draws``, ``_envmap._direct_draws``).
* **Samplers** — ``independent`` (default), ``stratified``, ``multijitter``, ``ldsampler``,
  ``orthogonal`` with the spp each runs (``_envmap.SAMPLERS``); ``ldsampler``'s points in
  its own order (``_ldsampler``: TEA, ``permute``), which the film footprint's model reads.
* **BSDFs** — white ``diffuse`` (cosine sampling, :func:`mitsuba_frame`); ``roughconductor``
  GGX / Beckmann with separable G and ``smith_g1`` view masking, visible normals as
  ``MicrofacetDistribution::sample``, α its own parameter
  (:class:`envfit.shading.microfacet.Conductor` ``renderer="mitsuba3"``, ``_vndf``'s
  ``_sample_mitsuba``); ``roughplastic`` (:class:`envfit.shading.microfacet.RoughPlastic`),
  modelled for the samplers of the record's ``microfacet``.
* **Scene text and renders** — the snippet (``_envmap._snippet``: Python dict or XML), the
  rendered measurement of envfit's sphere (``_render``: :class:`Mitsuba3Sphere`,
  ``version``, ``open_sphere``).

The folder's record is :data:`MITSUBA3` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {"MITSUBA3": "_envmap"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

"""Blender's Cycles (5.0; blender/cycles @ 2eba41024174, rendered with bpy 5.0.1 and 5.3.0),
as envfit reads it from its source: everything envfit assumes Cycles does, and where each
assumption is held. The files read are unchanged for this scene in v5.1.0 and on main @
97dbe6f57 (2026-07-13, the newest source here) but for a texture-cache ``.tx`` map (main
only), which the model does not cover; bpy 5.3.0 was checked by rendering
(``docs/renderers.md``, "Newer releases").

* **Emitter** — the world light: :class:`CyclesBackground` in ``_background`` (the
  importance map at ≥ 4096 × 2048 under Auto, ``background_cdf`` by the absolute
  radiance, linear or closest lookup; compiled ``bsdf_lookup`` and ``eval_pdf``, bit for
  bit the numpy form).
* **Integrator** ``path`` at 1 bounce — light and BSDF samples combined by the power
  heuristic; emitter-only sampling is not renderable (the record's strategies).
* **Samplers** — ``tabulated_sobol`` (the factory default) and ``sobol_burley``:
  Owen-scrambled Sobol' prefixes, any spp (``_background.SAMPLERS``): the ``owen`` model, the
  record's ``prefix`` (the sample index shuffled by ``nested_uniform_scramble``). Cycles
  scrambles with a hash (``intern/cycles/kernel/sample/util.h``: ``nested_uniform_scramble`` =
  bit reversal, ``reversed_bit_owen`` — Vegdahl's improved Laine–Karras hash — and reversal
  back; ``sobol_burley.h`` seeds it per pixel and dimension; ``tabulated_sobol.h`` reads 256
  tables scrambled so), which the model takes as nested uniform scrambling; the light's and the
  BSDF's dimensions are scrambled apart (pairing ``independent``). ``blue_noise`` (what
  *Automatic* renders a final frame with) is not per pixel: one sequence with fixed-seed
  scrambles, each pixel a run of it (``_patterns``: :data:`~._patterns.BLUE_NOISE`), the
  ``shared_sequence`` randomisation, drawn at every spp.
* **BSDFs** — white ``diffuse`` (:func:`cycles_frame`); in ``_bsdf`` (the record's ``bsdf``,
  ``roughness``): Glossy GGX / Beckmann (:class:`envfit.shading.microfacet.Conductor` with
  height-correlated G, the ``hemisphere_concentric`` visible-normal warp —
  ``microfacet_ggx_sample_vndf``: hemisphere, concentric disk, m_z ≥ 0; Beckmann by
  ``microfacet_beckmann_sample_vndf``'s safeguarded Newton/bisection, exact erf and erf⁻¹
  where Cycles uses ``fast_erff`` / ``fast_ierff``; the compiled model's variant 2;
  ``src/kernel/closure/bsdf_microfacet.h``), roughness R and α = R² (the Glossy BSDF's
  roughness √α in the harness, ``_render.glossy_bsdf``); Multiscatter GGX (``multiggx``) as
  an energy scale on it, 1/E of its own albedo table; the Principled BSDF (``principled``) at
  metallic 1 (the F82-tint metal) and at metallic 0, its default (a dielectric GGX closure
  over a Lambert one: :class:`envfit.shading.microfacet.AlbedoLayered`), the closure picked by
  the third coordinate of the BSDF's 3-D request (``_patterns.first_hit_points``: the record's
  ``film_points`` and ``lobe_points`` of Tabulated Sobol and Sobol–Burley).
* **Scene text and renders** — the bpy snippet (``_scene``), the rendered measurement through
  ``bpy`` (``_render``: :class:`CyclesSphere`, ``version``, ``open_sphere``).

The folder's record is :data:`CYCLES` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {"CYCLES": "_background"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

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
  ``orthogonal`` with the spp each runs (``_envmap.SAMPLERS``), each with the exact model of
  its randomisation and the options the record hands it (``src/samplers/*.cpp``):

  - ``stratified`` — r × r jittered strata, spp rounded up to a square
    (``StratifiedSampler::set_sample_count``): ``jittered`` with ``r``;
  - ``multijitter`` — Kensler's correlated multi-jittering on the grid
    (⌈spp/⌊√spp⌋⌉, ⌊√spp⌋) (``MultijitterSampler::set_sample_count``, ``next_2d``), its
    permutations ``permute_kensler`` (``include/mitsuba/core/random.h``) with the seeds
    ``perm_seed · 0x68bc21eb`` and ``perm_seed · 0x02e5be93``: ``cmj`` with ``nx``, ``ny``
    and ``permutations`` = :data:`_kensler.KENSLER_PERMUTATIONS` (``_kensler``: the port of
    ``permute_kensler``, the pair tables of its permutations, ``multijitter_shape``);
  - ``ldsampler`` — the (0, 2)-sequence (``include/mitsuba/core/qmc.h``:
    ``radical_inverse_2``, ``sobol_2``) XOR one per-pixel scramble
    ``sample_tea_32(seed, 0x98bc51ab)`` for every 2-D dimension, each dimension only permuting
    the order (``LowDiscrepancySampler::next_2d``, ``permute``): ``digital_shift``, pairing
    ``same_net_permuted``; its points in its own order (``_ldsampler``: TEA, ``permute``;
    film x right, y down), which the film footprint's model reads;
  - ``orthogonal`` — a Bose orthogonal array of strength 2 (``OrthogonalSampler::bose``; the
    index permuted once by ``permute_kensler``, which only reorders; stratum and sub-stratum
    of each dimension permuted by a per-pixel, per-dimension ``permute_kensler``; fresh
    jitter; ``next_2d`` two ``next_1d``): ``orthogonal`` with the dimension of each draw
    (the strategies' ``dimensions``), over uniform permutations (``tests/
    test_randomisation_orthogonal.py`` measures the difference Kensler's hashes make);
  - the 1-D draws (``next_1d``) — ``stratified``, ``multijitter``: ``(permute_kensler(i, N,
    seed_d) + jitter) / N``; ``ldsampler``: ``radical_inverse_2(permute(i, N, seed_d),
    scramble)``: N strata, one point each (the ``roughplastic`` lobe choice's model,
    ``STRATIFIED_1D``).
* **BSDFs** — white ``diffuse`` (cosine sampling, :func:`mitsuba_frame`); in ``_bsdf``
  (the record's ``bsdf``, ``roughness``): ``roughconductor`` GGX / Beckmann
  (:class:`envfit.shading.microfacet.Conductor` with separable G and ``smith_g1`` view
  masking, the ``slope_space`` visible-normal warp of ``MicrofacetDistribution::sample`` —
  the compiled model's variant 0 —, Moeller's conductor Fresnel, the weight
  ``smith_g1(wo, m)``; ``src/bsdfs/roughconductor.cpp``), α its own parameter;
  ``roughplastic`` (:class:`envfit.shading.microfacet.RoughPlastic`,
  ``src/bsdfs/roughplastic.cpp``: ``sample1`` < ``prob_specular`` picks the specular lobe,
  ``sample2`` the direction), modelled for the samplers of the record's ``microfacet``.
* **Scene text and renders** — the snippet (``_envmap._snippet``: Python dict or XML), the
  rendered measurement of envfit's sphere (``_render``: :class:`Mitsuba3Sphere`,
  ``version``, ``open_sphere``).

The folder's record is :data:`MITSUBA3` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {"MITSUBA3": "_envmap"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

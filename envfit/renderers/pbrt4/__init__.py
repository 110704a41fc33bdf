"""pbrt-v4 (mmp/pbrt-v4 @ 5f7a606806a4), as envfit reads it from its source: everything envfit
assumes pbrt-v4 does, and where each assumption is held. Rendered by ``bench/pbrt4_check.py``
with pbrt-v4 built from that commit (docs/validation.md): with its wavelengths fixed
(``--disable-wavelength-jitter``) the estimator's noise is the model's; by default pbrt-v4 is
spectral, four wavelengths drawn per camera sample, and that noise is not in the model.

* **Emitter** — ``ImageInfiniteLight`` on the equal-area square of ``imgtool
  makeequiarea`` (``_equal_area``): :class:`Pbrt4ImageInfiniteLight` in ``_light`` with its
  compensated ``PiecewiseConstant2D`` and a compiled ``eval_pdf`` / ``bsdf_lookup``.
* **Integrators** — ``simplepath`` for one technique, ``path`` for MIS, power heuristic
  (the record's strategies).
* **Samplers** — ``zsobol`` (default), ``paddedsobol``, ``sobol``, ``pmj02bn``, ``halton``,
  ``stratified`` (x × y strata), ``independent`` (``_light.SAMPLERS``; ``src/pbrt/samplers.h``,
  ``samplers.cpp``), each with the exact model of its randomisation and the options the
  record hands it:

  - ``zsobol``, ``paddedsobol``, ``sobol`` — the Sobol' (0, 2)-sequence
    (``src/pbrt/util/sobolmatrices.cpp``: ``SobolMatrices32``, dimension 0 the identity
    columns, dimension 1 the Pascal matrix; ``SobolSample`` XORs the columns) under the
    hashed Owen scramblers (``FastOwenScrambler``, the default, and ``OwenScrambler``): the
    ``owen`` model; ``paddedsobol`` runs any spp, its points the first spp of a net after
    ``PermutationElement(sampleIndex, samplesPerPixel)`` (``PaddedSobolSampler::Get2D``:
    the record's ``prefix``); the light's and the BSDF's dimensions scrambled apart (pairing
    ``independent``); the ``randomize "permutedigits"`` option (not modelled) would be a
    digital shift in base 2;
  - ``stratified`` — x × y strata, x = spp/d, d the largest divisor ≤ √spp
    (``StratifiedSampler::Create``; ``Get2D``: ``(x + dx)/xPixelSamples``, x along u_0):
    ``jittered`` with ``strata`` = :func:`_light.pbrt_strata`;
  - ``pmj02bn`` — ``cp_shift``; ``independent`` — ``independent``.
* **BSDFs** — white ``diffuse`` (:func:`pbrt_sphere_frame`); in ``_bsdf`` (the record's
  ``bsdf``, ``roughness``): the conductor with the Trowbridge–Reitz (GGX) distribution only
  (:class:`envfit.shading.microfacet.Conductor` with height-correlated G, the
  ``hemisphere_polar`` visible-normal warp — ``TrowbridgeReitzDistribution::Sample_wm`` of
  ``src/pbrt/util/scattering.h``, ``SampleUniformDiskPolar``, m_z ≥ 1e-6; the compiled
  model's variant 1 —, ``FrComplex``; the weight G2/G1, ``src/pbrt/bxdfs.h``:
  ``ConductorBxDF::Sample_f``), roughness R and α = √R.
* **Scene text** — the scene lines and the conversion command (``_light._snippet``).

The folder's record is :data:`PBRT4` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {"PBRT4": "_light"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

r"""A real renderer's noise, predicted from its own estimator (the renderer's record,
:mod:`envfit.renderers`) and its sampler's exact randomisation (:mod:`.randomisation`).

Modules:

* :mod:`~envfit.predict.renderer._preset_model` — a real renderer's noise on a white diffuse
  surface (its own estimator, its sampler's exact randomisation); its integrand tables
  (``_preset_integrand``), its cells as the renderer runs them (``_preset_request``), the
  nets a pass samples (``_sampled_nets``) and the model's own error (``_model_error``).
* :mod:`~envfit.predict.renderer._microfacet_model` — the same for a rough conductor or a
  rough plastic (GGX, Beckmann), per frame (normal, view): view-dependent; its compiled loops
  (``_microfacet_kernels``, ``_vndf_kernels``, ``_plastic_kernels``), a two-lobe BSDF's cells
  (``_lobe_parts``) and the view-angle bands (``_bands``).
* :mod:`~envfit.predict.renderer._frames` — the frames it averages over: a render's pixels,
  or views in a band of polar angles.
* :mod:`~envfit.predict.renderer._footprint` — a rendered pixel's footprint: the normals it
  spans and the variance its film position adds.
* :mod:`~envfit.predict.renderer.randomisation` — the exact MSE of every randomisation of a
  pixel's N points (independent, jittered, CMJ, digital shift, Owen, CP shift, orthogonal
  arrays) from one dyadic grid of the warped integrand.

envfit's own rules (its renderer rows) are predicted by :mod:`envfit.predict.warped`.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "PresetModel": "_preset_model", "PresetModelOptions": "_preset_model",
    "PresetPrediction": "_preset_model",
    "MicrofacetModel": "_microfacet_model", "band_frames": "_frames",
    "pixel_frames": "_frames", "pixel_footprints": "_footprint",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "BsdfTable": "_preset_integrand",
    "MapTable": "_preset_integrand",
    "midpoints": "_preset_integrand",
    "preset_request": "_preset_model",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

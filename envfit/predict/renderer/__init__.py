r"""A real renderer's noise, predicted from its own estimator (the renderer's record,
:mod:`envfit.renderers`) and its sampler's exact randomisation (:mod:`.randomisation`).

Modules:

* :mod:`~envfit.predict.renderer._diffuse_model` — a real renderer's noise on a white diffuse
  surface (its own estimator, its sampler's exact randomisation); its integrand tables
  (``_integrand_tables``), its cells as the renderer runs them (``_cell_request``), the
  nets a pass samples (``_sampled_nets``) and the model's own error (``_model_error``).
* :mod:`~envfit.predict.renderer._microfacet_model` — the same for a rough conductor or a
  rough plastic (GGX, Beckmann), per frame (normal, view): view-dependent; its compiled loops
  (``_microfacet_kernels``, ``_vndf_kernels``, ``_plastic_kernels``), a two-lobe BSDF's cells
  (``_lobe_parts``) and the view-angle bands (``_bands``).
* :mod:`~envfit.predict.renderer._adaptive` — a renderer's adaptive sampling on the white
  diffuse surface: for a noise threshold, the samples each pixel spends and the error left,
  by running the renderer's own test on its own points (:class:`AdaptiveModel`).
* :mod:`~envfit.predict.renderer._frames` — the frames it averages over: a render's pixels,
  or views in a band of polar angles.
* :mod:`~envfit.predict.renderer._footprint` — a rendered pixel's footprint: the normals it
  spans and the variance its film position adds.
* :mod:`~envfit.predict.renderer.randomisation` — the exact MSE of every randomisation of a
  pixel's N points (independent, jittered, CMJ, digital shift, Owen, CP shift, orthogonal
  arrays) from one dyadic grid of the warped integrand.

envfit's own rules (its renderer rows) are predicted by :mod:`envfit.predict.warped`.

The former names ``PresetModel``, ``PresetModelOptions`` and ``PresetPrediction`` (of
``DiffuseModel``, ``RendererModelOptions``, ``RendererPrediction``) still resolve, as aliases
outside ``__all__``.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "DiffuseModel": "_diffuse_model", "RendererModelOptions": "_diffuse_model",
    "RendererPrediction": "_diffuse_model",
    # the former names, kept as aliases
    "PresetModel": "_diffuse_model", "PresetModelOptions": "_diffuse_model",
    "PresetPrediction": "_diffuse_model",
    "MicrofacetModel": "_microfacet_model", "band_frames": "_frames",
    "AdaptiveModel": "_adaptive", "AdaptiveOptions": "_adaptive",
    "AdaptivePrediction": "_adaptive",
    "pixel_frames": "_frames", "pixel_footprints": "_footprint",
}

#: the former names: they resolve, but the supported names are the new ones
_FORMER = ("PresetModel", "PresetModelOptions", "PresetPrediction")

__all__ = sorted(k for k in _LAZY if k not in _FORMER)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "BsdfTable": "_integrand_tables",
    "MapTable": "_integrand_tables",
    "midpoints": "_integrand_tables",
    "cell_request": "_diffuse_model",
    "strata_reach": "_drawn_strata",
    "lobe_choice_modelled": "_lobe_parts",
    "compiled_layered": "_layered_kernels",
    "layered_eval_pdf": "_layered_kernels",
    "layered_sample": "_layered_kernels",
    "layered_views": "_layered_kernels",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

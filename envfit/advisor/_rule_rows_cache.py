r"""The advisor's cache of the renderer model: each warped spectrum of
:class:`envfit.predict.RendererModel` (one per map, lobe, grid, axes and technique) stored in
the :class:`~envfit.advisor._cache.AdviseCache` by :meth:`WarpedSpectrum.to_json` under
:func:`spectrum_cache_key`, read back by :meth:`WarpedSpectrum.from_json`, the missing ones
computed by :func:`envfit.predict.renderer_model`. The model is what the renderer predictors
read from :attr:`envfit.predict.PredictionContext.renderer`.
"""
from __future__ import annotations

from envfit.advisor._cache import AdviseCache
from envfit.base import ParameterError
from envfit.base import progress_bar
from envfit.measure import RendererSetup
from envfit.predict import RendererModel, WarpedSpectrum, renderer_model
from envfit.predict.warped import SPECTRUM_FORMAT
from envfit.sampling import STRATEGIES

__all__ = ["spectrum_cache_key", "source_cost", "cached_renderer_model"]


def spectrum_cache_key(map_key: dict, brdf: str, shininess: float | None, grid: int, axes: int,
                       technique: str, on_rest: bool, source_pixels: int) -> dict:
    """The cache key of one spectrum: the map's key (fingerprint, shape, up, scale), the lobe,
    the grid and axes, the technique, whether on the rest map, the sources' pixel count, and
    the spectrum algorithm's version (:data:`envfit.predict.warped._warped_spectrum.SPECTRUM_FORMAT`)."""
    return {**map_key, "spectrum_format": SPECTRUM_FORMAT, "brdf": brdf, "shininess": None if brdf == "diffuse" else shininess,
            "grid": int(grid), "axes": int(axes), "technique": technique,
            "on_rest": bool(on_rest), "source_pixels": int(source_pixels)}


def source_cost(setup: RendererSetup) -> int:
    """The exact source integral's cost per shading point: the source pixels it visits,
    ``sum(pixels)`` over ``setup.sources``."""
    return int(sum(s.summary()["pixels"] for s in setup.sources))


def cached_renderer_model(setup: RendererSetup, map_key: dict, brdf: str, shininess: float,
                          strategies, grid: int, axes: int, store: AdviseCache, *,
                          quiet: bool = True) -> tuple[RendererModel, int, int]:
    """The :class:`RendererModel` of ``strategies`` with each spectrum from the cache or
    computed (:func:`renderer_model`) and saved; (model, spectra loaded, spectra computed).

    A cached entry that does not parse as a spectrum is recomputed with a note in
    ``store.notes`` (checksum failures are noted by the cache itself); a progress bar over
    the spectra computed unless ``quiet``."""
    pixels = source_cost(setup)
    spectra, missing = {}, []
    for s in strategies:
        tech, rest = STRATEGIES[s]
        if (tech, rest) in spectra or s in missing:
            continue
        key = spectrum_cache_key(map_key, brdf, shininess, grid, axes, tech, rest, pixels)
        doc = store.load("renderer", key)
        if doc is not None:
            try:
                spectra[(tech, rest)] = WarpedSpectrum.from_json(doc)
                continue
            except ParameterError as exc:
                store.notes.append(f"cache: recomputed {store.path('renderer', key)}: {exc}")
        missing.append(s)
    loaded = len(spectra)
    if missing:
        bar = progress_bar(len(missing), desc="advise: renderer spectra", quiet=quiet,
                           unit="spectrum")
        step = [0]

        def progress(label: str) -> None:
            if step[0]:
                bar.update(1)
            step[0] += 1
            if hasattr(bar, "set_postfix_str"):
                bar.set_postfix_str(label)
        try:
            fresh = renderer_model(setup, brdf, shininess, strategies=missing, grid=grid,
                                   axes=axes, progress=progress)
        finally:
            bar.close()
        for (tech, rest), spec in fresh.spectra.items():
            spectra[(tech, rest)] = spec
            store.save("renderer", spectrum_cache_key(map_key, brdf, shininess, grid, axes,
                                                      tech, rest, pixels),
                       spec.to_json())
    whole = [v for (t, r), v in spectra.items() if not r]
    mean = whole[0].mean if whole else float("nan")
    return RendererModel(str(brdf), float(shininess), spectra, mean), loaded, len(missing)

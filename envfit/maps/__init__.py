r"""Environment maps: lat-long geometry, the EnvMap type and its file I/O, value scales, image
metrics, library map sources, the built-in map, bright-source detection and the map preview.

Modules:

* ``_lookup`` (private) — The compiled bilinear lat-long lookup behind
  :func:`envfit.maps._latlong.bilinear_lookup`.
* :mod:`~envfit.maps._conventions` — Lat-long conventions of renderers: each renderer's
  direction ↔ pixel formula, and the conversion of a map in that convention into envfit's
  (:mod:`envfit.maps._latlong`); the grids and the base class are in ``_convention_base``.
* :mod:`~envfit.maps._default_map` — The built-in default map: a synthesized map of known
  smoothness, so every command runs without a file. It is a Gaussian-process sample with
  covariance K_gd^(1.5) (data_gen), RGB, 256×512, made positive by a constant offset (a
  constant only changes the l = 0 term). Its spectrum is exactly :math:`a_l^{(1.5)}` for l ≤
  255 (the grid's Nyquist degree) and zero above, and Table 2 reads it through the bilinear
  lookup (resized for ``--quick``): at the pixel scale it is smoother than :math:`K_{1.5}`,
  so Table 2's best s on it is expected above 1.5 (:mod:`envfit.fit._kriging` gives the
  expected optimum; ``envfit table2`` prints it).
* :mod:`~envfit.maps._envmap` — Environment maps: the :class:`EnvMap` container (geometry,
  lookup, resizing) and the sample-count guard :func:`check_sample_count`.
* :mod:`~envfit.maps._io` — Environment map file I/O through OpenImageIO: :func:`load_envmap`
  (with a renderer's ``convention`` and ``max_height``, in that order) and
  :func:`save_envmap`; the pixel reading itself is ``_oiio_read``.
* :mod:`~envfit.maps._latlong` — The latitude-longitude (equirectangular) convention of
  envfit — the ONE place it is defined.
* :mod:`~envfit.maps._lazy_maps` — Maps of a library, named but not loaded: files (loaded
  lazily, on whichever worker needs them) or in-memory :class:`~envfit.maps._envmap.EnvMap`
  objects.
* :mod:`~envfit.maps._metrics` — Image error metrics between a reference map and a
  reconstruction (same shape).
* :mod:`~envfit.maps._preview` — What ``envfit info`` says of a map (:func:`describe_envmap`)
  and what its preview shows: its pixels tone-mapped in the file's lat-long layout, the
  angles along its axes in that layout's terms, and its bright sources with their direction,
  solid angle and share of the power (``envfit info --out``, ``envfit synth --out``).
* :mod:`~envfit.maps._scales` — Value scales on which images are compared (the scale of an
  RMSE is an explicit choice).
* :mod:`~envfit.maps._synth` — :func:`synthesize_envmap`: a kind of
  :data:`envfit.data_gen.SYNTH_KINDS` laid out on envfit's grid or in a renderer's layout
  (what ``envfit synth`` writes).
* :mod:`~envfit.maps._bright_sources` — Bright-source detection on a map (the sun, lamps): connected
  bright regions on the sphere.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "convention": "_conventions", "CONVENTIONS": "_conventions",
    "lat_long_convention": "_conventions",
    "default_envmap": "_default_map",
    "EnvMap": "_envmap",
    "load_envmap": "_io", "save_envmap": "_io",
    "bilinear_lookup": "_latlong", "pixel_directions": "_latlong",
    "pixel_solid_angles": "_latlong",
    "describe_envmap": "_preview", "list_sources": "_preview", "map_preview": "_preview",
    "MapPreview": "_preview",
    "fit_scale": "_scales", "Scale": "_scales",
    "BrightSource": "_bright_sources", "find_bright_sources": "_bright_sources",
    "synthesize_envmap": "_synth", "SynthesizedEnvMap": "_synth",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "rows_dot": "_latlong",
    "rows_times": "_latlong",
    "LoadOptions": "_lazy_maps",
    "MAP_EXTENSIONS": "_lazy_maps",
    "MapSource": "_lazy_maps",
    "NotLatLong": "_conventions",
    "SCALES": "_scales",
    "check_not_constant": "_scales",
    "check_sample_count": "_envmap",
    "direction_to_pixel": "_latlong",
    "local_to_world": "_latlong",
    "pixel_angles": "_latlong",
    "resolve_map_sources": "_lazy_maps",
    "rmse": "_metrics",
    "rmse_solid_angle": "_metrics",
    "row_solid_angles": "_latlong",
    "variance_kept": "_envmap",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

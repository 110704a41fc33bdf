r"""The Python entry point of the renderer answer, ``envfit.advise_renderer``: the spp a
renderer's sampler must run on a map (or on each map of a library) for an RMSE target,
predicted for its own estimator — what ``envfit advise MAP --renderer NAME`` prints.

One map (an :class:`~envfit.maps.EnvMap`, or one file path) gives a
:class:`~envfit.advisor.RendererAdvice` (:func:`envfit.advisor.advise_with`, the advisor's one
entry point);
several (a list, a folder, a glob pattern) give a
:class:`~envfit.batch._library_advise.LibraryAdvice`
(:func:`~envfit.batch._library_advise.advise_library`: one row per map, the spp that meets the
target on 50/90/100 % of the maps, resumable with ``out``, on a local pool or dask through
``library``). The renderer's options are
:class:`~envfit.advisor._renderer_options.RendererAdviseOptions`, checked before any map is read.

Example
-------
>>> import numpy as np, tempfile, envfit
>>> env = envfit.EnvMap(np.random.default_rng(0).random((8, 16, 3)) + 0.5, name="noise")
>>> from envfit.renderers import RENDERERS
>>> name = next(n for n, r in RENDERERS.items() if "independent" in r.samplers)
>>> a = envfit.advise_renderer(env, name, sampler="independent", normals=4, level=3,
...                            target_relative=0.05, cache_dir=tempfile.mkdtemp())
>>> a.recommendation["strategy"], a.recommendation["predicted_rmse"] <= a.target_rmse
('mis', True)
"""
from __future__ import annotations

import os
from pathlib import Path

from envfit.base import ParameterError

__all__ = ["advise_renderer"]

#: the keywords that are :class:`RendererAdviseOptions` fields
_OPTION_NAMES = ("sampler", "strategies", "spp", "mis_compensation", "max_spp", "level",
                 "normals", "bsdf", "roughness", "bsdf_params", "sphere_pixels")


def advise_renderer(maps, renderer: str, *, target_rmse: float | None = None,
                    target_relative: float | None = None, snippet: bool = False,
                    cache: bool = True, cache_dir=None, library=None, out=None, **options):
    """How many spp ``renderer`` needs on ``maps`` for the target (module docstring).

    Parameters
    ----------
    maps : EnvMap, path, or a list of them, a folder or a glob pattern
        One map (an EnvMap or a single file) is advised alone; anything else (a list, even of
        one map, a folder, a pattern) is a library.
    renderer : str
        A name of :data:`envfit.renderers.RENDERERS` (any case).
    target_rmse, target_relative : float, optional
        The RMSE target (at most one; default 1 % of the map's mean radiance).
    snippet : bool
        One map only: also the scene text of the recommendation.
    cache, cache_dir
        The advisor's on-disk cache of predicted cells.
    library : LibraryOptions, optional
        Several maps: where they run (inline, local pool, dask) and how files are read.
    out : path, optional
        Several maps: the resumable store of finished maps.
    **options
        :class:`~envfit.advisor._renderer_options.RendererAdviseOptions` fields: ``sampler``,
        ``strategies``, ``spp``, ``mis_compensation``, ``max_spp``, ``level``, ``normals``,
        ``bsdf``, ``roughness``, ``bsdf_params``, ``sphere_pixels``.

    Returns
    -------
    RendererAdvice or LibraryAdvice
    """
    from envfit.advisor import RendererAdviseOptions
    from envfit.maps import EnvMap
    unknown = sorted(set(options) - set(_OPTION_NAMES))
    if unknown:
        raise TypeError(f"advise_renderer() got unexpected keyword argument(s) "
                        f"{', '.join(unknown)}; the options are {', '.join(_OPTION_NAMES)}")
    opts = RendererAdviseOptions(renderer, **options)
    one = maps if isinstance(maps, EnvMap) else _one_file(maps)
    if one is None:
        if snippet:
            raise ParameterError("snippet: a scene names one map file; advise that map alone")
        from envfit.batch._library_advise import advise_library
        return advise_library(maps if isinstance(maps, (list, tuple)) else [maps], opts,
                              target_rmse=target_rmse, target_relative=target_relative,
                              library=library, out=out, cache=cache, cache_dir=cache_dir)
    from envfit.advisor import advise_with
    env = one if isinstance(one, EnvMap) else _load(one)
    return advise_with(env, opts.asking(
        target_rmse=target_rmse, target_relative=target_relative, snippet=snippet,
        filename=str(one) if not isinstance(one, EnvMap) else env.name or "envmap.exr",
        cache=cache, cache_dir=cache_dir))


def _one_file(maps):
    """The single map file ``maps`` names (a path of a file, not a folder or a pattern), else
    None (a list is always a library, even of one map)."""
    if isinstance(maps, (str, os.PathLike)) and Path(maps).is_file():
        return maps
    return None


def _load(path):
    from envfit.maps import load_envmap
    return load_envmap(path)

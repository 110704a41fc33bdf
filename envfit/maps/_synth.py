r"""A synthetic map laid out for a file: :func:`synthesize_envmap`, the kinds of
:data:`envfit.data_gen.SYNTH_KINDS` on envfit's pixel grid (with an ``up`` axis) or in a
renderer's lat-long layout (``convention``), what ``envfit synth`` writes.

The kinds are made in the map's local frame (z up) on envfit's grid and, with a
convention C, laid out in C's grid by C's own bilinear lookup
(:meth:`~envfit.maps._convention_base.LatLongConvention.from_internal`, exact where the
grids coincide), with C's up axis as the world frame. A kind that takes ``directions``
(``marker``) is evaluated directly at the world direction of every pixel of the file's
layout instead (C's, or envfit's with ``up``), so it is exact in every layout.

Example
-------
>>> s = synthesize_envmap("marker", 16, convention="blender")
>>> s.envmap.up, s.envmap.data.shape, s.convention.name
('z', (16, 32, 3), 'blender')
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.data_gen import SYNTH_KINDS, SynthesizedMap, synthesize
from envfit.maps._conventions import lat_long_convention
from envfit.maps._convention_base import LatLongConvention
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import pixel_directions

__all__ = ["SynthesizedEnvMap", "synthesize_envmap"]


@dataclass(frozen=True)
class SynthesizedEnvMap:
    """A synthesized map in a file's layout.

    Attributes
    ----------
    envmap : the float32 :class:`EnvMap` to write (pixels in the layout, ``up`` its world
        up axis, named ``synth:<kind>``)
    pixels : the same pixels in float64, before the cast (their min/max are the map's)
    synth : the :class:`~envfit.data_gen.SynthesizedMap` (local frame) and how it was made
    convention : the layout's convention, or None for envfit's grid
    """

    envmap: EnvMap
    pixels: np.ndarray
    synth: SynthesizedMap
    convention: LatLongConvention | None = None


def synthesize_envmap(kind: str, height: int, *, seed=0, up: str | None = None,
                      convention=None, **params) -> SynthesizedEnvMap:
    """The map of ``kind`` (:data:`envfit.data_gen.SYNTH_KINDS`) with ``height`` rows, laid
    out on envfit's grid with ``up`` (default ``"y"``) or in ``convention``'s layout.

    Parameters
    ----------
    kind, height, seed, **params : as :func:`envfit.data_gen.synthesize`.
    up : the world axis of the top row on envfit's grid; not with ``convention``.
    convention : a name of :data:`~envfit.maps._conventions.CONVENTIONS` or a convention
        object (:func:`~envfit.maps._conventions.lat_long_convention`).

    Raises :class:`ParameterError` (one line) for a bad kind, parameter or value (the
    generators' ``ValueError`` messages), a bad convention, or ``up`` with ``convention``.
    """
    conv = lat_long_convention(convention, up)
    axis = conv.up if conv is not None else (up or "y")
    spec = SYNTH_KINDS.get(kind)
    at_directions = spec is not None and "directions" in spec.params
    try:
        if (at_directions and params.get("directions") is None
                and isinstance(height, (int, np.integer)) and height >= 2):
            params["directions"] = (conv.pixel_directions(height) if conv is not None
                                    else pixel_directions(height, up=axis))
        synth = synthesize(kind, height, seed, **params)
    except ValueError as exc:    # data_gen reports bad parameters as ValueError subclasses
        raise ParameterError(str(exc)) from None
    f = synth.data
    if conv is not None and not at_directions:   # made on envfit's grid with conv's up
        f = conv.from_internal(EnvMap(np.asarray(f, dtype=np.float64), up=conv.up))
    # envfit:up names the world axis of the top row (the convention's, with a convention)
    env = EnvMap(np.asarray(f, dtype=np.float32), up=axis, name=f"synth:{kind}")
    return SynthesizedEnvMap(envmap=env, pixels=f, synth=synth, convention=conv)

"""Mitsuba 3 (3.9.1, ``scalar_rgb``), as envfit reads it from its source: the ``envmap``
emitter (``Hierarchical2D`` warp of a bilinear density) and the ``direct`` integrator
(``_envmap``), and the renders of envfit's measurement (``_render``).

The folder's record is :data:`MITSUBA3` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {"MITSUBA3": "_envmap"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

"""Blender's Cycles (5.0), as envfit reads it from its source: the world light and its
importance map (``_background``), the scene text (``_scene``), and the renders of envfit's
measurement through ``bpy`` (``_render``).

The folder's record is :data:`CYCLES` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {"CYCLES": "_background"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

"""pbrt-v4, as envfit reads it from its source: ``ImageInfiniteLight`` with its compensated
``PiecewiseConstant2D`` (``_light``) on the equal-area square of ``imgtool makeequiarea``
(``_equal_area``).

The folder's record is :data:`PBRT4` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base._lazy import lazy_exports

_LAZY = {"PBRT4": "_light"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

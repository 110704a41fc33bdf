"""envfit's own rules, held as a renderer so that the advice compares them alike: the
:class:`~envfit.sampling.MapSampler` (luminance × solid angle with a floor), lobe (cosine)
sampling and balance MIS (``_technique``: :class:`EnvfitMapTechnique`), the point sets
``random``, ``jitter``, ``sobol`` (default), ``lp``, ``sf``, ``bnot`` with one
Cranley–Patterson shift per axis.

The folder's record is :data:`ENVFIT` (a :class:`~envfit.renderers.Renderer`).

The names of ``__all__`` are imported lazily, on first use (PEP 562).
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {"ENVFIT": "_technique"}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

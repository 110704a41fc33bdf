r"""Spherical-harmonic export for engines: coefficients and windows, CSV/GLSL formats, the
ringing and negativity checks, the plan and the ``envfit sh`` report.

Modules:

* :mod:`~envfit.sh._plan` — Time and memory of ``envfit sh`` before the work: every
  option's valid range (issue 22, item 7).
* :mod:`~envfit.sh._report` — ``envfit sh``'s whole result: the exported coefficients,
  their predicted (and measured) error and negativity, the ringing table over degrees and
  windows, and the choice for a target (:func:`sh_report`, :class:`SHReport`); its documents
  (JSON, CSV, GLSL: :func:`document`), its files for ``--out`` (:func:`sh_outputs`) and the
  preview images of ``sh.png`` (:func:`preview_images`).
* :mod:`~envfit.sh._ringing` — ``envfit sh``'s predictions: the truncation error of
  exported SH coefficients, the fraction of directions where the windowed, truncated signal
  goes negative, and the (degree, window) to use for a target.
* :mod:`~envfit.sh._sh_export` — Real spherical-harmonic coefficients of a map for
  engines: conversion, irradiance, windows.
* :mod:`~envfit.sh._sh_format` — Text forms of
  :class:`envfit.sh._sh_export.SHCoefficients` for engines: CSV and GLSL.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "check_sh_plan": "_plan",
    "sh_report": "_report", "SHReport": "_report", "SHReportOptions": "_report",
    "sh_coefficients": "_sh_export", "SHCoefficients": "_sh_export",
    "to_csv": "_sh_format", "to_glsl": "_sh_format",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "BAND_LIMIT": "_ringing",
    "CHECK_AXES": "_ringing",
    "DENSE_HEIGHT": "_ringing",
    "FORMATS": "_report",
    "MAX_CHECK_AXES": "_plan",
    "MAX_CHECK_HEIGHT": "_plan",
    "TABLE_LMAX": "_ringing",
    "WINDOWS": "_sh_export",
    "document": "_report",
    "measured_where": "_report",
    "plan": "_report",
    "sh_outputs": "_report",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

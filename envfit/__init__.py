"""envfit — how smooth is this environment map, and what shading error will a sampler make on it?

The public API (imported lazily, so ``import envfit`` stays fast)::

    from envfit import load_envmap, save_envmap, EnvMap          # maps (envfit.maps._io, .envmap)
    from envfit import SobolevInterpolator                       # kernel interpolation, Eq. 14
    from envfit import fit_smoothness, run_table2                # s of a map; the paper's Table 2
    from envfit import shading_integral                          # ground-truth shading integrals
    from envfit import run_validation                            # measured vs predicted errors
    from envfit import advise, advise_renderer                   # N of a rule; spp of a renderer

Conventions (lat-long geometry, value scales) are documented in docs/conventions.md and implemented
in :mod:`envfit.maps._latlong` and :mod:`envfit.maps._scales`.
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

import envfit.base._code  # noqa: E402,F401  (records when this process imported envfit)

from envfit.base import (DuplicatePointsError, EnvfitError, EnvMapFileError, EnvMapFormatError,
                         MemoryBudgetError, NonFiniteError, ParameterError)

_LAZY = {
    "EnvMap": "maps._envmap", "load_envmap": "maps._io", "save_envmap": "maps._io",
    "fit_scale": "maps._scales", "Scale": "maps._scales",
    "SobolevInterpolator": "sobolev._interpolation",
    "fit_smoothness": "fit._smoothness", "FitResult": "fit._smoothness",
    "run_table2": "fit._table2", "Table2Result": "fit._table2",
    "shading_integral": "shading._ground_truth",
    "quadrature_estimates": "shading._estimators", "sh_truncation_estimates": "shading._estimators",
    "hsh_truncation_estimates": "shading._estimators",
    "run_validation": "validate._pipeline", "ValidateConfig": "validate._config",
    "ValidationResult": "validate._results",
    "default_envmap": "maps._default_map",
    "advise": "advisor._advise", "Advice": "advisor._result", "AdviseOptions": "advisor._options",
    "advise_renderer": "batch._advise_renderer", "RendererAdvice": "advisor._renderer_advice",
    "PresetAdvice": "advisor._renderer_advice",      # the former name of RendererAdvice
    "LibraryAdvice": "batch._library_advise",
}

__all__ = ["__version__", "EnvfitError", "EnvMapFileError", "EnvMapFormatError",
           "NonFiniteError", "ParameterError", "MemoryBudgetError", "DuplicatePointsError",
           *sorted(k for k in _LAZY if k != "PresetAdvice")]     # the former name resolves


def __getattr__(name: str):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'envfit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))

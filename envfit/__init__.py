"""envfit — how smooth is this environment map, and what shading error will a sampler make on it?

The public API (imported lazily, so ``import envfit`` stays fast)::

    from envfit import load_envmap, save_envmap, EnvMap          # maps (envfit.maps.io, .envmap)
    from envfit import SobolevInterpolator                       # kernel interpolation, Eq. 14
    from envfit import fit_smoothness, run_table2                # s of a map; the paper's Table 2
    from envfit import shading_integral                          # ground-truth shading integrals
    from envfit import run_validation                            # measured vs predicted errors

Conventions (lat-long geometry, value scales) are documented in docs/conventions.md and implemented
in :mod:`envfit.maps.latlong` and :mod:`envfit.maps.scales`.
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

from envfit.base.errors import (DuplicatePointsError, EnvfitError, EnvMapFileError, EnvMapFormatError,
                     MemoryBudgetError, NonFiniteError, ParameterError)

_LAZY = {
    "EnvMap": "maps.envmap", "load_envmap": "maps.io", "save_envmap": "maps.io",
    "fit_scale": "maps.scales", "Scale": "maps.scales",
    "SobolevInterpolator": "kernels.interpolation",
    "fit_smoothness": "fit.smoothness", "FitResult": "fit.smoothness",
    "run_table2": "fit.table2", "Table2Result": "fit.table2",
    "shading_integral": "shading.ground_truth",
    "quadrature_estimates": "shading.estimators", "sh_truncation_estimates": "shading.estimators",
    "hsh_truncation_estimates": "shading.estimators",
    "run_validation": "validate.pipeline", "ValidateConfig": "validate.config",
    "ValidationResult": "validate.results",
    "default_envmap": "maps.default_map",
    "advise": "advisor.advise", "Advice": "advisor.result", "AdviseOptions": "advisor.options",
}

__all__ = ["__version__", "EnvfitError", "EnvMapFileError", "EnvMapFormatError",
           "NonFiniteError", "ParameterError", "MemoryBudgetError", "DuplicatePointsError",
           *sorted(_LAZY)]


def __getattr__(name: str):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'envfit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))

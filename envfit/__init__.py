"""envfit — how smooth is this environment map, and what shading error will a sampler make on it?

The public API (imported lazily, so ``import envfit`` stays fast)::

    from envfit import load_envmap, save_envmap, EnvMap          # maps (envfit.envmap)
    from envfit import SobolevInterpolator                       # kernel interpolation, Eq. 14
    from envfit import fit_smoothness, run_table2                # s of a map; the paper's Table 2
    from envfit import shading_integral                          # ground-truth shading integrals
    from envfit import run_validation                            # measured vs predicted errors

Conventions (lat-long geometry, value scales) are documented in README.md and implemented
in :mod:`envfit.latlong` and :mod:`envfit.scales`.
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

from .errors import (DuplicatePointsError, EnvfitError, EnvMapFileError, EnvMapFormatError,
                     MemoryBudgetError, NonFiniteError, ParameterError)

_LAZY = {
    "EnvMap": "envmap", "load_envmap": "envmap", "save_envmap": "envmap",
    "fit_scale": "scales", "Scale": "scales",
    "SobolevInterpolator": "interpolation",
    "fit_smoothness": "fit", "FitResult": "fit",
    "run_table2": "table2", "Table2Result": "table2",
    "shading_integral": "shading",
    "quadrature_estimates": "estimators", "sh_truncation_estimates": "estimators",
    "hsh_truncation_estimates": "estimators",
    "run_validation": "validate", "ValidateConfig": "validate",
    "default_envmap": "default_map",
    "advise": "advisor", "Advice": "advisor",
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

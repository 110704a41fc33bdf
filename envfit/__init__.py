"""envfit — how smooth is this environment map, and what shading error will a sampler make on it?

The public API is re-exported here; see README.md for the conventions.
"""
__version__ = "0.1.0"

from .errors import (DuplicatePointsError, EnvfitError, EnvMapFileError, EnvMapFormatError,
                     MemoryBudgetError, NonFiniteError, ParameterError)

__all__ = ["__version__", "EnvfitError", "EnvMapFileError", "EnvMapFormatError",
           "NonFiniteError", "ParameterError", "MemoryBudgetError", "DuplicatePointsError"]

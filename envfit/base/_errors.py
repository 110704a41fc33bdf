"""The exception types of envfit.

Every error that a user can cause (bad file, bad parameter, not enough memory) is
raised as a subclass of :class:`EnvfitError`. The CLI turns any ``EnvfitError`` into a
one-line message on stderr and exit code 2; anything else is a bug and keeps its
traceback.
"""
from __future__ import annotations

__all__ = [
    "EnvfitError",
    "EnvMapFileError",
    "EnvMapFormatError",
    "NonFiniteError",
    "ParameterError",
    "MemoryBudgetError",
    "DuplicatePointsError",
    "ExecutorError",
    "OutputError",
]


class EnvfitError(Exception):
    """Base class of every error a user can cause; the CLI exits with code 2."""


class EnvMapFileError(EnvfitError, OSError):
    """The file is missing, unreadable, corrupt or truncated."""


class EnvMapFormatError(EnvfitError, ValueError):
    """The image is readable but is not a usable lat-long map (aspect ratio, empty, channels)."""


class NonFiniteError(EnvMapFormatError):
    """The map holds NaN or Inf pixels (use ``fix_nonfinite=True`` / ``--fix-nonfinite``)."""


class ParameterError(EnvfitError, ValueError):
    """A parameter is outside its valid range (e.g. Sobolev smoothness s not in (1, 2))."""


class MemoryBudgetError(EnvfitError, MemoryError):
    """The requested work would not fit in memory; the message says how much it needs."""


class DuplicatePointsError(ParameterError):
    """Two interpolation nodes coincide, so the kernel matrix is singular."""


class ExecutorError(EnvfitError, RuntimeError):
    """The executor cannot run the sweep: dask missing, scheduler unreachable, workers lost
    (finished cells are kept; the message says to re-run)."""



class OutputError(EnvfitError, OSError):
    """An output (``--out`` folder, ``--json`` file, a written map, a cache folder) cannot be
    written: read-only file system, no permission, a path through a regular file, a folder
    where a file is wanted, a symlink loop. The CLI checks every output this way *before*
    any work (``envfit.base._atomic.check_writable_dir`` / ``check_writable_file``), so the message
    comes in seconds, not after the computation."""

"""Errors raised by ``data_gen`` for invalid parameters (one clear line each)."""
from __future__ import annotations

__all__ = ["SyntheticMapError"]


class SyntheticMapError(ValueError):
    """A parameter of a synthetic-map generator is invalid or a request is too large."""

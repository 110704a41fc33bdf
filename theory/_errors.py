"""Errors raised by ``theory`` for invalid parameters (the CLI reports them in one line)."""
from __future__ import annotations

__all__ = ["TheoryParameterError", "check_smoothness", "check_degree"]


class TheoryParameterError(ValueError):
    """A parameter of a theory function is outside its valid range."""


def check_degree(value, what: str = "lmax") -> int:
    """Return ``value`` as an int ≥ 0 (a degree l or band limit; 3.0 is accepted, 3.5 is not)."""
    try:
        v = int(value)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"{what} must be an integer, got {value!r}") from None
    if v != value or v < 0:
        raise TheoryParameterError(f"{what} must be an integer >= 0, got {value!r}")
    return v


def check_smoothness(s: float) -> float:
    """Return ``float(s)`` if 1 < s < 2 (the range of the generalized distance kernel, Eq. 14)."""
    try:
        s = float(s)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"Sobolev smoothness s must be a number, got {s!r}") from None
    if not (1.0 < s < 2.0):
        raise TheoryParameterError(
            f"Sobolev smoothness s must satisfy 1 < s < 2 for the generalized distance kernel "
            f"(Eq. 14), got s = {s:g}")
    return s

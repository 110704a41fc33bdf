"""Checks of user-given names, integers and positive numbers shared by the pipelines (validate, advise).

Each raises :class:`envfit.base.errors.ParameterError` with a one-line message naming the value,
which the CLI prints as ``envfit COMMAND: error: …`` with exit code 2.
"""
from __future__ import annotations

import math
from typing import Iterable, Sequence

from envfit.base.errors import ParameterError

__all__ = ["check_names", "check_int", "check_ints", "check_positive"]


def check_names(values: str | Iterable, allowed: Sequence[str], what: str) -> list[str]:
    """Lower-cased, de-duplicated names, each one of ``allowed`` (a single string is one name).

    >>> check_names(["SF", "random", "sf"], ("sf", "random"), "point set")
    ['sf', 'random']
    """
    if isinstance(values, str):
        values = [values]
    out: list[str] = []
    for v in values:
        name = str(v).strip().lower()
        if name not in allowed:
            raise ParameterError(f"unknown {what} {v!r}; choose from {', '.join(allowed)}")
        if name not in out:
            out.append(name)
    return out


def check_int(value, what: str, lo: int) -> int:
    """``value`` as an int ≥ ``lo``; 3.0 is accepted, 3.5, "x" and None are not.

    >>> check_int(3.0, "N", 2)
    3
    """
    try:
        k = int(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be an integer >= {lo}, got {value!r}") from None
    if k != value or k < lo:
        raise ParameterError(f"{what} must be an integer >= {lo}, got {value!r}")
    return k


def check_ints(values: Iterable, what: str, lo: int) -> list[int]:
    """:func:`check_int` of every value.

    >>> check_ints([16, 64.0], "N", 2)
    [16, 64]
    """
    return [check_int(v, what, lo) for v in values]


def check_positive(value, what: str) -> float:
    """``value`` as a finite float > 0; "x", None, NaN, inf, 0 and negatives are not.

    >>> check_positive("2.5", "shininess")
    2.5
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be a number > 0, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"{what} must be a finite number > 0, got {value!r}")
    return v

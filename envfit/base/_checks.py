"""Checks of user-given names, integers and positive numbers shared by the pipelines (validate, advise).

Each raises :class:`envfit.base._errors.ParameterError` with a one-line message naming the value,
which the CLI prints as ``envfit COMMAND: error: …`` with exit code 2.
"""
from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np

from envfit.base._errors import ParameterError

__all__ = ["as_square_points", "check_names", "check_int", "check_ints", "check_positive"]


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


def check_s(s) -> float:
    """The Sobolev smoothness s in (1, 2) of the kernel K_gd (Eq. 14) as a float; else
    :class:`ParameterError` (theory's check, raised as envfit's error type)."""
    from envfit.theory import TheoryParameterError, check_smoothness
    try:
        return check_smoothness(s)
    except TheoryParameterError as exc:
        raise ParameterError(str(exc)) from None


def as_square_points(u, *, name: str = "u") -> np.ndarray:
    """Square points (..., 2) as a float64 (K, 2) array in [0, 1]²; :class:`ParameterError`
    for a wrong shape or a point that is not finite or lies outside the closed square.

    >>> as_square_points([0.25, 1.0]).tolist()
    [[0.25, 1.0]]
    """
    try:
        a = np.asarray(u, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array of points in [0, 1]^2") from None
    if a.ndim < 1 or a.shape[-1] != 2:
        raise ParameterError(f"{name} must have shape (..., 2), got {a.shape}")
    a = a.reshape(-1, 2)
    if not np.all(np.isfinite(a)) or a.size and (a.min() < 0.0 or a.max() > 1.0):
        raise ParameterError(f"{name} must be finite points in [0, 1]^2")
    return a


def as_unit_vectors(points, *, name: str = "points", allow_empty: bool = False) -> np.ndarray:
    """``points`` (..., 3) as a C-contiguous float64 (M, 3) array of unit vectors.

    Rejects (with :class:`~envfit.base._errors.ParameterError`, never a numpy warning) a wrong
    shape, NaN/Inf entries, zero vectors and (unless ``allow_empty``) no vectors at all. Vectors are rescaled by their largest
    component before the norm is taken, so huge or tiny finite vectors do not overflow.

    >>> as_unit_vectors([[0, 0, 2.0], [3.0, 4.0, 0]])
    array([[0. , 0. , 1. ],
           [0.6, 0.8, 0. ]])
    """
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array of 3-vectors") from None
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ParameterError(f"{name} must have shape (..., 3), got {p.shape}")
    p = p.reshape(-1, 3)
    if p.shape[0] == 0:
        if allow_empty:
            return np.zeros((0, 3))
        raise ParameterError(f"{name} is empty")
    finite = np.isfinite(p).all(axis=1)
    if not finite.all():
        i = int(np.argmin(finite))
        raise ParameterError(f"{name}[{i}] = {p[i].tolist()} is not finite")
    big = np.abs(p).max(axis=1)
    if not (big > 0).all():
        i = int(np.argmin(big > 0))
        raise ParameterError(f"{name}[{i}] is the zero vector, which has no direction")
    # vectors that are unit to rounding are kept bit for bit (so normalising is idempotent
    # and a query equal to a node gives d = 0 exactly: at s near 1 the kernel's cusp turns a
    # 1e-16 displacement into a 1e-3 kernel change); elementwise ops only, so a row's
    # result never depends on the other rows
    with np.errstate(over="ignore", under="ignore"):
        n2 = p[:, 0] * p[:, 0] + p[:, 1] * p[:, 1] + p[:, 2] * p[:, 2]
    keep = np.abs(n2 - 1.0) <= 8 * np.finfo(np.float64).eps
    if keep.all():
        return np.ascontiguousarray(p)
    q = p / big[:, None]
    q /= np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2])[:, None]
    q[keep] = p[keep]
    return np.ascontiguousarray(q)

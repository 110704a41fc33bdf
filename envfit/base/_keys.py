"""The one key of a smoothness value s (issue 23, point 3): how s names a stored result.

Two precisions, one place:

* :func:`s_key` — the string key of s in stored JSON (validate's cells' per-s dicts, Table 2's
  cell names ``s1.5000_n64``, the per-s residuals of the validate report): four decimals.
  Stored files written by any earlier version use exactly these strings, so the format is
  frozen (a store written before must resume).
* :func:`s_value` — s as the advisor uses it for its OSW weights, its wce curves and their
  cache keys: the fitted s rounded to 1e-6 (:data:`S_VALUE_DIGITS`), so that a refit that moves
  s by rounding noise hits the same cache entries and gives the same weights.

>>> s_key(1.5), s_key(1.15), s_key(1.9999999)
('1.5000', '1.1500', '2.0000')
>>> s_value(1.23456789)
1.234568
"""
from __future__ import annotations

__all__ = ["S_KEY_DIGITS", "S_VALUE_DIGITS", "s_key", "s_value"]

#: decimals of s in the string keys of stored results (frozen: the stores' format)
S_KEY_DIGITS = 4
#: decimals of the s the advisor computes with (and keys its caches by)
S_VALUE_DIGITS = 6


def s_key(s: float) -> str:
    """The key of a smoothness value in stored per-s dicts and cell names (4 decimals).

    >>> s_key(1.5), s_key(2)
    ('1.5000', '2.0000')
    """
    return f"{float(s):.{S_KEY_DIGITS}f}"


def s_value(s: float) -> float:
    """s rounded to 1e-6: the s of the advisor's OSW weights and of its curves' cache keys.

    >>> s_value(1.23456789)
    1.234568
    """
    return round(float(s), S_VALUE_DIGITS)

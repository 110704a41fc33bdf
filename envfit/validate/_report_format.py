"""Small formatting helpers of ``report.md`` (:mod:`envfit.validate._report`).

Numbers with a placeholder for missing values, Markdown tables, display names, and the few
figures of a result (the band limit, medians over the cells) that several sections print.

Example
-------
>>> _f(None), _f(float("nan")), _f(0.12345), _f(3, "d")
('–', '–', '0.123', '3')
>>> _table(["a", "b"], [[1, 2]])
['| a | b |', '|---|---|', '| 1 | 2 |']
"""
from __future__ import annotations

import math

from envfit.defaults import DEFAULT_SHININESS

# ----------------------------------------------------------------------------- formatting

def _f(v, fmt=".3g", none="–"):
    """``format(v, fmt)``, or ``none`` for a missing or non-finite value."""
    if v is None:
        return none
    try:
        if isinstance(v, float) and not math.isfinite(v):
            return none
        return format(v, fmt)
    except (TypeError, ValueError):
        return str(v)


def _table(header: list[str], rows: list[list]) -> list[str]:
    """Markdown table lines."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(x) for x in r) + " |")
    return out


def _brdf_name(result, b):
    """Display name of BRDF ``b`` (the glossy one with its shininess)."""
    n = result["config"].get("shininess", DEFAULT_SHININESS)
    return f"glossy (n = {n:g})" if b == "glossy" else b


def _band(r):
    """The band limit (highest degree) of the map, from the first cell that has it."""
    for e in r.get("results", []):
        if e.get("band_lmax") is not None:
            return e["band_lmax"]
    return "H − 1"


def _median(xs):
    """Median of the finite values of ``xs`` (``None`` if there are none)."""
    xs = sorted(x for x in xs if x is not None and math.isfinite(x))
    if not xs:
        return None
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def _median_of(r: dict, key: str):
    """Median over every cell of ``results`` of the list ``key``."""
    return _median([x for e in r.get("results", []) for x in (e.get(key) or [])])

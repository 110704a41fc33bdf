"""The strict parsing primitives under every argparse type of the CLI (``_common``,
``_ranges``): whole numbers, finite numbers, comma-separated lists without repeats, and the
number types whose range ``_ranges`` states in the help."""
from __future__ import annotations

import argparse
import math
from decimal import Decimal, InvalidOperation

__all__ = ["parse_whole", "parse_finite", "split_items", "check_unique", "positive_int",
           "nonneg_int", "finite_float", "positive_float"]

#: the largest integer an option accepts (exponent notation beyond it is surely a typo)
_INT_LIMIT = 10 ** 18


def parse_whole(text: str) -> int:
    """``text`` as an exact whole number (``"100"``, ``"1e3"``, ``"100.0"``) or
    ArgumentTypeError ("100.5 is not a whole number")."""
    t = str(text).strip()
    if not t:
        raise argparse.ArgumentTypeError("expected a whole number, got an empty value")
    try:
        return int(t)
    except ValueError:
        pass
    try:
        d = Decimal(t)
    except InvalidOperation:
        raise argparse.ArgumentTypeError(f"{t} is not a number") from None
    if not d.is_finite():
        raise argparse.ArgumentTypeError(f"{t} is not a whole number")
    if d.adjusted() > 18:
        raise argparse.ArgumentTypeError(f"{t} is too large")
    if d != d.to_integral_value():
        raise argparse.ArgumentTypeError(f"{t} is not a whole number")
    return int(d)


def parse_finite(text: str) -> float:
    """``text`` as a finite float or ArgumentTypeError."""
    t = str(text).strip()
    try:
        v = float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{t} is not a number" if t else "expected a number, got an empty value") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{t} is not a finite number")
    return v


def split_items(text: str) -> list[str]:
    """The comma-separated entries of ``text`` (stripped); ArgumentTypeError for an empty
    list or entry."""
    raw = str(text)
    items = [x.strip() for x in raw.split(",")]
    if not raw.strip():
        raise argparse.ArgumentTypeError("empty list; give comma-separated values")
    if any(not x for x in items):
        raise argparse.ArgumentTypeError(f"empty entry in {raw!r}")
    return items


def check_unique(values: list, items: list[str], raw: str) -> list:
    """``values`` (parsed from ``items`` of ``raw``) or ArgumentTypeError naming a repeat."""
    seen: dict = {}
    for v, x in zip(values, items):
        if v in seen:
            raise argparse.ArgumentTypeError(
                f"{x} is given twice in {raw!r}" if seen[v] == x
                else f"{seen[v]} and {x} are the same value in {raw!r}")
        seen[v] = x
    return values


def _int_in_range(text: str, lo: int) -> int:
    k = parse_whole(text)
    if k < lo:
        raise argparse.ArgumentTypeError(
            f"{str(text).strip()} is not {'positive' if lo == 1 else f'>= {lo}'}")
    if k > _INT_LIMIT:
        raise argparse.ArgumentTypeError(f"{str(text).strip()} is too large")
    return k


def positive_int(text: str) -> int:
    """A whole number >= 1 (argparse ``type=``): ``"100"``, ``"1e3"``; not ``"100.5"``, ``"0"``.

    >>> positive_int("1e3"), positive_int("64")
    (1000, 64)
    """
    return _int_in_range(text, 1)


def nonneg_int(text: str) -> int:
    """A whole number >= 0 (argparse ``type=``), e.g. ``--seed``, ``--lmax``."""
    return _int_in_range(text, 0)


def finite_float(text: str) -> float:
    """A finite number (argparse ``type=``): not NaN, not inf."""
    return parse_finite(text)


def positive_float(text: str) -> float:
    """A finite number > 0 (argparse ``type=``), e.g. ``--shininess``, ``--target``."""
    v = parse_finite(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"{str(text).strip()} is not positive")
    return v

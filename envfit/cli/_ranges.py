"""Argparse types whose range is stated once: the words of a number's range (:class:`Range`)
are both its ``--help`` text and its error, and a list of names (:func:`distinct_names`)
refuses a repeat as a list of numbers does (issue 38: ``envfit advise``'s options).

>>> r = Range(int, 1, 11)
>>> r.words, r("7")
('an integer from 1 to 11', 7)
>>> Range(float, 0, 1, lo_open=True, hi_open=True).words
'a number in (0, 1)'
>>> distinct_names("mis, MAP")
['mis', 'map']
"""
from __future__ import annotations

import argparse

from envfit.cli._common import _finite, _items, _unique, _whole

__all__ = ["Range", "RangeList", "distinct_names", "name_words", "common_range",
           "state_common_ranges"]


class Range:
    """An argparse ``type=``: an integer (``kind`` int: a whole number, ``1e3`` is 1000) or a
    finite number (float) from ``lo`` to ``hi`` (None: unbounded; ``lo_open``/``hi_open``:
    the end excluded), a multiple of ``multiple`` if given; ``also``: words taken as
    themselves (lower case), e.g. ``auto``. :attr:`words` says the range; :meth:`outside`
    gives values just outside it (for tests)."""

    def __init__(self, kind=int, lo=None, hi=None, *, lo_open: bool = False,
                 hi_open: bool = False, multiple: int | None = None, also: tuple = ()):
        self.kind, self.lo, self.hi = kind, lo, hi
        self.lo_open, self.hi_open, self.multiple, self.also = lo_open, hi_open, multiple, also
        self.__name__ = "integer" if kind is int else "number"

    @property
    def words(self) -> str:
        """The range in words, e.g. ``an integer from 1 to 11``, ``a number > 0``."""
        what = "an integer" if self.kind is int else "a number"
        lo, hi = (None if x is None else f"{x:g}" for x in (self.lo, self.hi))
        if lo is not None and hi is not None:
            if self.lo_open or self.hi_open:
                span = (f"in {'(' if self.lo_open else '['}{lo}, {hi}"
                        f"{')' if self.hi_open else ']'}")
            else:
                span = f"from {lo} to {hi}"
        elif lo is not None:
            span = f"{'>' if self.lo_open else '>='} {lo}"
        else:
            span = f"{'<' if self.hi_open else '<='} {hi}"
        mult = f", a multiple of {self.multiple}" if self.multiple else ""
        pre = "".join(f"'{a}' or " for a in self.also)
        return f"{pre}{what} {span}{mult}"

    def inside(self, v) -> bool:
        """Whether the number ``v`` is in the range."""
        ok_lo = self.lo is None or (v > self.lo if self.lo_open else v >= self.lo)
        ok_hi = self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)
        return ok_lo and ok_hi and not (self.multiple and v % self.multiple)

    def __call__(self, text):
        t = str(text).strip()
        if t.lower() in self.also:
            return t.lower()
        v = _whole(t) if self.kind is int else _finite(t)
        if not self.inside(v):
            raise argparse.ArgumentTypeError(f"{t} is not {self.words}")
        return v

    def outside(self) -> list[str]:
        """Values just outside the range, as typed."""
        step = 1 if self.kind is int else 1e-3 * max(1.0, abs(self.lo or 0), abs(self.hi or 0))
        out = []
        if self.lo is not None:
            out.append(self.lo if self.lo_open and self.kind is not int else self.lo - step)
        if self.hi is not None:
            out.append(self.hi if self.hi_open and self.kind is not int else self.hi + step)
        if self.multiple:
            out.append((self.lo or 0) + self.multiple + 1)
        return [f"{x:g}" if isinstance(x, float) else str(x) for x in out]


class RangeList:
    """An argparse ``type=``: comma-separated distinct numbers, each in ``item``'s range."""

    def __init__(self, item: Range):
        self.item = item
        self.__name__ = "list"

    @property
    def words(self) -> str:
        return f"distinct values, each {self.item.words}"

    def __call__(self, text):
        items = _items(text)
        return _unique([self.item(x) for x in items], items, str(text))

    def outside(self) -> list[str]:
        return self.item.outside()


def distinct_names(text: str) -> list[str]:
    """Comma-separated names, lower case, each once (argparse ``type=``): an empty list, an
    empty entry or a repeat (in any case) is an error.

    >>> distinct_names("sf,sobol")
    ['sf', 'sobol']
    """
    items = _items(text)
    return _unique([x.lower() for x in items], items, str(text))


def name_words(names, default=None) -> str:
    """``a (default), b, c``: a registry's names for ``--help``."""
    return ", ".join(f"{n} (default)" if n == default else n for n in names)


def common_range(type_) -> Range | None:
    """The :class:`Range` of one of :mod:`envfit.cli._common`'s number types (positive_int,
    nonneg_int, positive_float), or None."""
    from envfit.cli import _common as c
    return {c.positive_int: Range(int, 1), c.nonneg_int: Range(int, 0),
            c.positive_float: Range(float, 0, lo_open=True)}.get(type_)


def state_common_ranges(parser) -> None:
    """Append its range to the help of each option of ``parser`` typed by a number type of
    :mod:`envfit.cli._common` (``--seed``, ``--max-height``), whose help does not say it."""
    for action in parser._actions:
        rng = common_range(action.type)
        if rng is not None and action.help and rng.words not in action.help:
            action.help = f"{action.help}; {rng.words}"

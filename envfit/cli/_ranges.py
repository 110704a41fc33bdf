"""Numeric options with a stated range: one object gives argparse its ``type=``, ``--help``
its words and the error the same words.

``N = Ranged(1, 65536, "N")`` parses ``"1e3"`` to 1000 and refuses ``"1e12"`` as
``argument --n: 1e12 is outside 1 <= N <= 65536`` (one line, exit 2, :class:`OneLineParser`);
``--help`` states the range with ``str(N)`` (``"1 <= N <= 65536"``), so the help and the error
say the same. A bound that depends on the input (the map's band limit ``H-1``, its pixels
``W x H``) is stated in words (``hi_text``) and checked after the map is read, before any
work, by the command with :meth:`Ranged.check_dynamic` (the same words again).

:func:`ranged_actions` lists a parser's ranged options (the tests walk them).
"""
from __future__ import annotations

import argparse
import math

from envfit.cli._common import _finite, _items, _unique, _whole


def _fmt(v) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}".replace("e+0", "e").replace("e+", "e")


class Ranged:
    """An argparse ``type=`` for a number (or a comma list of them, ``many=True``) in a
    stated range.

    Parameters
    ----------
    lo, hi : the bounds (``hi=None``: only ``hi_text``, a bound checked after the input is
        read).
    name : the symbol in the range's words (``N``, ``L``, ``s``).
    integer : whole numbers (``1e3`` is 1000; ``100.5`` is refused) or finite floats.
    lo_open, hi_open : strict bounds (``1 < s < 2``).
    hi_text : words of an input-dependent upper bound (``"H-1 (the map's band limit)"``),
        stated after the fixed range.
    many : a comma list of distinct values (``colour=True``: repeats allowed).
    words : literal words accepted as themselves (``auto``).
    """

    def __init__(self, lo, hi, name: str, *, integer: bool = True, lo_open: bool = False,
                 hi_open: bool = False, hi_text: str = "", many: bool = False,
                 words: tuple = (), repeats: bool = False):
        self.lo, self.hi, self.name, self.integer = lo, hi, name, integer
        self.lo_open, self.hi_open, self.hi_text = lo_open, hi_open, hi_text
        self.many, self.words, self.repeats = many, tuple(words), repeats
        self.__name__ = "ranged"          # argparse names a type by it in some messages

    # ---------------------------------------------------------------- words
    def __str__(self) -> str:
        lo = f"{_fmt(self.lo)} {'<' if self.lo_open else '<='} "
        if self.hi is None:
            hi = f" <= {self.hi_text}"
        else:
            hi = f" {'<' if self.hi_open else '<='} {_fmt(self.hi)}"
            if self.hi_text:
                hi += f" and <= {self.hi_text}"
        return lo + self.name + hi

    def __repr__(self) -> str:
        return f"Ranged({self})"

    # ---------------------------------------------------------------- parsing
    def inside(self, v) -> bool:
        """Whether ``v`` is within the fixed range."""
        if not math.isfinite(v):          # "too large" (beyond 10^18) is never inside
            return False
        above_lo = v > self.lo if self.lo_open else v >= self.lo
        if self.hi is None:
            return above_lo
        return above_lo and (v < self.hi if self.hi_open else v <= self.hi)

    def _one(self, text: str):
        t = str(text).strip()
        if t.lower() in self.words:
            return t.lower()
        try:
            v = _whole(t) if self.integer else _finite(t)
        except argparse.ArgumentTypeError as exc:
            if "too large" not in str(exc):
                raise
            v = math.inf
        if not self.inside(v):
            raise argparse.ArgumentTypeError(f"{t} is outside {self}")
        return v

    def __call__(self, text: str):
        if not self.many:
            return self._one(text)
        items = _items(text)
        values = [self._one(x) for x in items]
        return values if self.repeats else _unique(values, items, str(text))

    # ---------------------------------------------------------------- input-dependent bound
    def check_dynamic(self, flag: str, values, bound: int, where: str) -> None:
        """:class:`ParameterError` (one line) when a value of ``flag`` is above ``bound``,
        the value of ``hi_text`` for this input (``where``: "this 128x64 map")."""
        from envfit.base._errors import ParameterError
        vals = values if isinstance(values, (list, tuple)) else [values]
        over = [v for v in vals if v is not None and not isinstance(v, str) and v > bound]
        if over:
            raise ParameterError(f"{flag} {_fmt(over[0])} is outside {self}: "
                                 f"{self.hi_text.split(' (')[0]} = {bound} for {where}")


#: the words of the sample count's input-dependent bound (table2, fit)
PIXELS = "W x H (the map's pixels: more samples add no information)"


def check_pixels(rng: Ranged, flag: str, values, env) -> None:
    """``flag``'s values within ``rng``'s bound :data:`PIXELS` for the map ``env``, before
    any work (one line, the words of ``--help``)."""
    rng.check_dynamic(flag, values, int(env.width) * int(env.height),
                      f"map {env.name or ''} ({env.width}x{env.height})")


def check_library_pixels(rng: Ranged, flag: str, values, maps, load_options) -> None:
    """:func:`check_pixels` for a library (``maps``: the MAP arguments): against the map of
    fewest pixels, read from the headers before any work."""
    from envfit.maps._mapsource import resolve_map_sources
    sources = [s for s in resolve_map_sources(maps, load_options) if s.pixels() > 0]
    if sources:
        least = min(sources, key=lambda s: s.pixels())
        rng.check_dynamic(flag, values, least.pixels(), f"map {least.label}, the library's "
                          "smallest")


def workers_range() -> Ranged:
    """``--workers K``: 1 <= K <= this machine's cores
    (:func:`envfit.base._resources.machine_cores`)."""
    from envfit.base._resources import machine_cores
    return Ranged(1, machine_cores(), "K")


def ranged_actions(parser: argparse.ArgumentParser) -> list:
    """The optional arguments of ``parser`` whose ``type`` is a :class:`Ranged`."""
    return [a for a in parser._actions if isinstance(a.type, Ranged) and a.option_strings]


# --------------------------------------------------------------------------- advise's options
# ``envfit advise`` states its ranges with :class:`Range` (words such as "an integer from 1 to
# 11", the same in ``--help`` and the error); a list of names (:func:`distinct_names`) refuses
# a repeat as a list of numbers does.  (issue 38.)
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

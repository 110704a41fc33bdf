"""Numeric options with a stated range: one object gives argparse its ``type=``, ``--help``
its words and the error the same words.

``N = Ranged(1, 65536, "N")`` parses ``"1e3"`` to 1000 and refuses ``"1e12"`` as
``argument --n: 1e12 is outside 1 <= N <= 65536`` (one line, exit 2, :class:`OneLineParser`);
``--help`` states the range with ``str(N)`` (``"1 <= N <= 65536"``), so the help and the error
say the same. Every command's numeric options use it (sh, theory, table2, fit, synth,
validate, advise, ``--workers``): one range type, one way of saying a range. A bound that
depends on the input (the map's band limit ``H-1``, its pixels ``W x H``) is stated in words
(``hi_text``) and checked after the map is read, before any work, by the command with
:meth:`Ranged.check_dynamic` (the same words again).

:func:`ranged_actions` lists a parser's ranged options (the tests walk them);
:meth:`Ranged.outside` gives values just outside a range (the tests type them).
"""
from __future__ import annotations

import argparse
import math

from envfit.cli._parse import check_unique, parse_finite, parse_whole, split_items


def _fmt(v) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}".replace("e+0", "e").replace("e+", "e")


def _positional(v: float) -> str:
    """A float as a user types it, without an exponent (argparse reads ``-1e-06`` as an
    option, ``-0.000001`` as a value)."""
    return format(v, ".12f").rstrip("0").rstrip(".")


class Ranged:
    """An argparse ``type=`` for a number (or a comma list of them, ``many=True``) in a
    stated range.

    Parameters
    ----------
    lo, hi : the bounds (``hi=None``: no upper bound, ``N >= 10``, or only ``hi_text``, a
        bound checked after the input is read).
    name : the symbol in the range's words (``N``, ``L``, ``s``).
    integer : whole numbers (``1e3`` is 1000; ``100.5`` is refused) or finite floats.
    lo_open, hi_open : strict bounds (``1 < s < 2``).
    hi_text : words of an input-dependent upper bound (``"H-1 (the map's band limit)"``),
        stated after the fixed range.
    many : a comma list of distinct values (``repeats=True``: repeats allowed).
    literals : words accepted as themselves, lower case (``auto``); ``--help`` names them.
    multiple : whole numbers that are a multiple of it (``G >= 8, a multiple of 4``).
    """

    def __init__(self, lo, hi, name: str, *, integer: bool = True, lo_open: bool = False,
                 hi_open: bool = False, hi_text: str = "", many: bool = False,
                 literals: tuple = (), repeats: bool = False, multiple: int | None = None):
        self.lo, self.hi, self.name, self.integer = lo, hi, name, integer
        self.lo_open, self.hi_open, self.hi_text = lo_open, hi_open, hi_text
        self.many, self.literals, self.repeats = many, tuple(literals), repeats
        self.multiple = multiple
        self.__name__ = "ranged"          # argparse names a type by it in some messages

    # ---------------------------------------------------------------- words
    def __str__(self) -> str:
        mult = f", a multiple of {self.multiple}" if self.multiple else ""
        if self.hi is None and not self.hi_text:        # no upper bound: "N >= 10"
            return f"{self.name} {'>' if self.lo_open else '>='} {_fmt(self.lo)}{mult}"
        lo = f"{_fmt(self.lo)} {'<' if self.lo_open else '<='} "
        if self.hi is None:
            hi = f" <= {self.hi_text}"
        else:
            hi = f" {'<' if self.hi_open else '<='} {_fmt(self.hi)}"
            if self.hi_text:
                hi += f" and <= {self.hi_text}"
        return lo + self.name + hi + mult

    def __repr__(self) -> str:
        return f"Ranged({self})"

    # ---------------------------------------------------------------- parsing
    def inside(self, v) -> bool:
        """Whether ``v`` is within the fixed range."""
        if not math.isfinite(v):          # "too large" (beyond 10^18) is never inside
            return False
        above_lo = v > self.lo if self.lo_open else v >= self.lo
        if self.multiple and v % self.multiple:
            return False
        if self.hi is None:
            return above_lo
        return above_lo and (v < self.hi if self.hi_open else v <= self.hi)

    def outside(self) -> list[str]:
        """Values just outside the fixed range, as typed (for tests): below ``lo``, above
        ``hi`` (none above an input-dependent bound) and, with ``multiple``, the first
        value above ``lo`` that is not a multiple of it.

        >>> Ranged(8, None, "G", multiple=4).outside(), Ranged(0, 1, "F", integer=False,
        ...                                                    lo_open=True).outside()
        (['7', '9'], ['0', '1.000001'])
        """
        def step(end):
            return 1 if self.integer else 1e-6 * max(1.0, abs(end))
        out = [self.lo if self.lo_open else self.lo - step(self.lo)]
        if self.hi is not None:
            out.append(self.hi if self.hi_open else self.hi + step(self.hi))
        if self.multiple:
            out.append(next(v for v in range(self.lo + 1, self.lo + self.multiple + 1)
                            if v % self.multiple))
        return [_positional(v) if isinstance(v, float) else str(v) for v in out]

    def _one(self, text: str):
        t = str(text).strip()
        if t.lower() in self.literals:
            return t.lower()
        try:
            v = parse_whole(t) if self.integer else parse_finite(t)
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
        items = split_items(text)
        values = [self._one(x) for x in items]
        return values if self.repeats else check_unique(values, items, str(text))

    # ---------------------------------------------------------------- input-dependent bound
    def check_dynamic(self, flag: str, values, bound: int, where: str) -> None:
        """:class:`ParameterError` (one line) when a value of ``flag`` is above ``bound``,
        the value of ``hi_text`` for this input (``where``: "this 128x64 map")."""
        from envfit.base import ParameterError
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
    from envfit.maps import resolve_map_sources
    sources = [s for s in resolve_map_sources(maps, load_options) if s.pixels() > 0]
    if sources:
        least = min(sources, key=lambda s: s.pixels())
        rng.check_dynamic(flag, values, least.pixels(), f"map {least.label}, the library's "
                          "smallest")


def workers_range() -> Ranged:
    """``--workers K``: 1 <= K <= this machine's cores
    (:func:`envfit.base._resources.machine_cores`)."""
    from envfit.base import machine_cores
    return Ranged(1, machine_cores(), "K")


def ranged_actions(parser: argparse.ArgumentParser) -> list:
    """The optional arguments of ``parser`` whose ``type`` is a :class:`Ranged`."""
    return [a for a in parser._actions if isinstance(a.type, Ranged) and a.option_strings]


# --------------------------------------------------------------------------- lists of names
# ``envfit advise``'s lists of names (:func:`distinct_names`) refuse a repeat as a list of
# numbers does; :func:`state_common_ranges` gives _common's number types their range.
def distinct_names(text: str) -> list[str]:
    """Comma-separated names, lower case, each once (argparse ``type=``): an empty list, an
    empty entry or a repeat (in any case) is an error.

    >>> distinct_names("sf,sobol")
    ['sf', 'sobol']
    """
    items = split_items(text)
    return check_unique([x.lower() for x in items], items, str(text))


def name_words(names, default=None) -> str:
    """``a (default), b, c``: a registry's names for ``--help``."""
    return ", ".join(f"{n} (default)" if n == default else n for n in names)


def common_range(type_, name: str) -> Ranged | None:
    """The :class:`Ranged` of one of :mod:`envfit.cli._parse`'s number types (positive_int,
    nonneg_int, positive_float), its symbol ``name``; None for another type."""
    from envfit.cli import _parse as c
    lo = {c.positive_int: 1, c.nonneg_int: 0, c.positive_float: 0}.get(type_)
    if lo is None:
        return None
    return Ranged(lo, None, name, integer=type_ is not c.positive_float,
                  lo_open=type_ is c.positive_float)


def state_common_ranges(parser) -> None:
    """Give each option of ``parser`` typed by a number type of :mod:`envfit.cli._parse`
    (``--seed``, ``--max-height``) its :class:`Ranged` (the symbol its metavar, else its
    name: ``H >= 1``, ``SEED >= 0``), stated in its help, so that the help and the error say
    the same words."""
    for action in parser._actions:
        rng = common_range(action.type, action.metavar or action.dest.upper())
        if rng is None or not action.option_strings:
            continue
        action.type = rng
        if action.help and str(rng) not in action.help:
            action.help = f"{action.help}; {rng}"

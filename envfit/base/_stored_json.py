"""Stored JSON read without a traceback, and its values checked: a file that cannot be
decoded says why in a few words, a folder where a file belongs is moved aside, and the
field checks of :meth:`envfit.base._store.ResultStore.get` say what is wrong with a value
(:mod:`envfit.base._store`, "Cells you can trust").
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Callable

from envfit.base._files import MAX_JSON_BYTES, read_bounded

__all__ = ["read_json_file", "move_aside", "config_problem", "json_type", "number_problem",
           "number", "one_of"]


def read_json_file(path: Path, max_bytes: int = MAX_JSON_BYTES) -> tuple[Any, str | None]:
    """``(document, None)``, or ``(None, why)`` for a file that cannot be decoded or is no
    regular file of at most ``max_bytes`` (a FIFO, a device, a socket, a symbolic link loop or
    a dangling one: :func:`envfit.base._files.read_bounded`, which never blocks on one and
    never reads more than the cap); ``(None, None)`` when there is no file at all."""
    raw, why = read_bounded(path, max_bytes, "a file")
    if raw is None:     # "is a named pipe (FIFO), not a file" -> a noun phrase, as below
        return None, why if why is None or not why.startswith("is ") else why[3:]
    if not raw.strip():
        return None, "an empty file"
    try:
        return json.loads(raw.decode("utf-8")), None
    except UnicodeDecodeError:
        return None, "not a JSON file (binary data)"
    except (ValueError, RecursionError):
        return None, "not valid JSON (truncated or corrupt)"


def move_aside(path: Path) -> str:
    """Rename a folder standing where a JSON file belongs (so that the file can be written)
    to ``<name>.folder``, ``<name>.folder1``, …; returns `` (moved to NAME)``, or "" if it
    could not be moved (the caller then keeps its value in memory)."""
    for k in range(100):
        aside = path.with_name(f"{path.name}.folder{k or ''}")
        if not os.path.lexists(aside):
            try:
                os.rename(path, aside)
            except OSError:
                break
            return f" (moved to {aside.name})"
    return ""


def config_problem(doc: Any, kind: str) -> str | None:
    """Why ``doc``, read from a store's ``<kind>_config.json``, is not a config at all
    (corrupt: not a JSON object, ``{}``, no ``kind`` or another one), or None when it is one
    (equal to this run's or not)."""
    if not isinstance(doc, dict):
        return f"a JSON {type(doc).__name__}, not an object"
    if not doc:
        return "an empty JSON object {}"
    if "kind" not in doc:
        return "no 'kind' field"
    if doc["kind"] != kind:
        return f"kind {doc['kind']!r}, not {kind!r}"
    return None


# ------------------------------------------------------------- value checks (schemas)
def json_type(v: Any) -> str:
    """``v``'s JSON type in words, for a note (``"a string"``, ``"null"``, …)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    return {str: "a string", list: "a list", dict: "an object"}.get(type(v), type(v).__name__)


def number_problem(v: Any, name: str, lo: float = -math.inf, hi: float = math.inf, *,
                   open_: bool = False, integer: bool = False) -> str | None:
    """Why the stored ``v`` is not a finite number (an integer if ``integer``; booleans are
    not numbers) in [lo, hi] ((lo, hi) when ``open_``), or None.

    >>> number_problem(5, "s", 1, 2, open_=True), number_problem("x", "rmse")
    ('s = 5 is outside (1, 2)', 'rmse is a string, not a number')
    """
    if isinstance(v, bool) or not isinstance(v, int if integer else (int, float)):
        return f"{name} is {json_type(v)}, not {'an integer' if integer else 'a number'}"
    if not math.isfinite(v):
        return f"{name} is {v!r}, not finite"
    if (lo < v < hi) if open_ else (lo <= v <= hi):
        return None
    if lo == 0 and hi == math.inf and not open_:
        return f"{name} = {v!r} is negative"
    return f"{name} = {v!r} is outside {'(' if open_ else '['}{lo:g}, {hi:g}{')' if open_ else ']'}"


def number(lo: float = -math.inf, hi: float = math.inf, *, open_: bool = False,
           integer: bool = False) -> Callable[[Any, str], str | None]:
    """A field check for :meth:`ResultStore.get`: :func:`number_problem` with these bounds."""
    return lambda v, name: number_problem(v, name, lo, hi, open_=open_, integer=integer)


def one_of(*allowed: Any) -> Callable[[Any, str], str | None]:
    """A field check for :meth:`ResultStore.get`: the value is one of ``allowed`` (numbers
    compared to 1e-9 relative, as a cell's s against its key)."""
    def check(v, name):
        for a in allowed:
            if isinstance(a, (int, float)) and not isinstance(a, bool):
                if not number_problem(v, name) and math.isclose(v, a, rel_tol=1e-9):
                    return None
            elif v == a:
                return None
        return f"{name} is {v!r}, not {' or '.join(repr(a) for a in allowed)}"
    return check

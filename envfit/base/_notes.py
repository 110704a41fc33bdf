"""Notes with a kind: a message that is still a ``str`` (so whatever prints, joins or
serialises notes is unchanged) and says what it is about, so a caller acts on the kind,
never on the wording.

>>> n = Note("cache switched off: cannot write under /x", NoteKind.CACHE_OFF)
>>> n.kind is NoteKind.CACHE_OFF, n.startswith("cache"), str(n) == n
(True, True, True)
>>> import pickle; pickle.loads(pickle.dumps(n)).kind
<NoteKind.CACHE_OFF: 'cache-off'>
"""
from __future__ import annotations

from enum import Enum

__all__ = ["Note", "NoteKind", "note_kind"]


class NoteKind(str, Enum):
    """What a note is about."""

    #: the advisor cache is not written this run (not writable, or a write failed): the
    #: results are right but not cached
    CACHE_OFF = "cache-off"


class Note(str):
    """A message with a :class:`NoteKind` (``kind``; None for a plain note)."""

    kind: NoteKind | None

    def __new__(cls, text: str, kind: NoteKind | None = None):
        obj = super().__new__(cls, text)
        obj.kind = kind
        return obj

    def __reduce__(self):
        return (type(self), (str(self), self.kind))


def note_kind(note) -> NoteKind | None:
    """The kind of ``note`` (a :class:`Note`), None for a plain ``str``."""
    return getattr(note, "kind", None)

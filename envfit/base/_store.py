"""A resumable result store: one JSON file per finished cell, written atomically, checked on read.

A long sweep (Table 2, validation, a library of maps) writes each finished cell as soon as
it is done. Re-running with the same output folder and the same configuration skips the
finished cells, so an interrupted run (Ctrl-C, a killed worker) loses at most the cells in
progress. A folder written for a different configuration is refused rather than mixed.

Cells you can trust
-------------------
Every cell file (format :data:`STORE_FORMAT`) says what it is for and carries a checksum::

    {"format": 2, "config": {"kind": "table2", "map": …, "scale": …, "seed": …},
     "key": "s1.5000_n1000", "cell": {…the numbers…}, "sha256": "…"}

``config`` is the store's identity (the sweep's kind, the map's fingerprint, scale, point
set, seed, …), ``key`` names the cell's own fields (s, N, …), and ``sha256`` is the SHA-256
of the canonical JSON (sorted keys, no spaces) of the other four entries. JSON keeps a
float's shortest round-trip repr, so the checksum of what is read equals that of what was
written. On read, a cell that cannot be decoded (random bytes, a truncated file, a folder in
its place; a named pipe, a device, a symbolic link loop, never opened:
:mod:`envfit.base._files`), whose checksum does not match (edited by hand or corrupt), whose
key or config is not the one asked for (a file copied from another cell or run), or that was
written in an older format (no checksum) is treated as **missing**: the caller recomputes it,
and the store emits one note naming the file and why, e.g. ``recomputed out/cells/s1.5000_n1000.json:
checksum mismatch (edited or corrupt)``. It is never a traceback, and an edited value is
never used. The folder's ``<kind>_config.json`` is checked the same way: one that is not a
config at all (empty, unparseable, ``{}``, no ``kind``, a folder) is rewritten with one
note, ``rewrote …: corrupt config (…)`` — safe, since every cell carries its own copy —
and only a well-formed config of *another* run refuses the folder ("a different … run").
Notes go to ``on_note`` (the library sweeps collect them in ``lib.notes``, which
the CLI prints); without one they are printed to stderr as ``note: …``.

One run per folder
------------------
A run holds :class:`~envfit.base._lock.FolderLock` on its output folder (a second run on it
exits with :class:`~envfit.base._lock.StoreBusyError`; :mod:`envfit.base._lock`).
"""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np

from envfit.base._atomic import atomic_write_json, to_jsonable
from envfit.base._errors import EnvfitError, ParameterError
from envfit.base._lock import LOCK_NAME, LOCK_TIMEOUT, FolderLock, StoreBusyError
from envfit.base._progress import print_note
from envfit.base._stored_json import (config_problem, json_type, move_aside, number,
                                      number_problem, one_of, read_json_file)

# FolderLock & co. (_lock), print_note (_progress) and the JSON checks (_stored_json) are
# re-exported: the store's callers import them from here
__all__ = ["ResultStore", "FolderLock", "StoreBusyError", "StoreWriteError", "STORE_FORMAT",
           "LOCK_TIMEOUT", "LOCK_NAME", "array_fingerprint", "canonical_sha256", "print_note", "move_aside",
           "config_problem", "read_json_file", "json_type", "number_problem", "number", "one_of"]

#: 1: bare cell dicts (no identity, no checksum); 2: identity + key + SHA-256 envelope
STORE_FORMAT = 2


class StoreWriteError(EnvfitError, OSError):
    """A cell or the store's config cannot be written (read-only folder, disk full, …)."""


def array_fingerprint(a: np.ndarray) -> str:
    """A short content hash of an array (shape, dtype and bytes), to tie results to their input."""
    a = np.ascontiguousarray(a)
    h = hashlib.sha1()
    h.update(str((a.shape, a.dtype.str)).encode())
    h.update(memoryview(a).cast("B"))
    return h.hexdigest()[:16]


def canonical_sha256(obj: Any) -> str:
    """SHA-256 (hex) of the canonical JSON of ``obj`` (sorted keys, no spaces, ASCII).

    >>> canonical_sha256({"b": 1, "a": [0.1]}) == canonical_sha256({"a": [0.1], "b": 1})
    True
    """
    text = json.dumps(to_jsonable(obj), sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def _safe_key(key: str) -> str:
    if not re.fullmatch(r"[A-Za-z0-9._=+-]+", key):
        raise ValueError(f"store keys must be file-name safe, got {key!r}")
    return key


# ------------------------------------------------------------------------------ the store
class ResultStore:
    """Cells of a sweep under ``folder/cells/<key>.json``, tied to ``folder/<kind>_config.json``.

    Parameters
    ----------
    folder : path or None
        Where to keep the cells. ``None`` keeps them in memory only (no resume, no lock).
    config : dict
        What identifies the sweep (input fingerprint, scale, point set, seed, …). An
        existing folder whose config differs raises :class:`~envfit.base._errors.ParameterError`;
        every cell carries it too (see the module docstring).
    kind : str
        The sweep's name (e.g. ``"table2"``), part of the config check.
    lock : bool
        Hold :class:`FolderLock` on ``folder`` until :meth:`close` (or until the store is
        garbage-collected); False when the caller locks a folder above it.
    on_note : callable or None
        Called with each note (a cell ignored and recomputed, a config file rewritten);
        default :func:`print_note`. ``notes`` keeps them all.
    """

    def __init__(self, folder: str | Path | None, config: dict[str, Any], *, kind: str,
                 lock: bool = True, on_note: Callable[[str], None] | None = None):
        self.folder = Path(folder) if folder is not None else None
        self.config = {"kind": kind, **to_jsonable(config)}
        self.kind = kind
        self.notes: list[str] = []
        self._on_note = on_note or print_note
        self._noted: set[str] = set()
        self._memory: dict[str, dict] = {}
        #: ``(path, reason)`` of every cell that could not be written (kept in memory instead)
        self.unwritten: list[tuple[str, str]] = []
        self._lock: FolderLock | None = None
        if self.folder is None:
            return
        if lock:    # (no bound method of self in the lock: the store must not be in a cycle)
            self._lock = FolderLock(self.folder, on_note=self._on_note).acquire()
            self.notes.extend(self._lock.notes)
        try:
            self._open_folder()
        except BaseException:
            self.close()
            raise

    def _open_folder(self) -> None:
        """Create the cells folder; write the config, or check the one already there."""
        cfg_path = self.folder / f"{self.kind}_config.json"
        try:
            self.cells_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StoreWriteError(f"cannot create {self.cells_dir}: {exc.strerror or exc}") from None
        old, why = read_json_file(cfg_path)
        if old is not None and config_problem(old, self.kind) is not None:
            old, why = None, config_problem(old, self.kind)
        if old is not None and old != self.config:
            diff = sorted(k for k in set(old) | set(self.config)
                          if old.get(k) != self.config.get(k))
            raise ParameterError(
                f"{self.folder} holds results of a different {self.kind} run (differs in: "
                f"{', '.join(diff)}); use another --out folder or delete it to start over")
        if old is None:
            if why is not None:     # every cell carries its own config: safe to rewrite
                if cfg_path.is_dir() and not cfg_path.is_symlink():
                    why += move_aside(cfg_path)
                self._note(f"rewrote {cfg_path}: corrupt config ({why}); nothing to do: each "
                           f"cell carries its own copy, and only this run's cells are reused")
            self._write(cfg_path, self.config)

    @property
    def cells_dir(self) -> Path:
        assert self.folder is not None
        return self.folder / "cells"

    def close(self) -> None:
        """Release the folder's lock (the store stays readable)."""
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def __enter__(self) -> "ResultStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _note(self, text: str) -> None:
        self.notes.append(text)
        self._on_note(text)

    def _write(self, path: Path, obj: Any) -> None:
        try:
            atomic_write_json(path, obj)
        except OSError as exc:
            raise StoreWriteError(f"cannot write {path}: {exc.strerror or exc}") from None

    def _envelope(self, key: str, cell: dict) -> dict:
        doc = {"format": STORE_FORMAT, "config": self.config, "key": key, "cell": cell}
        return {**doc, "sha256": canonical_sha256(doc)}

    def _check(self, doc: Any, key: str) -> tuple[dict | None, str | None]:
        """``(cell, None)`` if ``doc`` is a sound envelope of cell ``key``, else ``(None, why)``."""
        if not isinstance(doc, dict):
            return None, "not a cell file"
        if "sha256" not in doc or "format" not in doc:
            return None, "written by an older envfit (no checksum)"
        if doc.get("format") != STORE_FORMAT:
            return None, f"store format {doc.get('format')!r}, this envfit reads {STORE_FORMAT}"
        body = {k: doc.get(k) for k in ("format", "config", "key", "cell")}
        if doc["sha256"] != canonical_sha256(body):
            return None, "checksum mismatch (edited or corrupt)"
        if doc["key"] != key:
            return None, f"holds cell {doc['key']}, not {key}"
        if doc["config"] != self.config:
            other = doc["config"] if isinstance(doc["config"], dict) else {}
            diff = sorted(k for k in set(other) | set(self.config)
                          if other.get(k) != self.config.get(k))
            return None, f"belongs to another {self.kind} run (differs in: {', '.join(diff)})"
        if not isinstance(doc["cell"], dict):
            return None, "not a cell file"
        return doc["cell"], None

    def _load(self, path: Path, key: str, fields: Iterable[str],
              checks: Mapping | None = None) -> dict | None:
        """The checked cell at ``path``; None (after one note) if it is not sound."""
        doc, why = read_json_file(path)
        cell = None
        if why is None and doc is not None:
            cell, why = self._check(doc, key)
        if cell is not None:
            lacking = [f for f in fields if f not in cell]
            if lacking:
                cell, why = None, f"lacks {', '.join(lacking)}"
            elif checks:
                why = next((w for f, check in checks.items() if f in cell
                            for w in (check(cell[f], f),) if w is not None), None)
                if why is not None:
                    cell, why = None, f"invalid cell: {why}"
        if why is not None:
            if path.is_dir() and not path.is_symlink():
                why += self._move_aside(path)
            if str(path) not in self._noted:
                self._noted.add(str(path))
                self._note(f"recomputed {path}: {why}")
        return cell

    @staticmethod
    def _move_aside(path: Path) -> str:
        """Rename a folder standing where a cell file belongs (:func:`move_aside`)."""
        return move_aside(path)

    def get(self, key: str, *, fields: Iterable[str] = (),
            checks: Mapping[str, Callable[[Any, str], str | None]] | None = None) -> dict | None:
        """The finished cell ``key``, or None if it has not been computed or is not sound
        (undecodable, edited, another cell's or run's, older format; one note each).
        ``fields``: names the cell must hold (else it is treated as not sound); ``checks``:
        name → ``check(value, name) -> why | None`` for each of those fields the cell holds
        (e.g. :func:`number`, :func:`one_of`) — a cell forged with a valid checksum but a
        wrong type or an out-of-range value is then not sound either
        (``invalid cell: rmse is a string, not a number``)."""
        key = _safe_key(key)
        if self.folder is None or key in self._memory:
            return self._memory.get(key)
        return self._load(self.cells_dir / f"{key}.json", key, tuple(fields), checks)

    def put(self, key: str, cell: dict) -> None:
        """Store ``cell`` under ``key`` (atomically, with identity and checksum)."""
        key = _safe_key(key)
        cell = to_jsonable(cell)
        if self.folder is None:
            self._memory[key] = cell
            return
        path = self.cells_dir / f"{key}.json"
        try:
            if path.is_dir() and not path.is_symlink():
                self._move_aside(path)
            self._write(path, self._envelope(key, cell))
        except (StoreWriteError, OSError) as exc:
            # disk full or folder gone mid-run: the cell is kept for this run (its result is
            # reported), only its resumability is lost; one note, and ``unwritten`` says which
            self._memory[key] = cell
            reason = getattr(exc, "strerror", None) or str(exc).replace(f"cannot write {path}: ", "")
            if not self.unwritten:
                self._note(f"could not write {path} ({reason}); this run keeps its cells in "
                           "memory and reports them, but a rerun will compute them again")
            self.unwritten.append((str(path), reason))
            return
        self._noted.discard(str(path))        # a later fault in the new file is a new note

    def __contains__(self, key: str) -> bool:
        return self.get(key) is not None

    def items(self) -> Iterator[tuple[str, dict]]:
        """Every sound cell as ``(key, cell)``, in key order (unsound ones noted, skipped)."""
        if self.folder is None:
            yield from self._memory.items()
            return
        for p in sorted(self.cells_dir.glob("*.json")):
            if not re.fullmatch(r"[A-Za-z0-9._=+-]+", p.stem):
                continue
            cell = self._load(p, p.stem, ())
            if cell is not None:
                yield p.stem, cell

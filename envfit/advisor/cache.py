"""The on-disk cache of ``envfit advise``: fitted (s, σ̂) and lookup transfer per map, and
worst-case-error curves.

A second ``advise`` on the same map answers without refitting s and without recomputing a
single error spectrum: all are JSON files under the cache folder, written atomically
(:mod:`envfit.base.atomic`). JSON keeps a float's shortest round-trip repr, so a number read back
is the number written: a cached answer equals a fresh one.

* folder: ``$ENVFIT_CACHE_DIR`` if set, else ``~/.cache/envfit``; the advisor uses its
  ``advise/`` subfolder (``fit/``, ``transfer/`` and ``wce/`` inside).
* a file is named by the SHA-1 of its key (a JSON-able dict, e.g. the map's fingerprint,
  scale and kernel for a fit; s, BRDF, point set, weighting, seeds and band limit for a wce
  curve) and holds, besides the value, what it is for — the cache version, the entry's kind
  and key — and a checksum: ``sha256`` of the canonical JSON (sorted keys, no spaces) of
  ``{"version", "format", "kind", "key", "value"}`` (:func:`envfit.base.store.canonical_sha256`).
  A file that cannot be read or parsed (random bytes, truncated), whose checksum does not
  match (edited or corrupt), whose stored key or kind differs (a copied file, a hash
  collision) or that was written before checksums (format 1) is ignored and rewritten, with
  one note naming it in ``notes`` (the advisor passes them on as ``advice.notes``) — never
  an error, and an edited number is never used.
* a wce curve is a dict ``N → terms``; new points are merged into what the file holds at
  the time of writing, so two processes extending the same curve lose nothing but the
  points written between each other's read and write. The terms are map-independent (the
  rule's error power per degree, ``(Σw − 1)²``, …); the advisor weights them with the
  map's own numbers afresh.
* a folder that cannot be created or written (read-only home, read-only file system, a
  path through a regular file) switches the cache off with a note instead of failing the
  command. :func:`cache_write_problem` tells, in a few milliseconds, whether that will
  happen, so that a command can say so before long work.

Example
-------
>>> import tempfile
>>> c = AdviseCache(tempfile.mkdtemp())
>>> c.load("fit", {"map": "x"}) is None
True
>>> c.save("fit", {"map": "x"}, {"s": 1.5}); c.load("fit", {"map": "x"})
{'s': 1.5}
>>> c.merge_curve({"ps": "sf"}, {64: {"e2": 1.0}}); c.load_curve({"ps": "sf"})
{64: {'e2': 1.0}}
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from envfit.base.atomic import atomic_write_json, to_jsonable
from envfit.base.store import canonical_sha256, read_json_file

__all__ = ["AdviseCache", "default_cache_dir", "cache_write_problem", "CACHE_VERSION",
           "CACHE_FORMAT"]

#: bumped when the meaning of a cached number changes (old files are then ignored);
#: 2: band-limited fits, wce curves hold the error power per degree (not E² of one s)
CACHE_VERSION = 2
#: the file's layout: 1 (no checksum), 2 (identity + ``sha256``; see the module docstring)
CACHE_FORMAT = 2


def default_cache_dir() -> Path:
    """``$ENVFIT_CACHE_DIR`` if set and non-empty, else ``~/.cache/envfit`` (a folder under
    the temporary directory when there is no home directory)."""
    env = os.environ.get("ENVFIT_CACHE_DIR", "").strip()
    try:
        return Path(env).expanduser() if env else Path.home() / ".cache" / "envfit"
    except (RuntimeError, KeyError):        # no home directory: a per-user temporary folder
        return Path(tempfile.gettempdir()) / f"envfit-cache-{getattr(os, 'getuid', lambda: 0)()}"


def cache_write_problem(folder: str | os.PathLike | None = None) -> str | None:
    """Why the advisor could not write its cache under ``folder`` (default
    :func:`default_cache_dir`), as a one-line note; None if it can.

    Cheap (creates ``folder/advise`` if missing, then creates and removes one temporary file
    there), so a command can call it before long work and print the note; the advisor itself
    never fails on its cache (it switches the cache off with the same kind of note).

    >>> import tempfile
    >>> cache_write_problem(tempfile.mkdtemp()) is None
    True
    >>> f = tempfile.NamedTemporaryFile()
    >>> cache_write_problem(f.name).startswith("the advisor cache")
    True
    """
    base = (Path(folder) if folder is not None else default_cache_dir()) / "advise"
    try:
        base.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".envfit-write-check.", suffix=".tmp", dir=base)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        reason = " ".join(str(exc.strerror or exc).split())
        return (f"the advisor cache {base} is not writable ({reason}); advise works without it "
                f"but recomputes everything next time (set ENVFIT_CACHE_DIR to a writable folder)")
    return None


def _digest(kind: str, key: dict) -> str:
    text = json.dumps({"kind": kind, "version": CACHE_VERSION, **to_jsonable(key)},
                      sort_keys=True, separators=(",", ":"))
    return hashlib.sha1(text.encode()).hexdigest()[:24]


class AdviseCache:
    """JSON files under ``folder/advise/<kind>/<sha1(key)>.json``; ``enabled=False`` (or
    ``folder`` unusable) keeps everything in memory for this object's lifetime only.

    Attributes ``hits``, ``misses`` and ``writes`` count file reads that found / did not find
    a usable entry, and files written; ``notes`` collects why the cache was switched off and
    which files were ignored (one note per file).
    """

    def __init__(self, folder: str | os.PathLike | None = None, *, enabled: bool = True):
        self.enabled = bool(enabled)
        self.folder = (Path(folder) if folder is not None else default_cache_dir()) / "advise"
        self.hits = 0
        self.misses = 0
        self.writes = 0
        self.notes: list[str] = []
        self._noted: set[str] = set()
        self._memory: dict[str, Any] = {}

    # -- paths -----------------------------------------------------------------------
    def path(self, kind: str, key: dict) -> Path:
        """Where the entry of ``key`` lives (whether or not it exists)."""
        return self.folder / kind / f"{_digest(kind, key)}.json"

    def _disable(self, exc: OSError) -> None:
        if self.enabled:
            self.notes.append(f"cache switched off: cannot write under {self.folder} ({exc})")
        self.enabled = False

    def _note_file(self, p: Path, why: str) -> None:
        if str(p) not in self._noted:
            self._noted.add(str(p))
            self.notes.append(f"cache: recomputed {p}: {why}")

    def _read(self, kind: str, key: dict) -> Any:
        mem_key = f"{kind}/{_digest(kind, key)}"
        if not self.enabled:
            return self._memory.get(mem_key)
        p = self.path(kind, key)
        doc, why = read_json_file(p)
        if why is None and doc is not None:
            why = self._check(doc, kind, key)
        if why is not None:
            self._note_file(p, why)
            return None
        return None if doc is None else doc["value"]

    @staticmethod
    def _check(doc: Any, kind: str, key: dict) -> str | None:
        """Why ``doc`` is not a sound entry of ``(kind, key)``, or None if it is."""
        if not isinstance(doc, dict):
            return "not a cache entry"
        if "sha256" not in doc or "format" not in doc:
            return "written by an older envfit (no checksum)"
        body = {k: doc.get(k) for k in ("version", "format", "kind", "key", "value")}
        if doc["sha256"] != canonical_sha256(body):
            return "checksum mismatch (edited or corrupt)"
        if doc["format"] != CACHE_FORMAT or doc["version"] != CACHE_VERSION:
            return f"cache version {doc['version']!r}/{doc['format']!r}, not " \
                   f"{CACHE_VERSION}/{CACHE_FORMAT}"
        if doc["kind"] != kind or doc["key"] != to_jsonable(key):
            return "holds another entry (a copied file or a hash collision)"
        return None

    def _write(self, kind: str, key: dict, value: Any) -> None:
        mem_key = f"{kind}/{_digest(kind, key)}"
        if self.enabled:
            body = {"version": CACHE_VERSION, "format": CACHE_FORMAT, "kind": kind,
                    "key": to_jsonable(key), "value": to_jsonable(value)}
            try:
                atomic_write_json(self.path(kind, key), {**body, "sha256": canonical_sha256(body)})
                self.writes += 1
                self._noted.discard(str(self.path(kind, key)))
                return
            except OSError as exc:
                self._disable(exc)
        self._memory[mem_key] = to_jsonable(value)

    # -- plain entries ---------------------------------------------------------------
    def load(self, kind: str, key: dict) -> dict | None:
        """The stored dict for ``key``, or None (absent, corrupt, other key)."""
        v = self._read(kind, key)
        ok = isinstance(v, dict)
        if ok:
            self.hits += 1
        else:
            self.misses += 1
        return v if ok else None

    def save(self, kind: str, key: dict, value: dict) -> None:
        self._write(kind, key, value)

    # -- curves N -> terms -----------------------------------------------------------
    def load_curve(self, key: dict) -> dict[int, dict]:
        """The stored points ``{N: terms}`` of a wce curve ({} if none)."""
        v = self._read("wce", key)
        out: dict[int, dict] = {}
        if isinstance(v, dict):
            for k, t in v.items():
                try:
                    n = int(k)
                except ValueError:
                    continue
                if isinstance(t, dict):
                    out[n] = t
        if out:
            self.hits += 1
        else:
            self.misses += 1
        return out

    def merge_curve(self, key: dict, points: dict[int, dict]) -> None:
        """Add ``points`` to the stored curve (re-read first, so concurrent writers merge)."""
        if not points:
            return
        cur = self._read("wce", key)
        merged = dict(cur) if isinstance(cur, dict) else {}
        for n, t in points.items():
            old = merged.get(str(n))
            merged[str(int(n))] = {**old, **t} if isinstance(old, dict) else dict(t)
        self._write("wce", key, merged)

"""The on-disk cache of ``envfit advise``: fitted (s, σ̂) and lookup transfer per map, and
worst-case-error curves.

A second ``advise`` on the same map answers without refitting s and without recomputing a
single error spectrum: all are JSON files under the cache folder, written atomically
(:mod:`envfit.atomic`). JSON keeps a float's shortest round-trip repr, so a number read back
is the number written: a cached answer equals a fresh one.

* folder: ``$ENVFIT_CACHE_DIR`` if set, else ``~/.cache/envfit``; the advisor uses its
  ``advise/`` subfolder (``fit/``, ``transfer/`` and ``wce/`` inside).
* a file is named by the SHA-1 of its key (a JSON-able dict, e.g. the map's fingerprint,
  scale and kernel for a fit; s, BRDF, point set, weighting, seeds and band limit for a wce
  curve) and holds the key itself: a file whose stored key differs (a hash collision, an
  older format) or that cannot be parsed (a corrupt file) is ignored, then rewritten — never
  an error.
* a wce curve is a dict ``N → terms``; new points are merged into what the file holds at
  the time of writing, so two processes extending the same curve lose nothing but the
  points written between each other's read and write. The terms are map-independent (the
  rule's error power per degree, ``(Σw − 1)²``, …); the advisor weights them with the
  map's own numbers afresh.
* a folder that cannot be created or written (read-only home) switches the cache off with
  a note instead of failing the command.

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
from pathlib import Path
from typing import Any

from .atomic import atomic_write_json, to_jsonable

__all__ = ["AdviseCache", "default_cache_dir", "CACHE_VERSION"]

#: bumped when the meaning of a cached number changes (old files are then ignored);
#: 2: band-limited fits, wce curves hold the error power per degree (not E² of one s)
CACHE_VERSION = 2


def default_cache_dir() -> Path:
    """``$ENVFIT_CACHE_DIR`` if set and non-empty, else ``~/.cache/envfit``."""
    env = os.environ.get("ENVFIT_CACHE_DIR", "").strip()
    return Path(env).expanduser() if env else Path.home() / ".cache" / "envfit"


def _digest(kind: str, key: dict) -> str:
    text = json.dumps({"kind": kind, "version": CACHE_VERSION, **to_jsonable(key)},
                      sort_keys=True, separators=(",", ":"))
    return hashlib.sha1(text.encode()).hexdigest()[:24]


class AdviseCache:
    """JSON files under ``folder/advise/<kind>/<sha1(key)>.json``; ``enabled=False`` (or
    ``folder`` unusable) keeps everything in memory for this object's lifetime only.

    Attributes ``hits``, ``misses`` and ``writes`` count file reads that found / did not find
    a usable entry, and files written; ``notes`` collects why the cache was switched off.
    """

    def __init__(self, folder: str | os.PathLike | None = None, *, enabled: bool = True):
        self.enabled = bool(enabled)
        self.folder = (Path(folder) if folder is not None else default_cache_dir()) / "advise"
        self.hits = 0
        self.misses = 0
        self.writes = 0
        self.notes: list[str] = []
        self._memory: dict[str, Any] = {}

    # -- paths -----------------------------------------------------------------------
    def path(self, kind: str, key: dict) -> Path:
        """Where the entry of ``key`` lives (whether or not it exists)."""
        return self.folder / kind / f"{_digest(kind, key)}.json"

    def _disable(self, exc: OSError) -> None:
        if self.enabled:
            self.notes.append(f"cache switched off: cannot write under {self.folder} ({exc})")
        self.enabled = False

    def _read(self, kind: str, key: dict) -> Any:
        mem_key = f"{kind}/{_digest(kind, key)}"
        if not self.enabled:
            return self._memory.get(mem_key)
        p = self.path(kind, key)
        try:
            doc = json.loads(p.read_text())
        except (OSError, ValueError):               # missing or corrupt: recompute
            return None
        if not isinstance(doc, dict) or doc.get("version") != CACHE_VERSION \
                or doc.get("key") != to_jsonable(key):
            return None
        return doc.get("value")

    def _write(self, kind: str, key: dict, value: Any) -> None:
        mem_key = f"{kind}/{_digest(kind, key)}"
        if self.enabled:
            try:
                atomic_write_json(self.path(kind, key), {"version": CACHE_VERSION, "kind": kind,
                                                         "key": key, "value": value})
                self.writes += 1
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

"""The on-disk cache of ``envfit advise``: fitted (s, σ̂) and lookup transfer per map, and
worst-case-error curves.

A second ``advise`` on the same map answers without refitting s and without recomputing a
single error spectrum: all are JSON files under the cache folder, written atomically
(:mod:`envfit.base._atomic`). JSON keeps a float's shortest round-trip repr, so a number read back
is the number written: a cached answer equals a fresh one.

* folder: ``$ENVFIT_CACHE_DIR`` if set, else ``~/.cache/envfit``; the advisor uses its
  ``advise/`` subfolder (``fit/``, ``transfer/`` and ``wce/`` inside).
* a file is named by the SHA-1 of its key (a JSON-able dict, e.g. the map's fingerprint,
  scale and kernel for a fit; s, BRDF, point set, weighting, seeds and band limit for a wce
  curve) and holds, besides the value, what it is for — the cache version, the entry's kind
  and key — and a checksum: ``sha256`` of the canonical JSON (sorted keys, no spaces) of
  ``{"version", "format", "kind", "key", "value"}`` (:func:`envfit.base._store.canonical_sha256`).
  A file that cannot be read or parsed (random bytes, truncated, a folder in its place —
  moved aside; a named pipe, a device, a socket, a symbolic link loop — never opened,
  :mod:`envfit.base._files`; larger than :data:`~envfit.base._files.MAX_JSON_BYTES`), whose
  checksum does not match (edited or corrupt), whose stored key or kind differs (a copied
  file, a hash collision), that was written before checksums (format 1) or whose value does
  not fit its kind's schema (:data:`SCHEMAS`: types and ranges, e.g. a fit's s in (1, 2) and
  finite σ̂ ≥ 0; a renderer-advice cell's rmse² equal to the mean of its MSE and, given the
  map (:data:`MAP_CHECKS`), > 0 unless the map is constant — a file forged with a valid
  checksum) is ignored and rewritten, with one note naming it in ``notes`` (the advisor
  passes them on as ``advice.notes``) — never an error, and an edited number is never
  used. A bad entry is dropped alone: the rest of the cache stays on.
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
>>> fit = {"s": 1.5, "sigma_channels": [0.2], "source": "given"}
>>> c.save("fit", {"map": "x"}, fit); c.load("fit", {"map": "x"}) == fit
True
>>> terms = {"power": [0.0, 1e-3], "dev2": 0.0, "weight_sum": 1.0}
>>> c.merge_curve({"ps": "sf"}, {64: terms}); c.load_curve({"ps": "sf"}) == {64: terms}
True
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from envfit.base import atomic_write_json, probe_writable, to_jsonable
from envfit.base import Note, NoteKind
from envfit.base import (canonical_sha256, json_type as _what, move_aside,
                         number_problem as _bad_real, read_json_file)

__all__ = ["AdviseCache", "default_cache_dir", "cache_write_problem", "CACHE_VERSION",
           "CACHE_FORMAT", "SCHEMAS", "MAP_CHECKS", "entry_problem"]

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
        probe_writable(base)
    except OSError as exc:
        reason = " ".join(str(exc.strerror or exc).split())
        return (f"the advisor cache {base} is not writable ({reason}); advise works without it "
                f"but recomputes everything next time (set ENVFIT_CACHE_DIR to a writable folder)")
    return None


# ------------------------------------------------------------------- entry schemas
_NUMBER = (int, float)


def _leaves_are_numbers(v: Any, ndim: int) -> bool:
    if ndim == 1:
        return isinstance(v, list) and all(type(x) in _NUMBER for x in v)
    return isinstance(v, list) and all(_leaves_are_numbers(x, ndim - 1) for x in v)


def _bad_array(v: Any, name: str, ndim: int, lo: float = -math.inf,
               hi: float = math.inf) -> str | None:
    """Why ``v`` is not a rectangular ``ndim``-deep list of finite numbers in [lo, hi]."""
    try:
        a = np.array(v, dtype=np.float64) if _leaves_are_numbers(v, ndim) else None
    except (TypeError, ValueError):          # ragged
        a = None
    if a is None or a.ndim != ndim:
        return f"{name} is not a {ndim}-D array of numbers"
    bad = ~np.isfinite(a)
    if bad.any():
        return f"{name} holds a non-finite value ({float(a[bad][0])!r})"
    out = (a < lo) | (a > hi)
    if out.any():
        return f"{name} holds {float(a[out][0])!r}, outside [{lo:g}, {hi:g}]"
    return None


def _bad_fields(v: Any, required: dict, optional: dict) -> str | None:
    """Check an object's fields: ``{name: check(value, name) -> why | None}``."""
    if not isinstance(v, dict):
        return f"the value is {_what(v)}, not an object"
    lacking = [k for k in required if k not in v]
    if lacking:
        return f"lacks {', '.join(lacking)}"
    for name, check in (*required.items(), *((k, c) for k, c in optional.items() if k in v)):
        why = check(v[name], name)
        if why is not None:
            return why
    return None


def _bad_str(v, name):
    return None if isinstance(v, str) else f"{name} is {_what(v)}, not a string"


def _bad_sigma(v, name):
    why = _bad_array(v, name, 1, 0.0)
    if why is None and not any(x > 0 for x in v):
        why = f"{name} is {'empty' if not v else 'all 0'}"
    return why


def _bad_interval(v, name):
    if v is None:
        return None
    if not isinstance(v, list) or len(v) != 2:
        return f"{name} is {_what(v)}, not null or two numbers"
    return next((w for w in (_bad_real(x, f"{name}[{i}]") for i, x in enumerate(v)
                             if x is not None) if w), None)


def _bad_notes(v, name):
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        return f"{name} is not a list of strings"
    return None


def _bad_fit(v: Any) -> str | None:
    """A fitted (or given) s in (1, 2) and σ̂ per channel (finite, ≥ 0, not all 0)."""
    return _bad_fields(v, {"s": lambda x, n: _bad_real(x, n, 1.0, 2.0, open_=True),
                           "sigma_channels": _bad_sigma, "source": _bad_str},
                       {"s_interval": _bad_interval, "kernel": _bad_str, "notes": _bad_notes,
                        "band_lmax": lambda x, n: _bad_real(x, n, 0, integer=True),
                        "samples": lambda x, n: _bad_real(x, n, 1, integer=True),
                        "seconds": lambda x, n: _bad_real(x, n, 0.0)})


def _bad_power(v: Any) -> str | None:
    """The map's power per degree and channel: (C, L + 1), finite, ≥ 0."""
    return _bad_fields(v, {"power": lambda x, n: _bad_array(x, n, 2, 0.0)}, {})


def _bad_transfer(v: Any) -> str | None:
    """The lookup's transfer τ_l: finite, ≥ 0."""
    return _bad_fields(v, {"tau": lambda x, n: _bad_array(x, n, 1, 0.0)}, {})


def _bad_curve(v: Any) -> str | None:
    """A wce curve ``{"N": terms}``, N ≥ 1, each with its error power, (Σw − 1)² ≥ 0 and Σw."""
    if not isinstance(v, dict):
        return f"the value is {_what(v)}, not an object"
    for k, terms in v.items():
        if not (k.isdigit() and int(k) >= 1 and str(int(k)) == k):
            return f"curve point {k!r} is not a sample count N >= 1"
        why = _bad_fields(terms, {"power": lambda x, n: _bad_array(x, n, 1),
                                  "dev2": lambda x, n: _bad_real(x, n, 0.0),
                                  "weight_sum": _bad_real},
                          {"e2_plain": _bad_real})
        if why is not None:
            return f"N = {k}: {why}"
    return None


def _bad_spectrum(v: Any) -> str | None:
    """A stored warped spectrum (:meth:`envfit.predict.warped._warped_spectrum.WarpedSpectrum.to_json`): its
    fields typed and its arrays finite (the shapes are checked when it is parsed)."""
    def cross(x, n):
        return _bad_fields(x, {"real": lambda y, m: _bad_array(y, f"{n}.{m}", 1),
                               "imag": lambda y, m: _bad_array(y, f"{n}.{m}", 1)}, {})
    return _bad_fields(v, {
        "technique": _bad_str, "brdf": _bad_str, "heuristic": _bad_str,
        "shininess": lambda x, n: None if x is None else _bad_real(x, n, 0.0, open_=True),
        "fraction": lambda x, n: _bad_real(x, n, 0.0, 1.0),
        "band": lambda x, n: _bad_real(x, n, 0, integer=True),
        "grid": lambda x, n: _bad_real(x, n, 1, integer=True),
        "axes": lambda x, n: _bad_real(x, n, 1, integer=True),
        "mean": _bad_real, "variance": lambda x, n: _bad_array(x, n, 1, 0.0),
        "power": lambda x, n: _bad_array(x, n, 3), "cross": cross}, {})


def _bad_bands(v: Any, name: str) -> str | None:
    """Per view-angle band RMSE of a microfacet cell: {"lo-hi": finite number >= 0}."""
    if not isinstance(v, dict):
        return f"{name} is {_what(v)}, not an object"
    for k, x in v.items():
        why = _bad_real(x, f"{name}[{k}]", 0.0)
        if why is not None:
            return why
    return None


def _bad_band_errors(v: Any, name: str) -> str | None:
    """Per band of a microfacet cell: {"lo-hi" or "all": {"frames": int >= 1, "rel_se":
    finite number >= 0 or null}}."""
    if not isinstance(v, dict):
        return f"{name} is {_what(v)}, not an object"
    for k, x in v.items():
        why = _bad_fields(x, {"frames": lambda y, m: _bad_real(y, m, 1, integer=True),
                              "rel_se": lambda y, m: None if y is None else _bad_real(y, m, 0.0)},
                          {})
        if why is not None:
            return f"{name}[{k}]: {why}"
    return None


def _bad_renderer_cells(v: Any) -> str | None:
    """The renderer advice's predictions ``{"cells": {"strategy:spp": {"rmse", "mse"}}}``:
    a strategy of map, brdf, mis, spp ≥ 1, finite RMSE ≥ 0 and MSE per channel ≥ 0."""
    why = _bad_fields(v, {"cells": lambda x, n: None if isinstance(x, dict)
                          else f"{n} is {_what(x)}, not an object"}, {})
    if why is not None:
        return why
    for k, cell in v["cells"].items():
        s, _, n = k.partition(":")
        if s not in ("map", "brdf", "mis") or not (n.isdigit() and int(n) >= 1):
            return f"cell {k!r} is not strategy:spp"
        why = _bad_fields(cell, {"rmse": lambda x, m: _bad_real(x, m, 0.0),
                                 "mse": lambda x, m: _bad_array(x, m, 1, 0.0)},
                          {"bands": _bad_bands, "band_errors": _bad_band_errors})
        if why is not None:
            return f"cell {k}: {why}"
        why = _bad_rmse(cell["rmse"], cell["mse"])
        if why is not None:
            return f"cell {k}: {why}"
    return None


def _bad_rmse(rmse: float, mse: list) -> str | None:
    """A cell's RMSE is √(mean over channels of its MSE)
    (:class:`envfit.predict.renderer._diffuse_model.RendererPrediction`): rmse² equals the
    mean to rounding (1e-9 relative; both 0 only together)."""
    if not mse:
        return "mse is empty"
    mean = math.fsum(mse) / len(mse)
    if math.isclose(rmse * rmse, mean, rel_tol=1e-9, abs_tol=0.0):
        return None
    return f"rmse = {rmse!r} is not the root of the mean of its mse ({mean!r})"


def _renderer_cells_for_map(v: dict, envmap) -> str | None:
    """Against the map the entry is for: a map that is not constant in some channel has
    noise under every strategy and spp, so each cell's RMSE is > 0."""
    data = np.asarray(envmap.data)
    if data.size == 0 or bool(np.all(data == data.reshape(-1, data.shape[-1])[0])):
        return None
    k = next((k for k, cell in v["cells"].items() if not cell["rmse"] > 0), None)
    return None if k is None else f"cell {k}: rmse = 0 for a map that is not constant"


#: the schema of each kind's value: why an entry is not one (types and ranges), or None;
#: a kind without one is returned as stored
SCHEMAS: dict[str, Callable[[Any], str | None]] = {
    "fit": _bad_fit, "power": _bad_power, "transfer": _bad_transfer, "wce": _bad_curve,
    "renderer": _bad_spectrum, "renderer_cells": _bad_renderer_cells}


#: checks of a kind's value against the map it was computed for (after its schema)
MAP_CHECKS: dict[str, Callable[[Any, Any], str | None]] = {
    "renderer_cells": _renderer_cells_for_map}


def entry_problem(kind: str, value: Any, envmap=None) -> str | None:
    """Why ``value`` is not a valid entry of ``kind`` (:data:`SCHEMAS`; with ``envmap``,
    the map it is for, also :data:`MAP_CHECKS`), or None.

    >>> entry_problem("fit", {"s": 5, "sigma_channels": [0.1], "source": "fit"})
    'invalid fit entry: s = 5 is outside (1, 2)'
    >>> entry_problem("fit", {"s": 1.5, "sigma_channels": [float("nan")], "source": "fit"})
    'invalid fit entry: sigma_channels holds a non-finite value (nan)'
    """
    check = SCHEMAS.get(kind)
    why = None if check is None else check(value)
    if why is None and envmap is not None and kind in MAP_CHECKS:
        why = MAP_CHECKS[kind](value, envmap)
    return None if why is None else f"invalid {kind} entry: {why}"


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
            self.notes.append(Note(f"cache switched off: cannot write under {self.folder} "
                                   f"({exc})", NoteKind.CACHE_OFF))
        self.enabled = False

    def _note_file(self, p: Path, why: str) -> None:
        if str(p) not in self._noted:
            self._noted.add(str(p))
            self.notes.append(f"cache: recomputed {p}: {why}")

    def _read(self, kind: str, key: dict, envmap=None) -> Any:
        mem_key = f"{kind}/{_digest(kind, key)}"
        if not self.enabled or mem_key in self._memory:
            return self._memory.get(mem_key)
        p = self.path(kind, key)
        doc, why = read_json_file(p)
        if why is None and doc is not None:
            why = self._check(doc, kind, key) or entry_problem(kind, doc["value"], envmap)
        if why is not None:
            if p.is_dir() and not p.is_symlink():
                why += move_aside(p)            # so that the recomputed entry can be written
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
            p = self.path(kind, key)
            try:
                if p.is_dir() and not p.is_symlink():
                    move_aside(p)
                atomic_write_json(p, {**body, "sha256": canonical_sha256(body)})
                self.writes += 1
                self._noted.discard(str(p))
                self._memory.pop(mem_key, None)
                return
            except OSError as exc:
                if os.path.lexists(p) and not p.is_file():
                    # this entry's own fault (a folder that cannot be moved): it alone is
                    # kept in memory, the rest of the cache stays on
                    self.notes.append(f"cache: cannot write {p} (a folder is in its place); "
                                      f"this entry is kept in memory for this run only")
                else:
                    self._disable(exc)
        self._memory[mem_key] = to_jsonable(value)

    # -- plain entries ---------------------------------------------------------------
    def load(self, kind: str, key: dict, *, envmap=None) -> dict | None:
        """The stored dict for ``key``, or None (absent, corrupt, other key, not valid; with
        ``envmap``, the map the entry is for, also checked against it: :data:`MAP_CHECKS`)."""
        v = self._read(kind, key, envmap)
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

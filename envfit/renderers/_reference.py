r"""The high-spp reference renders of the sphere, cached on disk.

A reference is two renders of the six views (:mod:`._sphere`) at high spp with distinct
seeds; it is the same for every strategy and sampler of one map, so it is rendered once per
(renderer, map, spp, resolution, settings) and stored as one ``.npz`` file named by the hash
of that key. The file holds the key (JSON) and the SHA-256 of the two arrays; a file whose key
or digest does not match (another key hashed alike, a torn or corrupt file), or that is no
regular file (a FIFO, a device, a symbolic link loop: never opened) or larger than
:data:`MAX_REFERENCE_BYTES`, is rendered again and replaced. Files are written atomically (a
temporary name in the same folder, then ``os.replace``), so concurrent runs never read half a
file.

Example
-------
>>> import tempfile
>>> calls = []
>>> def render():
...     calls.append(1)
...     return np.zeros((6, 4, 4, 3)), np.ones((6, 4, 4, 3)), 1.5
>>> d = tempfile.mkdtemp()
>>> key = {"renderer": "demo", "map": "abc", "spp": 8}
>>> r1 = cached_reference(key, render, d)
>>> r2 = cached_reference(key, render, d)
>>> len(calls), r2.cached, float(r2.b.mean()), r2.seconds
(1, True, 1.0, 1.5)
"""
from __future__ import annotations

import hashlib
import io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from envfit.base import atomic_write_bytes
from envfit.base import OutputError
from envfit.base import open_regular

__all__ = ["ReferencePair", "map_digest", "cached_reference"]

#: the largest reference file read back (six views of 1024² RGB pixels, twice, are 144 MiB)
MAX_REFERENCE_BYTES = 2 * 2**30


@dataclass(frozen=True)
class ReferencePair:
    """Two reference renders a, b (6, R, R, C) of one key, the seconds they took to render
    (when they were rendered, even if read from the cache now) and whether they were read
    from the cache."""

    a: np.ndarray
    b: np.ndarray
    seconds: float
    cached: bool


def map_digest(envmap) -> str:
    """SHA-256 (hex) of a map's pixels as float32, its shape and its up axis."""
    h = hashlib.sha256()
    data = np.ascontiguousarray(envmap.data, dtype=np.float32)
    h.update(repr((data.shape, envmap.up)).encode())
    h.update(data.tobytes())
    return h.hexdigest()


def _arrays_digest(a: np.ndarray, b: np.ndarray) -> str:
    h = hashlib.sha256()
    for x in (a, b):
        x = np.ascontiguousarray(x, dtype=np.float32)
        h.update(repr(x.shape).encode())
        h.update(x.tobytes())
    return h.hexdigest()


def _load(path: Path, key_json: str) -> ReferencePair | None:
    """The pair stored at ``path`` if its key and digest match, else None."""
    fh, _ = open_regular(path, MAX_REFERENCE_BYTES)     # not a FIFO, a device, a loop
    if fh is None:
        return None
    try:
        with fh, np.load(fh, allow_pickle=False) as z:
            if str(z["key"]) != key_json:
                return None
            a, b = z["a"], z["b"]
            if str(z["digest"]) != _arrays_digest(a, b):
                return None
            return ReferencePair(a.astype(np.float64), b.astype(np.float64),
                                 float(z["seconds"]), True)
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None


def _store(path: Path, key_json: str, a, b, seconds: float) -> None:
    buf = io.BytesIO()
    a32 = np.ascontiguousarray(a, dtype=np.float32)
    b32 = np.ascontiguousarray(b, dtype=np.float32)
    np.savez(buf, a=a32, b=b32, key=np.array(key_json), seconds=np.array(float(seconds)),
             digest=np.array(_arrays_digest(a32, b32)))
    try:
        atomic_write_bytes(path, buf.getvalue())
    except OSError as exc:
        raise OutputError(f"cannot write the reference cache {path}: {exc.strerror or exc}") \
            from None


def cached_reference(key: dict, render: Callable[[], tuple], cache_dir=None) -> ReferencePair:
    """The reference pair of ``key`` from ``cache_dir`` (verified), else ``render()`` →
    (a, b, seconds), stored there. ``cache_dir`` None: no cache (always renders). The arrays
    are stored as float32 and returned as float64 (also when just rendered, so a cached and a
    fresh reference give the same numbers)."""
    key_json = json.dumps(key, sort_keys=True)
    path = None
    if cache_dir is not None:
        name = hashlib.sha256(key_json.encode()).hexdigest()[:24]
        path = Path(cache_dir) / f"{key.get('renderer', 'render')}-ref-{name}.npz"
        hit = _load(path, key_json)
        if hit is not None:
            return hit
    a, b, seconds = render()
    a = np.asarray(a, dtype=np.float32).astype(np.float64)
    b = np.asarray(b, dtype=np.float32).astype(np.float64)
    if path is not None:
        _store(path, key_json, a, b, seconds)
    return ReferencePair(a, b, float(seconds), False)

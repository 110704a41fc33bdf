"""Maps of a library, named but not loaded: files (loaded lazily, on whichever worker needs
them) or in-memory :class:`~envfit.maps._envmap.EnvMap` objects.

A library of 2k–8k maps does not fit in memory, so a sweep carries :class:`MapSource`
objects (a path and the loading options, a few hundred bytes each) and every task loads,
uses and drops its one map. :func:`resolve_map_sources` expands what a user typed — files,
folders (the map files directly inside), glob patterns — and refuses, with one line, a
missing file, a path that is no regular file (a FIFO, a device, a socket, a symbolic link
loop: named, never opened), a folder without maps, a pattern matching nothing, or maps
whose ``up`` axes differ (a library shares one set of sample directions, and those depend
on ``up``).

Each source gets a ``slug``, a file-name-safe label unique within the library (the file's
stem; a short hash of the full path is appended when two stems collide), which names its
result folder ``OUT/<slug>/``.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> srcs = resolve_map_sources([EnvMap(np.ones((4, 8, 3)), name="a b.exr"), EnvMap(np.ones((2, 4)))])
>>> [s.slug for s in srcs], srcs[0].load().height
(['a_b', 'map2'], 4)
"""
from __future__ import annotations

import glob
import hashlib
import os
import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Iterable

from envfit.maps._envmap import EnvMap
from envfit.maps._io import load_envmap
from envfit.base import EnvMapFileError, ParameterError
from envfit.base import NO_SUCH_FILE, regular_file_problem
from envfit.base import array_fingerprint

__all__ = ["MAP_EXTENSIONS", "LoadOptions", "MapSource", "resolve_map_sources"]

#: files a folder is scanned for (case-insensitive)
MAP_EXTENSIONS = (".exr", ".hdr", ".pfm", ".tif", ".tiff", ".png", ".jpg", ".jpeg")
_GLOB_CHARS = re.compile(r"[*?\[]")


@dataclass(frozen=True)
class LoadOptions:
    """The :func:`~envfit.maps._io.load_envmap` options every map of a library is read with."""
    up: str = "y"
    max_height: int | None = None
    fix_nonfinite: bool = False
    allow_negative: bool = False


@dataclass
class MapSource:
    """One map of a library: ``path`` (loaded on demand) or ``envmap`` (in memory)."""
    label: str
    slug: str
    path: str | None = None
    envmap: EnvMap | None = None
    options: LoadOptions = LoadOptions()
    #: the file's identity when the run planned it (set by the first :meth:`identity` call);
    #: :meth:`load` refuses a file that no longer matches it
    planned: dict[str, Any] | None = None

    @property
    def up(self) -> str:
        return self.envmap.up if self.envmap is not None else self.options.up

    def load(self) -> EnvMap:
        """The map (read from disk for a file source; every call reads it again)."""
        if self.envmap is not None:
            return self.envmap
        if self.planned is not None and self._file_identity() != self.planned:
            raise EnvMapFileError(
                f"{self.path} changed during the run (its size or modification time differ "
                "from when the run started): finished cells belong to the old file; rerun to "
                "use the new one")
        o = self.options
        return load_envmap(self.path, up=o.up, allow_negative=o.allow_negative,
                           fix_nonfinite=o.fix_nonfinite, max_height=o.max_height)

    def pixels(self) -> int:
        """W x H of the map as loaded (after ``max_height``), from the file's header, no
        pixel read; 0 where the header cannot be read (loading it says why)."""
        if self.envmap is not None:
            return int(self.envmap.width * self.envmap.height)
        try:
            import OpenImageIO as oiio
            inp = oiio.ImageInput.open(str(self.path))
            if not inp:
                return 0
            w, h = int(inp.spec().width), int(inp.spec().height)
            inp.close()
        except Exception:       # noqa: BLE001 - any reader failure: load() reports it
            return 0
        cap = self.options.max_height
        if cap and h > cap:
            w, h = max(2, round(w * cap / h)), cap
        return w * h

    def identity(self) -> dict[str, Any]:
        """What ties stored results to this input: for a file its name, size and
        modification time (no read: a library is planned without loading it) and the
        loading options; for an in-memory map a hash of its pixels. For a file, the first
        call fixes it for the run (:attr:`planned`)."""
        if self.envmap is not None:
            return {"pixels": array_fingerprint(self.envmap.data), "up": self.envmap.up}
        if self.planned is None:
            self.planned = self._file_identity()
        return self.planned

    def _file_identity(self) -> dict[str, Any]:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            why = regular_file_problem(self.path, "an image file") or exc.strerror or exc
            raise EnvMapFileError(f"{self.path}: {why}") from None
        return {"file": os.path.basename(self.path), "bytes": st.st_size,
                "mtime_ns": st.st_mtime_ns, **asdict(self.options)}


def _slug(text: str) -> str:
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "map"
    return s[:80]


def _regular_files(paths: list[str], where: str) -> list[str]:
    """``paths`` less the folders; :class:`EnvMapFileError` naming the first that is no
    regular file (a FIFO, a device, a socket, a symbolic link loop or a dangling one: it
    would block or fail when read, so the library is refused before any work)."""
    found = []
    for f in paths:
        if os.path.isdir(f):
            continue
        why = regular_file_problem(f, "an image file")
        if why is not None:
            raise EnvMapFileError(f"{f} (in {where}): {why}")
        found.append(f)
    return found


def _expand(item: str) -> list[str]:
    """The map files ``item`` names: itself (a regular file), the files with a map
    extension directly inside it (a folder), or those a glob pattern matches."""
    why = regular_file_problem(item, "an image file")
    if why is None:
        return [item]
    if os.path.isdir(item):
        try:
            names = sorted(os.listdir(item))
        except OSError as exc:
            raise EnvMapFileError(f"folder {item}: {exc.strerror or exc}") from None
        found = _regular_files([os.path.join(item, n) for n in names
                                if Path(n).suffix.lower() in MAP_EXTENSIONS], f"folder {item}")
        if not found:
            raise EnvMapFileError(f"folder {item} holds no maps ({', '.join(MAP_EXTENSIONS)})")
        return found
    if why == NO_SUCH_FILE and _GLOB_CHARS.search(item):
        found = _regular_files(sorted(glob.glob(item)), f"the files {item} matches")
        if not found:
            raise EnvMapFileError(f"no file matches {item}")
        return found
    raise EnvMapFileError(f"{item}: {why}")


def resolve_map_sources(items: Iterable, options: LoadOptions | None = None) -> list[MapSource]:
    """:class:`MapSource` objects for files, folders, glob patterns or :class:`EnvMap` objects
    (:class:`MapSource` objects are kept as they are).

    Duplicates (the same file twice) are kept once; order is as given (folders and
    patterns sorted by name). Raises :class:`~envfit.base._errors.EnvMapFileError` for a missing
    file or one that is no regular file (also among a folder's maps or a pattern's
    matches), an empty folder or an unmatched pattern,
    :class:`~envfit.base._errors.ParameterError` for an empty list or maps with different
    ``up`` axes.
    """
    options = options or LoadOptions()
    sources: list[MapSource] = []
    seen: set[str] = set()
    for k, item in enumerate(items if not isinstance(items, (str, os.PathLike, EnvMap)) else [items]):
        if isinstance(item, MapSource):
            sources.append(item)
            continue
        if isinstance(item, EnvMap):
            label = item.name or f"map{k + 1}"
            slug = _slug(Path(item.name).stem) if item.name else f"map{k + 1}"
            sources.append(MapSource(label=label, slug=slug, envmap=item))
            continue
        for path in _expand(os.fspath(item)):
            real = os.path.realpath(path)
            if real in seen:
                continue
            seen.add(real)
            # absolute: workers (a dask cluster) may run in another working directory
            sources.append(MapSource(label=os.path.basename(path), slug=_slug(Path(path).stem),
                                     path=os.path.abspath(path), options=options))
    if not sources:
        raise ParameterError("no maps given")
    ups = sorted({s.up for s in sources})
    if len(ups) > 1:
        first = {u: next(s.label for s in sources if s.up == u) for u in ups}
        raise ParameterError(
            "the maps do not share one up axis (" + ", ".join(f"{first[u]}: up={u}" for u in ups)
            + "); a library is sampled at one set of directions, which depends on up")
    _dedupe_slugs(sources)
    return sources


def _dedupe_slugs(sources: list[MapSource]) -> None:
    counts: dict[str, int] = {}
    for s in sources:
        counts[s.slug] = counts.get(s.slug, 0) + 1
    used: set[str] = set()
    for k, s in enumerate(sources):
        if counts[s.slug] > 1:
            key = os.path.realpath(s.path) if s.path else f"{k}"
            s.slug = f"{s.slug}-{hashlib.sha1(key.encode()).hexdigest()[:8]}"
        while s.slug in used:  # pragma: no cover - hash collision / repeated in-memory names
            s.slug += f"-{k}"
        used.add(s.slug)

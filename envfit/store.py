"""A resumable result store: one JSON file per finished cell, written atomically.

A long sweep (Table 2, validation, a library of maps) writes each finished cell as soon as
it is done. Re-running with the same output folder and the same configuration skips the
finished cells, so an interrupted run (Ctrl-C, a killed worker) loses at most the cells in
progress. A folder written for a different configuration is refused rather than mixed.
"""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from .atomic import atomic_write_json, to_jsonable
from .errors import ParameterError

__all__ = ["ResultStore", "array_fingerprint"]


def array_fingerprint(a: np.ndarray) -> str:
    """A short content hash of an array (shape, dtype and bytes), to tie results to their input."""
    a = np.ascontiguousarray(a)
    h = hashlib.sha1()
    h.update(str((a.shape, a.dtype.str)).encode())
    h.update(memoryview(a).cast("B"))
    return h.hexdigest()[:16]


def _safe_key(key: str) -> str:
    if not re.fullmatch(r"[A-Za-z0-9._=+-]+", key):
        raise ValueError(f"store keys must be file-name safe, got {key!r}")
    return key


class ResultStore:
    """Cells of a sweep under ``folder/cells/<key>.json``, tied to ``folder/config.json``.

    Parameters
    ----------
    folder : path or None
        Where to keep the cells. ``None`` keeps them in memory only (no resume).
    config : dict
        What identifies the sweep (input fingerprint, scale, point set, seed, …). An
        existing folder whose config differs raises :class:`~envfit.errors.ParameterError`.
    kind : str
        The sweep's name (e.g. ``"table2"``), part of the config check.
    """

    def __init__(self, folder: str | Path | None, config: dict[str, Any], *, kind: str):
        self.folder = Path(folder) if folder is not None else None
        self.config = {"kind": kind, **to_jsonable(config)}
        self._memory: dict[str, dict] = {}
        if self.folder is None:
            return
        self.cells_dir.mkdir(parents=True, exist_ok=True)
        cfg_path = self.folder / f"{kind}_config.json"
        if cfg_path.exists():
            try:
                old = json.loads(cfg_path.read_text())
            except (OSError, json.JSONDecodeError):
                old = None
            if old != self.config:
                diff = sorted(k for k in set(old or {}) | set(self.config)
                              if (old or {}).get(k) != self.config.get(k))
                raise ParameterError(
                    f"{self.folder} holds results of a different {kind} run (differs in: "
                    f"{', '.join(diff) or 'unreadable config'}); use another --out folder or "
                    f"delete it to start over")
        else:
            atomic_write_json(cfg_path, self.config)

    @property
    def cells_dir(self) -> Path:
        assert self.folder is not None
        return self.folder / "cells"

    def get(self, key: str) -> dict | None:
        """The finished cell ``key``, or None if it has not been computed (or is unreadable)."""
        key = _safe_key(key)
        if self.folder is None:
            return self._memory.get(key)
        path = self.cells_dir / f"{key}.json"
        if not path.exists():
            return None
        try:
            return json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):
            return None  # a torn file cannot exist (atomic writes), but be forgiving

    def put(self, key: str, cell: dict) -> None:
        key = _safe_key(key)
        cell = to_jsonable(cell)
        if self.folder is None:
            self._memory[key] = cell
        else:
            atomic_write_json(self.cells_dir / f"{key}.json", cell)

    def __contains__(self, key: str) -> bool:
        return self.get(key) is not None

    def items(self) -> Iterator[tuple[str, dict]]:
        if self.folder is None:
            yield from self._memory.items()
            return
        for p in sorted(self.cells_dir.glob("*.json")):
            try:
                yield p.stem, json.loads(p.read_text())
            except (OSError, json.JSONDecodeError):
                continue

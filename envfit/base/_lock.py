"""The advisory lock of an output folder: one envfit run per folder.

One run per folder
------------------
A run holds :class:`FolderLock` on its output folder (``.envfit.lock`` there, a
:class:`filelock.FileLock`; the holder's pid in ``.envfit.lock.owner``). A second run on the
same folder waits :data:`LOCK_TIMEOUT` seconds, then **exits** with
:class:`StoreBusyError` (exit code 2 in the CLI: ``OUT is in use by another envfit run (pid
N); wait for it or use another --out``). Exiting was chosen over waiting: a sweep can run for
hours, and a second command that silently blocks that long looks hung; after the first run
ends, the same command resumes every cell it finished, so nothing is computed twice either
way. The short wait only covers a run that is just finishing.

The lock is ``flock(2)``: the kernel releases it when its process dies, so a run killed by
SIGKILL leaves a lock *file* that blocks nobody, and a re-run resumes. Only the driver
process writes cells and holds the lock; executor workers (process pool, dask) never touch
the store, and they are spawned (fresh interpreters, no inherited descriptors), so a
surviving worker cannot keep a dead driver's lock. Within one process the lock is shared
(acquisitions are counted), so nested or repeated runs in one interpreter never block
themselves; it protects against other processes, not other threads.
"""
from __future__ import annotations

import json
import os
import socket
import threading
from pathlib import Path
from typing import Callable

from envfit.base._atomic import atomic_write_text
from envfit.base._errors import EnvfitError
from envfit.base._progress import print_note
from envfit.base._stored_json import read_json_file

__all__ = ["FolderLock", "StoreBusyError", "LOCK_TIMEOUT", "LOCK_NAME"]

#: seconds a second run waits for a busy folder before it gives up (see the module docstring)
LOCK_TIMEOUT = 1.0
LOCK_NAME = ".envfit.lock"


class StoreBusyError(EnvfitError, RuntimeError):
    """Another envfit process holds the output folder's lock."""


_held: dict[str, list] = {}           # canonical lock path -> [FileLock, acquisitions]
_held_guard = threading.Lock()


class FolderLock:
    """The advisory lock of one output folder (``folder/.envfit.lock``); see the module doc.

    Use as a context manager, or :meth:`acquire` / :meth:`release`. A folder where no lock
    file can be created (read-only) is used without a lock, with a note: nothing can be
    written there anyway.

    Parameters
    ----------
    folder : the output folder (created if missing).
    timeout : seconds to wait for another process's lock before :class:`StoreBusyError`.
    on_note : where the read-only note goes (default :func:`print_note`); ``notes`` keeps it.
    """

    def __init__(self, folder: str | os.PathLike, *, timeout: float | None = None,
                 on_note: Callable[[str], None] | None = None):
        self.folder = Path(folder)
        self.timeout = LOCK_TIMEOUT if timeout is None else float(timeout)
        self.on_note = on_note or print_note
        self._path = os.path.realpath(self.folder / LOCK_NAME)
        self.held = False
        self.notes: list[str] = []

    def acquire(self) -> "FolderLock":
        """Take the lock (counted within this process); StoreBusyError if another has it."""
        if self.held:
            return self
        from filelock import FileLock, Timeout
        with _held_guard:
            entry = _held.get(self._path)
            if entry is None:
                try:
                    self.folder.mkdir(parents=True, exist_ok=True)
                    lock = FileLock(self._path, timeout=self.timeout)
                    lock.acquire()
                except Timeout:
                    raise StoreBusyError(
                        f"{self.folder} is in use by another envfit run ({self._owner()}); "
                        f"wait for it or use another --out") from None
                except OSError as exc:
                    self.notes.append(f"cannot lock {self.folder} ({exc.strerror or exc}): "
                                      f"running without a lock; do not start a second run on it")
                    self.on_note(self.notes[-1])
                    return self
                entry = _held[self._path] = [lock, 0]
                self._write_owner()
            entry[1] += 1
            self.held = True
        return self

    def release(self) -> None:
        """Give the lock back (the file stays; it blocks nobody once released)."""
        with _held_guard:
            if not self.held:
                return
            self.held = False
            entry = _held.get(self._path)
            if entry is None:
                return
            entry[1] -= 1
            if entry[1] <= 0:
                del _held[self._path]
                entry[0].release()

    def _write_owner(self) -> None:
        try:
            atomic_write_text(f"{self._path}.owner",
                              json.dumps({"pid": os.getpid(), "host": socket.gethostname()}))
        except OSError:
            pass                          # the pid is a courtesy for the busy message

    def _owner(self) -> str:
        doc, _ = read_json_file(Path(f"{self._path}.owner"))
        if not isinstance(doc, dict) or not isinstance(doc.get("pid"), int):
            return "pid unknown"
        host = doc.get("host")
        where = f" on {host}" if isinstance(host, str) and host != socket.gethostname() else ""
        return f"pid {doc['pid']}{where}"

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self):
        try:
            self.release()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass

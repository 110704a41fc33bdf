"""Atomic file writes: a result file is either the old one or the complete new one.

Also the checks the CLI runs on every output *before* any work
(:func:`check_writable_dir`, :func:`check_writable_file`): they prove writability by
creating and removing a temporary file — ``os.access`` answers "yes" for root on a folder
it may not write in practice and says nothing of a read-only mount — and raise
:class:`envfit.base._errors.OutputError` with a one-line reason.

>>> import tempfile
>>> d = Path(tempfile.mkdtemp())
>>> check_writable_dir(d / "new" / "sub", "--out").is_dir()
True
>>> atomic_write_text(d / "f.txt", "x").read_text()
'x'
>>> check_writable_dir(d / "f.txt", "--out")
Traceback (most recent call last):
  ...
envfit.base._errors.OutputError: cannot write --out ...f.txt: exists and is not a folder
>>> check_writable_file(d, "--json")
Traceback (most recent call last):
  ...
envfit.base._errors.OutputError: cannot write --json ...: it is a folder, not a file
>>> check_writable_file(d / "f.txt" / "x.json", "--json")
Traceback (most recent call last):
  ...
envfit.base._errors.OutputError: cannot write --json ...x.json: Not a directory
>>> check_writable_file("-", "--json") is None
True
"""
from __future__ import annotations

import csv
import errno
import io
import json
import math
import os
import secrets
import stat
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from envfit.base._errors import OutputError
from envfit.base._files import file_kind

__all__ = ["replace_via_temporary", "probe_writable", "atomic_write_bytes", "atomic_write_text", "atomic_write_json", "atomic_write_csv",
           "to_jsonable", "check_writable_dir", "check_writable_file", "os_reason"]


def current_umask() -> int:
    """The process umask (read without changing it for good)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _unlink_quietly(tmp: Path) -> None:
    try:
        os.unlink(tmp)
    except OSError:
        pass


def _write_new(tmp: Path, data: bytes) -> None:
    """Create ``tmp`` (mode ``"xb"``: ``O_EXCL``, FileExistsError if the name is taken; the
    usual permissions 0666 less the umask) and write ``data`` durably."""
    with open(tmp, "xb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def replace_via_temporary(path: str | os.PathLike, write: Callable[[Path], None],
                          suffix: str = ".tmp") -> Path:
    """Make ``path`` by ``write(tmp)`` on a temporary beside it, then ``os.replace``.

    ``tmp`` is ``.<name>.<random>{suffix}`` in the same folder (``suffix`` lets a writer that
    picks its format by extension, such as OpenImageIO, see the right one); ``write`` must
    create it (mode ``"xb"`` or its own writer) and may raise ``FileExistsError`` for a taken
    name, which draws another. On any exception — disk full, EIO, the folder removed, Ctrl-C,
    SIGTERM at any bytecode — the old ``path`` is untouched and no temporary is left: the
    name is bound *before* the file exists (``tempfile.mkstemp`` binds it only on return, and
    a SIGTERM in that window left one behind in an interrupted sweep)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(100):
        tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}{suffix}"
        try:
            write(tmp)
            os.replace(tmp, path)
            return path
        except FileExistsError:         # the 48-bit name is taken: nothing created, draw again
            continue
        except BaseException:
            _unlink_quietly(tmp)
            raise
    raise FileExistsError(errno.EEXIST, f"no free temporary name beside {path}")


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder + ``os.replace``
    (:func:`replace_via_temporary`): ``path`` is the old file or the complete new one."""
    return replace_via_temporary(path, lambda tmp: _write_new(tmp, data))


# ------------------------------------------------------------------ preflight of outputs
def os_reason(exc: BaseException) -> str:
    """The one-line reason of an ``OSError`` ("No space left on device"), else ``str(exc)``."""
    reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    return " ".join(str(reason).split())


def probe_writable(folder: str | os.PathLike) -> None:
    """Create and remove a temporary file in ``folder`` (raises ``OSError`` if it cannot);
    the name is bound before the file exists, so an interruption leaves nothing behind."""
    folder = Path(folder)
    for _ in range(100):
        tmp = folder / f".envfit-write-check.{secrets.token_hex(6)}.tmp"
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
            os.unlink(tmp)
            return
        except FileExistsError:
            continue
        except BaseException:
            _unlink_quietly(tmp)
            raise
    raise FileExistsError(errno.EEXIST, f"no free temporary name in {folder}")


def _label(what: str, path) -> str:
    return f"{what} {path}" if what else str(path)


def _stat(path: Path, what: str, shown: Path) -> os.stat_result | None:
    """``os.stat`` of ``path``; None if nothing is there; OutputError for a symlink loop, a
    path through a regular file, a dangling symbolic link, no permission to look."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        if os.path.lexists(path):
            raise OutputError(f"cannot write {_label(what, shown)}: {path} is a dangling symbolic "
                              "link") from None
        return None
    except OSError as exc:
        raise OutputError(f"cannot write {_label(what, shown)}: {os_reason(exc)}") from None


def _existing_ancestor(folder: Path, what: str, shown: Path) -> Path:
    """The nearest of ``folder`` and its parents that exists; OutputError if it is not a
    folder (or is a dangling symbolic link, a loop)."""
    while True:
        st = _stat(folder, what, shown)
        if st is not None:
            break
        if folder.parent == folder:  # pragma: no cover - the root always exists
            raise OutputError(f"cannot write {_label(what, shown)}: no existing parent folder")
        folder = folder.parent
    if not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"cannot write {_label(what, shown)}: {folder} is not a folder")
    return folder


def _probe_reason(exc: OSError, folder: Path) -> str:
    """Why no file could be created in ``folder``: the OS's reason, and where the folder
    exists but the file system says "No such file or directory" (``/proc``, ``/sys``: they
    create no files), that no file can be created there — what is true, not "no such file"."""
    if isinstance(exc, FileNotFoundError) and os.path.isdir(folder):
        return f"no file can be created in {folder} (its file system answers \"{os_reason(exc)}\")"
    return os_reason(exc)


def check_writable_dir(path: str | os.PathLike, what: str = "--out") -> Path:
    """Make sure ``path`` is a folder this process can write in: create it (with its parents)
    if missing, then create and remove a temporary file inside. Returns ``path``.

    ``what`` names the option in the message (empty: the path alone). Raises
    :class:`envfit.base._errors.OutputError` ("cannot write --out /ro/x: Read-only file system") if it exists and is not a folder, cannot be created, or refuses the file.
    """
    path = Path(path)
    st = _stat(path, what, path)
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"cannot write {_label(what, path)}: exists and is not a folder")
    try:
        if st is None:
            _existing_ancestor(path.parent, what, path)
            path.mkdir(parents=True, exist_ok=True)
        probe_writable(path)
    except OSError as exc:
        raise OutputError(f"cannot write {_label(what, path)}: {_probe_reason(exc, path)}") \
            from None
    return path


def check_writable_file(path: str | os.PathLike, what: str = "--json") -> Path | None:
    """Make sure an atomic write of ``path`` can succeed, without creating anything: ``path``
    is not a folder (nor a device, a symlink loop, a path through a regular file) and its
    nearest existing ancestor is a folder that accepts a temporary file (the missing folders
    in between are created at write time). ``"-"`` (stdout) passes; returns None for it.

    Raises :class:`envfit.base._errors.OutputError` with a one-line reason.
    """
    if str(path) == "-":
        return None
    path = Path(path)
    st = _stat(path, what, path)
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OutputError(f"cannot write {_label(what, path)}: it is a folder, not a file")
        if not stat.S_ISREG(st.st_mode):
            raise OutputError(f"cannot write {_label(what, path)}: it is {file_kind(st.st_mode)}, "
                              "not a regular file (an atomic write would replace it; use '-' "
                              "for stdout)")
    folder = _existing_ancestor(path.parent, what, path)
    try:
        probe_writable(folder)
    except OSError as exc:
        raise OutputError(f"cannot write {_label(what, path)}: {_probe_reason(exc, folder)}") \
            from None
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def _plain_floats(seq) -> bool:
    """Whether every item is a finite float or an int (not bool): JSON-able as it is."""
    try:
        return all(type(v) is int or (type(v) is float and math.isfinite(v)) for v in seq)
    except TypeError:  # pragma: no cover - defensive
        return False


def to_jsonable(obj: Any) -> Any:
    """Convert numpy scalars/arrays (recursively) to plain Python for ``json``; non-finite
    floats become None (NaN) or ±1e308. Lists of plain finite numbers and finite float
    arrays are passed through without visiting each item in Python (a cached spectrum holds
    ~10⁵ numbers)."""
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        if _plain_floats(obj):
            return list(obj)
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fiu" and bool(np.all(np.isfinite(obj))):
            return obj.tolist()
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None if np.isnan(obj) else (1e308 if obj > 0 else -1e308)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    return atomic_write_text(path, json.dumps(to_jsonable(obj), indent=2) + "\n")


def atomic_write_csv(path: str | os.PathLike, header: Sequence[str],
                     rows: Iterable[Sequence[Any]]) -> Path:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    for r in rows:
        w.writerow([to_jsonable(v) for v in r])
    return atomic_write_text(path, buf.getvalue())

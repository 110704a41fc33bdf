"""Reading a file envfit did not write in this run — a map, a cache entry, a stored cell —
only if it is a regular file of a bounded size (issue 38).

``open()`` of a named pipe (FIFO) blocks until a writer comes, in the kernel, where neither
SIGTERM's handler nor Ctrl-C can run; a cache entry replaced by a link to ``/dev/zero``
reads for ever. So every read first ``stat``\\ s the path (which never blocks) and refuses,
with one line saying what the path truly is, anything but a regular file: a folder, a named
pipe, a character or block device, a socket, a symbolic link loop, a dangling symbolic
link. A file larger than the caller's cap is refused by its size before a byte is read.
:func:`read_bounded` then opens with ``O_NONBLOCK`` (a FIFO swapped in after the ``stat``
opens at once instead of blocking), checks the open file again (``fstat``) and reads at
most the cap.

>>> import os, tempfile
>>> d = tempfile.mkdtemp()
>>> os.mkfifo(os.path.join(d, "pipe.exr"))
>>> regular_file_problem(os.path.join(d, "pipe.exr"))
'is a named pipe (FIFO), not a regular file'
>>> os.symlink("loop", os.path.join(d, "loop"))
>>> regular_file_problem(os.path.join(d, "loop"))
'is a symbolic link loop (a link that leads back to itself)'
>>> regular_file_problem(os.path.join(d, "absent")) == NO_SUCH_FILE
True
"""
from __future__ import annotations

import errno
import os
import stat
from typing import BinaryIO

__all__ = ["NO_SUCH_FILE", "MAX_JSON_BYTES", "file_kind", "regular_file_problem",
           "open_regular", "read_bounded", "size_words"]

#: what :func:`regular_file_problem` says when nothing is there at all
NO_SUCH_FILE = "no such file"
#: the largest JSON file envfit reads back (a cache entry, a cell, a config): the largest
#: entries, the advisor's warped spectra, hold ~G²/8 numbers per channel for a grid of G
#: (``--renderer-grid``): 2.2 MB at the default 512, ~560 MiB at 8192
MAX_JSON_BYTES = 2**30

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def file_kind(mode: int) -> str | None:
    """What a ``st_mode`` that is not a regular file's is, in words; None for a regular file.

    >>> file_kind(os.stat("/dev/null").st_mode)
    'a character device'
    """
    if stat.S_ISREG(mode):
        return None
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def size_words(nbytes: int) -> str:
    """``nbytes`` in words (``"3.2 GiB"``, ``"512 bytes"``)."""
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes} bytes"


def _stat_problem(exc: OSError, path) -> str:
    """Why ``os.stat(path)`` failed, in words: what is true of the path."""
    if isinstance(exc, FileNotFoundError):
        if os.path.lexists(path):
            try:
                to = f" to {os.readlink(path)}"
            except OSError:             # pragma: no cover - removed meanwhile
                to = ""
            return f"is a dangling symbolic link{to} (nothing is there)"
        return NO_SUCH_FILE
    if exc.errno == errno.ELOOP:
        return "is a symbolic link loop (a link that leads back to itself)"
    if exc.errno == errno.ENOTDIR:
        return "no such file (a part of its path is a file, not a folder)"
    if exc.errno == errno.EACCES:
        return "permission denied"
    return " ".join(str(exc.strerror or exc).split())


def _too_large(size: str, max_bytes: int) -> str:
    return f"is {size}; envfit reads at most {size_words(max_bytes)} from such a file"


def _problem_of(st: os.stat_result, noun: str, max_bytes: int | None) -> str | None:
    """Why the file of ``st`` may not be read (its kind, its size), or None."""
    kind = file_kind(st.st_mode)
    if kind is not None:
        return f"is {kind}, not {noun}" if kind.startswith("a ") else f"is {kind}"
    if max_bytes is not None and st.st_size > max_bytes:
        return _too_large(size_words(st.st_size), max_bytes)
    return None


def regular_file_problem(path, noun: str = "a regular file",
                         max_bytes: int | None = None) -> str | None:
    """Why ``path`` is not a readable regular file of at most ``max_bytes`` bytes, in words
    that start after ``"PATH: "`` (:data:`NO_SUCH_FILE` when nothing is there), or None.

    Symbolic links are followed by ``stat`` only: nothing is opened, so a FIFO or a device
    never blocks. ``noun`` names what was expected (``"an image file"``).
    """
    try:
        st = os.stat(path)
    except OSError as exc:
        return _stat_problem(exc, path)
    except ValueError:                  # an embedded NUL byte
        return "is not a valid file name"
    why = _problem_of(st, noun, max_bytes)
    if why is not None and file_kind(st.st_mode) is not None and os.path.islink(path):
        try:
            why = f"is a symbolic link to {os.readlink(path)}, which {why}"
        except OSError:                 # pragma: no cover - replaced meanwhile
            pass
    if why is None and not os.access(path, os.R_OK):
        why = "permission denied"
    return why


def open_regular(path, max_bytes: int | None = None,
                 noun: str = "a regular file") -> tuple[BinaryIO | None, str | None]:
    """``(file, None)``: ``path`` opened for binary reading if it is a regular file of at
    most ``max_bytes``; ``(None, None)`` when nothing is there; ``(None, why)`` for anything
    else (:func:`regular_file_problem`). Opened with ``O_NONBLOCK`` and checked again with
    ``fstat``: a FIFO swapped in after the ``stat`` is refused, never waited on."""
    why = regular_file_problem(path, noun, max_bytes)
    if why is not None:     # nothing there, or cannot be (a file in the path)
        return None, None if why.startswith(NO_SUCH_FILE) else why
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None, None
    except OSError as exc:
        return None, _stat_problem(exc, path)
    try:
        why = _problem_of(os.fstat(fd), noun, max_bytes)
    except OSError as exc:              # pragma: no cover - fstat of an open fd
        why = _stat_problem(exc, path)
    if why is not None:
        os.close(fd)
        return None, why
    return os.fdopen(fd, "rb", buffering=0), None


def read_bounded(path, max_bytes: int = MAX_JSON_BYTES,
                 noun: str = "a regular file") -> tuple[bytes | None, str | None]:
    """``(content, None)`` of the regular file ``path``; ``(None, None)`` when nothing is
    there; ``(None, why)`` for anything else (:func:`open_regular`, a file that grows past
    ``max_bytes`` while read, a read error). Never blocks on a FIFO or a device and never
    reads more than ``max_bytes + 1`` bytes."""
    fh, why = open_regular(path, max_bytes, noun)
    if fh is None:
        return None, why
    with fh:
        chunks, size = [], 0
        try:
            while size <= max_bytes:
                b = fh.read(min(1 << 20, max_bytes + 1 - size))
                if not b:
                    break
                chunks.append(b)
                size += len(b)
        except OSError as exc:
            return None, f"unreadable ({' '.join(str(exc.strerror or exc).split())})"
    if size > max_bytes:
        return None, _too_large(f"more than {size_words(max_bytes)}", max_bytes)
    return b"".join(chunks), None

"""Which envfit code a process runs, so that a driver and its dask workers can be checked to
run the same code before a sweep starts.

A long-lived ``dask worker`` imports envfit once; if the checkout changes afterwards (a pull,
an edit, a reinstall), that worker keeps computing with the old modules — and lazily imports
new ones beside them — while its results are stored as this driver's. :func:`code_state` says,
in any process, what envfit's source files are now (a digest) and whether any changed after
envfit was imported there (``stale``); :func:`check_same_code` compares the workers' states
with the driver's and refuses, in one line, a worker that runs other or stale code.

>>> s = code_state()
>>> sorted(s), len(s["digest"])
(['digest', 'stale', 'version'], 16)
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

__all__ = ["IMPORTED_AT", "code_state", "check_same_code"]

#: when this process imported envfit (``envfit/__init__.py`` imports this module first)
IMPORTED_AT = time.time()


def code_state() -> dict:
    """``{"digest", "stale", "version"}`` of this process: a SHA-256 digest (16 hex digits)
    of envfit's source files (relative path and bytes), whether any of them was modified
    after envfit was imported here, and ``envfit.__version__``."""
    import envfit
    root = Path(envfit.__file__).parent
    h, newest = hashlib.sha256(), 0.0
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
        newest = max(newest, f.stat().st_mtime)
    return {"digest": h.hexdigest()[:16], "stale": newest > IMPORTED_AT,
            "version": envfit.__version__}


def check_same_code(workers: dict, driver: dict) -> None:
    """Raise :class:`~envfit.base._errors.ExecutorError` (one line) if a worker's
    :func:`code_state` (``workers``: address → state) differs from the ``driver``'s, or
    either runs code older than its files.

    >>> me = {"digest": "a" * 16, "stale": False, "version": "0.1.0"}
    >>> check_same_code({"tcp://w:1": dict(me)}, me)
    >>> check_same_code({"tcp://w:1": {**me, "stale": True}}, me)
    Traceback (most recent call last):
    ...
    envfit.base._errors.ExecutorError: the dask worker tcp://w:1 runs envfit imported before its files changed: restart the workers (dask worker) so that they run this envfit
    """
    from envfit.base._errors import ExecutorError
    if driver.get("stale"):
        raise ExecutorError("this process runs envfit imported before its files changed: "
                            "restart it (and the dask workers)")
    for addr, s in sorted(workers.items()):
        if s.get("stale"):
            raise ExecutorError(f"the dask worker {addr} runs envfit imported before its files "
                                f"changed: restart the workers (dask worker) so that they run "
                                f"this envfit")
        if s.get("digest") != driver["digest"]:
            raise ExecutorError(f"the dask worker {addr} runs other envfit code than this "
                                f"process (version {s.get('version')}, source digest "
                                f"{s.get('digest')}; here {driver['version']}, "
                                f"{driver['digest']}): install the same envfit on every "
                                f"worker")

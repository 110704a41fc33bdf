"""Memory budget: check before allocating, fail with a clear message instead of swapping."""
from __future__ import annotations

import os

from .errors import MemoryBudgetError

__all__ = ["available_memory_bytes", "check_memory", "format_bytes"]

#: fraction of the available memory one allocation plan may take
MEMORY_FRACTION = 0.8


def available_memory_bytes() -> int:
    """Memory that can be allocated now (``MemAvailable`` from /proc/meminfo, else total RAM).

    The environment variable ``ENVFIT_MEMORY_LIMIT`` (bytes, or with a K/M/G suffix)
    overrides it, e.g. to reserve memory for other processes or to test the guard.
    """
    env = os.environ.get("ENVFIT_MEMORY_LIMIT")
    if env:
        units = {"K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
        env = env.strip().upper().rstrip("B")
        mult = units.get(env[-1:], 1)
        return int(float(env[:-1] if env[-1:] in units else env) * mult)
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic platforms
        return 8 * 2**30


def format_bytes(n: float) -> str:
    """Human-readable size, e.g. ``3.2 GB`` (decimal units, as the paper's '3.2 GB')."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1000.0
    return f"{n:.1f} TB"  # pragma: no cover


def check_memory(nbytes: int, what: str, *, hint: str = "") -> None:
    """Raise :class:`MemoryBudgetError` if ``nbytes`` exceeds the memory budget.

    ``what`` names the work (e.g. ``"the 20000x20000 kernel matrix"``); ``hint`` can say
    what would fit (e.g. ``"the largest N that fits is 15000"``).
    """
    budget = int(available_memory_bytes() * MEMORY_FRACTION)
    if nbytes > budget:
        msg = (f"{what} needs {format_bytes(nbytes)} but only {format_bytes(budget)} "
               f"can be used ({int(MEMORY_FRACTION * 100)}% of available memory)")
        if hint:
            msg += f"; {hint}"
        raise MemoryBudgetError(msg)

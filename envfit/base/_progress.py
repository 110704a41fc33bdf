"""Progress bars (tqdm on stderr), switched off by ``quiet``, and notes printed past them."""
from __future__ import annotations

import sys
from typing import Iterable, TypeVar

T = TypeVar("T")


def progress(iterable: Iterable[T], *, total: int | None = None, desc: str = "",
             quiet: bool = False, unit: str = "it") -> Iterable[T]:
    """Wrap ``iterable`` in a tqdm bar on stderr unless ``quiet``."""
    if quiet:
        return iterable
    from tqdm.auto import tqdm
    return tqdm(iterable, total=total, desc=desc, unit=unit, leave=False, dynamic_ncols=True)


def progress_bar(total: int, *, desc: str = "", quiet: bool = False, unit: str = "it"):
    """A manual tqdm bar (``.update(k)``, ``.close()``); a no-op object when ``quiet``."""
    if quiet:
        return _NullBar()
    from tqdm.auto import tqdm
    return tqdm(total=total, desc=desc, unit=unit, leave=False, dynamic_ncols=True)


class _NullBar:
    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass


def print_note(text: str) -> None:
    """The default ``on_note``: ``note: text`` on a line of its own on stderr (through
    ``tqdm.write``, which lifts a running progress bar out of the way)."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        print(f"note: {text}", file=sys.stderr, flush=True)
        return
    tqdm.write(f"note: {text}", file=sys.stderr)

"""Tick helpers for axes that count things (maps, samples N, degrees L): whole numbers only.

* :func:`integer_axis` — a linear axis of counts or degrees: ``MaxNLocator(integer=True)``
  (no 0.5 maps, no L = 2.5).
* :func:`count_log_axis` — a log axis of counts: ticks at the given values (the N of a
  sweep) or at 1, 2, 5 × 10^k, written as plain integers (``64``, not ``6.4×10^1``), no
  minor ticks.

>>> import matplotlib.pyplot as plt
>>> fig, ax = plt.subplots()
>>> _ = ax.loglog([16, 64, 256], [1, 2, 3])
>>> count_log_axis(ax.xaxis, [16, 64, 256])
>>> [t.get_text() for t in ax.get_xticklabels()]
['16', '64', '256']
>>> plt.close(fig)
"""
from __future__ import annotations

from typing import Sequence

from . import matplotlib  # noqa: F401  (selects the Agg backend)

__all__ = ["integer_axis", "count_log_axis"]


def integer_axis(axis) -> None:
    """Whole-number major ticks on ``axis`` (``ax.xaxis`` / ``ax.yaxis``)."""
    from matplotlib.ticker import MaxNLocator
    axis.set_major_locator(MaxNLocator(integer=True))


def _plain(v, _pos=None) -> str:
    return f"{v:.0f}" if v >= 1 else f"{v:g}"


def count_log_axis(axis, values: Sequence[float] | None = None, *, fontsize: float | None = None) -> None:
    """A log ``axis`` of counts: major ticks at ``values`` (None: 1, 2, 5 × 10^k), labels
    as plain integers, no minor ticks (``fontsize``: of the labels)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullLocator
    if values is not None:
        axis.set_major_locator(FixedLocator(sorted({float(v) for v in values})))
    else:
        axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    axis.set_minor_locator(NullLocator())
    axis.set_major_formatter(FuncFormatter(_plain))
    if fontsize is not None:
        axis.set_tick_params(labelsize=fontsize)

r"""Compact HTML tables of results, for Jupyter's rich display (``_repr_html_``).

Every result class (:class:`~envfit.fit._smoothness.FitResult`,
:class:`~envfit.fit._table2.Table2Result`, :class:`~envfit.advisor._result.Advice`,
:class:`~envfit.validate._results.ValidationResult`, the library results of
:mod:`envfit.batch`) supplies its rows in a few lines of ``_repr_html_`` and renders them
with :func:`html_result`: a bold title, a two-column table of ``(label, value)`` rows and,
optionally, one small table (a header and rows, truncated after ``max_rows``). Every text —
labels, values, map names, notes — goes through :func:`html.escape`, so a map called
``<sky>.exr`` shows as such and cannot inject markup; numbers are written by
:func:`format_value` (4 significant digits, lists as comma-separated values).

Example
-------
>>> print(html_result("fit <a>", [("s", 1.23456), ("interval", (1.1, 1.4))]))
<div class="envfit-result"><b>fit &lt;a&gt;</b><table><tr><th style="text-align:left">s</th><td style="text-align:left">1.235</td></tr><tr><th style="text-align:left">interval</th><td style="text-align:left">1.1, 1.4</td></tr></table></div>
"""
from __future__ import annotations

import html
import math
from numbers import Integral, Real
from typing import Any, Sequence

import numpy as np

__all__ = ["format_value", "html_result"]

_CELL = ' style="text-align:left"'


def format_value(v: Any, digits: int = 4, max_items: int = 6) -> str:
    """Plain text of a value: None → "–", integers as they are, reals to ``digits``
    significant digits (``g`` format), sequences as comma-separated values (at most
    ``max_items``, then "…"), anything else by ``str``.

    >>> format_value(None), format_value(3000), format_value(0.0012346), format_value([1.5, 2, None])
    ('–', '3000', '0.001235', '1.5, 2, –')
    >>> format_value(list(range(9)))
    '0, 1, 2, 3, 4, 5, …'
    """
    if v is None:
        return "–"
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (Integral, np.integer)):
        return str(int(v))
    if isinstance(v, (Real, np.floating)):
        x = float(v)
        return f"{x:.{digits}g}" if math.isfinite(x) else str(x)
    if isinstance(v, (list, tuple, np.ndarray)):
        items = list(np.asarray(v, dtype=object).ravel()) if isinstance(v, np.ndarray) else list(v)
        text = [format_value(x, digits) for x in items[:max_items]]
        return ", ".join(text + (["…"] if len(items) > max_items else []))
    return str(v)


def _row(cells: Sequence[Any], tag: str) -> str:
    return "<tr>" + "".join(f"<{tag}{_CELL}>{html.escape(format_value(c))}</{tag}>"
                            for c in cells) + "</tr>"


def html_result(title: str, rows: Sequence[tuple[str, Any]],
                table: tuple[Sequence[str], Sequence[Sequence[Any]]] | None = None, *,
                max_rows: int = 20) -> str:
    """The HTML of a result: ``title``, the ``(label, value)`` rows, and ``table`` =
    ``(header, rows)`` (after ``max_rows`` rows one line says how many were left out).

    Every label and value is escaped (:func:`html.escape`) after :func:`format_value`.

    >>> h = html_result("t", [], (["N", "RMSE"], [[100, 0.5], [200, 0.25], [400, 0.125]]), max_rows=2)
    >>> "<th" in h, "0.25" in h, "0.125" in h, "1 more row" in h
    (True, True, False, True)
    """
    parts = [f'<div class="envfit-result"><b>{html.escape(str(title))}</b>']
    if rows:
        parts.append("<table>" + "".join(
            f"<tr><th{_CELL}>{html.escape(str(label))}</th>"
            f"<td{_CELL}>{html.escape(format_value(value))}</td></tr>" for label, value in rows)
            + "</table>")
    if table is not None:
        header, body = table
        body = list(body)
        parts.append("<table>" + _row(header, "th") + "".join(_row(r, "td") for r in body[:max_rows]))
        if len(body) > max_rows:
            more = len(body) - max_rows
            parts.append(f'<tr><td colspan="{len(header)}">… {more} more row'
                         f'{"s" if more > 1 else ""}</td></tr>')
        parts.append("</table>")
    parts.append("</div>")
    return "".join(parts)

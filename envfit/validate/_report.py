r"""``report.md``: a short validation report written from the result of ``envfit validate``.

:func:`render_report` turns the JSON-ready dict of :func:`envfit.validate._pipeline.run_validation`
(or the JSON file it was saved to) into Markdown: what was run, the figures, the agreement
numbers (slopes, rank order, the shape fit (a) and the choice of s, the absolute
predictions (b) and (b'), the truncation curves), a "what disagrees and why" section and,
with ``--renderer``, a "Renderer rules" section
(:mod:`~envfit.validate._report_renderer`).

Every sentence that states a judgement (a verdict, a trend, a shape of a distribution, a
cause) is chosen by a named, pure predicate of numbers printed in the same report; the
predicates, their thresholds and the sentence each outcome prints are listed in
:data:`envfit.validate._report_conditions.CONDITIONS`. So the text never claims what the data
do not show: when a test fails the report prints the sentence that is true of the numbers
instead (e.g. "It does not rise with l (0.17–0.92; …)"). :func:`write_report` writes the
report atomically.

The parts live in sibling modules: :mod:`~envfit.validate._report_conditions` (thresholds,
predicates, the table of conditions), :mod:`~envfit.validate._report_sections` (what was run,
the predictions, the figures, the agreement tables), :mod:`~envfit.validate._report_statements`
(what disagrees and why), :mod:`~envfit.validate._report_renderer` (the renderer rules) and
:mod:`~envfit.validate._report_format` (formatting helpers).

Example
-------
>>> md = render_report({"map": "m", "map_size": [8, 4], "channels": 1, "s": 1.5, "sigma": 1.0,
...                     "sigma_channels": [1.0], "scale": "linear", "scale_description": "linear",
...                     "fit": {"source": "given", "s_interval": None, "method": "given", "n": 10},
...                     "config": {"brdfs": ["diffuse"], "pointsets": [], "weights": [],
...                                "n_values": [], "shininess": 30.0, "truncation": False},
...                     "axes": 10, "seed": 0, "results": [], "truncation": [],
...                     "agreement": {"slopes": [], "rank": [], "shape_fit": {"constant": {},
...                                   "residual_dex": {}, "method": ""}, "s_choice": {},
...                                   "absolute": {}, "truncation": [], "acceptance": {},
...                                   "slope_range": [64, 4096]},
...                     "map_stats": {}, "timings": {"total": 1.0}, "notes": []})
>>> md.splitlines()[0]
'# Validation of predicted shading-integral errors: m'
"""
from __future__ import annotations

from pathlib import Path

from envfit.base._atomic import atomic_write_text

from envfit.validate._report_sections import (_agreement_section, _figures_section,
                                              _predictions_explained, _what_was_run)
from envfit.validate._report_renderer import _renderer_section
from envfit.validate._report_statements import _disagreements_section

__all__ = ["render_report", "write_report"]


def render_report(result: dict, figures: dict[str, str] | None = None) -> str:
    """Markdown text of the validation report for ``result`` (see the module docstring).

    Parameters
    ----------
    result : dict
        The JSON-ready dict of :func:`envfit.validate._pipeline.run_validation` (its
        ``to_json()``, or the saved ``validate.json``); an object with ``to_json`` is converted.
    figures : dict, optional
        Figure name → path; linked by file name (the report is written next to them).

    Returns
    -------
    str
        The Markdown text.
    """
    if hasattr(result, "to_json"):
        result = result.to_json()
    lines = [f"# Validation of predicted shading-integral errors: {result['map']}", ""]
    lines += _what_was_run(result)
    lines += _predictions_explained(result)
    lines += _figures_section(figures)
    lines += _agreement_section(result)
    lines += _disagreements_section(result)
    lines += _renderer_section(result)
    return "\n".join(lines)


def write_report(result: dict, path: str | Path, figures: dict[str, str] | None = None) -> Path:
    """Write :func:`render_report` to ``path`` atomically.

    Parameters
    ----------
    result : dict
        What :func:`envfit.validate._pipeline.run_validation` returns.
    path : str or Path
        Where to write ``report.md``.
    figures : dict, optional
        Figure name → path (see :func:`render_report`).

    Returns
    -------
    Path
        ``path``.
    """
    return atomic_write_text(path, render_report(result, figures))

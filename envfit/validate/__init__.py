r"""Predicted against measured shading errors on a map (the paper's Figs. 7-8) and the report
that states them.

Modules:

* :mod:`~envfit.validate._agreement` — Agreement between measured and predicted errors: log-
  log slopes, shape constants, rank agreement, equivalent N, and the per-cell verdicts that
  ``report.md`` states.
* :mod:`~envfit.validate._cells` — The stored quadrature cells of ``envfit validate``: their
  keys, the measured statistics they keep, whether a stored one is current, and the
  :class:`envfit.predict.QuadratureRule` one gives.
* :mod:`~envfit.validate._config` — What ``envfit validate`` runs: :class:`ValidateConfig`,
  the ``--quick`` preset (:func:`quick_config`, :data:`QUICK_DESCRIPTION`) and the named
  sets it draws from.
* :mod:`~envfit.validate._fitting` — The two fits of ``envfit validate``, each a stored cell:
  the paper's (s and σ for predictions (a) and (b)) and the band-limited model's (ŝ′, σ̂′
  for (b′)).
* :mod:`~envfit.validate._keys` — Where each predictor of :data:`envfit.predict.PREDICTORS`
  lands in the result of ``envfit validate`` (the keys the report, the plots and the JSON
  readers use).
* :mod:`~envfit.validate._pipeline` — Predicted errors checked against ground-truth shading
  integrals on a map (Figs. 7–8).
* :mod:`~envfit.validate._renderer` — ``envfit validate --renderer``: the renderer
  estimators' predicted RMSE against the measured one.
* :mod:`~envfit.validate._rendered` — ``envfit validate MAP --renderer NAME``: the
  renderer renders a sphere and its measured RMSE is set beside the renderer model's prediction
  (:func:`render_validation`, :class:`RenderValidationOptions`, :func:`measure_cell`).
* :mod:`~envfit.validate._renderer_results` — What ``envfit validate --renderer`` returns and
  prints: the cells, their summaries per rule and per lobe, the section and its table.
* :mod:`~envfit.validate._report` — ``report.md``: a short validation report written from the
  result of ``envfit validate`` (the descriptive sections, and the assembly).
* :mod:`~envfit.validate._report_predicates` — The judgements of ``report.md``: named
  thresholds, pure predicates (:data:`CONDITIONS`) and the :class:`Verdict` data class.
* :mod:`~envfit.validate._report_verdicts` — Every statement of ``report.md`` on a result,
  as a list of verdicts (which statement, its numbers, whether its predicate holds): the
  ``verdicts`` of ``validate.json``.
* :mod:`~envfit.validate._report_template` — The sentence of every verdict and the tables of
  ``report.md``.
* :mod:`~envfit.validate._results` — The result of ``envfit validate``:
  :class:`ValidationResult` (its :meth:`~ValidationResult.to_json` is the JSON-ready dict
  the report, the plots, ``--json`` and ``validate.json`` read), and the per-rule entries of
  ``results`` with every quadrature-rule predictor of :data:`envfit.predict.PREDICTORS`.
* :mod:`~envfit.validate._truncation` — The truncation part of ``envfit validate`` (Fig. 8):
  SH truncation at degree L on the full map and all axes, HSH truncation on the map
  downscaled to ``hsh_max_height`` rows and the first ``hsh_axes`` axes, each curve a stored
  cell with its worst-case error E(L) (Eqs. 51–52), the band-limited E′(L) of prediction
  (b′), and the QMC-equivalent N.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "quick_config": "_config", "ValidateConfig": "_config",
    "run_validation": "_pipeline",
    "ValidationResult": "_results",
    "RenderValidation": "_rendered", "RenderValidationOptions": "_rendered",
    "render_validation": "_rendered", "measure_cell": "_rendered",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "check_renderer": "_rendered",
    "rendered_summary_lines": "_rendered",
    "QUICK_DESCRIPTION": "_config",
    "rendered_renderers": "_rendered",
    "renderer_config": "_renderer",
    "summary_lines": "_renderer",
    "write_report": "_report",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

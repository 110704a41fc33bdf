r"""Measurement statistics: the adaptive RMSE over axes with bootstrap intervals, the axis
proposal, and the measured RMSE of renderer rules.

Modules:

* :mod:`~envfit.measure._adaptive_rmse` — Measuring an estimator's RMSE over random axes with
  a confidence interval that survives heavy tails, an adaptive number of axes, and the
  comparison of a prediction with it.
* :mod:`~envfit.measure._axis_proposal` — An importance density over shading axes, for
  measuring an RMSE over *uniform* axes.
* :mod:`~envfit.measure._rules` — The measured error of a renderer rule
  (:class:`envfit.sampling._rules.RendererRule`) on a map.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "AdaptiveRMSE": "_adaptive_rmse", "rmse_interval": "_adaptive_rmse",
    "RMSEInterval": "_adaptive_rmse",
    "AxisProposal": "_axis_proposal",
    "measure_rule": "_rules", "RendererSetup": "_rules",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "AXIS_SAMPLING": "_rules",
    "agreement_with_interval": "_adaptive_rmse",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

r"""Figures (PNG, matplotlib's Agg backend), one module per experiment.

Modules:

* ``_save`` (private) — Atomic PNG saving for matplotlib figures.
* ``_ticks`` (private) — Tick helpers for axes that count things (maps, samples N, degrees
  L): whole numbers only.
* :mod:`~envfit.plots._advise` — The figure of ``envfit advise --out DIR``: the renderer
  rules' predicted RMSE against N.
* :mod:`~envfit.plots._advise_rules` — The figure every ``envfit advise --out DIR`` writes
  (``advise_rules.png``): what each rule costs to reach the target.
* :mod:`~envfit.plots._library` — Figures of a library run: how the smoothness s is
  distributed across the maps.
* :mod:`~envfit.plots._preview` — The preview figure of a map (``envfit info --out``,
  ``envfit synth --out``): the tone-mapped lat-long image in the file's layout, its axes in
  the layout's angles, the bright sources marked and listed.
* :mod:`~envfit.plots._renderer` — The figure of ``envfit validate --renderer``: renderer
  rules, measured and predicted RMSE vs N.
* :mod:`~envfit.plots._sh` — The figure of ``envfit sh --out DIR`` (``sh.png``): what the
  exported SH coefficients look like, and the ringing table.
* :mod:`~envfit.plots._table2` — Table 2 and fit figures.
* :mod:`~envfit.plots._theory` — Figures 1–5 of the paper and the BNOT check, drawn from
  :mod:`envfit.theory._figures` data; the error spectrum of one rule (``envfit theory wce
  --out``) and Table 1's E(L) curves (``envfit theory table1 --out``).
* :mod:`~envfit.plots._validate` — Figures of ``envfit validate``: measured errors with the
  predicted curves overlaid.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

import matplotlib

matplotlib.use("Agg", force=False)

_LAZY = {
    "plot_advise_rules": "_advise_rules",
    "plot_map_preview": "_preview",
    "plot_fit_curve": "_table2", "plot_table2": "_table2",
    "plot_all": "_validate",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "plot_bnot": "_theory",
    "plot_convergence": "_theory",
    "plot_error_spectra": "_theory",
    "plot_low_order_closeup": "_theory",
    "plot_power_spectra": "_theory",
    "plot_truncation": "_theory",
    "plot_advise": "_advise",
    "plot_advise_library": "_advise_library",
    "plot_frame": "_frame",
    "plot_rendered": "_rendered",
    "plot_renderer": "_renderer",
    "plot_s_histogram": "_library",
    "plot_sh": "_sh",
    "plot_table1": "_theory",
    "plot_wce_spectrum": "_theory",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

r"""The advisor's ``check=True`` (``envfit advise --check``): the RMSE measured on the map at each
reached row's chosen N or L, beside the prediction.

Over ``axes`` random axes (:func:`envfit.shading._quadrature.random_axes`, seeded by the options'
seed), against the ground truth :func:`envfit.shading._ground_truth.shading_integral`:

* quadrature: the rotated and twisted rule
  (:func:`envfit.shading._quadrature.quadrature_estimates_multi`), for a stochastic point set
  the root mean square over the same realisations as the prediction averages;
* SH truncation: :func:`envfit.shading._estimators.sh_truncation_curve` on the full map;
* HSH truncation: :func:`envfit.shading._estimators.hsh_truncation_curve` on the map
  downscaled to ``check_hsh_height`` rows with the first ``check_hsh_axes`` axes (the HSH
  projection is a per-axis quadrature over the hemisphere, ~1000× dearer than an SH one).

Each measured row gets ``measured_rmse``, ``measured_over_predicted`` (over the prediction of
the row's ``predictor``, :attr:`~envfit.advisor._result.AdviceRow.predicted`) and
``measured_over_target``; :func:`check_rows` returns the summary stored as ``Advice.check``,
with the median of measured over each prediction, (b′) and (c), beside the one used.
"""
from __future__ import annotations

import math

import numpy as np

from envfit.advisor._model import MapModel
from envfit.advisor._options import DEFAULT_SHININESS, AdviseOptions
from envfit.advisor._prediction import make_rule, seed_list
from envfit.advisor._result import Advice, AdviceRow
from envfit.base import progress_bar
from envfit.maps import EnvMap
from envfit.shading import hsh_truncation_curve, rmse_over_axes, sh_truncation_curve
from envfit.shading import shading_integral
from envfit.shading import quadrature_estimates_multi, random_axes

__all__ = ["check_rows"]


class _Measure:
    """The map, the axes and their ground truth, and the rows' measurements on them (the HSH
    one on a downscaled map, set up on first use)."""

    def __init__(self, scaled: EnvMap, wf, model: MapModel, opts: AdviseOptions):
        self.scaled, self.wf, self.opts = scaled, wf, opts
        self.s = model.s_rounded
        self.brdf = opts.brdf
        self.shininess = opts.shininess if opts.shininess is not None else DEFAULT_SHININESS
        self.A = random_axes(opts.axes, [opts.seed, 31])
        self.truth = shading_integral(scaled, self.A, self.brdf, self.shininess)
        self.hsh_env = self.hsh_A = self.hsh_truth = None

    def quadrature(self, r: AdviceRow) -> None:
        """RMSE of the rotated rule, RMS over the realisations of a stochastic set."""
        seed = self.opts.seed
        sds = seed_list(r.pointset, seed, self.opts.seeds) or [None]
        ms = []
        for k, sd in enumerate(sds):
            pts, w = make_rule(r.pointset, r.n, self.wf, self.s, r.weights, sd)
            est = quadrature_estimates_multi(self.scaled, self.A, pts, [w], seed=[seed, 32, k],
                                             workers=self.opts.workers)[0]
            ms.append(float(rmse_over_axes(est, self.truth).total) ** 2)
        r.measured_rmse = math.sqrt(float(np.mean(ms)))
        if len(sds) > 1:
            r.check_note = f"RMS over the {len(sds)} realisations"

    def sh(self, r: AdviceRow) -> None:
        """RMSE of SH truncation at the row's L on the full map."""
        est = sh_truncation_curve(self.scaled, self.A, self.brdf, [r.L],
                                  shininess=self.shininess)[0]
        r.measured_rmse = float(rmse_over_axes(est, self.truth).total)

    def hsh(self, r: AdviceRow) -> None:
        """RMSE of HSH truncation at the row's L on the downscaled map and fewer axes."""
        if self.hsh_env is None:
            self.hsh_env = self.scaled.resized(min(self.opts.check_hsh_height, self.scaled.height))
            self.hsh_A = self.A[:min(self.opts.check_hsh_axes, self.A.shape[0])]
            self.hsh_truth = shading_integral(self.hsh_env, self.hsh_A, self.brdf, self.shininess)
        est = hsh_truncation_curve(self.hsh_env, self.hsh_A, self.brdf, [r.L],
                                   shininess=self.shininess)[0]
        r.measured_rmse = float(rmse_over_axes(est, self.hsh_truth).total)
        if self.hsh_env.height < self.scaled.height or self.hsh_A.shape[0] < self.A.shape[0]:
            r.check_note = f"measured on {self.hsh_env.height} rows, {self.hsh_A.shape[0]} axes"

    def row(self, r: AdviceRow, target: float) -> None:
        """Measure ``r`` and fill its ratios to the prediction and to the target."""
        {"quadrature": self.quadrature, "sh": self.sh, "hsh": self.hsh}[r.method](r)
        if r.predicted:
            r.measured_over_predicted = r.measured_rmse / r.predicted
        r.measured_over_target = r.measured_rmse / target


def _summary(adv: Advice, measured: list[AdviceRow], m: _Measure) -> dict:
    """Axes, the HSH check's size, measured/predicted (the predictor used) over the
    recommendable rows, the median of measured over (b′) and over (c) separately, and the
    recommended row's measured RMSE."""
    ratios = [r.measured_over_predicted for r in measured
              if r.measured_over_predicted is not None and r.recommendable]
    summary = {"axes": int(m.opts.axes),
               "hsh_height": None if m.hsh_env is None else m.hsh_env.height,
               "hsh_axes": None if m.hsh_A is None else int(m.hsh_A.shape[0])}
    if ratios:
        summary.update({"median_measured_over_predicted": float(np.median(ratios)),
                        "min_measured_over_predicted": float(np.min(ratios)),
                        "max_measured_over_predicted": float(np.max(ratios))})
    for name, attr in (("bandlimited", "predicted_rmse"), ("spectral", "predicted_rmse_spectral")):
        rs = [r.measured_rmse / getattr(r, attr) for r in measured
              if r.recommendable and r.measured_rmse is not None and getattr(r, attr)]
        if rs:
            summary[f"median_measured_over_{name}"] = float(np.median(rs))
    best = adv.best()
    if best is not None and best.measured_rmse is not None:
        summary["recommended_measured_rmse"] = best.measured_rmse
        summary["recommended_measured_over_target"] = best.measured_over_target
    return summary


def check_rows(adv: Advice, wf, model: MapModel, opts: AdviseOptions) -> dict:
    """Measure the RMSE at every reached row of ``adv`` (filled in place) on ``model.scaled``
    and return the summary (see the module docstring)."""
    m = _Measure(model.scaled, wf, model, opts)
    todo = [r for r in adv.rows if r.reached]
    bar = progress_bar(len(todo), desc="advise: check", quiet=opts.quiet, unit="rule")
    try:
        for r in todo:
            m.row(r, adv.target_rmse)
            bar.update(1)
    finally:
        bar.close()
    return _summary(adv, todo, m)

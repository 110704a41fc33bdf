r"""Prediction of the renderer rules' RMSE (:mod:`envfit.sampling._rules`) from the map.

One predictor, exact for every strategy and point set: the *warped integrand's spectrum*
(:mod:`envfit.predict.warped._warped_spectrum`). A rule's estimator is a Cranley–Patterson-shifted,
twisted mean of its technique's warped integrand :math:`h_i` over its square points, so

.. math:: \mathrm{MSE} = \sum_{k\ne0}\Big|\sum_i\hat h_i(k)S_i(k)\Big|^2

(:math:`S_i` the point sets' exponential sums), averaged over uniform axes and the channels;
for ``random`` points (a fresh set per axis) :math:`\mathbb E|S_i|^2 = 1/n_i` and it is the
Monte Carlo variance :math:`\sum_i V_i/n_i`. The ``split`` strategy's error is the one of MIS
on the rest map (the sources are integrated exactly). Two predictors of
:data:`envfit.predict.PREDICTORS`, each ``f(ctx, rule: RendererRule) -> Prediction`` with the
spectra in ``ctx.renderer`` (:class:`RendererModel`, :func:`renderer_model`):
``"random-variance"`` (:func:`predict_random_variance`) for random points,
``"warped-spectrum"`` (:func:`predict_warped_spectrum`) for the others
(:func:`renderer_predictor` names the one of a rule).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.sampling import RendererRule
>>> from envfit.measure._rules import RendererSetup
>>> setup = RendererSetup.of(EnvMap(np.full((8, 16, 1), 2.0)), sources=[])
>>> from envfit.predict import PredictionContext, predict
>>> model = renderer_model(setup, "diffuse", strategies=["brdf"], grid=16, axes=4)
>>> p = predict("warped-spectrum", PredictionContext(renderer=model), RendererRule("brdf", "sobol", 16))
>>> p.name, round(p.rmse, 6)
('warped-spectrum', 0.0)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from envfit.defaults import DEFAULT_SHININESS, REFERENCE_SPECTRUM_AXES, RENDERER_GRID
from envfit.base import ParameterError
from envfit.sampling import STRATEGIES, RendererRule, rule_points
from envfit.measure import RendererSetup
from envfit.predict.warped._warped_spectrum import (SpectrumInputs, WarpedSpectrum,
                                                      random_mse, shifted_mse_terms,
                                                      warped_spectrum)

from envfit.predict._context import Prediction, PredictionContext, reads

__all__ = ["RendererModel", "renderer_model", "predict_random_variance",
           "predict_warped_spectrum", "renderer_predictor",
           "RENDERER_PREDICTORS"]

#: predictor names by kind of point set
RENDERER_PREDICTORS = {"random": "random-variance", "quasi-random": "warped-spectrum"}


@dataclass(frozen=True)
class RendererModel:
    """The spectra of one map and lobe, by (technique, on the rest map), and the lobe: what
    the renderer predictors read from :attr:`envfit.predict.PredictionContext.renderer`."""

    brdf: str
    shininess: float
    spectra: dict
    mean: float

    def spectrum(self, rule: RendererRule) -> WarpedSpectrum:
        key = (rule.technique, rule.on_rest)
        if key not in self.spectra:
            raise ParameterError(f"the model has no spectrum for strategy {rule.strategy!r} "
                                 "(build it with that strategy)")
        return self.spectra[key]


def renderer_model(setup: RendererSetup, brdf: str = "diffuse",
                   shininess: float = DEFAULT_SHININESS, *, strategies=tuple(STRATEGIES),
                   grid: int = RENDERER_GRID, axes: int = REFERENCE_SPECTRUM_AXES,
                   progress=None) -> RendererModel:
    """The warped spectra the ``strategies`` need on ``setup``'s map (and rest map), for
    the renderer predictors (``PredictionContext(renderer=...)``). ``progress(label)`` is called before each spectrum.

    Cost: per axis (2G)² lookups for the lobe part and one single-precision non-uniform FFT
    of the map part's ≈ (2πB)² + πB(H + W) + HW nodes (B = G/4), axes on all cores; on
    city.exr (1024×512, G = 512, 32 axes) the four spectra of one lobe took 35 s wall on 2
    cores (load 3–4, the run at a raised priority).
    """
    keys = []
    for s in strategies:
        if s not in STRATEGIES:
            raise ParameterError(f"strategy must be one of {', '.join(STRATEGIES)}; got {s!r}")
        if STRATEGIES[s] not in keys:
            keys.append(STRATEGIES[s])
    spectra, shared = {}, {}
    for i, (tech, rest) in enumerate(keys):
        if progress is not None:
            progress(f"{tech}{' (rest of the map)' if rest else ''}")
        m, sampler = ((setup.rest_map, setup.rest_sampler) if rest
                      else (setup.envmap, setup.sampler))
        if rest not in shared:            # what the spectra of one map share, built once
            shared[rest] = SpectrumInputs.of(m, sampler)
        spectra[(tech, rest)] = warped_spectrum(m, tech, brdf, shininess, sampler=sampler,
                                                grid=grid, axes=axes, inputs=shared[rest])
        if all(r != rest for _, r in keys[i + 1:]):
            del shared[rest]              # freed before the other map's spectra
    whole = [v for (t, r), v in spectra.items() if not r]
    mean = whole[0].mean if whole else float("nan")
    return RendererModel(str(brdf), float(shininess), spectra, mean)


def _points(ctx: PredictionContext, rule: RendererRule):
    """The context's spectrum for the rule's technique and the rule's square points (one
    set, or MIS's pair), seed ``ctx.point_seed``."""
    ctx.need("renderer", who=renderer_predictor(rule))
    pts = rule_points(rule, ctx.point_seed)
    return ctx.renderer.spectrum(rule), (pts[0] if len(pts) == 1 else tuple(pts))


@reads(RendererRule)
def predict_random_variance(ctx: PredictionContext, rule: RendererRule) -> Prediction:
    r"""The Monte Carlo RMSE of ``rule``'s strategy with N i.i.d. uniform points (a fresh set
    per axis): :math:`(\sum_i V_i/n_i)^{1/2}`, :math:`V_i` the variance of technique i's
    warped integrand over the square, averaged over axes and channels
    (:func:`envfit.predict.warped._prediction_sums.random_mse`); the exact mean over random
    sets. ``ctx.renderer`` holds the spectra (:func:`renderer_model`).

    Returns :class:`envfit.predict.Prediction` named ``"random-variance"``.
    """
    spec, u = _points(ctx, rule)
    return Prediction(name="random-variance", rmse=math.sqrt(random_mse(spec, u)))


@reads(RendererRule)
def predict_warped_spectrum(ctx: PredictionContext, rule: RendererRule) -> Prediction:
    r"""The RMSE of ``rule`` with its point set (the realisation of ``ctx.point_seed``),
    Cranley–Patterson shifted and twisted per axis: :math:`\sum_{k\ne0}|\sum_i\hat
    h_i(k)S_i(k)|^2` inside the spectrum's box plus the strips' tail beyond it
    (:func:`envfit.predict.warped._prediction_sums.shifted_mse_terms`). ``ctx.renderer``
    holds the spectra (:func:`renderer_model`).

    Returns :class:`envfit.predict.Prediction` named ``"warped-spectrum"``.
    """
    spec, u = _points(ctx, rule)
    terms = shifted_mse_terms(spec, u)
    return Prediction(name="warped-spectrum",
                      rmse=math.sqrt(max(terms["box"] + terms["tail"], 0.0)))


def renderer_predictor(rule: RendererRule) -> str:
    """The name of the predictor of :data:`RENDERER_PREDICTORS` for ``rule``: the exact mean
    over random sets for ``random`` points, the warped spectrum of the set for the others.

    >>> renderer_predictor(RendererRule("map", "random", 16)), renderer_predictor(RendererRule("map", "sf", 16))
    ('random-variance', 'warped-spectrum')
    """
    return RENDERER_PREDICTORS["random" if rule.pointset == "random" else "quasi-random"]

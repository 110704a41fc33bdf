r"""Prediction of the renderer rules' RMSE (:mod:`envfit.sampling._rules`) from the map.

One predictor, exact for every strategy and point set: the *warped integrand's spectrum*
(:mod:`envfit.predict.renderer._warped_spectrum`). A rule's estimator is a Cranley–Patterson-shifted,
twisted mean of its technique's warped integrand :math:`h_i` over its square points, so

.. math:: \mathrm{MSE} = \sum_{k\ne0}\Big|\sum_i\hat h_i(k)S_i(k)\Big|^2

(:math:`S_i` the point sets' exponential sums), averaged over uniform axes and the channels;
for ``random`` points (a fresh set per axis) :math:`\mathbb E|S_i|^2 = 1/n_i` and it is the
Monte Carlo variance :math:`\sum_i V_i/n_i`. The ``split`` strategy's error is the one of MIS
on the rest map (the sources are integrated exactly). Names in :data:`RENDERER_PREDICTORS`:
``"random-variance"`` for random points, ``"warped-spectrum"`` for the others.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.sampling._rules import RendererRule
>>> from envfit.measure._rules import RendererSetup
>>> setup = RendererSetup.of(EnvMap(np.full((8, 16, 1), 2.0)), sources=[])
>>> model = renderer_model(setup, "diffuse", strategies=["brdf"], grid=16, axes=4)
>>> p = predict_rule(model, RendererRule("brdf", "sobol", 16))
>>> p.name, round(p.rmse, 6)
('warped-spectrum', 0.0)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from envfit.defaults import DEFAULT_SHININESS, REFERENCE_SPECTRUM_AXES, RENDERER_GRID
from envfit.base._errors import ParameterError
from envfit.sampling._rules import STRATEGIES, RendererRule, rule_points
from envfit.measure._rules import RendererSetup
from envfit.predict.renderer._warped_spectrum import (WarpedSpectrum, random_mse,
                                                      shifted_mse_terms, warped_spectrum)

from envfit.predict._context import Prediction

__all__ = ["RendererModel", "renderer_model", "predict_rule", "RENDERER_PREDICTORS"]

#: predictor names by kind of point set
RENDERER_PREDICTORS = {"random": "random-variance", "quasi-random": "warped-spectrum"}


@dataclass(frozen=True)
class RendererModel:
    """The spectra of one map and lobe, by (technique, on the rest map), and the lobe."""

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
    :func:`predict_rule`. ``progress(label)`` is called before each spectrum.

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
    spectra = {}
    for tech, rest in keys:
        if progress is not None:
            progress(f"{tech}{' (rest of the map)' if rest else ''}")
        m, sampler = ((setup.rest_map, setup.rest_sampler) if rest
                      else (setup.envmap, setup.sampler))
        spectra[(tech, rest)] = warped_spectrum(m, tech, brdf, shininess, sampler=sampler,
                                                grid=grid, axes=axes)
    whole = [v for (t, r), v in spectra.items() if not r]
    mean = whole[0].mean if whole else float("nan")
    return RendererModel(str(brdf), float(shininess), spectra, mean)


def predict_rule(model: RendererModel, rule: RendererRule, *, seed: int = 0) -> Prediction:
    """The predicted RMSE of ``rule`` (:class:`envfit.predict._context.Prediction`, named by
    :data:`RENDERER_PREDICTORS`); ``seed`` of the points as :func:`rule_points`."""
    spec = model.spectrum(rule)
    pts = rule_points(rule, seed)
    u = pts[0] if len(pts) == 1 else tuple(pts)
    if rule.pointset == "random":
        return Prediction(name=RENDERER_PREDICTORS["random"], rmse=math.sqrt(random_mse(spec, u)))
    terms = shifted_mse_terms(spec, u)
    return Prediction(name=RENDERER_PREDICTORS["quasi-random"],
                      rmse=math.sqrt(max(terms["box"] + terms["tail"], 0.0)))

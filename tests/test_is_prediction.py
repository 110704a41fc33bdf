"""The exact random-point RMSE of renderer estimators (oracles.is_variance) against the
RMSE the estimators themselves make (envfit.sampling._importance), on a sun + sky map and a GP
map. The two modules were written independently; here the variance integral (a quadrature
over the map) must predict a Monte Carlo measurement over axes and realisations.
"""
from __future__ import annotations

import numpy as np
import pytest

from envfit.data_gen._analytic import SunSkyMap
from envfit.data_gen._gp import gaussian_process_map
from envfit.maps._envmap import EnvMap
from envfit.shading._ground_truth import shading_integral
from envfit.sampling._importance import brdf_sampling_estimates, map_is_estimates, mis_estimates
from oracles.is_variance import LobePdf, MapPdf, is_variance, mis_variance
from envfit.sampling._map_sampler import MapSampler

N, M, R = 32, 60, 40          # samples per estimate, axes, independent realisations


@pytest.fixture(scope="module")
def maps():
    # a sun large enough that every lobe's hits are counted in the measurement: with a
    # small, bright sun, BRDF sampling hits it with probability ~1e-5, the squared error is
    # a rare-event sum and a finite measurement (here 2400 estimates) sits far below its
    # expectation (measured 0.45x the exact value at radius 0.15, 800 realisations)
    sun = SunSkyMap(sun_theta=0.6, sun_phi=1.0, sun_radius=0.35, sun_radiance=20.0,
                    sky=(0.5, 0.7, 1.0))
    gp = gaussian_process_map(1.5, 16, seed=3, channels=3, offset=4.0)
    return {"sun": EnvMap(sun.render(16), up="z"), "gp": EnvMap(gp, up="y")}


def _axes(seed):
    v = np.random.default_rng(seed).normal(size=(M, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _measured_mse(env, axes, estimator, **kw):
    """Mean over realisations, axes and channels of the squared error, and its standard error."""
    truth = shading_integral(env, axes, kw.get("brdf", "diffuse"), kw.get("shininess", 30.0))
    sq = []
    for r in range(R):
        u = np.random.default_rng(100 + r).random((N, 2))
        est = estimator(env, axes, u, seed=1000 + r, **kw)
        sq.append((est - truth) ** 2)
    sq = np.stack(sq)
    return float(sq.mean()), float(sq.mean(axis=(1, 2)).std(ddof=1) / np.sqrt(R))


@pytest.mark.parametrize("name", ["sun", "gp"])
@pytest.mark.parametrize("brdf,n", [("diffuse", 30.0), ("glossy", 30.0)])
@pytest.mark.parametrize("technique", ["map", "brdf", "mis"])
def test_exact_variance_predicts_the_measured_rmse(maps, name, brdf, n, technique):
    env, axes = maps[name], _axes(7)
    kw = {"brdf": brdf, "shininess": n}
    pmap, plobe = MapPdf(env), LobePdf(brdf, n)
    if technique == "map":
        pred = is_variance(env, axes, pmap, brdf, n).mean() / N
        meas, se = _measured_mse(env, axes, map_is_estimates, sampler=MapSampler(env), **kw)
    elif technique == "brdf":
        pred = is_variance(env, axes, plobe, brdf, n).mean() / N
        meas, se = _measured_mse(env, axes, brdf_sampling_estimates, **kw)
    else:
        n1 = N // 2
        pred = mis_variance(env, axes, pmap, plobe, brdf, n, mode="multi",
                            counts=(n1, N - n1)).mean()
        meas, se = _measured_mse(env, axes, mis_estimates, sampler=MapSampler(env), **kw)
    if pred == 0.0:
        assert meas < 1e-20
        return
    # the measurement's own standard error, plus 5 % for the finite set of 40 realisations
    assert abs(meas - pred) <= 4.0 * se + 0.05 * pred, (meas, pred, se)

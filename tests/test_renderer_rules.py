"""Renderer rules: their measurement (envfit.sampling._rules) against their prediction
(envfit.predict.renderer), two independent algorithms — brute-force estimates over random
axes, twists and shifts versus the warped integrand's spectrum and pixel-quadrature variances."""
import numpy as np
import pytest

from envfit.base._errors import ParameterError
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.maps._envmap import EnvMap
from envfit.predict import predict_rule
from envfit.predict.warped._predictor import renderer_model
from envfit.sampling._rules import RendererRule, rule_points
from envfit.measure._rules import RendererSetup, measure_rule, replicates, rule_estimates


@pytest.fixture(scope="module")
def setup():
    arr, _ = sun_gp_map(16, seed=5, channels=1, sun_radiance=60.0, sun_radius=0.2)
    return RendererSetup.of(EnvMap(arr))


def test_the_sun_is_found_and_split_off(setup):
    assert len(setup.sources) == 1
    # the source map and the rest add up to the map
    np.testing.assert_allclose(setup.source_map.data + setup.rest_map.data, setup.envmap.data,
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("brdf", ["diffuse", "glossy"])
def test_measured_rmse_agrees_with_the_prediction(setup, brdf):
    """Every strategy, a QMC and a random set, N = 16 and 64: the prediction lies inside the
    measured 95 % interval or within 15 % of the measured RMSE."""
    # grid 256: the lobe part aliases less than 5 % here; 128 axes, calibrated by the exact
    # means (48 put glossy brdf/sf N = 64 12 % above an 8000-axis measurement, 1024 axes 7 %)
    model = renderer_model(setup, brdf, 30.0, grid=256, axes=128)
    bad = []
    for strategy in ("brdf", "map", "mis", "split"):
        for ps, n in (("sobol", 16), ("random", 16), ("sf", 64)):
            rule = RendererRule(strategy, ps, n)
            pred = predict_rule(model, rule).rmse
            iv = measure_rule(setup, rule, brdf, 30.0, seed=2, axes_start=400, max_axes=1600,
                              resamples=400, target_relative=0.06).interval
            if not (iv.low <= pred <= iv.high or abs(pred / iv.rmse - 1) <= 0.15):
                bad.append((rule.label, n, pred, iv))
    assert not bad, bad


def test_split_estimates_add_the_exact_source_part(setup):
    """A split rule's error is the rest map's MIS error: same twists, shifts and points."""
    A = np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    split = rule_estimates(setup, RendererRule("split", "sobol", 16), A, seed=3)
    rest = rule_estimates(RendererSetup.of(setup.rest_map, sources=[]),
                          RendererRule("mis", "sobol", 16), A, seed=3)
    src = setup.truth(A, "diffuse", 30.0, part="source")
    np.testing.assert_allclose(split, rest + src, rtol=1e-12)


def test_mis_points_are_two_sets_and_replicates_cover_small_n():
    pts = rule_points(RendererRule("mis", "random", 17), seed=4)
    assert [p.shape[0] for p in pts] == [9, 8] and not np.array_equal(pts[0][:8], pts[1])
    assert replicates(16) * 16 >= 4096 and replicates(8192) == 1


@pytest.mark.parametrize("args, msg", [(("bogus", "sobol", 16), "strategy must be one of"),
                                       (("mis", "halton", 16), "point set must be one of"),
                                       (("mis", "sobol", 1), "N")])
def test_bad_rules_are_one_line_errors(args, msg):
    with pytest.raises(ParameterError, match=msg):
        RendererRule(*args)

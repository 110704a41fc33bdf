"""Cycles' Multiscatter GGX (``envfit.renderers.cycles._bsdf``, the energy scale of
``envfit.shading.microfacet._multiscatter``): the albedo table
against a direction-space quadrature of the single-scatter BSDF, the lookup's interpolation,
the conductor's eval and weight scaled, the noise model scaled per frame, and bad
combinations refused. Rendered by Cycles: tests/test_render_cycles.py (a white sphere under
a constant map renders the map's value)."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.predict.renderer import MicrofacetModel
from envfit.predict.renderer._diffuse_model import RendererModelOptions
from envfit.renderers import get_renderer
from envfit.shading.microfacet import Conductor
from envfit.shading.microfacet import energy_scale as _energy_scale
from envfit.shading.microfacet._multiscatter import TABLE_SIZE
from envfit.shading.microfacet._multiscatter import _column as _technique_column

CYCLES = get_renderer("cycles")
#: the techniques of Cycles' GGX (its record's conductor)
TECHNIQUE = {"shadowing": CYCLES.bsdf("ggx", 0.3).shadowing,
             "vndf": CYCLES.bsdf("ggx", 0.3).vndf}


def _column(x):
    return _technique_column(TECHNIQUE["shadowing"], TECHNIQUE["vndf"], x)


def energy_scale(alpha, cos_i):
    return _energy_scale(alpha, cos_i, **TECHNIQUE)


def _albedo_by_directions(alpha: float, mu: float, n: int = 1200) -> float:
    """∫ f cos dω_o of the single-scatter Cycles GGX by a Gauss–Legendre rule in
    (cos θ_o, φ_o), the φ axis split at the mirror azimuth."""
    c = CYCLES.bsdf("ggx", alpha)
    x, w = np.polynomial.legendre.leggauss(n)
    ct = (x + 1) / 2
    wt = w / 2
    phi = np.pi * (x + 1) / 2                       # [0, π], symmetric about φ = 0: ×2
    wp = w * np.pi / 2 * 2
    C, P = np.meshgrid(ct, phi, indexing="ij")
    st = np.sqrt(1 - C * C)
    wo = np.stack([st * np.cos(P), st * np.sin(P), C], axis=-1).reshape(-1, 3)
    wi = np.broadcast_to([-np.sqrt(1 - mu * mu), 0.0, mu], wo.shape)   # mirror at φ = 0
    f = c.eval(wi, wo).reshape(n, n)
    return float(wt @ f @ wp)


@pytest.mark.parametrize("x, y", [(10, 31), (10, 16), (17, 3), (31, 8), (7, 20)])
def test_table_is_the_single_scatter_albedo(x, y):
    r, mu = x / (TABLE_SIZE - 1), max(y / (TABLE_SIZE - 1), 1e-4)
    assert _column(x)[y] == pytest.approx(_albedo_by_directions(r * r, mu), abs=1.5e-3)


def test_lookup_interpolates_as_cycles():
    a = (10 / 31) ** 2                              # on a roughness node
    col = _column(10)
    assert energy_scale(a, 16 / 31) == pytest.approx(1 / col[16], rel=1e-12)
    mid = energy_scale(a, 16.5 / 31)
    assert mid == pytest.approx(1 / (0.5 * col[16] + 0.5 * col[17]), rel=1e-12)
    r = 10.25 / 31                                  # between nodes: linear in r, then μ
    e = 0.75 * _column(10)[16] + 0.25 * _column(11)[16]
    assert energy_scale(r * r, 16 / 31) == pytest.approx(1 / e, rel=1e-12)


def test_conductor_scales_eval_and_weight_not_the_pdf():
    one, multi = CYCLES.bsdf("ggx", 0.4), CYCLES.bsdf("multiggx", 0.4)
    rng = np.random.default_rng(2)
    wi = np.broadcast_to([0.6, 0.0, 0.8], (500, 3))
    u = rng.random((500, 2))
    s1, s2 = one.sample(wi, u), multi.sample(wi, u)
    k = float(energy_scale(0.4, 0.8))
    np.testing.assert_allclose(s2.weight, k * s1.weight, rtol=1e-12)
    np.testing.assert_allclose(s2.pdf, s1.pdf, rtol=1e-12)
    np.testing.assert_allclose(multi.eval(wi, s1.wo), k * one.eval(wi, s1.wo), rtol=1e-12)


def test_model_mse_scales_by_the_square_per_frame():
    rng = np.random.default_rng(0)
    env = EnvMap((rng.random((16, 32, 3)) * 2 + 0.5).astype(np.float32))
    frame = (np.array([[0.0, 0.0, 1.0]]), np.array([[0.6, 0.0, 0.8]]))
    opts = RendererModelOptions(max_level=5)
    one = MicrofacetModel(env, CYCLES, CYCLES.bsdf("ggx", 0.3), frame, options=opts)
    multi = MicrofacetModel(env, CYCLES, CYCLES.bsdf("multiggx", 0.3), frame, options=opts)
    k = float(energy_scale(0.3, 0.8))
    for s in ("brdf", "mis"):
        assert multi.predict(s, "tabulated_sobol", 16).rmse == pytest.approx(
            k * one.predict(s, "tabulated_sobol", 16).rmse, rel=1e-9)


def test_bad_combinations():
    with pytest.raises(ParameterError, match="Multiscatter"):
        get_renderer("mitsuba3").bsdf("multiggx", 0.3)
    for kind, kw in (("beckmann", {}), ("ggx", {"eta": 0.3, "k": 2.5, "fresnel": "moeller"})):
        with pytest.raises(ParameterError, match="multiscatter"):
            Conductor(kind, 0.3, **TECHNIQUE, multiscatter=True, **kw)


def test_f82_metal_energy_scale_and_fresnel_average():
    """The F82-tint metal's pieces against their definitions: F82's cosine-weighted average
    (f0 + (1 − f0)/21 − b/126) by quadrature, b's tint at cos θ = 1/7, E_avg = ∫2μE dμ against
    the albedo table's rows (trapezoid over its 32 μ nodes), and the energy scale: 1/E at
    F_ss = 1, 1 + F_ms(1/E − 1) below it, between 1 and 1/E."""
    from scipy.integrate import quad

    from envfit.shading.microfacet._fresnel import f82_average, f82_tint_b, fresnel_f82
    from envfit.shading.microfacet._multiscatter import albedo_table, average_albedo
    from envfit.shading.microfacet._multiscatter import energy_scale
    for f0, tint in ((0.8, 1.0), (0.3, 0.7), (0.95, 0.4)):
        b = f82_tint_b(f0, tint)
        s = (1 - np.array([1 / 7])) ** 5
        assert fresnel_f82(1 / 7, f0, b) == pytest.approx((f0 + (1 - f0) * s[0]) * tint)
        q = quad(lambda m: 2 * m * (f0 + (1 - f0) * (1 - m) ** 5 - b * m * (1 - m) ** 6), 0, 1)
        assert f82_average(f0, b) == pytest.approx(q[0], rel=1e-12)
    kw = {"shadowing": "height_correlated", "vndf": "hemisphere_concentric"}
    table = albedo_table(**kw)
    mu = np.clip(np.arange(32) / 31, 1e-4, 1)
    for x in (8, 16, 31):
        alpha = (x / 31) ** 2
        trap = np.trapezoid(2 * mu * table[:, x], mu)
        assert average_albedo(alpha, **kw) == pytest.approx(trap, abs=3e-3)
    e = 1 / energy_scale(0.25, [0.2, 0.9], **kw)
    assert np.allclose(energy_scale(0.25, [0.2, 0.9], **kw, fss=1.0), 1 / e)
    avg = average_albedo(0.25, **kw)
    fss = 0.8
    fms = fss * avg / (1 - fss * (1 - avg))
    got = energy_scale(0.25, [0.2, 0.9], **kw, fss=fss)
    np.testing.assert_allclose(got, 1 + fms * (1 / e - 1), rtol=1e-12)
    assert np.all((got > 1) & (got < 1 / e))

"""A BSDF's lobe choice by a 1-D number of its own (Mitsuba's ``roughplastic``:
``sample1 < p``) under QMC samplers: :func:`lobe_choice_mse` / :func:`lobe_choice_mis`
against Mitsuba 3's own samplers (``scalar_rgb``) driven one pixel at a time as its
``direct`` integrator draws a BSDF sample (``next_2d`` for ``sample2``, then ``next_1d`` for
``sample1``; the emitter's ``next_2d`` first under MIS) and as ``path`` does (``next_1d``
first, then ``next_2d``), over thousands of pixels, and a numpy brute force of the
stratified case. The integrands are the oracles' edge (lobe a) and
peak (lobe b); the value of a sample is a(x) when u1 < p, else b(x).

Tolerance: |prediction − brute force| ≤ Z standard errors (+1 %). For ``ldsampler`` the test
also shows that the prediction of i.i.d. lobe choices on one square (the independent
sampler's model) fails the same check, and under MIS that the cross term matters."""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from oracles.randomisers import INTEGRANDS, jittered_points

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import (DyadicGrid, lobe_choice_mis,
                                                   lobe_choice_mse, randomised_mse)
from envfit.renderers.mitsuba3._kensler import KENSLER_PERMUTATIONS, multijitter_shape

A, B, E = INTEGRANDS["edge"], INTEGRANDS["peak"], INTEGRANDS["edge"]
P = 0.3
SEEDS, Z = 2000, 4.0


def _grid(f):
    return DyadicGrid.from_callable(f, 8, nodes=3)


@functools.lru_cache(maxsize=None)
def _grid_of(x: float, y: float) -> DyadicGrid:
    return _grid(lambda u: x * A.h(u) + y * B.h(u))


@functools.lru_cache(maxsize=None)
def _total_of(x: float, y: float) -> DyadicGrid:
    return _grid(lambda u: E.h(u) + x * A.h(u) + y * B.h(u))


def _errors(x, u1, p=P) -> np.ndarray:
    """F − I per pixel: x (pixels, N, 2), u1 (pixels, N)."""
    f = np.where(u1 < p, A.h(x), B.h(x)).mean(axis=1)
    return f - (p * A.integral + (1.0 - p) * B.integral)


def _agree(pred: float, err: np.ndarray) -> tuple[float, float]:
    """Assert the agreement; return the brute force and its standard error."""
    e2 = err ** 2
    bf, se = float(e2.mean()), float(e2.std(ddof=1) / math.sqrt(e2.size))
    assert abs(pred - bf) <= Z * se + 0.01 * pred, \
        f"predicted {pred:.4e}, brute force {bf:.4e} ± {se:.1e} (z = {(pred - bf) / se:+.2f})"
    return bf, se


def _square_prediction(name: str, n: int, **options) -> float:
    """The i.i.d.-style model: the lobe from u_x on one square (``sample_square``)."""
    def h(u):
        a = np.clip(u[..., 0] / P, 0.0, 1.0 - 1e-12)
        b = np.clip((u[..., 0] - P) / (1.0 - P), 0.0, 1.0 - 1e-12)
        return np.where(u[..., 0] < P, A.h(np.stack([a, u[..., 1]], -1)),
                        B.h(np.stack([b, u[..., 1]], -1)))
    return float(randomised_mse(name, _grid(h), n, **options).mse[0])


def test_one_sample_is_the_mixture_variance():
    """N = 1: p V(a) + (1 − p) V(b) + p(1 − p) D², by the grids' own variances."""
    va, vb = _grid_of(1.0, 0.0).variance[0], _grid_of(0.0, 1.0).variance[0]
    d = _grid_of(1.0, -1.0).integral[0]
    want = P * va + (1 - P) * vb + P * (1 - P) * d * d
    got = lobe_choice_mse("jittered", _grid_of, 1, P, r=1)[0]
    assert got == pytest.approx(want, rel=1e-9)


def test_stratified_numpy_brute_force():
    """Jittered 4 × 4 points and 16 jittered 1-D strata in a uniformly random order."""
    rng = np.random.default_rng(5)
    reps, r = 20000, 4
    x = jittered_points(rng, reps, r)
    u1 = (rng.permuted(np.tile(np.arange(r * r), (reps, 1)), axis=1)
          + rng.random((reps, r * r))) / (r * r)
    pred = lobe_choice_mse("jittered", _grid_of, r * r, P, r=r)[0]
    _agree(pred, _errors(x, u1))


def test_bad_arguments_are_one_line():
    with pytest.raises(ParameterError, match="lobe choice"):
        lobe_choice_mse("cp_shift", _grid_of, 16, P)
    with pytest.raises(ParameterError, match="p must be"):
        lobe_choice_mse("jittered", _grid_of, 16, 1.5, r=4)


def _mitsuba():
    """Mitsuba 3 in its ``scalar_rgb`` variant; the calling test is skipped where it is not
    installed (the tests above need numpy only)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


@functools.lru_cache(maxsize=None)
def bsdf_draws(kind: str, spp: int, seeds: int, emitter: bool = False,
               integrator: str = "direct"):
    """(emitter (seeds, N, 2) or None, sample2 (seeds, N, 2), sample1 (seeds, N)) as the
    ``direct`` integrator (or ``path``) draws them per sample (film position first)."""
    s = _mitsuba().load_dict({"type": kind, "sample_count": spp})
    n = s.sample_count()
    em, x, u1 = np.empty((seeds, n, 2)), np.empty((seeds, n, 2)), np.empty((seeds, n))
    for seed in range(seeds):
        s.seed(seed)
        for i in range(n):
            s.next_2d()                                       # the film position
            if emitter:
                em[seed, i] = tuple(s.next_2d())
            if integrator == "path":                          # two statements, in order
                u1[seed, i] = s.next_1d()
                x[seed, i] = tuple(s.next_2d())
            else:
                x[seed, i] = tuple(s.next_2d())               # sample2 (evaluated first)
                u1[seed, i] = s.next_1d()                     # sample1
            s.advance()
    return (em if emitter else None), x, u1


CASES = [("ldsampler", 16, "digital_shift", {}), ("ldsampler", 64, "digital_shift", {}),
         ("stratified", 16, "jittered", {"r": 4}), ("stratified", 36, "jittered", {"r": 6}),
         ("multijitter", 16, "cmj", {"permutations": KENSLER_PERMUTATIONS}),
         ("multijitter", 35, "cmj", {"permutations": KENSLER_PERMUTATIONS})]


@pytest.mark.parametrize("kind, spp, name, options", CASES)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_lobe_choice_against_mitsubas_samplers(kind, spp, name, options, integrator):
    _, x, u1 = bsdf_draws(kind, spp, SEEDS, integrator=integrator)
    n = x.shape[1]
    if name == "cmj":
        assert math.prod(multijitter_shape(spp)) == n
    pred = lobe_choice_mse(name, _grid_of, n, P, **options)[0]
    bf, se = _agree(pred, _errors(x, u1))
    if name == "digital_shift" and integrator == "direct":   # the one-square model fails it
        assert abs(_square_prediction(name, n, **options) - bf) > Z * se + 0.01 * bf


@pytest.mark.parametrize("spp", [16, 64])
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_ldsampler_mis_shares_the_point_set(spp, integrator):
    """Emitter stream (edge) + BSDF stream with its lobe choice, one shifted net: the cross
    term C_N(h_e, c_p) is > 10 % of the MSE at 16 spp; in ``direct``'s order of the BSDF's
    draws and in ``path``'s (the record's ``mis``)."""
    em, x, u1 = bsdf_draws("ldsampler", spp, SEEDS, emitter=True, integrator=integrator)
    first = _grid(E.h)
    mse, e_mse, b_mse, cross = lobe_choice_mis("digital_shift", first, _grid_of, spp, P,
                                               shared=True, options={}, options_b={},
                                               total_of=_total_of)
    err = (E.h(em).mean(axis=1) - E.integral) + _errors(x, u1)
    _agree(mse[0], err)
    if spp == 16:
        assert abs(2.0 * cross[0]) > 0.1 * mse[0]

"""Mitsuba 3's ``orthogonal`` sampler (Bose orthogonal array, strength 2) against the
prediction of ``randomisation._orthogonal``:

* its strata are the Bose construction's forms, permuted (Mitsuba's own points with
  ``jitter=False``: the pairs of samples agree on the same axes as the forms' pairs do), at the
  dimensions Mitsuba's ``direct`` integrator draws (emitter 2–3, BSDF 5–6 after a 1-D draw);
* at an even first dimension the pattern is correlated multi-jittering (the prediction equals
  ``cmj`` with uniform permutations);
* the formula equals brute force over uniform permutations of the same forms;
* Mitsuba's own points (hashed permutations, PCG32 jitter) over 3000 pixels agree with the
  prediction within Z standard errors + 2 % (Kensler's hash is not a uniform permutation; the
  difference measured with 30 000 pixels at p = 3, 5, 7 was ≤ 1.6 %);
* the emitter's and the BSDF's streams are independent (cross term 0).
"""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from oracles.randomisers import INTEGRANDS, mse_estimate

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import DyadicGrid, randomised_mse
from envfit.predict.renderer.randomisation._orthogonal import _pattern_counts, bose_indices

mi = pytest.importorskip("mitsuba")

SEEDS, Z = 3000, 4.0
DIMS = (2, 5)                      # the emitter's and the BSDF's first 2-D dimension (MIS)


@pytest.fixture(scope="module", autouse=True)
def scalar_variant():
    mi.set_variant("scalar_rgb")


@pytest.fixture(scope="module")
def grids():
    return {name: DyadicGrid.from_callable(f.h, 9, nodes=3) for name, f in INTEGRANDS.items()}


@functools.lru_cache(maxsize=None)
def orthogonal_points(spp: int, seeds: int, jitter: bool = True) -> np.ndarray:
    """(seeds, N, 2, 2): per pixel and sample the 2-D draws at dimensions 2–3 and 5–6, drawn
    as ``direct`` draws them (film 0–1, emitter 2–3, BSDF 1-D 4 then 2-D 5–6)."""
    s = mi.load_dict({"type": "orthogonal", "sample_count": spp, "jitter": jitter})
    n = s.sample_count()
    out = np.empty((seeds, n, 2, 2))
    for seed in range(seeds):
        s.seed(seed)
        for i in range(n):
            s.next_2d()
            e = s.next_2d()
            s.next_1d()
            b = s.next_2d()
            out[seed, i] = (e[0], e[1]), (b[0], b[1])
            s.advance()
    out.flags.writeable = False
    return out


def _strata(points: np.ndarray, p: int) -> np.ndarray:
    """(N, 4) stratum and sub-stratum per coordinate of jitter-free points."""
    fine = np.floor(points * p * p + 1e-3).astype(np.int64)         # centres: no rounding issue
    return np.stack([fine[:, 0] // p, fine[:, 0] % p, fine[:, 1] // p, fine[:, 1] % p], axis=1)


@pytest.mark.parametrize("spp", [9, 25, 49])
def test_strata_are_the_bose_forms_permuted(spp):
    p = math.isqrt(spp)
    pts = orthogonal_points(spp, 3, jitter=False)
    for seed in range(3):
        for k, dim in enumerate(DIMS):
            mine = _strata(pts[seed, :, k], p)
            for axis in range(4):                                    # each axis a permutation
                assert sorted(np.bincount(mine[:, axis], minlength=p)) == [p] * p
            np.testing.assert_array_equal(_pattern_counts(mine),
                                          _pattern_counts(bose_indices(p, dim)))


def test_even_dimension_is_uniform_cmj_and_odd_is_not(grids):
    g = grids["edge"]
    for p in (3, 5, 7):
        even = randomised_mse("orthogonal", g, p * p, dimension=2).mse[0]
        cmj = randomised_mse("cmj", g, p * p, nx=p, ny=p).mse[0]
        assert even == pytest.approx(cmj, rel=1e-12)
    odd = randomised_mse("orthogonal", g, 49, dimension=5).mse[0]
    assert abs(odd / randomised_mse("orthogonal", g, 49, dimension=2).mse[0] - 1) > 0.01


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("p", [3, 5])
def test_formula_is_brute_force_over_uniform_permutations(grids, p, dim):
    rng = np.random.default_rng(5)
    t, n, reps = bose_indices(p, dim), p * p, 40000
    perms = np.argsort(rng.random((reps, 4, p)), axis=2)             # uniform permutations
    fine = [np.take_along_axis(perms[:, a], np.broadcast_to(t[:, a], (reps, n)), axis=1)
            for a in range(4)]
    u1 = (fine[0] + (fine[1] + rng.random((reps, n))) / p) / p
    u2 = (fine[2] + (fine[3] + rng.random((reps, n))) / p) / p
    pts = np.stack([u1, u2], axis=-1)
    for name in ("smooth", "edge"):
        bf, se = mse_estimate(INTEGRANDS[name], pts)
        pred = randomised_mse("orthogonal", grids[name], n, dimension=dim).mse[0]
        assert abs(pred - bf) <= Z * se + 0.005 * pred, (name, pred, bf, se)


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("spp", [16, 49])
def test_mitsuba_orthogonal_mse(grids, name, spp):
    pts = orthogonal_points(spp, SEEDS)
    n = pts.shape[1]
    assert n == {16: 25, 49: 49}[spp]
    for k, dim in enumerate(DIMS):
        bf, se = mse_estimate(INTEGRANDS[name], pts[:, :, k])
        pred = randomised_mse("orthogonal", grids[name], n, dimension=dim).mse[0]
        assert abs(pred - bf) <= Z * se + 0.02 * pred, \
            f"{name} dim {dim}: predicted {pred:.4e}, Mitsuba {bf:.4e} ± {se:.1e}"


def test_streams_are_independent():
    one, two = INTEGRANDS["edge"], INTEGRANDS["peak"]
    pts = orthogonal_points(25, SEEDS)
    prod = (one.h(pts[:, :, 0]).mean(axis=1) - one.integral) \
        * (two.h(pts[:, :, 1]).mean(axis=1) - two.integral)
    assert abs(prod.mean()) <= Z * prod.std(ddof=1) / math.sqrt(SEEDS)


def test_bad_point_counts(grids):
    for n in (16, 8, 1):
        with pytest.raises(ParameterError, match="p prime"):
            randomised_mse("orthogonal", grids["edge"], n)
    with pytest.raises(ParameterError, match="dimension"):
        randomised_mse("orthogonal", grids["edge"], 25, dimension=-1)

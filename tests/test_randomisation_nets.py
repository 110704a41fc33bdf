"""Randomised digital nets and shifted point sets: the exact MSE of
envfit.predict.renderer.randomisation against brute force over thousands of randomisations
(seeded numpy Generators) of the (van der Corput, Sobol' 2) net built by the oracle's own loops —
uniform random 32-bit XOR shifts, a bit-by-bit nested uniform (Owen) scramble, pbrt-v4's
hashed Owen scramblers (ported), random torus shifts — and the MIS cross term of two streams sharing one shifted net in two random orders.
Owen's variance identity (gains × Haar components) is *checked* here, not assumed.
Tolerance: |prediction − brute force| ≤ Z standard errors of the brute force (+1 %)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from oracles.randomisers import (INTEGRANDS, mse_estimate, owen_scrambled_points,
                                 pbrt_scrambled_points, sobol_digits, xor_shifted_points)

from envfit.predict.renderer.randomisation import (NETS, DyadicGrid, mis_mse,
                                                   randomised_mse)

REPS, Z = 3000, 4.0


@pytest.fixture(scope="module")
def grids():
    """M = 512 = 2N at N = 256: the digital shift needs N ≤ M/2 for its shell estimate."""
    return {name: DyadicGrid.from_callable(f.h, 9, nodes=3) for name, f in INTEGRANDS.items()}


def _agree(pred: float, points: np.ndarray, name: str) -> None:
    bf, se = mse_estimate(INTEGRANDS[name], points)
    assert abs(pred - bf) <= Z * se + 0.01 * pred, \
        f"{name}: predicted {pred:.4e}, brute force {bf:.4e} ± {se:.1e} (z = {(pred - bf) / se:+.2f})"


CASES = [(name, n) for name in sorted(INTEGRANDS) for n in (4, 16, 64, 256)]


@pytest.mark.parametrize("name, n", CASES)
def test_owen_scrambling_against_bit_by_bit_scrambles(grids, name, n):
    rng = np.random.default_rng(100 + n)
    res = randomised_mse("owen", grids[name], n)
    assert res.exact
    pts = owen_scrambled_points(rng, REPS, sobol_digits(n), n.bit_length() - 1)
    _agree(res.mse[0], pts, name)


@pytest.mark.parametrize("scrambler", ["fastowen", "owen"])
@pytest.mark.parametrize("name", sorted(INTEGRANDS))
def test_owen_prediction_holds_for_pbrts_hashed_scramblers(grids, scrambler, name):
    """pbrt-v4's ``FastOwenScrambler`` (its default; a hash, not a nested uniform scramble)
    and ``OwenScrambler``, ported from its source, with random 32-bit seeds per pixel and
    coordinate (``PaddedSobolSampler``): the nested-uniform prediction holds for both."""
    rng = np.random.default_rng(500)
    for n in (16, 64):
        pts = pbrt_scrambled_points(rng, REPS, sobol_digits(n), scrambler)
        _agree(randomised_mse("owen", grids[name], n).mse[0], pts, name)


@pytest.mark.parametrize("name, n", CASES)
def test_digital_shift_against_random_xor_shifts(grids, name, n):
    """Exact below the grid; above it the dual net's share of the finest shell (on the smooth
    integrand at N = 256 = M/4 the plain 1/N share would miss 8 %)."""
    rng = np.random.default_rng(200 + n)
    res = randomised_mse("digital_shift", grids[name], n)
    _agree(res.mse[0], xor_shifted_points(rng, REPS, sobol_digits(n)), name)


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
def test_cp_shift_against_random_torus_shifts(grids, name):
    """The Fourier adapter: exact on the box, envfit's strip tail and 1/N outside it — checked
    in its documented range N ≤ M/8 (M = 512)."""
    rng = np.random.default_rng(300)
    for n in (4, 16, 64):
        base = NETS["sobol"].points(n.bit_length() - 1)
        pts = (base[None] + rng.random((REPS, 1, 2))) % 1.0
        res = randomised_mse("cp_shift", grids[name], n)
        assert "N > M/8" not in res.note
        _agree(res.mse[0], pts, name)
    assert "N > M/8" in randomised_mse("cp_shift", grids[name], 128).note


@pytest.fixture(scope="module")
def edge_plus_peak():
    one, two = INTEGRANDS["edge"], INTEGRANDS["peak"]
    return DyadicGrid.from_callable(lambda u: one.h(u) + two.h(u), 9, nodes=3)


@pytest.mark.parametrize("n", [16, 64, 256])
def test_mis_cross_term_of_one_shifted_net_in_two_orders(grids, edge_plus_peak, n):
    """Mitsuba's ldsampler gives the emitter and the BSDF stream the same XOR-shifted net in
    two random orders: C12 = Σ_{D*\\0} ĥ1 ĥ2, checked against E[(F1 − I1)(F2 − I2)] by brute
    force; independent streams have C12 = 0 (checked too)."""
    rng = np.random.default_rng(400 + n)
    one, two = INTEGRANDS["edge"], INTEGRANDS["peak"]
    pred = mis_mse("digital_shift", grids["edge"], grids["peak"], n, shared=True,
                   total=edge_plus_peak)
    pts = xor_shifted_points(rng, REPS, sobol_digits(n))
    order = rng.random((REPS, n)).argsort(axis=1)[:, :, None]
    pts2 = np.take_along_axis(pts, order, axis=1)
    e1 = one.h(pts).mean(axis=1) - one.integral
    e2 = two.h(pts2).mean(axis=1) - two.integral
    cross, se = float(np.mean(e1 * e2)), float(np.std(e1 * e2, ddof=1) / math.sqrt(REPS))
    assert abs(pred.cross[0] - cross) <= Z * se + 0.01 * abs(pred.cross[0])
    tot = (e1 + e2) ** 2
    assert abs(pred.mse[0] - tot.mean()) <= Z * tot.std(ddof=1) / math.sqrt(REPS) + 0.01 * pred.mse[0]
    assert abs(cross) > 4 * se                     # the shared shift really correlates them
    indep = mis_mse("digital_shift", grids["edge"], grids["peak"], n)
    assert indep.cross[0] == 0.0
    e2i = two.h(xor_shifted_points(rng, REPS, sobol_digits(n))).mean(axis=1) - two.integral
    assert abs(np.mean(e1 * e2i)) <= Z * np.std(e1 * e2i, ddof=1) / math.sqrt(REPS)

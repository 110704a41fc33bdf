"""Mitsuba 3's ``orthogonal`` sampler (Bose orthogonal array, strength 2) against the
prediction of ``randomisation._orthogonal``:

* its strata are the Bose construction's forms, permuted (Mitsuba's own points with
  ``jitter=False``: the pairs of samples agree on the same axes as the forms' pairs do), for a
  2-D draw starting at an even dimension (2–3) and at an odd one (5–6);
* in a render, ``direct`` draws the BSDF's 2-D sample before its 1-D one (the C++ arguments
  of ``bsdf->sample(ctx, si, next_1d(), next_2d())`` are evaluated right to left in the PyPI
  build): recorded by a Python BSDF, the BSDF's points form the even (CMJ) pattern; ``path``
  draws the 1-D one first (two statements), so after the emitter's 2–3 its BSDF's points
  form the odd pattern of dimensions 5–6;
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

SEEDS, Z = 3000, 4.0
DIMS = (2, 5)                      # an even and an odd first dimension of a 2-D draw


def _mitsuba():
    """Mitsuba 3 in its ``scalar_rgb`` variant; the calling test is skipped where it is not
    installed (the formula's checks against cmj, brute force and bad counts need numpy only)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


@pytest.fixture(scope="module")
def grids():
    return {name: DyadicGrid.from_callable(f.h, 9, nodes=3) for name, f in INTEGRANDS.items()}


@functools.lru_cache(maxsize=None)
def orthogonal_points(spp: int, seeds: int, jitter: bool = True) -> np.ndarray:
    """(seeds, N, 2, 2): per pixel and sample the 2-D draws at dimensions 2–3 and 5–6 (a
    2-D draw, a 1-D draw at 4, a 2-D draw)."""
    s = _mitsuba().load_dict({"type": "orthogonal", "sample_count": spp, "jitter": jitter})
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


def _recorded_bsdf_points(emitter_samples: int, integrator: str = "direct") -> np.ndarray:
    """The 2-D samples Mitsuba's ``direct`` integrator (or ``path`` at its defaults) hands a
    BSDF (a Python plugin that records them and returns no sample), one pixel of a sphere
    that fills it, ``orthogonal`` at 25 spp without jitter."""
    mi = _mitsuba()
    seen = []

    class Recorder(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.m_flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def sample(self, ctx, si, sample1, sample2, active=True):
            seen.append((float(sample2[0]), float(sample2[1])))
            return mi.BSDFSample3f(), mi.Color3f(0.0)

        def eval(self, ctx, si, wo, active=True):
            return mi.Color3f(0.0)

        def pdf(self, ctx, si, wo, active=True):
            return 0.0

        def eval_pdf(self, ctx, si, wo, active=True):
            return mi.Color3f(0.0), 0.0

        def to_string(self):
            return "Recorder"

    mi.register_bsdf("envfit_recorder", lambda props: Recorder(props))
    look = mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
    scene = mi.load_dict({
        "type": "scene",
        "integrator": ({"type": "path"} if integrator == "path" else
                       {"type": "direct", "emitter_samples": emitter_samples,
                        "bsdf_samples": 1}),
        "sensor": {"type": "orthographic", "to_world": look,
                   "film": {"type": "hdrfilm", "width": 1, "height": 1,
                            "rfilter": {"type": "box"}},
                   "sampler": {"type": "orthogonal", "sample_count": 25, "jitter": False}},
        "sphere": {"type": "sphere", "radius": 3.0, "bsdf": {"type": "envfit_recorder"}},
        "emitter": {"type": "constant"}})
    mi.render(scene, spp=25)
    return np.array(seen)


@pytest.mark.parametrize("emitter_samples", [0, 1])
def test_direct_draws_the_bsdfs_2d_sample_first(emitter_samples):
    """brdf (dimensions 2–3) and mis (4–5 after the emitter's 2–3): the BSDF's points have the
    even-start pattern, not the odd one a 1-D draw first would give (3–4, 5–6) — as the
    preset's dimensions say."""
    from envfit.renderers import get_renderer
    pts = _recorded_bsdf_points(emitter_samples)
    assert pts.shape == (25, 2)
    mine = _strata(pts, 5)
    dim = 2 + 2 * emitter_samples
    if not emitter_samples:
        assert get_renderer("mitsuba3").strategy("brdf").dimensions == (2, dim)
    np.testing.assert_array_equal(_pattern_counts(mine), _pattern_counts(bose_indices(5, dim)))
    assert not np.array_equal(_pattern_counts(mine), _pattern_counts(bose_indices(5, dim + 1)))


def test_path_draws_the_bsdfs_1d_sample_first():
    """``path`` (the record's ``mis``): its first bounce draws the emitter's 2–3, then the
    BSDF's ``next_1d`` (4) and ``next_2d`` (5–6): the BSDF's points have the odd-start pattern
    of dimension 5, not direct's even one at 4 — as the record's ``dimensions`` (and the
    ``calls`` 1 and 3 that ``ldsampler`` counts, from the same order) say."""
    from envfit.renderers import get_renderer
    s = get_renderer("mitsuba3").strategy("mis")
    assert s.integrator == "path" and s.dimensions == (2, 5) and s.calls == (1, 3)
    mine = _strata(_recorded_bsdf_points(1, "path"), 5)
    np.testing.assert_array_equal(_pattern_counts(mine), _pattern_counts(bose_indices(5, 5)))
    assert not np.array_equal(_pattern_counts(mine), _pattern_counts(bose_indices(5, 4)))

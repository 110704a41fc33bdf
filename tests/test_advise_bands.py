"""The view-angle bands of ``envfit advise --renderer R --brdf ggx`` (issue 38): each band's
interval is a bootstrap over the frames behind it (withheld below BAND_MIN_FRAMES frames), and
the whole sphere is the frame-weighted combination of the bands.

Reference values come from second paths: the interval's coverage is simulated on toy
per-frame distributions whose mean is known; the per-frame MSE are recomputed by one
single-frame model per frame; the bands' weights from the pool's view angles.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from envfit.defaults import BAND_MIN_FRAMES
from envfit.maps import EnvMap, save_envmap
from envfit.predict.renderer import MicrofacetModel, RendererModelOptions, band_frames
from envfit.predict.renderer._bands import STRATA, band_key, bootstrap_interval, in_stratum
from envfit.renderers import get_renderer

_DRAWS = {"normal": lambda rng, k: rng.normal(1.0, 0.3, k),
          "gamma2": lambda rng, k: rng.gamma(2.0, 0.5, k)}        # both of mean 1


@pytest.mark.parametrize("dist", sorted(_DRAWS))
@pytest.mark.parametrize("k", [BAND_MIN_FRAMES, 48])
def test_interval_covers_the_true_rmse_about_95_percent(dist, k):
    """K i.i.d. per-frame MSE of mean 1 (equal weights): the interval of sqrt(mean) holds the
    true RMSE 1 in 0.91–0.985 of 400 seeds (binomial s.e. ≈ 0.011 at 0.95)."""
    hits = 0
    for seed in range(400):
        m = _DRAWS[dist](np.random.default_rng(seed), k)
        lo, hi, _ = bootstrap_interval([(np.ones(k), m)], seed=seed, resamples=1000)
        hits += lo <= 1.0 <= hi
    assert 0.91 <= hits / 400 <= 0.985, hits


def test_stratified_interval_covers_the_weighted_combination():
    """Two strata of BAND_MIN_FRAMES frames, weights 0.3 and 0.7 spread unevenly over the
    frames (importance weights): the interval of sqrt(0.3 mu_1 + 0.7 mu_2) covers it in
    0.91–0.985 of 400 seeds."""
    truth = np.sqrt(0.3 * 1.0 + 0.7 * 4.0)
    hits = 0
    for seed in range(400):
        rng = np.random.default_rng(seed)
        k = BAND_MIN_FRAMES
        w1, w2 = rng.uniform(0.5, 1.5, k), rng.uniform(0.5, 1.5, k)
        m1, m2 = rng.gamma(2.0, 0.5, k), rng.gamma(2.0, 2.0, k)    # the ratio estimator's
        w1, w2 = 0.3 * w1 / w1.sum(), 0.7 * w2 / w2.sum()           # weights are not the
        lo, hi, _ = bootstrap_interval([(w1, m1), (w2, m2)], seed=seed, resamples=1000)
        hits += lo <= truth <= hi                                   # draws' density: ~
    assert 0.90 <= hits / 400 <= 0.985, hits


def test_too_few_frames_have_no_interval():
    """Below BAND_MIN_FRAMES frames (or frames of weight 0 making it so) there is no
    interval, for a band and for the whole sphere with one such stratum; at it there is."""
    m = np.linspace(1.0, 2.0, BAND_MIN_FRAMES)
    assert bootstrap_interval([(np.ones(2), m[:2])]) is None
    assert bootstrap_interval([(np.ones(BAND_MIN_FRAMES - 1), m[1:])]) is None
    w = np.ones(BAND_MIN_FRAMES)
    w[0] = 0.0
    assert bootstrap_interval([(w, m)]) is None
    assert bootstrap_interval([(np.ones(BAND_MIN_FRAMES), m)]) is not None
    assert bootstrap_interval([(np.ones(BAND_MIN_FRAMES), m), (np.ones(3), m[:3])]) is None


@pytest.fixture(scope="module")
def sun_map():
    data = np.full((8, 16, 3), 0.5)
    data[2, 5] = 60.0                                   # a sun that a sharp lobe meets rarely
    return EnvMap(data, up="y", name="sun8")


def test_whole_sphere_is_the_weighted_combination_of_the_bands(sun_map):
    """Frames importance-sampled from a pool (select): each band's MSE is the weighted mean of
    its frames' MSE, recomputed by a model of that frame alone; each band's weight is the
    pool's share in it (and near the orthographic density's sin^2 hi - sin^2 lo); the whole
    sphere's MSE is the bands' MSE weighted so (what was wrong: the frames' weights put a
    band's share far from the pool's, e.g. 0.016 for 0-30 instead of 0.25)."""
    opts = RendererModelOptions(max_level=3, pilot_level=2)
    pool = band_frames(1024, (0, 90), seed=7)
    c = get_renderer("mitsuba3").bsdf("ggx", 0.1)
    m = MicrofacetModel(sun_map, get_renderer("mitsuba3"), c, pool, options=opts, select=24)
    whole = m.predict("mis", "independent", 4).rmse
    spread = m.predict_band_errors("mis", "independent", 4)
    per = []
    for normal, view in m.normals:                           # each frame's MSE on its own
        one = MicrofacetModel(sun_map, get_renderer("mitsuba3"), c, ([normal], [view]), options=opts)
        per.append(one.predict("mis", "independent", 4).rmse ** 2)
    per = np.array(per)
    pool_theta = np.degrees(np.arccos(np.clip(np.sum(pool[0] * pool[1], axis=1), -1, 1)))
    total = 0.0
    for lo, hi in STRATA:
        e = spread[band_key(lo, hi)]
        inside = in_stratum(m.theta, lo, hi)
        w = m.weights[inside]
        assert e["frames"] == inside.sum()
        assert e["weight"] == pytest.approx(np.mean(in_stratum(pool_theta, lo, hi)), abs=1e-12)
        assert e["weight"] == pytest.approx(np.sin(np.radians(min(hi, 90))) ** 2
                                            - np.sin(np.radians(lo)) ** 2, abs=0.01)
        assert e["rmse"] ** 2 == pytest.approx(w @ per[inside] / w.sum(), rel=1e-9)
        total += e["weight"] * e["rmse"] ** 2
    assert whole ** 2 == pytest.approx(total, rel=1e-9)
    assert spread["all"]["rmse"] == pytest.approx(whole, rel=1e-12)
    assert whole ** 2 == pytest.approx(m.weights @ per, rel=1e-9)


def _advise(tmp_path, capsys, normals: int, extra=()):
    from envfit.cli import main
    data = np.full((8, 16, 3), 0.5, np.float32)
    data[2, 5] = 60.0
    path = tmp_path / "sun8.exr"
    save_envmap(path, EnvMap(data, up="y", name="sun8"))
    out = tmp_path / f"a{normals}.json"
    rc = main(["advise", str(path), "--renderer", "mitsuba3", "--brdf", "ggx", "--roughness",
               "0.3", "--sampler", "independent", "--strategies", "mis", "--renderer-level",
               "3", "--renderer-normals", str(normals), "--target-relative", "0.05",
               "--cache-dir", str(tmp_path / "cache"), "--json", str(out), *extra])
    lines = capsys.readouterr().out.splitlines()
    assert rc == 0
    return lines, json.loads(out.read_text())["renderer"]


def test_band_lines_with_enough_frames_print_the_interval(tmp_path, capsys):
    """48 frames asked: every band has >= BAND_MIN_FRAMES frames, so each line prints its
    share, frames, the interval of the JSON and its RMSE; its 'meets the target at' sentence
    is true of the band's predictions; the whole sphere is the printed bands' combination."""
    lines, r = _advise(tmp_path, capsys, 48)
    n = r["recommendation"]["spp"]
    target = r["recommendation"]["target_rmse"]
    cells = {p["spp"]: p for p in r["predictions"]}
    spread = cells[n]["band_errors"]
    whole = next(ln for ln in lines if ln.startswith("  whole sphere ("))
    lo, hi = spread["all"]["interval"]
    assert f"95 % {lo:.4g}…{hi:.4g}): predicted RMSE" in whole
    total = 0.0
    for band, e in spread.items():
        if band == "all":
            continue
        ln = next(x for x in lines if x.startswith(f"  {band} deg ("))
        assert e["frames"] >= BAND_MIN_FRAMES and e["interval"] is not None
        assert (f"({100 * e['weight']:.3g} % of the sphere, {e['frames']} frames, 95 % "
                f"{e['interval'][0]:.4g}…{e['interval'][1]:.4g}): predicted RMSE") in ln
        assert "withheld" not in ln
        if "meets the target at " in ln:
            k = int(ln.split("meets the target at ")[1].split()[0])
            assert cells[k]["band_errors"][band]["rmse"] <= target
            if ", not at " in ln:
                j = int(ln.split(", not at ")[1].split()[0])
                assert cells[j]["band_errors"][band]["rmse"] > target
        else:
            assert all(c["band_errors"][band]["rmse"] > target for c in cells.values())
        total += e["weight"] * e["rmse"] ** 2
    assert np.sqrt(total) == pytest.approx(cells[n]["predicted_rmse"], rel=1e-9)


def test_band_lines_with_too_few_frames_are_withheld(tmp_path, capsys):
    """6 frames asked: 1-2 frames per band, so no band value or crossing is printed, and the
    whole sphere says which bands have too few frames for its interval."""
    lines, r = _advise(tmp_path, capsys, 6)
    n = r["recommendation"]["spp"]
    spread = next(p for p in r["predictions"] if p["spp"] == n)["band_errors"]
    whole = next(ln for ln in lines if ln.startswith("  whole sphere ("))
    assert spread["all"]["interval"] is None
    assert f"no interval: fewer than {BAND_MIN_FRAMES} frames in " in whole
    assert " 95 % " not in whole
    for band, e in spread.items():
        if band == "all":
            continue
        ln = next(x for x in lines if x.startswith(f"  {band} deg ("))
        assert e["frames"] < BAND_MIN_FRAMES and e["interval"] is None
        assert f"{band} deg ({e['frames']})" in whole
        assert "withheld, too few frames for an interval" in ln
        assert "predicted RMSE" not in ln and "meets the target" not in ln

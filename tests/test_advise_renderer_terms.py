"""Tests of ``envfit advise MAP --renderer NAME`` (envfit.advisor._renderer_advice, _renderer_search,
_renderer_options; envfit.cli._advise_renderer): the answer in the renderer's terms.

Reference values come from a second path: a fresh
:class:`envfit.predict.renderer._diffuse_model.DiffuseModel` built here with the same options
predicts every runnable spp below the answer (all must miss the target) and the answer (it
must meet it), and the ``--spp`` table and the JSON predictions must equal its numbers; the
snippet is loaded by Mitsuba itself. Maps: 16-row synthesized maps (a sun on a GP, a smooth
GP), the model at 6 normals and grid level 5–6, so the whole file runs in seconds.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from envfit.data_gen import gaussian_process_map, sun_gp_map
from envfit.maps import EnvMap, save_envmap
from envfit.predict.renderer._diffuse_model import DiffuseModel, RendererModelOptions
from envfit.renderers import get_renderer

NORMALS = 6
MODEL = ["--renderer-normals", str(NORMALS)]


def _options(level: int, microfacet: bool = False) -> RendererModelOptions:
    """The model options the CLI builds for ``--renderer-level level`` and NORMALS (a
    conductor's frames from a pool of MICROFACET_POOL)."""
    from envfit.advisor._renderer_options import MICROFACET_POOL
    pool = MICROFACET_POOL if microfacet else RendererModelOptions().pool
    return RendererModelOptions(normals=NORMALS, pool=pool, max_level=level)


@pytest.fixture(scope="module")
def sun_file(tmp_path_factory):
    env = EnvMap(sun_gp_map(16, seed=2, sun_radiance=30.0, sun_radius=0.25)[0], name="sun16")
    path = tmp_path_factory.mktemp("maps") / "sun16.exr"
    save_envmap(path, env)
    return path


@pytest.fixture(scope="module")
def gp_file(tmp_path_factory):
    env = EnvMap(gaussian_process_map(1.8, 16, seed=3, channels=3) + 2.0, name="gp16")
    path = tmp_path_factory.mktemp("maps") / "gp16.exr"
    save_envmap(path, env)
    return path


def _load(path):
    from envfit.maps import load_envmap
    return load_envmap(path)


def _run(capsys, args, tmp_path):
    """``envfit advise`` in-process: (exit code, stdout lines, stderr lines, JSON or None)."""
    from envfit.cli import main
    out = tmp_path / "a.json"
    rc = main(["advise", *map(str, args), "--cache-dir", str(tmp_path / "cache"),
               "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err.strip().splitlines(), d


def _answer(lines: list[str]) -> str:
    """The answer's first line (the map's and the run's notes come before it)."""
    return next(ln for ln in lines if not ln.startswith("note: "))


def _body(lines: list[str]) -> list[str]:
    """The lines printed but the notes."""
    return [ln for ln in lines if not ln.startswith("note: ")]


# ----------------------------------------------------------------------------- the answer

def test_independent_answer_is_the_smallest_spp_meeting_the_target(sun_file, tmp_path, capsys):
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--sampler",
                                    "independent", "--target-relative", "0.05",
                                    "--renderer-level", "5", *MODEL], tmp_path)
    assert rc == 0
    rec = d["renderer"]["recommendation"]
    n, target = rec["spp"], rec["target_rmse"]
    assert _answer(lines).startswith(f"Mitsuba 3, sampler independent, integrator path: "
                                     f"spp = {n} for an RMSE of at most ")
    assert "(5 % of the map's mean radiance" in _answer(lines)
    assert rec["strategy"] == "mis" and rec["reached"] and n > 4
    # independently: every spp below the answer misses, the answer meets
    m = DiffuseModel(_load(sun_file), get_renderer("mitsuba3"), options=_options(5))
    preds = m.predict_many([("mis", "independent", k) for k in range(1, n + 1)])
    assert preds[-1].rmse <= target
    assert all(p.rmse > target for p in preds[:-1])
    assert preds[n // 2 - 1].rmse > target                     # half of it misses
    assert rec["predicted_rmse"] == pytest.approx(preds[-1].rmse, rel=1e-12)
    # one line per other strategy, in the renderer's order
    assert lines[1].startswith("  emitter sampling only, direct (emitter_samples=1, "
                               "bsdf_samples=0): ")
    assert lines[2].startswith("  BSDF sampling only, direct (emitter_samples=0, "
                               "bsdf_samples=1): ")


def test_ldsampler_answer_runs_a_power_of_four_and_the_one_below_misses(gp_file, tmp_path,
                                                                        capsys):
    m = DiffuseModel(_load(gp_file), get_renderer("mitsuba3"), options=_options(6))
    p4, p16 = (m.predict("mis", "ldsampler", k).rmse for k in (4, 16))
    assert p16 < p4
    target = float(np.sqrt(p4 * p16))                         # between the two
    rc, lines, _, d = _run(capsys, [gp_file, "--renderer", "mitsuba3", "--sampler",
                                    "ldsampler", "--target-rmse", repr(target),
                                    "--renderer-level", "6", *MODEL], tmp_path)
    assert rc == 0 and d["renderer"]["recommendation"]["spp"] == 16
    assert ": spp = 16 for an RMSE of at most" in _answer(lines)
    assert " at 4 spp (misses by " in _answer(lines)
    # a target below every runnable spp's prediction: said, not claimed (level 6 searches
    # ldsampler to 4^7/256 = 64 spp, its power above the grid sampled there)
    p64 = m.predict("mis", "ldsampler", 64).rmse
    rc, lines, _, d = _run(capsys, [gp_file, "--renderer", "mitsuba3", "--sampler",
                                    "ldsampler", "--target-rmse", repr(p64 / 2),
                                    "--renderer-level", "6", *MODEL], tmp_path)
    rec = d["renderer"]["recommendation"]
    assert rc == 0 and rec["spp"] is None and not rec["reached"]
    assert "no spp up to 64 meets an RMSE of at most" in _answer(lines)
    assert "256 spp needs --renderer-level 7" in _answer(lines)
    assert rec["predicted_rmse"] == pytest.approx(p64, rel=1e-12)
    assert rec["predicted_rmse"] > rec["target_rmse"]


def test_spp_table_json_and_mis_compensation_equal_the_model(sun_file, tmp_path, capsys):
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--sampler",
                                    "ldsampler", "--spp", "4,8,16", "--mis-compensation",
                                    "--renderer-level", "5", *MODEL], tmp_path)
    assert rc == 0
    r = d["renderer"]
    assert r["name"] == "mitsuba3" and r["sampler"] == "ldsampler" and r["mis_compensation"]
    m = DiffuseModel(_load(sun_file), get_renderer("mitsuba3"), {"mis_compensation": True},
                    _options(5))
    for p in r["predictions"]:
        assert set(p) == {"strategy", "sampler", "spp", "predicted_rmse"}
        assert p["strategy"] in ("map", "brdf", "mis") and p["sampler"] == "ldsampler"
        assert isinstance(p["spp"], int) and isinstance(p["predicted_rmse"], float)
        assert p["predicted_rmse"] == pytest.approx(
            m.predict(p["strategy"], "ldsampler", p["spp"]).rmse, rel=1e-12)
    assert {(p["strategy"], p["spp"]) for p in r["predictions"]} >= {
        (s, n) for s in ("mis", "map", "brdf") for n in (4, 16)}
    rec = r["recommendation"]
    assert {"strategy", "sampler", "spp", "integrator", "settings", "predicted_rmse",
            "target_rmse"} <= set(rec)
    assert rec["integrator"] == "path" and rec["settings"] == {}        # at its defaults
    head = lines.index(next(ln for ln in lines if ln.startswith("predicted RMSE at the")))
    rows = lines[head + 2:head + 5]
    assert [row.split()[0] for row in rows] == ["4", "8->16", "16"]
    for row in rows:
        n = int(row.split()[0].split("->")[-1])
        want = [m.predict(s, "ldsampler", n).rmse for s in r["strategies"]]
        assert [float(x) for x in row.split()[1:]] == pytest.approx(want, rel=1e-3)


def test_snippet_loads_in_mitsuba(gp_file, tmp_path, capsys):
    mi = pytest.importorskip("mitsuba")
    rc, lines, _, d = _run(capsys, [gp_file, "--renderer", "mitsuba3", "--sampler",
                                    "independent", "--target-relative", "0.1", "--snippet",
                                    "--renderer-level", "4", "--out", tmp_path / "out",
                                    *MODEL], tmp_path)
    assert rc == 0
    start = next(i for i, ln in enumerate(lines) if ln.startswith("scene (Mitsuba 3"))
    stop = next(i for i, ln in enumerate(lines) if ln.startswith("renderer model:"))
    code = "\n".join(lines[start + 1:stop])
    assert code == d["renderer"]["snippet"].rstrip("\n")
    spp = d["renderer"]["recommendation"]["spp"]
    # gp16 has negative values, clamped: the snippet reads the clamped map, written to --out
    written = str(tmp_path / "out" / "gp16-as-modelled.exr")
    assert f'"sample_count": {spp}' in code and repr(written) in code
    assert d["renderer"]["snippet_map"] == written
    scope: dict = {}
    exec(code, scope)                                          # mi.load_dict
    scene = scope["scene"]
    assert isinstance(scene, mi.Scene)
    assert scene.sensors()[0].sampler().sample_count() == spp
    assert type(scope["mi"]).__name__ == "module"


def test_cached_run_prints_the_same_answer_without_the_model(sun_file, tmp_path, capsys):
    args = [sun_file, "--renderer", "mitsuba3", "--sampler", "independent",
            "--target-relative", "0.05", "--renderer-level", "4", *MODEL]
    rc1, first, _, d1 = _run(capsys, args, tmp_path)
    rc2, second, _, d2 = _run(capsys, args, tmp_path)
    assert rc1 == rc2 == 0
    assert _body(first)[:3] == _body(second)[:3]
    assert d1["renderer"]["predictions"] == d2["renderer"]["predictions"]
    assert d2["renderer"]["model"]["passes"] == 0 and d1["renderer"]["model"]["passes"] >= 1
    assert "0 pass(es), 0 cell(s) computed" in "\n".join(second)
    # an edited entry is not used: recomputed with a note
    entry = next((tmp_path / "cache" / "advise" / "renderer_cells").glob("*.json"))
    doc = json.loads(entry.read_text())
    key = next(iter(doc["value"]["cells"]))
    doc["value"]["cells"][key]["rmse"] = 123.0
    entry.write_text(json.dumps(doc))
    rc3, third, _, d3 = _run(capsys, args, tmp_path)
    assert rc3 == 0 and _body(third)[:3] == _body(first)[:3] and d3["renderer"]["model"]["passes"] >= 1
    assert any(ln.startswith("note: cache: recomputed") for ln in third)


# ----------------------------------------------------------------------------- errors

@pytest.mark.parametrize("argv, words", [
    (["--renderer", "blender"], "--renderer must be one of"),
    (["--renderer", "mitsuba3", "--sampler", "zsobol"], "--sampler for mitsuba3"),
    (["--renderer", "cycles", "--strategies", "map"], "Cycles cannot render strategy 'map'"),
    (["--renderer", "pbrt4", "--mis-compensation"], "setting of Mitsuba 3's envmap"),
    (["--renderer", "pbrt4", "--sampler", "halton"], "no noise model"),
    (["--renderer", "mitsuba3", "--strategies", "split"], "unknown strategy"),
    (["--renderer", "mitsuba3", "--brdf", "glossy"], "no renderer's BSDF"),
    (["--renderer", "mitsuba3", "--brdf", "multiggx", "--roughness", "0.3"],
     "Multiscatter GGX"),
    (["--renderer", "mitsuba3", "--brdf", "ggx"], "needs --roughness"),
    (["--renderer", "mitsuba3", "--brdf", "ggx", "--roughness", "0.01"],
     "--roughness 0.01 is outside Mitsuba 3's alpha: 0.05 to 1"),
    (["--renderer", "pbrt4", "--brdf", "beckmann", "--roughness", "0.1"], "only the GGX"),
    (["--renderer", "envfit", "--brdf", "ggx", "--roughness", "0.1"], "no microfacet"),
    (["--renderer", "mitsuba3", "--roughness", "0.1"], "parameter of --brdf ggx"),
    (["--brdf", "ggx", "--roughness", "0.1"], "--roughness needs --renderer"),
    (["--brdf", "beckmann"], "--brdf beckmann needs --renderer"),
    (["--renderer", "pbrt4", "--brdf", "ggx", "--roughness", "0.5", "--snippet"],
     "written for Mitsuba 3 or Cycles only"),
    (["--renderer", "mitsuba3", "--scale", "log"], "--scale must be linear"),
    (["--renderer", "mitsuba3", "--no-renderer"], "--no-renderer is an option"),
    (["--renderer", "mitsuba3", "--sampler", "ldsampler", "--spp", "5000"], "beyond the 4096"),
    (["--sampler", "ldsampler"], "--sampler needs --renderer"),
    (["--renderer", "mitsuba3", "--sphere-pixels", "3"],
     "--sphere-pixels: 3 is outside 4 <= D <= 65536"),
    (["--renderer", "mitsuba3", "--brdf", "ggx", "--roughness", "0.1", "--sphere-pixels", "2"],
     "--sphere-pixels: 2 is outside 4 <= D"),
    (["--sphere-pixels", "64"], "--sphere-pixels needs --renderer"),
    (["--spp", "16"], "--spp needs --renderer"),
    (["--snippet"], "--snippet needs --renderer"),
])
def test_bad_combinations_are_one_line_before_the_map_is_read(argv, words, tmp_path, capsys):
    from envfit.cli import main
    rc = main(["advise", str(tmp_path / "absent.exr"), "--no-cache", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("envfit advise: error:")
    assert words in err[0] and "absent.exr" not in err[0]


def test_without_renderer_the_output_is_todays(sun_file, tmp_path, capsys):
    """No --renderer: today's pipeline (notes, then the map header; no renderer
    answer, the JSON's renderer section is absent)."""
    rc, lines, _, d = _run(capsys, [sun_file, "--target-rmse", "0.5", "--fit-n", "100",
                                    "--pointsets", "sf", "--weights", "equal", "--bases",
                                    "sh", "--no-renderer"], tmp_path)
    body = [ln for ln in lines if not ln.startswith("note: ")]
    assert rc == 0 and body[0].startswith("map sun16.exr: 32x16")
    assert not any("sampler" in ln or "spp" in ln for ln in lines)
    assert d["renderer"] is None and "rows" in d


# ----------------------------------------------------------------------------- microfacet

def test_microfacet_answer_bands_and_json_equal_the_model(sun_file, tmp_path, capsys):
    """--brdf ggx --roughness 0.3: the answer's spp meets the target and the runnable spp
    below misses, per a fresh MicrofacetModel over the same frames; the JSON's predictions
    carry the per-band values of that model; every band sentence is true of its numbers."""
    from envfit.defaults import MICROFACET_FRAMES_SEED
    from envfit.predict.renderer import MicrofacetModel, band_frames
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf", "ggx",
                                    "--roughness", "0.3", "--sampler", "independent",
                                    "--target-relative", "0.05", "--renderer-level", "5",
                                    *MODEL], tmp_path)
    assert rc == 0
    r = d["renderer"]
    rec, target = r["recommendation"], r["recommendation"]["target_rmse"]
    assert r["bsdf"] == {"type": "ggx", "roughness": 0.3, "alpha": 0.3, "fresnel": 1.0,
                         "sphere_pixels": None}
    opts = _options(5, microfacet=True)
    m = MicrofacetModel(_load(sun_file), get_renderer("mitsuba3"),
                        get_renderer("mitsuba3").bsdf("ggx", 0.3),
                        band_frames(opts.pool, (0, 90), seed=MICROFACET_FRAMES_SEED),
                        options=opts, select=NORMALS)
    n = rec["spp"]
    assert m.predict("mis", "independent", n).rmse <= target < \
        m.predict("mis", "independent", n - 1).rmse
    for p in r["predictions"]:
        assert p["predicted_rmse"] == pytest.approx(
            m.predict(p["strategy"], "independent", p["spp"]).rmse, rel=1e-12)
        assert p["bands"] == pytest.approx(m.predict_bands(p["strategy"], "independent",
                                                           p["spp"]), rel=1e-12)
    assert any("GGX conductor (alpha 0.3, Fresnel 1)" in ln for ln in lines)
    bands = [ln for ln in lines if ln.startswith("  ") and ln.split()[0][0].isdigit()
             and " deg (" in ln]
    assert bands, lines
    errors = m.predict_band_errors("mis", "independent", n)
    for p in r["predictions"]:
        assert p["band_errors"] == m.predict_band_errors(p["strategy"], "independent", p["spp"])
    whole = next(ln for ln in lines if ln.startswith("  whole sphere ("))
    assert errors["all"]["frames"] == len(m.weights)
    assert f"({len(m.weights)} frames; no interval: fewer than 8 frames in " in whole
    for ln in bands:                       # NORMALS frames: too few in every band
        band = ln.split()[0]
        lo, hi = (float(x) for x in band.split("-"))
        k = int(np.sum((m.theta >= lo) & (m.theta < hi)))            # the frames in the band
        assert errors[band]["frames"] == k and errors[band]["interval"] is None
        assert f"{k} frame{'s' if k != 1 else ''}): withheld, too few frames" in ln
        assert "predicted RMSE" not in ln and "meets the target" not in ln


def test_sphere_pixels_adds_the_footprint_of_the_model(sun_file, tmp_path, capsys):
    """--sphere-pixels 8: the predictions are those of a MicrofacetModel whose frames carry
    their pixels' footprints (pixel_footprints of the same frames, side FOOTPRINT_SIDE), not
    the point frames' (the footprint adds the film's interaction but smooths the mean
    integrand, so it moves a cell either way: ldsampler's map part at 4 spp went down 1.3 %
    at level 6); the JSON and the model line say so. Level 5, the least that resolves 16 spp
    (a quarter of level 6's tables: the two footprint tests 95 -> 53 CPU-s at load 5-6)."""
    from envfit.defaults import FOOTPRINT_SIDE, MICROFACET_FRAMES_SEED
    from envfit.predict.renderer import MicrofacetModel, band_frames, pixel_footprints
    base = [sun_file, "--renderer", "mitsuba3", "--brdf", "ggx", "--roughness", "0.1",
            "--sampler", "ldsampler", "--target-relative", "0.05", "--renderer-level", "5",
            "--spp", "4,16", *MODEL]
    rc, lines, _, d = _run(capsys, [*base, "--sphere-pixels", "8"], tmp_path)
    assert rc == 0
    r = d["renderer"]
    assert r["bsdf"]["sphere_pixels"] == 8
    assert any("8 pixels across (each pixel's footprint included, the box pixel filter; "
               "Mitsuba's hdrfilm defaults to the gaussian filter" in ln for ln in lines)
    opts = _options(5, microfacet=True)
    frames = band_frames(opts.pool, (0, 90), seed=MICROFACET_FRAMES_SEED)
    mitsuba = get_renderer("mitsuba3")
    m = MicrofacetModel(_load(sun_file), mitsuba, mitsuba.bsdf("ggx", 0.1), frames,
                        options=opts, select=NORMALS,
                        footprints=pixel_footprints(*frames, 8, FOOTPRINT_SIDE))
    point = MicrofacetModel(_load(sun_file), mitsuba, mitsuba.bsdf("ggx", 0.1),
                            frames, options=opts, select=NORMALS)
    for p in r["predictions"]:
        got = m.predict(p["strategy"], "ldsampler", p["spp"]).rmse
        assert p["predicted_rmse"] == pytest.approx(got, rel=1e-12)
        assert got != pytest.approx(point.predict(p["strategy"], "ldsampler", p["spp"]).rmse,
                                    rel=1e-6)


def test_diffuse_sphere_pixels_is_the_model_with_footprints(sun_file, tmp_path, capsys):
    """Diffuse --sphere-pixels 8: the predictions are those of a DiffuseModel whose normals
    carry the footprints of a sphere 8 pixels across (sphere_pixels=8, side FOOTPRINT_SIDE),
    above the point normals' at every cell; the JSON and the model line say so (level 5,
    the least that resolves 16 spp)."""
    from dataclasses import replace
    from envfit.defaults import FOOTPRINT_SIDE
    base = [sun_file, "--renderer", "mitsuba3", "--sampler", "ldsampler",
            "--target-relative", "0.05", "--renderer-level", "5", "--spp", "4,16", *MODEL]
    rc, lines, _, d = _run(capsys, [*base, "--sphere-pixels", "8"], tmp_path)
    assert rc == 0
    r = d["renderer"]
    assert r["bsdf"] == {"type": "diffuse", "reflectance": 1.0, "sphere_pixels": 8,
                         "pixel_filter": "box 1 px"}
    assert any("white diffuse sphere 8 pixels across (each pixel's footprint included, the "
               "box pixel filter; Mitsuba's hdrfilm defaults to the gaussian filter" in ln
               and "each pixel seen by the axis view nearest its normal" in ln for ln in lines)
    opts = replace(_options(5), sphere_pixels=8, footprint_side=FOOTPRINT_SIDE)
    m = DiffuseModel(_load(sun_file), get_renderer("mitsuba3"), options=opts)
    point = DiffuseModel(_load(sun_file), get_renderer("mitsuba3"), options=_options(5))
    for p in r["predictions"]:
        got = m.predict(p["strategy"], "ldsampler", p["spp"]).rmse
        assert p["predicted_rmse"] == pytest.approx(got, rel=1e-12)
        assert got != pytest.approx(point.predict(p["strategy"], "ldsampler", p["spp"]).rmse,
                                    rel=1e-6)


def test_microfacet_snippet_loads_in_mitsuba_with_the_rough_conductor(gp_file, tmp_path, capsys):
    """--brdf beckmann --roughness 0.2 --snippet: Mitsuba loads the printed scene and its
    sphere's BSDF is a roughconductor with that alpha (read back from the loaded scene)."""
    rc, lines, _, d = _run(capsys, [gp_file, "--renderer", "mitsuba3", "--brdf", "beckmann",
                                    "--roughness", "0.2", "--sampler", "independent",
                                    "--target-relative", "0.2", "--renderer-level", "4",
                                    "--snippet", "--out", tmp_path / "out", *MODEL], tmp_path)
    assert rc == 0
    mi = pytest.importorskip("mitsuba")
    start = next(i for i, ln in enumerate(lines) if ln.startswith("import mitsuba"))
    end = next(i for i, ln in enumerate(lines) if ln == "})")
    ns = {}
    exec("\n".join(lines[start:end + 1]).replace(repr(str(gp_file)), repr(str(gp_file))), ns)
    bsdf = ns["scene"].shapes()[0].bsdf()
    assert "RoughConductor" in str(bsdf) and "0.2" in str(bsdf)


def test_the_stop_sentence_names_the_next_spp_the_sampler_runs(gp_file, tmp_path, capsys):
    """pbrt-v4's zsobol rounds a request down to a power of two (65 -> 64): when the search
    stops at 64 spp (level 6: 32 on the grid, 4^7/256 = 64 with the power above it sampled),
    the sentence names 128 spp and the level that resolves it (it once named the spp already
    searched)."""
    rc, lines, _, d = _run(capsys, [gp_file, "--renderer", "pbrt4", "--target-rmse", "1e-9",
                                    "--renderer-level", "6", *MODEL], tmp_path)
    assert rc == 0 and not d["renderer"]["recommendation"]["reached"]
    assert "the model resolves zsobol to 64 spp at grid level 6; 128 spp needs " \
           "--renderer-level 7 (4x the time and memory)" in _answer(lines)


def test_roughplastic_answer_is_the_models_and_orthogonal_is_refused(sun_file, tmp_path,
                                                                     capsys):
    """--brdf roughplastic (Mitsuba's roughplastic, a GGX coat): the answer's spp meets the
    target and the spp below misses per a fresh MicrofacetModel of RoughPlastic over the same
    frames; the JSON names the BSDF (no Fresnel-1 claim); the snippet is Mitsuba's
    roughplastic; ``ldsampler`` answers by the lobe-choice model, ``orthogonal`` or another
    renderer is one line."""
    from envfit.defaults import MICROFACET_FRAMES_SEED
    from envfit.predict.renderer import MicrofacetModel, band_frames
    from envfit.shading.microfacet import RoughPlastic
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf",
                                    "roughplastic", "--roughness", "0.2", "--target-relative",
                                    "0.05", "--renderer-level", "5", "--snippet", *MODEL],
                           tmp_path)
    assert rc == 0
    r = d["renderer"]
    assert r["bsdf"]["type"] == "roughplastic" and "fresnel" not in r["bsdf"]
    assert r["bsdf"]["eta"] == pytest.approx(1.49 / 1.000277)
    opts = _options(5)
    m = MicrofacetModel(_load(sun_file), get_renderer("mitsuba3"), RoughPlastic("ggx", 0.2),
                        band_frames(opts.pool, (0, 90), seed=MICROFACET_FRAMES_SEED),
                        options=opts, select=NORMALS)
    rec = r["recommendation"]
    n, target = rec["spp"], rec["target_rmse"]
    assert m.predict("mis", "independent", n).rmse <= target < \
        m.predict("mis", "independent", n - 1).rmse
    assert any('"type": "roughplastic", "distribution": "ggx", "alpha": 0.2' in ln
               for ln in lines)
    assert any("rough plastic (Mitsuba's roughplastic: a GGX coat of alpha 0.2" in ln
               for ln in lines)
    rc, _, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf", "roughplastic",
                                "--roughness", "0.2", "--sampler", "ldsampler",
                                "--target-relative", "0.05", "--renderer-level", "5", *MODEL],
                       tmp_path)
    assert rc == 0
    rec = d["renderer"]["recommendation"]
    assert m.predict("mis", "ldsampler", rec["spp"]).rmse <= rec["target_rmse"]
    for extra in (["--sampler", "orthogonal"], ["--renderer", "cycles"]):
        rc, _, err, _ = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf",
                                      "roughplastic", "--roughness", "0.2", *extra], tmp_path)
        assert rc == 2 and len(err) == 1 and "ldsampler" in err[0]


def test_principled_answer_is_the_models_with_its_defaults_and_parameters(sun_file, tmp_path,
                                                                        capsys):
    """--brdf principled (Mitsuba's principled) without --roughness is the plugin's defaults
    (roughness 0.5: alpha 0.25); --bsdf-param sets metallic: the answer's spp meets the
    target and the spp below misses per a fresh MicrofacetModel of Principled(0.5,
    metallic=1) over the same frames; the JSON and the model line name every parameter; the
    snippet is Mitsuba's principled and loads in Mitsuba; a bad parameter, a BSDF without
    parameters or another renderer is one line before the map is read."""
    from envfit.defaults import MICROFACET_FRAMES_SEED
    from envfit.predict.renderer import MicrofacetModel, band_frames
    from envfit.shading.microfacet import Principled
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf", "principled",
                                    "--bsdf-param", "metallic=1", "--target-relative", "0.05",
                                    "--renderer-level", "5", "--snippet", *MODEL], tmp_path)
    assert rc == 0
    b = d["renderer"]["bsdf"]
    assert (b["type"], b["roughness"], b["alpha"], b["metallic"], b["specular"]) == \
        ("principled", 0.5, 0.25, 1.0, 0.5) and b["eta"] == pytest.approx(1.5, rel=1e-6)
    m = MicrofacetModel(_load(sun_file), get_renderer("mitsuba3"), Principled(0.5, metallic=1),
                        band_frames(_options(5).pool, (0, 90), seed=MICROFACET_FRAMES_SEED),
                        options=_options(5), select=NORMALS)
    rec = d["renderer"]["recommendation"]
    n, target = rec["spp"], rec["target_rmse"]
    assert m.predict("mis", "independent", n).rmse <= target < \
        m.predict("mis", "independent", n - 1).rmse
    assert any("principled BSDF (Mitsuba's principled: roughness 0.5, GGX alpha 0.25, "
               "base_color 0.5, metallic 1," in ln for ln in lines)
    line = next(ln for ln in lines if '"bsdf": {"type": "principled"' in ln)
    text = line.split('"bsdf": ', 1)[1].rstrip("},") + "}"
    assert json.loads(text) == {"type": "principled", "roughness": 0.5, "metallic": 1}
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    assert "Principled" in str(mi.load_dict(json.loads(text)))
    for extra, words in ((["--bsdf-param", "metallic=2"], "metallic must be in [0, 1]"),
                         (["--bsdf-param", "clearcoat=1"], "clearcoat is not a parameter"),
                         (["--bsdf-param", "metallic"], "expected NAME=VALUE"),
                         (["--bsdf-param", "metallic=1", "--bsdf-param", "metallic=0"],
                          "given twice"),
                         (["--roughness", "0.1"], "alpha = R^2: 0.223607 to 1"),
                         (["--renderer", "cycles", "--bsdf-param", "metallic=0.5"],
                          "Principled BSDF with metallic 0.5"),
                         (["--renderer", "cycles", "--sampler", "blue_noise"],
                          "--sampler tabulated_sobol|sobol_burley"),
                         (["--renderer", "pbrt4"], "--renderer mitsuba3|cycles")):
        rc, _, err, _ = _run(capsys, [tmp_path / "missing.exr", "--renderer", "mitsuba3",
                                      "--brdf", "principled", *extra], tmp_path)
        assert rc == 2 and len(err) == 1 and words in err[0], err
    rc, _, err, _ = _run(capsys, [tmp_path / "missing.exr", "--renderer", "mitsuba3", "--brdf",
                                  "ggx", "--roughness", "0.2", "--bsdf-param", "metallic=1"],
                         tmp_path)
    assert rc == 2 and len(err) == 1 and "--brdf principled" in err[0]


def test_cycles_multiscatter_ggx_and_the_note_that_names_it(sun_file, tmp_path, capsys):
    """--renderer cycles --brdf ggx notes that Cycles' nodes default to Multiscatter GGX;
    --brdf multiggx does not, and predicts every cell above the single-scatter one (its
    energy scale 1/E > 1 multiplies each frame's error), equal to the model with a
    multiscatter conductor."""
    from envfit.defaults import MICROFACET_FRAMES_SEED
    from envfit.predict.renderer import MicrofacetModel, band_frames
    common = [sun_file, "--renderer", "cycles", "--roughness", "0.5", "--target-relative",
              "0.05", "--renderer-level", "5", *MODEL]
    runs = {b: _run(capsys, [*common, "--brdf", b], tmp_path / b) for b in ("ggx", "multiggx")}
    note = "the Principled and Glossy BSDF nodes default to Multiscatter GGX"
    assert any(note in ln for ln in runs["ggx"][1] if ln.startswith("note: "))
    assert not any(note in ln for ln in runs["multiggx"][1])
    single = {(p["strategy"], p["spp"]): p["predicted_rmse"]
              for p in runs["ggx"][3]["renderer"]["predictions"]}
    opts = _options(5, microfacet=True)
    m = MicrofacetModel(_load(sun_file), get_renderer("cycles"),
                        get_renderer("cycles").bsdf("multiggx", 0.25),
                        band_frames(opts.pool, (0, 90), seed=MICROFACET_FRAMES_SEED),
                        options=opts, select=NORMALS)
    for p in runs["multiggx"][3]["renderer"]["predictions"]:
        assert p["predicted_rmse"] == pytest.approx(
            m.predict(p["strategy"], "tabulated_sobol", p["spp"]).rmse, rel=1e-12)
        if (p["strategy"], p["spp"]) in single:
            assert p["predicted_rmse"] > single[(p["strategy"], p["spp"])]
    assert any("Multiscatter GGX (Cycles' default) conductor" in ln for ln in runs["multiggx"][1])

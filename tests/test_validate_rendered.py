"""``envfit validate MAP --renderer mitsuba3|cycles`` (envfit.validate._rendered): Mitsuba 3
renders the sphere and the measured RMSE is set beside the preset's prediction; the printed
sentences follow the rows both ways; bad flags and a missing renderer are one line, exit 2,
before the map is read."""
from __future__ import annotations

import json
import sys

import pytest

from envfit.data_gen import sun_gp_map
from envfit.maps import EnvMap, save_envmap
from envfit.validate._rendered import (RenderValidation, RenderValidationOptions,
                                       rendered_summary_lines)

SMALL = ["--resolution", "16", "--reference-spp", "256", "--frames", "12", "--max-level", "7",
         "--spp", "16"]


@pytest.fixture(scope="module")
def sun_file(tmp_path_factory):
    env = EnvMap(sun_gp_map(16, seed=2, sun_radiance=30.0, sun_radius=0.25)[0], name="sun16")
    path = tmp_path_factory.mktemp("maps") / "sun16.exr"
    save_envmap(path, env)
    return path


def _run(capsys, argv, tmp_path, monkeypatch):
    from envfit.cli import main
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "v.json"
    rc = main(["validate", *map(str, argv), "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err.strip().splitlines(), d


def test_mitsuba_renders_the_conductor_inside_its_prediction(sun_file, tmp_path, capsys,
                                                             monkeypatch):
    """A GGX α = 0.3 sphere rendered by Mitsuba 3 (independent and ldsampler × brdf, map, mis
    at 16 spp, 16 × 16-pixel views): every cell's prediction inside [0.8 low, 1.25 high] of
    the rendered interval; the JSON rows carry the contract; the files are written."""
    pytest.importorskip("mitsuba")
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf", "ggx",
                                    "--roughness", "0.3", *SMALL, "--out", tmp_path / "o"],
                           tmp_path, monkeypatch)
    assert rc == 0
    assert d["cells"] == 6 and d["inside"] == 6, lines
    assert 0.8 <= d["median_ratio"] <= 1.25
    assert {(r["sampler"], r["strategy"]) for r in d["rows"]} == {
        (s, st) for s in ("independent", "ldsampler") for st in ("brdf", "map", "mis")}
    for r in d["rows"]:
        assert r["low"] <= r["measured_rmse"] <= r["high"]
        assert r["ratio"] == pytest.approx(r["predicted"] / r["measured_rmse"])
        assert set(r["bands"]) == {"0-30", "30-60", "60-80"}
    assert any(ln.startswith("6 of 6 cells inside") for ln in lines)
    assert {p.name for p in (tmp_path / "o").iterdir()} >= {"rendered.json", "rendered.csv",
                                                           "rendered.png", "references"}


def test_mitsuba_renders_the_rough_plastic_inside_its_prediction(sun_file, tmp_path, capsys,
                                                                 monkeypatch):
    """Mitsuba's roughplastic (GGX α = 0.2, η 1.49, diffuse 0.5), the independent and
    ldsampler samplers × brdf, map, mis at 16 spp: every cell inside (ldsampler's BSDF
    sampling by the lobe-choice model); ``orthogonal`` is one line, exit 2, before the map
    is read."""
    pytest.importorskip("mitsuba")
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf",
                                    "roughplastic", "--roughness", "0.2", *SMALL],
                           tmp_path, monkeypatch)
    assert rc == 0 and d["cells"] == 6 and d["inside"] == 6, lines
    assert {r["sampler"] for r in d["rows"]} == {"independent", "ldsampler"}
    assert "rough plastic, GGX alpha 0.2" in lines[1]
    rc, _, err, _ = _run(capsys, [tmp_path / "missing.exr", "--renderer", "mitsuba3",
                                  "--brdf", "roughplastic", "--roughness", "0.2",
                                  "--samplers", "orthogonal"], tmp_path, monkeypatch)
    assert rc == 2 and len(err) == 1 and "orthogonal" in err[0]


def test_mitsuba_renders_the_principled_bsdf_inside_its_prediction(sun_file, tmp_path, capsys,
                                                                    monkeypatch):
    """Mitsuba's principled at its defaults but metallic 0.3 (roughness 0.5 without
    --roughness), the independent and ldsampler samplers × brdf, map, mis at 16 spp: every
    cell inside; the summary names the parameter; --bsdf-param with a conductor is one line."""
    pytest.importorskip("mitsuba")
    rc, lines, _, d = _run(capsys, [sun_file, "--renderer", "mitsuba3", "--brdf",
                                    "principled", "--bsdf-param", "metallic=0.3", *SMALL],
                           tmp_path, monkeypatch)
    assert rc == 0 and d["cells"] == 6 and d["inside"] == 6, lines
    assert "principled, GGX alpha 0.25, metallic 0.3" in lines[1]
    rc, _, err, _ = _run(capsys, [tmp_path / "missing.exr", "--renderer", "mitsuba3",
                                  "--brdf", "ggx", "--alpha", "0.2", "--bsdf-param",
                                  "metallic=1"], tmp_path, monkeypatch)
    assert rc == 2 and len(err) == 1 and "--bsdf-param" in err[0]


def _result(inside: list[bool]) -> RenderValidation:
    o = RenderValidationOptions("mitsuba3", brdf="beckmann", alpha=0.1, spp=(16,),
                                samplers=("independent",))
    rows = []
    for ok, st in zip(inside, o.strategies):
        pred = 1.0 if ok else 2.0
        rows.append({"sampler": "independent", "strategy": st, "spp": 16, "spp_used": 16,
                     "measured_rmse": 1.0, "low": 0.9, "high": 1.1, "predicted": pred,
                     "ratio": pred, "inside": ok, "mean_offset": 0.0,
                     "bands": {"0-30": {"measured_rmse": 1.0, "low": 0.9, "high": 1.1,
                                        "predicted": pred, "inside": ok}}})
    return RenderValidation("m", o, rows, renderer_version="Mitsuba x")


@pytest.mark.parametrize("inside,words", [
    ([True, True, True], ("3 of 3 cells inside", "median predicted/measured 1.000",
                          "0-30 deg: 3 of 3 cells inside")),
    ([True, False, False], ("1 of 3 cells inside", "median predicted/measured 2.000",
                            "0-30 deg: 1 of 3 cells inside")),
])
def test_sentences_follow_the_rows(inside, words):
    lines = rendered_summary_lines(_result(inside))
    text = "\n".join(lines)
    for w in words:
        assert w in text
    assert lines[0].startswith("Mitsuba x rendered the sphere (white Beckmann conductor, "
                               "alpha 0.1)")
    flags = [ln.split()[-1] for ln in lines[3:6]]
    assert flags == ["yes" if ok else "NO" for ok in inside]


@pytest.mark.parametrize("argv,words", [
    (["--roughness", "0.1"], "--roughness need(s) --renderer mitsuba3 or cycles"),
    (["--renderer", "pbrt4"], "--renderer takes mitsuba3 or cycles"),
    (["--renderer", "mitsuba3", "--brdf", "ggx"], "--roughness goes with a microfacet --brdf"),
    (["--renderer", "mitsuba3", "--roughness", "0.2"], "--roughness goes with a microfacet --brdf"),
    (["--renderer", "mitsuba3", "--brdf", "glossy"], "must be one of diffuse, ggx, beckmann"),
    (["--renderer", "mitsuba3", "--footprint", "9"], "--footprint: 9 is outside 1 <= J <= 8"),
    (["--renderer", "mitsuba3", "--brdf", "multiggx", "--roughness", "0.3"],
     "Cycles' Multiscatter GGX"),
    (["--renderer", "mitsuba3", "--brdf", "diffuse,ggx"], "takes one BSDF"),
    (["--renderer", "mitsuba3", "--renderer-n", "16"], "--renderer-n belong(s) to --renderer"),
    (["--renderer", "cycles", "--strategies", "map"], "cycles renders the strategies brdf, mis"),
    (["--renderer", "mitsuba3", "--samplers", "zsobol"], "must be one of independent"),
    (["--renderer", "--spp", "16"], "--spp need(s) --renderer mitsuba3 or cycles"),
])
def test_bad_flags_are_one_line_before_the_map_is_read(argv, words, tmp_path, capsys):
    from envfit.cli import main
    rc = main(["validate", str(tmp_path / "absent.exr"), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("envfit validate: error:")
    assert words in err[0] and "absent.exr" not in err[0]


def test_a_missing_renderer_is_one_line(tmp_path, capsys, monkeypatch):
    """Without ``bpy`` (the test extra does not install it): one line naming the package,
    before the map is read."""
    from envfit.cli import main
    monkeypatch.setitem(sys.modules, "bpy", None)
    rc = main(["validate", str(tmp_path / "absent.exr"), "--renderer", "cycles"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "pip install bpy" in err[0]


def test_cycles_json_on_stdout_is_only_json(sun_file, tmp_path, capfd, monkeypatch):
    """``--renderer cycles --json -``: Blender's own prints (its import's, each render's
    "Saved: …") do not reach stdout, which parses as the JSON (bpy only)."""
    pytest.importorskip("bpy")
    capfd.readouterr()                   # what importing bpy here printed (not the CLI's)
    from envfit.cli import main
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path / "cache"))
    rc = main(["validate", str(sun_file), "--renderer", "cycles", "--samplers",
               "tabulated_sobol", "--strategies", "mis", "--spp", "4", "--resolution", "8",
               "--reference-spp", "16", "--frames", "6", "--max-level", "5", "--json", "-"])
    out = capfd.readouterr().out
    assert rc == 0
    assert out.lstrip().startswith("{"), out[:300]
    d = json.loads(out)
    assert d["cells"] == 1 and d["rows"][0]["sampler"] == "tabulated_sobol"


def test_default_frames_are_256_for_a_microfacet_bsdf_and_64_normals_for_diffuse():
    """A microfacet band is the mean over the frames in it: 256 by default (64 put about 14 in
    60–80°, whose sampling error read 1.4–1.5× the render of the plastic on city); the diffuse
    sphere keeps 64 normals; an explicit value is kept."""
    assert RenderValidationOptions("mitsuba3", brdf="ggx", alpha=0.3).frames == 256
    assert RenderValidationOptions("mitsuba3", brdf="roughplastic", alpha=0.2).frames == 256
    assert RenderValidationOptions("mitsuba3").frames == 64
    assert RenderValidationOptions("mitsuba3", brdf="ggx", alpha=0.3, frames=12).frames == 12

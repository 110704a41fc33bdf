"""``envfit advise --renderer``: the map's notes come before the answer, the snippet names the
map the model saw, --allow-negative is refused with the renderer's reason, and a map on which
BSDF sampling is exact gets that strategy recommended (issue 38).

Maps: 16-row synthesized maps (a smooth GP, the same with five known negative values, a
constant), the model at 6 normals and grid level 4, so that each run takes seconds.
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from envfit.data_gen import gaussian_process_map
from envfit.maps import EnvMap, load_envmap, save_envmap

MODEL = ["--renderer-level", "4", "--renderer-normals", "6"]
NEGATIVE = 5                                   # negative values put into the night map


def _run(capsys, tmp_path, args):
    """``envfit advise`` in-process: (exit code, stdout lines, stderr lines, JSON or None)."""
    from envfit.cli import main
    out = tmp_path / "a.json"
    rc = main(["advise", *map(str, args), "--cache-dir", str(tmp_path / "cache"),
               "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err.strip().splitlines(), d


def _answer_index(lines: list[str]) -> int:
    return next(i for i, ln in enumerate(lines) if "spp = " in ln or "no spp up to" in ln)


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """{name: path}: gp (positive), night (gp with NEGATIVE negative red values), constant."""
    root = tmp_path_factory.mktemp("maps")
    gp = (gaussian_process_map(1.8, 16, seed=3, channels=3) + 3.0).astype(np.float32)
    assert gp.min() > 0
    night = gp.copy()
    night[[2, 5, 8, 11, 14], [3, 9, 17, 21, 30], 0] = -0.25
    out = {}
    for name, a in (("gp", gp), ("night", night),
                    ("constant", np.full((16, 32, 3), 0.7, np.float32))):
        out[name] = save_envmap(root / f"{name}.exr", EnvMap(a, name=name))
    return out


# ----------------------------------------------------------------------------- notes first

def test_renderer_map_notes_come_before_the_answer(maps, tmp_path, capsys):
    rc, lines, _, d = _run(capsys, tmp_path, [maps["night"], "--renderer", "mitsuba3",
                                              "--target-relative", "0.1", *MODEL])
    assert rc == 0
    note = f"note: clamped {NEGATIVE} negative value(s) in {NEGATIVE} pixel(s) to 0"
    assert lines.count(note) == 1
    assert lines.index(note) < _answer_index(lines)
    assert d["notes"][0] == note[len("note: "):]
    # and no such note where no value was clamped
    rc, lines, _, _ = _run(capsys, tmp_path, [maps["gp"], "--renderer", "mitsuba3",
                                              "--target-relative", "0.1", *MODEL])
    assert rc == 0 and not any("clamped" in ln for ln in lines)


def test_generic_advise_says_the_map_notes_before_its_table(maps, tmp_path, capsys):
    rc, lines, _, _ = _run(capsys, tmp_path, [maps["night"], "--no-renderer", "--bases", "sh",
                                              "--pointsets", "sf", "--weights", "equal",
                                              "--fit-n", "64"])
    assert rc == 0
    note = f"note: clamped {NEGATIVE} negative value(s) in {NEGATIVE} pixel(s) to 0"
    header = next(i for i, ln in enumerate(lines) if ln.startswith("map night.exr:"))
    assert lines.count(note) == 1 and lines.index(note) < header


# ----------------------------------------------------------------------------- negatives

@pytest.mark.parametrize("renderer, source", [
    ("mitsuba3", "src/emitters/envmap.cpp: rebuild_distribution"),
    ("pbrt4", "ImageInfiniteLight::ImageLe, ClampZero"),
    ("cycles", "background_cdf"),
    ("envfit", "MapSampler"),
])
def test_allow_negative_with_a_renderer_is_one_line_before_the_map(renderer, source, tmp_path,
                                                                   capsys):
    """Refused before the map is read (a missing file is not reached), with what that
    renderer does with negative radiance."""
    rc, lines, err, _ = _run(capsys, tmp_path, [tmp_path / "missing.exr", "--renderer",
                                                renderer, "--allow-negative"])
    assert rc == 2 and len(err) == 1 and lines == []
    assert err[0].startswith(f"envfit advise: error: --allow-negative with --renderer "
                             f"{renderer}: ")
    assert source in err[0] and "drop --allow-negative" in err[0]


def test_no_negative_percentage_is_printed(maps, tmp_path, capsys):
    """The night map (negative values clamped, as noted) with an absolute target: every
    percentage printed is positive, and the target's is target / mean radiance."""
    rc, lines, _, d = _run(capsys, tmp_path, [maps["night"], "--renderer", "mitsuba3",
                                              "--target-rmse", "0.05", *MODEL])
    assert rc == 0
    text = "\n".join(lines)
    assert not re.search(r"-\d[\d.]*\s?%", text)
    mean = d["renderer"]["mean_radiance"]
    assert mean > 0 and f"({0.05 / mean:.2%} of the map's mean radiance" in text


# ----------------------------------------------------------------------------- the map seen

def test_snippet_after_max_height_names_the_downscaled_map(maps, tmp_path, capsys):
    """--max-height 8 --snippet: without --out one line before the work; with --out the map
    the model saw is written there, the snippet names it, and advice on that file (no
    --max-height) recommends the same spp — the snippet's scene is the one predicted."""
    args = [maps["gp"], "--renderer", "mitsuba3", "--target-relative", "0.1", "--snippet",
            "--max-height", "8", *MODEL]
    rc, lines, err, _ = _run(capsys, tmp_path, args)
    assert rc == 2 and len(err) == 1 and lines == []
    assert "--max-height" in err[0] and "--out DIR" in err[0] and "16 rows to 8" in err[0]
    out = tmp_path / "out"
    rc, lines, _, d = _run(capsys, tmp_path, [*args, "--out", out])
    assert rc == 0
    written = out / "gp-as-modelled.exr"
    assert d["renderer"]["snippet_map"] == str(written)
    assert repr(str(written)) in d["renderer"]["snippet"]
    note = next(i for i, ln in enumerate(lines) if ln.startswith(f"note: the snippet reads "
                                                                 f"{written}"))
    assert note < _answer_index(lines) and "downscaled to 16 x 8 (--max-height)" in lines[note]
    seen = load_envmap(written)
    assert seen.data.shape == (8, 16, 3)
    assert np.array_equal(seen.data, load_envmap(maps["gp"], max_height=8).data)
    rc, _, _, d2 = _run(capsys, tmp_path / "again", [written, "--renderer", "mitsuba3",
                                                     "--target-relative", "0.1", *MODEL])
    assert rc == 0
    assert d2["renderer"]["recommendation"]["spp"] == d["renderer"]["recommendation"]["spp"]


def test_snippet_names_the_file_itself_when_the_model_saw_it(maps, tmp_path, capsys):
    """--max-height at or above the map's height downscales nothing: no --out needed, the
    snippet names MAP."""
    rc, lines, _, d = _run(capsys, tmp_path, [maps["gp"], "--renderer", "cycles",
                                              "--target-relative", "0.1", "--snippet",
                                              "--max-height", "16", *MODEL])
    assert rc == 0 and d["renderer"]["snippet_map"] == str(maps["gp"])
    assert repr(str(maps["gp"])) in d["renderer"]["snippet"]
    assert not any("the snippet reads" in ln for ln in lines)
    rc, _, err, _ = _run(capsys, tmp_path, [maps["gp"], "--renderer", "cycles", "--snippet",
                                            "--max-height", "2", *MODEL])
    assert rc == 2 and len(err) == 1 and "16 rows to 2" in err[0]


def test_snippet_after_convention_names_the_converted_map(maps, tmp_path, capsys):
    """--convention blender: the model sees the converted pixels; the snippet names them,
    written with the convention's up axis, and advice on that file recommends the same spp."""
    out = tmp_path / "out"
    rc, _, _, d = _run(capsys, tmp_path, [maps["gp"], "--renderer", "mitsuba3",
                                          "--convention", "blender", "--target-relative", "0.1",
                                          "--snippet", "--out", out, *MODEL])
    assert rc == 0
    written = out / "gp-as-modelled.exr"
    assert d["renderer"]["snippet_map"] == str(written)
    conv = load_envmap(maps["gp"], convention="blender")
    seen = load_envmap(written, up="z")
    assert np.array_equal(seen.data, conv.data)
    rc, _, _, d2 = _run(capsys, tmp_path / "again", [written, "--renderer", "mitsuba3",
                                                     "--up", "z", "--target-relative", "0.1",
                                                     *MODEL])
    assert rc == 0
    assert d2["renderer"]["recommendation"]["spp"] == d["renderer"]["recommendation"]["spp"]


def test_snippet_of_a_clamped_map_needs_out(maps, tmp_path, capsys):
    rc, _, err, _ = _run(capsys, tmp_path, [maps["night"], "--renderer", "pbrt4", "--snippet",
                                            *MODEL])
    assert rc == 2 and len(err) == 1
    assert f"clamped {NEGATIVE} negative value(s)" in err[0] and "--out DIR" in err[0]


# ----------------------------------------------------------------------------- exact BSDF

def test_constant_map_recommends_exact_bsdf_sampling(maps, tmp_path, capsys):
    """A constant map: the cosine-weighted BSDF sample of a white diffuse surface is exact
    (weight albedo x L = L), so BSDF sampling at 1 spp is recommended, and the sentence's
    numbers are the answers'."""
    rc, lines, _, d = _run(capsys, tmp_path, [maps["constant"], "--renderer", "mitsuba3",
                                              "--sampler", "independent", "--snippet", *MODEL])
    assert rc == 0
    rec = d["renderer"]["recommendation"]
    assert rec["strategy"] == "brdf" and rec["spp"] == 1 and rec["predicted_rmse"] == 0.0
    assert rec["default_strategy"] == "mis"
    mis = next(a for a in d["renderer"]["answers"] if a["strategy"] == "mis")
    assert mis["reached"] and mis["spp"] >= 10
    i = _answer_index(lines)
    assert "emitter_samples=0, bsdf_samples=1): spp = 1 for" in lines[i]
    why = lines[i + 1]
    assert why == f"  ({rec['why']})"
    assert f"which needs {mis['spp']} spp ({2 * mis['spp']} samples per pixel against 1)" in why
    assert "the map is constant" in why and "exact" in why
    assert d["renderer"]["snippet_spp"] == 1 and '"bsdf_samples": 1' in d["renderer"]["snippet"]


def test_default_strategy_kept_when_it_is_not_far_dearer(maps, tmp_path, capsys):
    """A smooth non-constant map: MIS stays the recommendation (no switch sentence), and on
    the constant map without BSDF sampling MIS stays too (emitter sampling is dearer)."""
    rc, lines, _, d = _run(capsys, tmp_path, [maps["gp"], "--renderer", "mitsuba3",
                                              "--sampler", "independent",
                                              "--target-relative", "0.05", *MODEL])
    assert rc == 0
    r = d["renderer"]
    rec = r["recommendation"]
    spp = {a["strategy"]: a["spp"] for a in r["answers"]}
    assert rec["strategy"] == "mis" and rec["why"] is None
    assert 2 * spp["mis"] < 10 * spp["brdf"]                 # the rule's condition, both ways
    assert not any("recommended instead" in ln for ln in lines)
    rc, lines, _, d = _run(capsys, tmp_path, [maps["constant"], "--renderer", "mitsuba3",
                                              "--sampler", "independent", "--strategies",
                                              "mis,map", *MODEL])
    assert rc == 0 and d["renderer"]["recommendation"]["strategy"] == "mis"
    assert not any("constant" in ln for ln in lines)

"""Issue 38 (helper D): every numeric option of theory, sh, table2, fit, synth, validate and
info has a range stated in --help and is refused in the same words, in one line, exit 2,
before any work; and the sentences of the fixed bugs are true of their numbers."""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import pytest

import envfit.cli as cli
from envfit.cli._ranges import PIXELS, Ranged, ranged_actions
from envfit.sh._ringing import BAND_LIMIT

#: numeric options of the shared groups of envfit/cli/_common.py (add_common_arguments,
#: add_map_arguments), which this slice does not own: --seed takes any seed numpy takes,
#: --max-height only ever downscales
SHARED = {"--seed", "--max-height"}
#: argparse types that parse numbers without a stated range
UNRANGED = ("positive_int", "nonneg_int", "finite_float", "positive_float", "int_list",
            "float_list", "nonneg_int_list", "colour_list", "int", "float")
H = 8                                       # the tiny map: 16 x 8 pixels


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    from envfit.maps._io import save_envmap
    d = tmp_path_factory.mktemp("maps")
    rng = np.random.default_rng(0)
    return str(save_envmap(d / "tiny.exr",
                           (0.5 + 0.1 * rng.random((H, 2 * H, 3))).astype(np.float32)))


def _parsers():
    """(command words, parser) of every command of the slice."""
    out = []
    for cmd in ("theory", "sh", "table2", "fit", "synth", "validate", "info"):
        top = cli.build_parser(cmd)
        sub = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
        p = sub.choices[cmd]
        if cmd == "theory":
            tsub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
            out += [(["theory", w], tsub.choices[w]) for w in ("wce", "table1", "figures")]
        else:
            out.append(([cmd], p))
    return out


def _base(words, tiny, tmp_path):
    """A command line that runs (the option under test is appended: argparse keeps the last)."""
    return {"theory wce": ["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "16"],
            "theory table1": ["theory", "table1"], "theory figures": ["theory", "figures"],
            "sh": ["sh", tiny, "--lmax", "1"], "table2": ["table2", tiny, "--n", "16"],
            "fit": ["fit", tiny], "synth": ["synth", str(tmp_path / "s.exr")],
            "validate": ["validate", tiny], "info": ["info", tiny]}[" ".join(words)]


def _outside(r: Ranged) -> list[str]:
    """Values just outside the stated range (both ends; the tiny map's bound where the upper
    one depends on the map) and an absurd one."""
    vals = r.outside()                      # the fixed range's ends (Ranged's own helper)
    dynamic = {PIXELS: 2 * H * H + 1, BAND_LIMIT: H}    # H - 1 is the largest degree
    if r.hi is None:
        assert r.hi_text in dynamic, f"unknown bound {r.hi_text!r}"
        vals.append(str(dynamic[r.hi_text]))
    return vals + ["1e12"]


def test_every_numeric_option_has_a_stated_range_and_is_refused_in_its_words(tiny, tmp_path,
                                                                            capsys,
                                                                            monkeypatch):
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path / "cache"))
    checked = 0
    for words, p in _parsers():
        for a in p._actions:                # no numeric option without a range
            name = getattr(a.type, "__name__", "")
            if a.option_strings and name in UNRANGED:
                assert set(a.option_strings) <= SHARED, (words, a.option_strings)
        for a in ranged_actions(p):
            flag = a.option_strings[-1]
            assert str(a.type) in " ".join(a.help.split()), (words, flag, a.help)
            for value in _outside(a.type):
                t0 = time.perf_counter()
                rc = cli.main(_base(words, tiny, tmp_path) + [f"{flag}={value}"])
                cap = capsys.readouterr()
                lines = [ln for ln in cap.err.splitlines() if ln.strip()]
                assert rc == 2 and len(lines) == 1, (words, flag, value, cap.err)
                assert "Traceback" not in cap.err
                line = lines[0]
                assert flag in line and f"is outside {a.type}" in line, line
                assert time.perf_counter() - t0 < 5.0, (words, flag, value)
                checked += 1
    assert checked > 100


def test_the_bounds_themselves_are_accepted():
    for words, p in _parsers():
        for a in ranged_actions(p):
            r = a.type
            if not r.lo_open:
                assert r(str(r.lo)) == r.lo or r.many
            if r.hi is not None and not r.hi_open:
                v = r(repr(r.hi) if isinstance(r.hi, float) else str(r.hi))
                assert (v[0] if r.many else v) == pytest.approx(r.hi), (words, a.option_strings)


# ------------------------------------------------------------------ item 1: sh --check-axes
def _sh_json(tiny, tmp_path, *extra):
    js = tmp_path / "sh.json"
    rc = cli.main(["sh", tiny, "--lmax", "2", "--table-lmax", "2", "--check-height", "16",
                   "--json", str(js), "--out", str(tmp_path / "o"), *extra])
    assert rc == 0
    return json.loads(js.read_text())


def test_sh_measured_error_says_what_it_was_measured_on(tiny, tmp_path, capsys):
    rad = _sh_json(tiny, tmp_path, "--check-axes", "7")
    out = capsys.readouterr()
    # radiance: the 2H-row grid, whatever --check-axes says; the note says it is unused
    grid = f"the {8 * H * H} pixel centres of a {4 * H}x{2 * H} grid, solid-angle weighted"
    assert rad["measured_on"] == grid and rad["check_axes"] is None
    assert f"measured {rad['measured_relative_rmse']:.3%} ({grid})" in out.out
    assert "--check-axes 7 is unused" in out.err and "7 directions" not in out.out
    rad2 = _sh_json(tiny, tmp_path, "--check-axes", "4096")
    capsys.readouterr()
    assert rad2["measured_relative_rmse"] == rad["measured_relative_rmse"]
    # irradiance: the count is used, and said
    irr7 = _sh_json(tiny, tmp_path, "--irradiance", "--check-axes", "7")
    out = capsys.readouterr()
    assert irr7["measured_on"] == "7 directions" and irr7["check_axes"] == 7
    assert "(7 directions)" in out.out and "unused" not in out.err
    irr = _sh_json(tiny, tmp_path, "--irradiance", "--check-axes", "300")
    assert irr["measured_relative_rmse"] != irr7["measured_relative_rmse"]


# ------------------------------------------------------------------ item 3: a 1-row map
def test_sh_one_row_map_is_named_not_an_option_never_given(tmp_path, capsys):
    from envfit.maps._io import save_envmap
    one = save_envmap(tmp_path / "one.exr", np.full((1, 2, 3), 0.5, dtype=np.float32))
    assert cli.main(["sh", str(one), "--lmax", "0"]) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and "one.exr (2x1)" in line and "H >= 2 rows" in line
    assert "--table-lmax" not in line and "<= 0" not in line
    two = save_envmap(tmp_path / "two.exr", np.full((2, 4, 3), 0.5, dtype=np.float32))
    assert cli.main(["sh", str(two), "--lmax", "1", "--no-check", "-q"]) == 0    # H = 2 runs


# ------------------------------------------------------------------ item 4: N and the pixels
@pytest.mark.parametrize("cmd", ["table2", "fit"])
def test_n_beyond_the_pixels_names_the_pixels_not_a_memory_limit(cmd, tiny, capsys):
    assert cli.main([cmd, tiny, "--n", "1e9"]) == 2
    line = capsys.readouterr().err.strip()
    assert f"W x H = {2 * H * H} for map tiny.exr ({2 * H}x{H})" in line
    assert "memory" not in line and "fits is" not in line


@pytest.mark.parametrize("cmd", ["table2", "fit"])
def test_library_n_beyond_the_smallest_maps_pixels_names_the_pixels(cmd, tiny, tmp_path,
                                                                     capsys):
    """Several maps: --n is checked against the map of fewest pixels, read from the headers
    before any work (not a memory limit's N, which may exceed every map's pixels)."""
    from envfit.maps._io import save_envmap
    big = save_envmap(tmp_path / "big.exr", np.full((2 * H, 4 * H, 1), 0.5, np.float32))
    assert cli.main([cmd, tiny, str(big), "--n", "1e9"]) == 2
    line = capsys.readouterr().err.strip()
    assert f"W x H = {2 * H * H} for map tiny.exr, the library's smallest" in line
    assert "memory" not in line and "fits is" not in line


def test_n_within_the_pixels_but_over_memory_names_memory(tmp_path, capsys, monkeypatch):
    from envfit.maps._io import save_envmap
    big = save_envmap(tmp_path / "b.exr", np.full((64, 128, 1), 0.5, dtype=np.float32))
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "300M")
    assert cli.main(["table2", str(big), "--n", "8000", "--solver", "cholesky"]) == 2
    line = capsys.readouterr().err.strip()
    fits = int(line.rsplit(" ", 1)[1])
    assert "can be used" in line and "ENVFIT_MEMORY_LIMIT=300M" in line
    assert fits < 8000 <= 64 * 128


# ------------------------------------------------------------------ item 8: --workers
def test_workers_above_the_cores_refused_and_the_memory_note_true(monkeypatch):
    from envfit.base._errors import ParameterError
    from envfit.batch import _executor
    with pytest.raises(ParameterError, match=r"--workers 1000 is outside 1 <= K <= 2 "):
        _executor.plan_workers(1000, cores=2, max_useful=8)
    monkeypatch.setattr(_executor, "available_memory_bytes", lambda: 10 * 2**30)
    w, notes = _executor.plan_workers(4, cores=4, max_useful=8, bytes_per_task=3 * 2**30)
    assert w == int(0.8 * 10 // 3) == 2                      # 8 GiB budget / 3 GiB per task
    assert notes and "using 2, the most whose tasks" in notes[0]
    w, notes = _executor.plan_workers(2, cores=4, max_useful=8, bytes_per_task=2**20)
    assert (w, notes) == (2, [])


# ------------------------------------------------------------------ item 7: alpha, roughness
def test_validate_alpha_and_roughness_one_meaning_each():
    from envfit.cli._validate_render import alpha_of
    from envfit.base._errors import ParameterError
    ns = argparse.Namespace
    assert alpha_of(ns(alpha=0.3, roughness=None, renderer="cycles")) == 0.3
    assert alpha_of(ns(alpha=None, roughness=0.5, renderer="cycles")) == pytest.approx(0.25)
    assert alpha_of(ns(alpha=None, roughness=0.3, renderer="mitsuba3")) == 0.3
    with pytest.raises(ParameterError, match=r"--roughness 0.1 gives alpha = 0.01 for cycles"):
        alpha_of(ns(alpha=None, roughness=0.1, renderer="cycles"))
    help_text = " ".join(cli.build_parser("validate")._subparsers._group_actions[0]
                         .choices["validate"].format_help().split())
    assert "Cycles' roughness R, alpha = R^2" in help_text and "0.05 <= alpha <= 1" in help_text


# ------------------------------------------------------------------ item 9: one basename
def test_two_maps_of_one_basename_are_told_apart(tmp_path, capsys):
    from envfit.maps._io import save_envmap
    rng = np.random.default_rng(1)
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        save_envmap(tmp_path / d / "forest.exr",
                    (0.5 + 0.2 * rng.random((8, 16, 3))).astype(np.float32))
    out = tmp_path / "o"
    rc = cli.main(["table2", str(tmp_path / "a" / "forest.exr"), str(tmp_path / "b" / "forest.exr"),
                   "--s", "1.5", "--n", "20", "--workers", "1", "--out", str(out)])
    text = capsys.readouterr().out
    assert rc == 0
    assert "a/forest.exr" in text and "b/forest.exr" in text
    import csv
    rows = list(csv.DictReader((out / "library_summary.csv").open()))
    assert sorted(r["map"] for r in rows) == ["a/forest.exr", "b/forest.exr"]


def test_distinct_labels_only_where_needed():
    from envfit.batch._library_result import distinct_labels
    from envfit.maps._lazy_maps import MapSource
    s = [MapSource(label="f.exr", slug="1", path="/x/a/y/f.exr"),
         MapSource(label="f.exr", slug="2", path="/x/b/y/f.exr"),
         MapSource(label="g.exr", slug="3", path="/x/b/y/g.exr")]
    assert [m.label for m in distinct_labels(s)] == ["a/y/f.exr", "b/y/f.exr", "g.exr"]

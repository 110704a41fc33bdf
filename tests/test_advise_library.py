"""A library of maps advised in a renderer's terms (envfit.batch._library_advise, issue 40): each
row equals the single-map advice of that map (a second computation), the coverage is the
order statistic of the rows, a rerun resumes every finished map and recomputes a changed,
forged or missing one, a local pool gives the same rows as inline, and the CLI writes the
table, the JSON and the figure."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from envfit import cli
from envfit.batch._library_advise import MapRow, advise_library, coverage
from envfit.advisor._renderer_advice import advise_renderer_map
from envfit.advisor._renderer_options import RendererAdviseOptions
from envfit.batch import LibraryOptions
from envfit.maps import EnvMap
from envfit.maps._io import save_envmap

#: a model small enough for a test: 4 normals, grid level 3
OPTS = dict(sampler="independent", normals=4, level=3)


def _maps(k=3, h=8):
    rng = np.random.default_rng(7)
    out = []
    for i in range(k):
        a = 0.2 + rng.random((h, 2 * h, 3))
        a[1, 3 + i] *= 40.0 * (i + 1)              # a sun whose strength differs per map
        out.append(EnvMap(a.astype(np.float32), name=f"m{i}.exr"))
    return out


def test_rows_are_the_single_map_advice(tmp_path):
    maps = _maps()
    opts = RendererAdviseOptions("mitsuba3", **OPTS)
    lib = advise_library(maps, opts, target_relative=0.05, cache=False,
                         library=LibraryOptions(workers=1))
    assert [r.slug for r in lib.rows] == ["m0", "m1", "m2"] and lib.computed == 3
    for env, row in zip(maps, lib.rows):
        one = advise_renderer_map(env, opts.asking(target_relative=0.05, cache=False))
        rec = one.recommendation
        assert (row.strategy, row.spp, row.reached) == (rec["strategy"], rec["spp"],
                                                        rec["reached"])
        assert row.predicted_rmse == rec["predicted_rmse"]
        assert row.target_rmse == pytest.approx(0.05 * one.mean_radiance, rel=1e-12)
        for a in one.to_dict()["answers"]:
            assert row.answers[a["strategy"]]["spp"] == a["spp"]
    # the coverage is the order statistic of the recommended spp
    spp = sorted(r.spp for r in lib.rows)
    assert [c["spp"] for c in lib.coverage] == [spp[1], spp[2], spp[2]]


def test_a_sized_model_stays_sized_in_a_library():
    """The library's task copies the options (``dataclasses.replace``): a sized default
    stays sized, so each row is the single-map answer of the sized model (pilot and final)
    and carries its model error."""
    maps = _maps(2, h=16)
    opts = RendererAdviseOptions("pbrt4", model_error=0.03)
    assert opts.auto
    lib = advise_library(maps, opts, target_relative=0.05, cache=False,
                         library=LibraryOptions(workers=1))
    for env, row in zip(maps, lib.rows):
        one = advise_renderer_map(env, opts.asking(target_relative=0.05, cache=False))
        assert one.model["sized"] and (row.spp, row.predicted_rmse) == (
            one.recommendation["spp"], one.recommendation["predicted_rmse"])
        assert row.model_se == one.model["model_se"][row.strategy]
    assert any(f"±{100 * r.model_se[0]:.1f} %" in line for r in lib.rows
               for line in lib.table_lines())


def test_coverage_counts_maps_that_reach_nothing():
    def row(spp, ok=True):
        return MapRow("m", "m", 8, 4, 1.0, 0.01, "mis", spp, ok, 0.01, 4096, {})
    rows = [row(16), row(64), row(256), row(1024), row(4096, ok=False)]
    got = coverage(rows, (0.2, 0.5, 0.8, 0.81, 1.0))
    assert [c["maps"] for c in got] == [1, 3, 4, 5, 5]
    assert [c["spp"] for c in got] == [16, 256, 1024, None, None]
    assert got[-1]["more_than"] == 4096 and coverage([]) == []


def test_rerun_resumes_and_recomputes_what_changed(tmp_path):
    paths = [save_envmap(tmp_path / "maps" / e.name, e) for e in _maps()]
    opts = RendererAdviseOptions("mitsuba3", **OPTS)
    out = tmp_path / "out"
    kw = dict(target_relative=0.05, cache=False, library=LibraryOptions(workers=1), out=out)
    first = advise_library([tmp_path / "maps"], opts, **kw)
    assert (first.computed, first.resumed) == (3, 0)
    again = advise_library([tmp_path / "maps"], opts, **kw)
    assert (again.computed, again.resumed) == (0, 3)
    assert [(r.spp, r.predicted_rmse) for r in again.rows] == \
        [(r.spp, r.predicted_rmse) for r in first.rows]
    # a forged cell (valid envelope, impossible value), a changed file, a deleted cell
    cell = out / "cells" / "m0.json"
    doc = json.loads(cell.read_text())
    doc["cell"]["row"]["predicted_rmse"] = -1.0
    from envfit.base._store import canonical_sha256
    doc["sha256"] = canonical_sha256({k: v for k, v in doc.items() if k != "sha256"})
    cell.write_text(json.dumps(doc))
    st = os.stat(paths[1])
    os.utime(paths[1], ns=(st.st_atime_ns, st.st_mtime_ns + 10 ** 9))
    (out / "cells" / "m2.json").unlink()
    third = advise_library([tmp_path / "maps"], opts, **kw)
    assert (third.computed, third.resumed) == (3, 0)
    assert [r.predicted_rmse for r in third.rows] == [r.predicted_rmse for r in first.rows]


def test_other_options_are_another_run(tmp_path):
    opts = RendererAdviseOptions("mitsuba3", **OPTS)
    kw = dict(cache=False, library=LibraryOptions(workers=1), out=tmp_path / "out")
    advise_library(_maps(2), opts, target_relative=0.05, **kw)
    from envfit.base._errors import ParameterError
    with pytest.raises(ParameterError, match="different"):
        advise_library(_maps(2), opts, target_relative=0.02, **kw)


@pytest.mark.slow
def test_a_local_pool_gives_the_inline_rows():
    opts = RendererAdviseOptions("mitsuba3", **OPTS)
    inline = advise_library(_maps(), opts, target_relative=0.05, cache=False,
                            library=LibraryOptions(workers=1))
    pool = advise_library(_maps(), opts, target_relative=0.05, cache=False,
                          library=LibraryOptions(workers=2))
    assert "2 processes" in pool.executor
    assert [(r.spp, r.predicted_rmse) for r in pool.rows] == \
        [(r.spp, r.predicted_rmse) for r in inline.rows]


def _files(tmp_path, k=3):
    folder = tmp_path / "lib"
    folder.mkdir()
    for env in _maps(k):
        save_envmap(folder / env.name, env)
    return folder


def test_cli_advises_a_folder_and_resumes(tmp_path, capsys):
    folder = _files(tmp_path)
    argv = ["advise", str(folder), "--renderer", "mitsuba3", "--renderer-normals", "4",
            "--renderer-level", "3", "--target-relative", "0.05", "--out", str(tmp_path / "o"),
            "--cache-dir", str(tmp_path / "c"), "--workers", "1"]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    d = json.loads((tmp_path / "o" / "advise_library.json").read_text())
    assert [m["label"] for m in d["maps"]] == ["m0.exr", "m1.exr", "m2.exr"]
    one = advise_renderer_map(_maps()[1], RendererAdviseOptions("mitsuba3", **OPTS).asking(
        target_relative=0.05, cache=False))
    assert d["maps"][1]["spp"] == one.recommendation["spp"]
    assert "  m1.exr " in out and "3 map(s) computed, 0 resumed" in out
    for name in ("advise_library.csv", "advise_library.png"):
        assert (tmp_path / "o" / name).stat().st_size > 0
    assert cli.main(argv) == 0                         # a rerun computes nothing
    assert "0 map(s) computed, 3 resumed" in capsys.readouterr().out


@pytest.mark.parametrize("extra, words", [
    ([], "give --renderer"),
    (["--renderer", "cycles", "--snippet"], "--snippet is not taken with several maps"),
    (["--renderer", "mitsuba3", "--rules"], "--rules is not taken with several maps"),
])
def test_cli_library_refusals_are_one_line_before_any_map_is_read(extra, words, tmp_path,
                                                                  capsys):
    folder = _files(tmp_path, 2)
    assert cli.main(["advise", str(folder / "*.exr"), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err

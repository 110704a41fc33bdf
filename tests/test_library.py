"""Library sweeps: one factorisation per (s, N) or per s serves every map, with the same
numbers as the single-map runs; cells resume; the local process pool survives a killed
worker on re-run; the CLI runs on several maps."""
from __future__ import annotations

import json
import os
import signal
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import envfit.cli as cli
from envfit.data_gen._gp import gaussian_process_map
from envfit.maps._envmap import EnvMap
from envfit.maps._io import save_envmap
from envfit.base._errors import EnvMapFileError, ExecutorError, ParameterError
from envfit.fit._smoothness import fit_smoothness
from envfit.sobolev._interpolation import SobolevInterpolator
from envfit.batch import LibraryOptions, fit_smoothness_library, run_table2_library
from envfit.maps._lazy_maps import MapSource, resolve_map_sources
from envfit.fit._table2 import run_table2

S, N = [1.3, 1.7], [60, 250]
INLINE = LibraryOptions(workers=1)  # every task in this process


def gp_map(seed, height=32, channels=3):
    f = gaussian_process_map(1.5, height, seed=seed, channels=channels)
    return EnvMap((f - f.min() + 0.5).astype(np.float32), name=f"gp{seed}")


@pytest.fixture(scope="module")
def maps():
    # different resolutions are fine: samples are lookups at shared directions
    return [gp_map(0), gp_map(1), gp_map(2, height=16)]


@pytest.fixture
def count_factorizations(monkeypatch):
    calls = []
    original = SobolevInterpolator._factorize

    def counting(self):
        calls.append(self.n)
        return original(self)

    monkeypatch.setattr(SobolevInterpolator, "_factorize", counting)
    return calls


def assert_same_tables(a, b, rel=1e-10):
    for key in ("rmse", "rmse_solid_angle"):
        np.testing.assert_allclose(a.rmse_table(key), b.rmse_table(key), rtol=rel, atol=0)


def test_library_equals_single_map_runs_with_one_factorization_per_cell(maps, count_factorizations):
    lib = run_table2_library(maps, S, N, scale="display", options=INLINE)
    assert len(count_factorizations) == len(S) * len(N) == lib.factorizations
    assert sorted(count_factorizations) == sorted(N * len(S))
    del count_factorizations[:]
    for m, r in zip(maps, lib.maps):
        assert_same_tables(r, run_table2(m, S, N, scale="display"))
        assert r.height == m.height and r.map == m.name
    assert len(count_factorizations) == len(maps) * len(S) * len(N)   # the single-map cost
    rows = lib.summary_rows()
    assert [r["slug"] for r in rows] == ["gp0", "gp1", "gp2"]
    assert all(r["s_best"] in S for r in rows)


def test_library_iterative_one_preconditioner_for_all_maps(maps, count_factorizations):
    """solver="iterative": every map's columns side by side in one CG solve per (s, N), no
    dense factorisation; each cell records the solver, and the RMSEs equal the single-map
    Cholesky runs to 1e-6 relative (the stopping rule's promise)."""
    lib = run_table2_library(maps, S, N, scale="display", options=INLINE, solver="iterative")
    assert count_factorizations == [] and lib.factorizations == len(S) * len(N)
    for m, r in zip(maps, lib.maps):
        for c in r.cells:
            assert c.solver == "iterative" and c.iterations > 0
            assert 0 < c.rmse_change_bound <= 1e-6 and c.residual < 1e-6
        dense = run_table2(m, S, N, scale="display", solver="cholesky")
        assert_same_tables(r, dense, rel=1e-6)


def test_library_solver_checked_before_work(maps):
    with pytest.raises(ParameterError, match="solver"):
        run_table2_library(maps, S, N, solver="lu")


def test_resume_factorizes_only_missing_cells(maps, tmp_path, count_factorizations):
    first = run_table2_library(maps, [1.5], N, out=tmp_path, options=INLINE,
                               save_reconstructions=True)
    assert first.cells_computed == 6 and len(count_factorizations) == 2
    assert (tmp_path / "gp0" / "cells" / "s1.5000_n250.json").exists()
    assert (tmp_path / "gp2" / "reconstruction_s1.50_n250.exr").exists()
    assert (tmp_path / "gp2" / "reconstruction_s1.50_n250.png").exists()
    assert not (tmp_path / "gp2" / "reconstruction_s1.50_n60.exr").exists()
    del count_factorizations[:]
    seen = []
    second = run_table2_library(maps, [1.5, 1.8], N, out=tmp_path, options=INLINE,
                                on_cell=lambda label, c, resumed: seen.append((label, c.s, resumed)))
    assert second.cells_resumed == 6 and second.cells_computed == 6
    assert len(count_factorizations) == 2                     # only s = 1.8, at both N
    assert sorted(x for x in seen if x[2]) == sorted((m.name, 1.5, True) for m in maps for _ in N)
    for a, b in zip(first.maps, second.maps):
        assert a.cell(1.5, 250).rmse == b.cell(1.5, 250).rmse
    for f in ("library_table2.csv", "library_summary.csv", "library_table2.json",
              "library_s_best.png", "gp2/table2.csv"):
        assert (tmp_path / f).exists(), f
    d = json.loads((tmp_path / "library_table2.json").read_text())
    assert set(d["maps"]) == {"gp0", "gp1", "gp2"} and len(d["summary"]) == 3
    summary = (tmp_path / "library_summary.csv").read_text().splitlines()
    assert summary[0].startswith("slug,map,height,s_best") and len(summary) == 4


def test_bad_input(maps, tmp_path):
    save_envmap(tmp_path / "a.exr", maps[0])
    with pytest.raises(EnvMapFileError, match="no such file"):
        resolve_map_sources([str(tmp_path / "a.exr"), str(tmp_path / "missing.exr")])
    (tmp_path / "empty").mkdir()
    with pytest.raises(EnvMapFileError, match="holds no maps"):
        resolve_map_sources([str(tmp_path / "empty")])
    with pytest.raises(EnvMapFileError, match="no file matches"):
        resolve_map_sources([str(tmp_path / "*.hdr")])
    z = EnvMap(maps[1].data, up="z", name="zmap")
    with pytest.raises(ParameterError, match="up axis"):
        run_table2_library([maps[0], z], S, N)
    with pytest.raises(ParameterError, match="1 < s < 2"):
        run_table2_library(maps, [2.5], N)
    with pytest.raises(ParameterError, match="--scheduler needs --executor dask"):
        run_table2_library(maps, S, N, options=LibraryOptions(executor="local",
                                                              scheduler="tcp://127.0.0.1:1"))
    for call in (run_table2_library, fit_smoothness_library):    # options is a dataclass
        with pytest.raises(ParameterError, match="options must be a LibraryOptions, got dict"):
            call(maps, options={"workers": 1})
    # duplicates are read once; equal stems in different folders get distinct slugs
    (tmp_path / "b").mkdir()
    save_envmap(tmp_path / "b" / "a.exr", maps[1])
    srcs = resolve_map_sources([str(tmp_path / "a.exr"), str(tmp_path / "a.exr"),
                                str(tmp_path / "b" / "a.exr")])
    assert len(srcs) == 2 and srcs[0].slug != srcs[1].slug and srcs[0].slug.startswith("a-")


@pytest.mark.parametrize("method", ["likelihood", "loo"])
def test_fit_library_matches_single_map_fits(maps, count_factorizations, method):
    """One search (envfit.fit._search) for both: a map alone and the same map inside a library
    get the same ŝ and interval to rounding; σ̂ (exact at ŝ alone, the lattice spline in a
    library) to 1e-6."""
    two = maps[1:]
    lib = fit_smoothness_library(two, n=200, scale="linear", options=INLINE, method=method)
    shared = len(count_factorizations)
    assert shared == lib.factorizations
    # each distinct s is factorised once per round for the maps requesting it
    assert shared >= len({round(c["s"], 8) for f in lib.fits for c in f.curve})
    del count_factorizations[:]
    for m, f in zip(two, lib.fits):
        ref = fit_smoothness(m, n=200, scale="linear", method=method)
        assert abs(f.s - ref.s) <= 1e-9
        assert np.max(np.abs(np.subtract(f.s_interval, ref.s_interval))) <= 1e-9
        np.testing.assert_allclose(f.sigma, ref.sigma, rtol=1e-6)
        # the criterion at the shared s equals the single-map one to rounding, and the single
        # map evaluates the same lattice (plus ŝ itself for the likelihood's σ̂)
        ours = {round(c["s"], 8): c["score"] for c in f.curve}
        theirs = {round(c["s"], 8): c["score"] for c in ref.curve}
        assert set(ours) <= set(theirs) and len(theirs) - len(ours) <= 1
        for s, score in ours.items():
            assert score == pytest.approx(theirs[s], rel=1e-10)
    # two maps together need fewer factorisations than two single-map fits
    assert shared < len(count_factorizations)


def test_cli_library_table2_and_fit(maps, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("table2", "fit"))
    lib_dir = tmp_path / "lib"
    for m in maps:
        save_envmap(lib_dir / f"{m.name}.exr", m)
    out, js = tmp_path / "out", tmp_path / "t.json"
    assert cli.main(["table2", str(lib_dir), "--s", "1.3,1.7", "--n", "40,120", "--out", str(out),
                     "--json", str(js), "--workers", "1"]) == 0
    d = json.loads(js.read_text())
    assert set(d["maps"]) == {"gp0", "gp1", "gp2"} and d["factorizations"] == 4
    assert len(d["maps"]["gp1"]["rows"]) == 4
    printed = capsys.readouterr().out
    assert "gp2.exr" in printed and "best s across maps" in printed
    assert (out / "library_s_best.png").exists() and (out / "gp0" / "cells").is_dir()
    js2 = tmp_path / "f.json"
    assert cli.main(["fit", str(lib_dir / "gp0.exr"), str(lib_dir / "gp1.exr"), "--n", "150",
                     "--scale", "linear", "--json", str(js2), "--out", str(tmp_path / "fo"),
                     "--workers", "1", "--quiet"]) == 0
    d = json.loads(js2.read_text())
    assert [r["map"] for r in d["summary"]] == ["gp0.exr", "gp1.exr"]
    # each row is that map's own fit (the interval contains ŝ by construction, so
    # s_low <= s <= s_high could not fail)
    for r, m in zip(d["summary"], maps[:2]):
        ref = fit_smoothness(m, n=150, scale="linear")
        assert (r["s"], r["s_low"], r["s_high"]) == pytest.approx((ref.s, *ref.s_interval),
                                                                  abs=1e-9), r["map"]
    for f in ("library_fit.csv", "library_fit.json", "library_fit_s.png"):
        assert (tmp_path / "fo" / f).exists(), f
    # bad input: a missing file among several, dask not installed
    assert cli.main(["table2", str(lib_dir / "gp0.exr"), str(lib_dir / "nope.exr")]) == 2
    err = capsys.readouterr().err
    assert "no such file" in err and "Traceback" not in err
    monkeypatch.setitem(__import__("sys").modules, "distributed", None)
    assert cli.main(["fit", str(lib_dir), "--executor", "dask", "--n", "50"]) == 2
    err = capsys.readouterr().err
    assert 'pip install "envfit[dask]"' in err and "Traceback" not in err


@dataclass
class KillingSource(MapSource):
    """Kills the process that loads it while ``flag`` exists (the flag is removed first)."""
    flag: str = ""

    def load(self):
        if self.flag and os.path.exists(self.flag):
            os.remove(self.flag)
            os.kill(os.getpid(), signal.SIGKILL)
        return super().load()


def killing_sources(maps, flag: Path) -> list[MapSource]:
    srcs = resolve_map_sources(maps)
    k = srcs[0]
    srcs[0] = KillingSource(label=k.label, slug=k.slug, envmap=k.envmap, flag=str(flag))
    return srcs


@pytest.mark.slow
def test_process_pool_killed_worker_then_rerun(maps, tmp_path):
    reference = run_table2_library(maps, S, N, options=INLINE)
    flag, out = tmp_path / "kill-now", tmp_path / "out"
    srcs = killing_sources(maps, flag)

    def arm(label, cell, resumed):
        if not flag.with_suffix(".armed").exists():
            flag.with_suffix(".armed").touch()
            flag.touch()

    with pytest.raises(ExecutorError, match="run the same command again"):
        run_table2_library(srcs, S, N, out=out, options=LibraryOptions(workers=2), on_cell=arm)
    finished = list(out.glob("*/cells/*.json"))
    assert 1 <= len(finished) < len(maps) * len(S) * len(N)
    again = run_table2_library(srcs, S, N, out=out, options=INLINE)
    assert again.cells_resumed == len(finished)
    assert again.cells_resumed + again.cells_computed == len(maps) * len(S) * len(N)
    for a, b in zip(again.maps, reference.maps):
        assert_same_tables(a, b)

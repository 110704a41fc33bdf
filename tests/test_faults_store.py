"""Stores you can trust (envfit.base._store, envfit.advisor._cache): faulty cells are recomputed with
one note, two runs never share an --out folder, a dead run's lock blocks nobody, and an
unusable advisor cache is a note.

Every reference value is computed independently, by a fresh run without any store.
"""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import envfit.cli as cli
import envfit.fit._table2 as table2_mod
from envfit.data_gen import gaussian_process_map
from envfit.advisor._advise import advise
from envfit.advisor._cache import cache_write_problem
from envfit.maps import EnvMap
from envfit.maps import load_envmap, save_envmap
from envfit.batch._library import run_table2_library
from envfit.batch._library_fit import fit_smoothness_library
from envfit.batch import LibraryOptions
from envfit.base._store import LOCK_NAME, FolderLock, StoreBusyError
from envfit.fit._table2 import run_table2

S, N = [1.3, 1.7], [50, 100]
INLINE = LibraryOptions(workers=1)  # every task in this process
VICTIM, OTHER = "s1.7000_n100", "s1.3000_n100"


def gp(seed: int, height: int = 16, channels: int = 3) -> EnvMap:
    f = gaussian_process_map(1.5, height, seed=seed, channels=channels)
    return EnvMap((f - f.min() + 0.5).astype(np.float32), name=f"gp{seed}")


@pytest.fixture(scope="module")
def map_file(tmp_path_factory) -> Path:
    return save_envmap(tmp_path_factory.mktemp("map") / "gp.exr", gp(1))


@pytest.fixture(scope="module")
def reference(map_file):
    """Table 2 of the map as the CLI reads it, computed without any store."""
    return run_table2(load_envmap(map_file), S, N, scale="linear")


# ---------------------------------------------------------------------------- the faults
def _random_bytes(p: Path) -> None:
    p.write_bytes(b"\xff\xfe" + random.Random(0).randbytes(254))


def _other_cell(p: Path) -> None:
    shutil.copyfile(p.with_name(f"{OTHER}.json"), p)


def _edited(p: Path) -> None:
    doc = json.loads(p.read_text())
    cell = doc["cell"] if "cell" in doc else doc
    cell["rmse"] = 0.125
    p.write_text(json.dumps(doc, indent=2))


def _old_format(p: Path) -> None:
    p.write_text(json.dumps(json.loads(p.read_text())["cell"], indent=2))   # as before checksums


def _truncated(p: Path) -> None:
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _directory(p: Path) -> None:
    p.unlink()
    p.mkdir()
    (p / "junk.txt").write_text("a folder where the cell should be")


FAULTS = {
    "random-bytes": (_random_bytes, "not a JSON file (binary data)"),
    "other-cell": (_other_cell, f"holds cell {OTHER}, not {VICTIM}"),
    "edited-rmse": (_edited, "checksum mismatch (edited or corrupt)"),
    "old-format": (_old_format, "written by an older envfit (no checksum)"),
    "truncated": (_truncated, "not valid JSON (truncated or corrupt)"),
    "directory": (_directory, f"a folder, not a file (moved to {VICTIM}.json.folder)"),
}


def stored_cell(cells: Path, key: str = VICTIM) -> dict:
    return json.loads((cells / f"{key}.json").read_text())["cell"]


@pytest.fixture
def count_interpolators(monkeypatch):
    """How many single-map Table 2 cells this process computes (one interpolator each)."""
    built = []
    base = table2_mod.SobolevInterpolator

    class Counting(base):
        def __init__(self, *a, **k):
            built.append(a[2] if len(a) > 2 else k.get("s"))
            super().__init__(*a, **k)

    monkeypatch.setattr(table2_mod, "SobolevInterpolator", Counting)
    return built


def cli_table2(map_file: Path, out: Path, *extra: str) -> int:
    return cli.main(["table2", str(map_file), "--s", "1.3,1.7", "--n", "50,100",
                     "--scale", "linear", "--out", str(out), *extra])


# ---------------------------------------------------------------------- cells: CLI and API
@pytest.mark.parametrize("fault", list(FAULTS))
def test_cli_recomputes_a_faulty_cell_with_one_note(fault, map_file, reference, tmp_path,
                                                    monkeypatch, capsys, count_interpolators):
    monkeypatch.setattr(cli, "COMMANDS", ("table2",))
    out = tmp_path / "out"
    assert cli_table2(map_file, out) == 0 and len(count_interpolators) == 4
    victim = out / "cells" / f"{VICTIM}.json"
    make_fault, why = FAULTS[fault]
    make_fault(victim)
    capsys.readouterr()
    count_interpolators.clear()
    assert cli_table2(map_file, out) == 0
    cap = capsys.readouterr()
    text = cap.out + cap.err
    assert "Traceback" not in text
    naming = [ln for ln in text.splitlines() if str(victim) in ln]
    assert naming == [f"note: recomputed {victim}: {why}"]
    assert count_interpolators == [1.7]                       # that cell only
    assert stored_cell(out / "cells")["rmse"] == pytest.approx(reference.cell(1.7, 100).rmse,
                                                               rel=1e-12)


@pytest.mark.parametrize("fault", list(FAULTS))
def test_api_recomputes_a_faulty_cell_with_one_note(fault, map_file, reference, tmp_path, capsys):
    env = load_envmap(map_file)
    out = tmp_path / "out"
    run_table2(env, S, N, scale="linear", out=out, on_note=pytest.fail)
    victim = out / "cells" / f"{VICTIM}.json"
    make_fault, why = FAULTS[fault]
    make_fault(victim)
    notes, seen = [], []
    res = run_table2(env, S, N, scale="linear", out=out, on_note=notes.append,
                     on_cell=lambda c, resumed: seen.append((c.s, c.n, resumed)))
    assert notes == [f"recomputed {victim}: {why}"] and res.notes == notes
    assert [x for x in seen if not x[2]] == [(1.7, 100, False)] and len(seen) == 4
    assert res.cell(1.7, 100).rmse == pytest.approx(reference.cell(1.7, 100).rmse, rel=1e-12)
    assert res.cell(1.7, 100).rmse != 0.125
    assert "note:" not in capsys.readouterr().err              # on_note given: not on stderr
    again = run_table2(env, S, N, scale="linear", out=out, on_note=notes.append)
    assert len(notes) == 1 and again.cell(1.7, 100).rmse == res.cell(1.7, 100).rmse


def test_api_without_on_note_prints_the_note_on_stderr(map_file, tmp_path, capsys):
    env = load_envmap(map_file)
    run_table2(env, S, N, scale="linear", out=tmp_path)
    _edited(tmp_path / "cells" / f"{VICTIM}.json")
    res = run_table2(env, S, N, scale="linear", out=tmp_path)
    err = capsys.readouterr().err.splitlines()
    assert [ln for ln in err if ln.startswith("note:")] == [f"note: {res.notes[0]}"]


def test_unreadable_config_is_rewritten_and_cells_still_resume(map_file, tmp_path):
    env = load_envmap(map_file)
    run_table2(env, S, N, scale="linear", out=tmp_path)
    cfg = tmp_path / "table2_config.json"
    _random_bytes(cfg)
    notes, seen = [], []
    run_table2(env, S, N, scale="linear", out=tmp_path, on_note=notes.append,
               on_cell=lambda c, resumed: seen.append(resumed))
    assert notes == [f"rewrote {cfg}: corrupt config (not a JSON file (binary data)); nothing to "
                     f"do: each cell carries its own copy, and only this run's cells are reused"]
    assert all(seen)
    assert json.loads(cfg.read_text())["kind"] == "table2"


@pytest.mark.parametrize("fault", ["edited-rmse", "other-cell", "directory"])
def test_library_recomputes_a_faulty_cell_with_one_note(fault, tmp_path):
    maps = [gp(1), gp(2)]
    fresh = run_table2_library(maps, S, N, scale="linear", options=INLINE)
    out = tmp_path / "lib"
    run_table2_library(maps, S, N, scale="linear", out=out, options=INLINE)
    victim = out / "gp2" / "cells" / f"{VICTIM}.json"
    make_fault, why = FAULTS[fault]
    make_fault(victim)
    lib = run_table2_library(maps, S, N, scale="linear", out=out, options=INLINE)
    assert [n for n in lib.notes if str(victim) in n] == [f"recomputed {victim}: {why}"]
    assert lib.cells_computed == 1 and lib.cells_resumed == 7
    assert lib.maps[1].cell(1.7, 100).rmse == pytest.approx(fresh.maps[1].cell(1.7, 100).rmse,
                                                            rel=1e-12)


def test_library_fit_recomputes_an_edited_evaluation(tmp_path):
    maps = [gp(1, channels=1), gp(2, channels=1)]
    fresh = fit_smoothness_library(maps, n=200, scale="linear", options=INLINE)
    out = tmp_path / "fit"
    first = fit_smoothness_library(maps, n=200, scale="linear", out=out, options=INLINE)
    cells = sorted((out / "gp1" / "fit_likelihood_n200" / "cells").glob("s*.json"))
    victim = cells[len(cells) // 2]
    doc = json.loads(victim.read_text())
    doc["cell"]["score"] = -1e9                                # would become the minimum
    victim.write_text(json.dumps(doc))
    lib = fit_smoothness_library(maps, n=200, scale="linear", out=out, options=INLINE)
    assert [n for n in lib.notes if str(victim) in n] == [
        f"recomputed {victim}: checksum mismatch (edited or corrupt)"]
    total = first.evaluations_resumed + sum(len(f.curve) for f in first.fits)
    assert lib.evaluations_resumed == total - 1
    for a, b in zip(lib.fits, fresh.fits):
        assert a.s == pytest.approx(b.s, rel=1e-12)


def test_validate_recomputes_an_edited_cell(tmp_path, capsys):
    import envfit.validate._pipeline as V
    env = EnvMap(gaussian_process_map(1.5, 16, seed=4, channels=2), name="gp-tiny")
    cfg = V.ValidateConfig(s=1.5, brdfs=("diffuse",), pointsets=("sf",), weights=("equal",),
                           n_values=(16, 32), axes=40, scale="linear", truncation=False,
                           fit_n=100)
    fresh = V.run_validation(env, cfg)
    V.run_validation(env, cfg, out=tmp_path)
    victim = tmp_path / "cells" / "quad_diffuse_sf_equal_32.json"
    doc = json.loads(victim.read_text())
    doc["cell"]["measured_rmse"] = 0.5
    victim.write_text(json.dumps(doc))
    capsys.readouterr()
    res = V.run_validation(env, cfg, out=tmp_path)
    err = capsys.readouterr().err
    line = f"recomputed {victim}: checksum mismatch (edited or corrupt)"
    assert [ln for ln in err.splitlines() if str(victim) in ln] == [f"note: {line}"]
    assert line in res.notes and "Traceback" not in err
    assert res.results[0]["measured_rmse"] == pytest.approx(
        fresh.results[0]["measured_rmse"], rel=1e-12)


# -------------------------------------------------------------------------------- the lock
PAUSED_RUN = """
import sys
from envfit.maps import load_envmap
from envfit.fit._table2 import run_table2
state = {"paused": False}
def on_cell(cell, resumed):
    if not state["paused"]:
        state["paused"] = True
        print("one cell done", flush=True)
        sys.stdin.readline()
run_table2(load_envmap(sys.argv[1]), [1.3, 1.7], [50, 100], scale="linear", out=sys.argv[2],
           on_cell=on_cell)
"""

KILLED_RUN = """
import os, signal, sys
from envfit.maps import load_envmap
from envfit.fit._table2 import run_table2
done = []
def on_cell(cell, resumed):
    done.append(cell)
    if len(done) == 2:
        os.kill(os.getpid(), signal.SIGKILL)
run_table2(load_envmap(sys.argv[1]), [1.3, 1.7], [50, 100], scale="linear", out=sys.argv[2],
           on_cell=on_cell)
"""


def _python(code: str, *args, **kw) -> subprocess.Popen:
    # not from the repository root: there ./envfit (without theory/, which installs as
    # envfit.theory) would shadow the installed package
    return subprocess.Popen([sys.executable, "-c", code, *map(str, args)],
                            cwd=tempfile.gettempdir(), text=True, **kw)


def test_second_run_on_a_busy_folder_exits_2_and_computes_nothing(
        map_file, tmp_path, monkeypatch, capsys, count_interpolators):
    """Choice (envfit.base._store): a second run exits 2 at once; no cell is computed twice."""
    monkeypatch.setattr(cli, "COMMANDS", ("table2",))
    out = tmp_path / "out"
    first = _python(PAUSED_RUN, map_file, out, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        assert first.stdout.readline().strip() == "one cell done"
        capsys.readouterr()
        assert cli_table2(map_file, out) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Traceback" not in err[0]
        assert err[0].endswith(f"{out} is in use by another envfit run (pid {first.pid}); "
                               "wait for it or use another --out")
        assert count_interpolators == []
        first.stdin.write("\n")
        first.stdin.flush()
        assert first.wait(timeout=120) == 0
    finally:
        if first.poll() is None:
            first.kill()
    assert cli_table2(map_file, out) == 0
    assert count_interpolators == []          # all 4 cells were computed once, by the first run
    assert len(list((out / "cells").glob("*.json"))) == 4


def test_library_run_on_a_locked_folder_is_refused(tmp_path):
    holder = _python("import sys; from envfit.base._store import FolderLock\n"
                     "l = FolderLock(sys.argv[1]).acquire(); print('held', flush=True)\n"
                     "sys.stdin.readline()", tmp_path, stdin=subprocess.PIPE,
                     stdout=subprocess.PIPE)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(StoreBusyError, match=rf"\(pid {holder.pid}\)"):
            run_table2_library([gp(1)], S, N, scale="linear", out=tmp_path, options=INLINE)
        assert not list(tmp_path.glob("*/cells"))
    finally:
        holder.stdin.close()
        holder.wait(timeout=60)
    with FolderLock(tmp_path, timeout=0):      # released with its process
        pass


def test_sigkill_leaves_a_lock_file_that_blocks_nobody(map_file, reference, tmp_path):
    out = tmp_path / "out"
    killed = _python(KILLED_RUN, map_file, out)
    assert killed.wait(timeout=120) == -signal.SIGKILL
    assert (out / LOCK_NAME).exists()
    assert len(list((out / "cells").glob("*.json"))) == 2
    seen = []
    res = run_table2(load_envmap(map_file), S, N, scale="linear", out=out,
                     on_cell=lambda c, resumed: seen.append(resumed), on_note=pytest.fail)
    assert seen == [True, True, False, False]
    np.testing.assert_allclose(res.rmse_table(), reference.rmse_table(), rtol=1e-13, atol=0)


def test_lock_is_shared_within_one_process(tmp_path):
    with FolderLock(tmp_path), FolderLock(tmp_path, timeout=0):
        pass


# ------------------------------------------------------------------------- advisor cache
def _advise(env, cache_dir, **kw):
    return advise(env, "glossy", 0.05, scale="linear", s=1.5, fit_n=150, pointsets=("sf",),
                  weights=("equal",), bases=("sh",), nmax=1024, seeds=1, cache_dir=cache_dir,
                  **kw)


def _rows(a):
    """Rule, N, L and the prediction (to 1e-10: threaded BLAS/ducc0 sum in any order)."""
    return [(r.label, r.n, r.L, pytest.approx(r.predicted_rmse, rel=1e-10)) for r in a.rows]


def _unwritable(tmp_path: Path) -> Path:
    """A cache folder this process cannot write: chmod 0o500, or (root, for whom chmod does
    not deny) a folder under a regular file."""
    if os.geteuid() == 0:
        blocker = tmp_path / "a-file"
        blocker.write_text("not a folder")
        return blocker / "cache"
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o500)
    return d


@pytest.fixture(scope="module")
def gp16():
    return EnvMap(gaussian_process_map(1.5, 16, seed=3, channels=3), name="gp16")


def test_unwritable_advisor_cache_is_a_note(gp16, tmp_path):
    bad = _unwritable(tmp_path)
    try:
        problem = cache_write_problem(bad)
        assert problem is not None and str(bad) in problem
        assert cache_write_problem(tmp_path / "fine") is None
        a = _advise(gp16, bad)
        assert any("cache switched off" in n for n in a.notes)
        assert _rows(a) == _rows(_advise(gp16, None, cache=False))
    finally:
        if bad.name == "ro":
            bad.chmod(0o700)


@pytest.mark.parametrize("fault", ["edited", "random-bytes", "old-format"])
def test_faulty_advisor_cache_entry_is_recomputed_with_one_note(fault, gp16, tmp_path):
    first = _advise(gp16, tmp_path)
    victim = next((tmp_path / "advise" / "fit").glob("*.json"))
    doc = json.loads(victim.read_text())
    if fault == "edited":
        doc["value"]["sigma_channels"] = [123.0] * 3
        victim.write_text(json.dumps(doc))
        why = "checksum mismatch (edited or corrupt)"
    elif fault == "random-bytes":
        _random_bytes(victim)
        why = "not a JSON file (binary data)"
    else:
        victim.write_text(json.dumps({k: doc[k] for k in ("version", "kind", "key", "value")}))
        why = "written by an older envfit (no checksum)"
    again = _advise(gp16, tmp_path)
    assert [n for n in again.notes if str(victim) in n] == [f"cache: recomputed {victim}: {why}"]
    assert not again.fit_cached and _rows(again) == _rows(first)
    assert json.loads(victim.read_text())["sha256"]           # rewritten, sound again


def test_cli_advise_with_an_unwritable_cache_is_a_note(tmp_path, monkeypatch, capsys):
    bad = _unwritable(tmp_path)
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(bad))
    try:
        rc = cli.main(["advise", "--max-height", "16", "--target-rmse", "0.05", "--fit-n", "150",
                       "--pointsets", "sf", "--weights", "equal", "--bases", "sh",
                       "--no-renderer"])
    finally:
        if bad.name == "ro":
            bad.chmod(0o700)
    cap = capsys.readouterr()
    assert rc == 0 and "Traceback" not in cap.out + cap.err
    assert any("note:" in ln and str(bad) in ln for ln in (cap.out + cap.err).splitlines())


# ------------------------------------- issue 22 item 9: forged entries, folders, corrupt configs
import envfit.advisor._cache as cache_mod                  # noqa: E402
from envfit.advisor._cache import AdviseCache, entry_problem   # noqa: E402
from envfit.base._store import canonical_sha256            # noqa: E402


def _forge(victim: Path, edit) -> None:
    """Edit an advisor cache entry's value and give it a *valid* checksum again (the cache's
    own rule: sha256 of the canonical JSON of version, format, kind, key and value)."""
    doc = json.loads(victim.read_text())
    edit(doc["value"])
    body = {k: doc[k] for k in ("version", "format", "kind", "key", "value")}
    doc["sha256"] = canonical_sha256(body)
    victim.write_text(json.dumps(doc))


def _set(field, value):
    return lambda v: v.update({field: value})


FORGED_FIT = {
    "wrong-type": (_set("s", "1.5"), "invalid fit entry: s is a string, not a number"),
    "s-out-of-range": (_set("s", 5), "invalid fit entry: s = 5 is outside (1, 2)"),
    "nan-sigma": (lambda v: v["sigma_channels"].__setitem__(0, float("nan")),
                  "invalid fit entry: sigma_channels holds a non-finite value (nan)"),
    "sigma-not-a-list": (_set("sigma_channels", {"r": 1}),
                         "invalid fit entry: sigma_channels is not a 1-D array of numbers"),
    "not-an-object": (lambda v: v.clear(), "invalid fit entry: lacks s, sigma_channels, source"),
}


@pytest.mark.parametrize("fault", list(FORGED_FIT))
def test_forged_fit_entry_with_a_valid_checksum_is_recomputed_alone(fault, gp16, tmp_path):
    first = _advise(gp16, tmp_path)
    victim = next((tmp_path / "advise" / "fit").glob("*.json"))
    edit, why = FORGED_FIT[fault]
    _forge(victim, edit)
    again = _advise(gp16, tmp_path)
    assert [n for n in again.notes if str(victim) in n] == [f"cache: recomputed {victim}: {why}"]
    assert not any("switched off" in n for n in again.notes)
    assert not again.fit_cached and _rows(again) == _rows(first)
    assert all(r.evaluations == 0 for r in again.rows)         # the curves: still cached
    assert entry_problem("fit", json.loads(victim.read_text())["value"]) is None   # rewritten


def test_a_folder_in_place_of_an_entry_does_not_switch_the_cache_off(gp16, tmp_path):
    first = _advise(gp16, tmp_path)
    victim = next((tmp_path / "advise" / "fit").glob("*.json"))
    victim.unlink()
    victim.mkdir()
    (victim / "junk.txt").write_text("a folder where the entry should be")
    again = _advise(gp16, tmp_path)
    assert [n for n in again.notes if str(victim) in n] == [
        f"cache: recomputed {victim}: a folder, not a file (moved to {victim.name}.folder)"]
    assert not any("switched off" in n for n in again.notes)
    assert _rows(again) == _rows(first) and all(r.evaluations == 0 for r in again.rows)
    assert victim.is_file() and (victim.parent / f"{victim.name}.folder" / "junk.txt").exists()
    third = _advise(gp16, tmp_path)
    assert third.fit_cached and not [n for n in third.notes if "cache" in n]


def test_an_unmovable_folder_keeps_its_entry_in_memory_only(tmp_path, monkeypatch):
    c = AdviseCache(tmp_path)
    fit = {"s": 1.5, "sigma_channels": [0.2, 0.3], "source": "given"}
    p = c.path("fit", {"map": "a"})
    p.mkdir(parents=True)
    (p / "x").write_text("x")
    monkeypatch.setattr(cache_mod, "move_aside", lambda path: "")
    assert c.load("fit", {"map": "a"}) is None
    c.save("fit", {"map": "a"}, fit)
    c.save("fit", {"map": "b"}, fit)
    assert c.enabled and c.load("fit", {"map": "a"}) == fit == c.load("fit", {"map": "b"})
    assert c.path("fit", {"map": "b"}).is_file() and p.is_dir()
    assert c.notes == [f"cache: recomputed {p}: a folder, not a file",
                       f"cache: cannot write {p} (a folder is in its place); this entry is "
                       f"kept in memory for this run only"]
    assert AdviseCache(tmp_path).load("fit", {"map": "b"}) == fit


GOOD = {
    "power": {"power": [[1.0, 0.5], [2.0, 0.25]]},
    "transfer": {"tau": [1.0, 0.6, 0.3]},
    "wce": {"16": {"power": [0.0, 1e-3], "dev2": 0.0, "weight_sum": 1.0, "e2_plain": 2e-3}},
}
FORGED_OTHER = [
    ("power", lambda v: v["power"][1].__setitem__(0, -1.0),
     "power holds -1.0, outside [0, inf]"),
    ("power", lambda v: v["power"].pop(), None),                   # (C, L+1) checked by caller
    ("power", lambda v: v["power"][0].pop(), "power is not a 2-D array of numbers"),
    ("transfer", lambda v: v["tau"].__setitem__(1, "0.6"), "tau is not a 1-D array of numbers"),
    ("transfer", lambda v: v["tau"].__setitem__(1, float("inf")),
     "tau holds a non-finite value (inf)"),
    ("wce", lambda v: v.update({"0": v["16"]}), "curve point '0' is not a sample count N >= 1"),
    ("wce", lambda v: v["16"].update(dev2=-0.5), "N = 16: dev2 = -0.5 is negative"),
    ("wce", lambda v: v["16"].update(weight_sum=None),
     "N = 16: weight_sum is null, not a number"),
    ("wce", lambda v: v["16"].pop("power"), "N = 16: lacks power"),
]


@pytest.mark.parametrize("kind, edit, why", FORGED_OTHER)
def test_every_kind_is_checked_against_its_schema(kind, edit, why, tmp_path):
    key = {"map": "m", "kind-test": kind}
    c = AdviseCache(tmp_path)
    if kind == "wce":
        c.merge_curve(key, {16: GOOD["wce"]["16"]})
    else:
        c.save(kind, key, GOOD[kind])
    c.save("fit", {"map": "m"}, {"s": 1.5, "sigma_channels": [0.2], "source": "given"})
    victim = c.path(kind, key)
    _forge(victim, edit)
    fresh = AdviseCache(tmp_path)
    got = fresh.load_curve(key) if kind == "wce" else fresh.load(kind, key)
    if why is None:
        assert got and fresh.notes == []
        return
    assert not got and fresh.notes == [f"cache: recomputed {victim}: invalid {kind} entry: {why}"]
    assert fresh.load("fit", {"map": "m"})["s"] == 1.5 and fresh.enabled   # the rest: in use


def test_a_forged_renderer_spectrum_is_recomputed(tmp_path):
    spec = {"technique": "map", "brdf": "diffuse", "shininess": None, "heuristic": "balance",
            "fraction": 0.5, "band": 1, "grid": 8, "variance": [0.1, 0.2],
            "power": [[[0.0] * 2] * 3] * 2, "cross": {"real": [0.0] * 3, "imag": [0.0] * 3},
            "mean": 1.0, "axes": 4}
    assert entry_problem("renderer", spec) is None
    c = AdviseCache(tmp_path)
    c.save("renderer", {"k": 1}, spec)
    _forge(c.path("renderer", {"k": 1}),
           lambda v: v["cross"]["imag"].__setitem__(0, float("nan")))
    fresh = AdviseCache(tmp_path)
    assert fresh.load("renderer", {"k": 1}) is None
    assert fresh.notes[0].endswith("invalid renderer entry: cross.imag holds a non-finite "
                                   "value (nan)")
    assert entry_problem("renderer", {**spec, "band": 1.5}) == \
        "invalid renderer entry: band is float, not an integer"


CORRUPT_CONFIGS = {
    "empty-object": (lambda p: p.write_text("{}"), "an empty JSON object {}"),
    "empty-file": (lambda p: p.write_text(""), "an empty file"),
    "truncated": (lambda p: p.write_text('{"kind": "tab'), "not valid JSON (truncated or corrupt)"),
    "a-list": (lambda p: p.write_text("[1, 2]"), "a JSON list, not an object"),
    "no-kind": (lambda p: p.write_text('{"seed": 0}'), "no 'kind' field"),
    "other-kind": (lambda p: p.write_text('{"kind": "validate", "seed": 0}'),
                   "kind 'validate', not 'table2'"),
    "a-folder": (lambda p: (p.unlink(), p.mkdir()),
                 "a folder, not a file (moved to table2_config.json.folder)"),
}


@pytest.mark.parametrize("fault", list(CORRUPT_CONFIGS))
def test_corrupt_store_config_is_one_note_not_another_run(fault, map_file, tmp_path):
    env = load_envmap(map_file)
    run_table2(env, S, N, scale="linear", out=tmp_path)
    cfg = tmp_path / "table2_config.json"
    make, why = CORRUPT_CONFIGS[fault]
    make(cfg)
    notes, seen = [], []
    run_table2(env, S, N, scale="linear", out=tmp_path, on_note=notes.append,
               on_cell=lambda c, resumed: seen.append(resumed))
    assert notes == [f"rewrote {cfg}: corrupt config ({why}); nothing to do: each cell carries "
                     f"its own copy, and only this run's cells are reused"]
    assert all(seen) and len(seen) == 4
    assert json.loads(cfg.read_text())["kind"] == "table2"


def test_cli_empty_config_is_one_note_and_another_run_is_still_refused(map_file, tmp_path,
                                                                       capsys):
    out = tmp_path / "out"
    assert cli_table2(map_file, out) == 0
    cfg = out / "table2_config.json"
    cfg.write_text("{}")
    capsys.readouterr()
    assert cli_table2(map_file, out) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if str(cfg) in ln]
    assert len(lines) == 1 and "corrupt config" in lines[0] and "different" not in err
    assert cli_table2(map_file, out, "--seed", "3") == 2           # a real other run
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "different table2 run" in err[0] and "seed" in err[0]


def _forge_cell(victim: Path, edit) -> None:
    """Edit a stored cell and give it a *valid* checksum again (the store's rule: sha256 of
    the canonical JSON of format, config, key and cell)."""
    doc = json.loads(victim.read_text())
    edit(doc["cell"])
    doc["sha256"] = canonical_sha256({k: doc[k] for k in ("format", "config", "key", "cell")})
    victim.write_text(json.dumps(doc))


FORGED_CELLS = {
    "rmse-string": (_set("rmse", "abc"), "rmse is a string, not a number"),
    "rmse-nan": (_set("rmse", float("nan")), "rmse is nan, not finite"),
    "rmse-negative": (_set("rmse", -0.5), "rmse = -0.5 is negative"),
    "other-n": (_set("n", 1000000000), "n is 1000000000, not 100"),
    "bad-solver": (_set("solver", "gmres"), "solver is 'gmres', not 'cholesky' or 'iterative'"),
}


@pytest.mark.parametrize("fault", list(FORGED_CELLS))
def test_forged_table2_cell_with_a_valid_checksum_is_recomputed(fault, map_file, reference,
                                                                tmp_path):
    env = load_envmap(map_file)
    run_table2(env, S, N, scale="linear", out=tmp_path)
    victim = tmp_path / "cells" / f"{VICTIM}.json"
    edit, why = FORGED_CELLS[fault]
    _forge_cell(victim, edit)
    notes = []
    res = run_table2(env, S, N, scale="linear", out=tmp_path, on_note=notes.append)
    assert notes == [f"recomputed {victim}: invalid cell: {why}"]
    assert res.cell(1.7, 100).rmse == pytest.approx(reference.cell(1.7, 100).rmse, rel=1e-12)
    assert stored_cell(tmp_path / "cells")["n"] == 100


def test_library_recomputes_a_forged_cell(tmp_path):
    maps = [gp(1), gp(2)]
    out = tmp_path / "lib"
    run_table2_library(maps, S, N, scale="linear", out=out, options=INLINE)
    victim = out / "gp2" / "cells" / f"{VICTIM}.json"
    _forge_cell(victim, _set("rmse_solid_angle", None))
    lib = run_table2_library(maps, S, N, scale="linear", out=out, options=INLINE)
    assert [n for n in lib.notes if str(victim) in n] == [
        f"recomputed {victim}: invalid cell: rmse_solid_angle is null, not a number"]
    assert lib.cells_computed == 1 and lib.cells_resumed == 7

"""Every file envfit reads is a regular file of bounded size, and a cache entry is consistent
in itself (issue 38): envfit.base._files, envfit.maps._io / _lazy_maps, envfit.base._stored_json,
envfit.advisor._cache, envfit.base._atomic.

A FIFO, a device, a socket, a symbolic link loop or a dangling link given as a map is named
in one line (exit 2) without being opened; in place of a cache entry or a stored cell it is
a bad entry: recomputed with a note, the answer equal to a fresh run's. Runs that could hang
on a regression (an ``open()`` of a FIFO blocks in the kernel) run in a subprocess with a
timeout, so a hang fails the test instead of blocking the suite.
"""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from envfit.base._files import read_bounded, regular_file_problem
from envfit.base._store import canonical_sha256
from envfit.base._stored_json import read_json_file
from envfit.data_gen import sun_gp_map
from envfit.maps import EnvMap, save_envmap

#: seconds a subprocess may take: envfit's import and a tiny map, never a hang
LIMIT = 120


def _envfit(*argv, env=None) -> tuple[int, list[str], str]:
    """``envfit ARGV`` in a subprocess killed after LIMIT s: (exit code, stderr lines,
    stdout). A run that hangs raises subprocess.TimeoutExpired: the test fails."""
    r = subprocess.run([sys.executable, "-m", "envfit.cli", *map(str, argv)],
                       capture_output=True, text=True, timeout=LIMIT,
                       cwd=tempfile.gettempdir(),   # outside the checkout: the installed envfit
                       env={**os.environ, "TQDM_DISABLE": "1", **(env or {})})
    assert "Traceback" not in r.stderr, r.stderr
    return r.returncode, [ln for ln in r.stderr.splitlines() if ln.strip()], r.stdout


def _refused(argv, words: str, env=None) -> str:
    """Exit 2, one stderr line holding ``words``, nothing on stdout; the line."""
    rc, err, out = _envfit(*argv, env=env)
    assert rc == 2 and len(err) == 1, err
    assert words in err[0], err[0]
    assert out == ""
    return err[0]


@pytest.fixture
def tiny_map(tmp_path) -> Path:
    a = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32) + 0.1
    return save_envmap(tmp_path / "tiny.exr", a)


def _fifo(p: Path) -> Path:
    os.mkfifo(p)
    return p


def _socket(p: Path):
    """A Unix socket bound at ``p`` (by its name from its folder: socket paths are short)."""
    s = socket.socket(socket.AF_UNIX)
    here = os.getcwd()
    os.chdir(p.parent)
    try:
        s.bind(p.name)
    finally:
        os.chdir(here)
    return s


# --------------------------------------------------------------------- maps (inputs)
def test_fifo_as_a_map_is_named_not_opened(tmp_path):
    p = _fifo(tmp_path / "fifo.exr")
    line = _refused(["info", p], "named pipe (FIFO)")
    assert line == f"envfit info: error: {p}: is a named pipe (FIFO), not an image file"


@pytest.mark.parametrize("device, words", [("/dev/null", "is a character device"),
                                            ("/dev/zero", "is a character device")])
def test_a_device_as_a_map(device, words, tmp_path):
    assert os.path.exists(device), f"Linux has {device}"      # the platform CI runs on
    _refused(["info", device], words)
    link = tmp_path / "zero.exr"                    # a map file that is a link to a device
    os.symlink(device, link)
    line = _refused(["info", link], words)
    assert f"is a symbolic link to {device}, which is a character device" in line


def test_a_socket_as_a_map(tmp_path):
    s = _socket(tmp_path / "sock.exr")
    try:
        _refused(["info", tmp_path / "sock.exr"], "is a socket, not an image file")
    finally:
        s.close()


def test_symlink_loop_and_dangling_link_say_what_they_are(tmp_path):
    loop = tmp_path / "loop.exr"
    os.symlink(loop.name, loop)
    line = _refused(["info", loop], "symbolic link loop")
    assert "no such file" not in line
    dangling = tmp_path / "gone.exr"
    os.symlink("nowhere.exr", dangling)
    _refused(["info", dangling], "is a dangling symbolic link to nowhere.exr")
    _refused(["info", tmp_path / "absent.exr"], "absent.exr: no such file")


@pytest.mark.parametrize("how", ["folder", "pattern", "list"])
def test_a_fifo_in_a_library_is_refused_before_work(how, tmp_path, tiny_map):
    lib = tmp_path / "lib"
    lib.mkdir()
    save_envmap(lib / "a.exr", np.ones((8, 16, 3), np.float32))
    fifo = _fifo(lib / "b.exr")
    maps = {"folder": [lib], "pattern": [f"{lib}/*.exr"], "list": [tiny_map, fifo]}[how]
    line = _refused(["fit", *maps, "--n", "50", "--out", tmp_path / "out"],
                    f"{fifo}")
    assert "is a named pipe (FIFO), not an image file" in line


def test_regular_file_problem_words(tmp_path, tiny_map):
    assert regular_file_problem(tiny_map) is None
    assert regular_file_problem(tmp_path) == "is a folder, not a regular file"
    assert regular_file_problem(tiny_map / "x") .startswith("no such file")
    small = tmp_path / "small.json"
    small.write_text("[" + "0," * 24 + "0]")                        # 51 bytes
    assert regular_file_problem(small, max_bytes=50) == (
        "is 51 bytes; envfit reads at most 50 bytes from such a file")
    assert regular_file_problem(small, max_bytes=51) is None


# ------------------------------------------------------------------ bounded JSON reads
def test_json_reads_are_bounded_and_typed(tmp_path):
    p = tmp_path / "big.json"
    p.write_text(json.dumps(list(range(100))))
    assert read_json_file(p)[0] == list(range(100))
    doc, why = read_json_file(p, max_bytes=100)
    assert doc is None and why.startswith(f"{p.stat().st_size} bytes; envfit reads at most 100")
    assert read_bounded(tmp_path / "absent.json") == (None, None)
    zero = tmp_path / "zero.json"
    os.symlink("/dev/zero", zero)
    assert read_json_file(zero) == (None, "a symbolic link to /dev/zero, which is a character "
                                          "device, not a file")


def _in_child(code: str) -> list[str]:
    """Run ``code`` in a Python subprocess killed after LIMIT s; its stdout lines."""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=LIMIT)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def test_fifo_and_device_cells_of_a_result_store_are_recomputed(tmp_path):
    """A FIFO and a link to /dev/zero in place of stored cells: each one note, the cell
    recomputed and rewritten as a regular file, nothing blocks."""
    lines = _in_child(f"""
import os
from envfit.base._store import ResultStore
s = ResultStore({str(tmp_path)!r}, {{"a": 1}}, kind="t", on_note=print)
os.mkfifo(s.cells_dir / "k1.json")
os.symlink("/dev/zero", s.cells_dir / "k2.json")
print(s.get("k1"), s.get("k2"))
s.put("k1", {{"x": 1}}); s.put("k2", {{"x": 2}})
print(s.get("k1"), s.get("k2"), (s.cells_dir / "k2.json").is_symlink())
""")
    cells = tmp_path / "cells"
    assert lines == [f"recomputed {cells / 'k1.json'}: a named pipe (FIFO), not a file",
                     f"recomputed {cells / 'k2.json'}: a symbolic link to /dev/zero, which is "
                     "a character device, not a file",
                     "None None", "{'x': 1} {'x': 2} False"]


# ---------------------------------------------------------------- outputs (--json)
def test_json_onto_a_fifo_or_proc_says_what_is_true(tmp_path, tiny_map):
    fifo = _fifo(tmp_path / "out.json")
    _refused(["info", tiny_map, "--json", fifo],
             f"cannot write --json {fifo}: it is a named pipe (FIFO), not a regular file")
    assert os.path.isfile("/proc/version"), "Linux has /proc"  # the platform CI runs on
    line = _refused(["info", tiny_map, "--json", "/proc/version"],
                    "cannot write --json /proc/version: no file can be created in /proc")
    assert "No such file" not in line.split("(")[0]


# ------------------------------------------------------------------- --fix-nonfinite
def _nan_map(tmp_path, name: str, nan: tuple) -> Path:
    a = np.random.default_rng(1).random((16, 32, 3)).astype(np.float32) + 0.1
    a[nan] = np.nan
    return save_envmap(tmp_path / name, a)


def test_fix_nonfinite_says_the_truth_both_ways(tmp_path):
    from envfit.cli import main
    few = _nan_map(tmp_path, "few.exr", (slice(3, 4), slice(5, 6), slice(None)))
    rc, err, out = _envfit("info", few, "--fix-nonfinite", "--json", "-")
    info = json.loads(out)
    assert rc == 0 and err == []
    assert info["notes"] == ["replaced 3 non-finite value(s) (3 NaN, 0 Inf) in 1 pixel(s) by "
                             "the mean of their finite neighbours"]
    assert main(["info", str(few), "--fix-nonfinite", "-q"]) == 0
    every = _nan_map(tmp_path, "allnan.exr", (slice(None),) * 3)
    line = _refused(["info", every, "--fix-nonfinite"], "all 1536 values are non-finite")
    assert "replaced" not in line and "no finite neighbour" in line
    blob = _nan_map(tmp_path, "blob.exr", (slice(4, 8), slice(10, 14), slice(0, 1)))
    line = _refused(["info", blob, "--fix-nonfinite"],
                    "4 of the 16 non-finite values have no finite neighbour")
    assert "row 5, col 11, channel 0" in line
    chan = _nan_map(tmp_path, "chan.exr", (slice(None), slice(None), slice(1, 2)))
    _refused(["info", chan, "--fix-nonfinite"], "channel 1 is non-finite throughout")


# ---------------------------------------- advise --renderer: the renderer_cells cache
ADVISE = ["--renderer", "mitsuba3", "--sampler", "independent", "--strategies", "brdf",
          "--target-relative", "0.05", "--renderer-level", "3", "--renderer-normals", "6"]


@pytest.fixture(scope="module")
def sun_file(tmp_path_factory) -> Path:
    env = EnvMap(sun_gp_map(16, seed=2, sun_radiance=30.0, sun_radius=0.25)[0], name="sun16")
    return save_envmap(tmp_path_factory.mktemp("maps") / "sun16.exr", env)


@pytest.fixture(scope="module")
def fresh(sun_file, tmp_path_factory) -> dict:
    """The renderer advice computed without any cache."""
    rc, err, out = _envfit("advise", sun_file, *ADVISE, "--no-cache", "--json", "-")
    assert rc == 0
    return json.loads(out)["renderer"]


def _advise(sun_file, cache: Path) -> tuple[dict, list[str]]:
    """The renderer section of ``advise --json -`` and its notes (with ``--json -`` the
    notes are in the JSON, not on stderr)."""
    rc, err, out = _envfit("advise", sun_file, *ADVISE, "--cache-dir", cache, "--json", "-")
    assert rc == 0 and err == []
    d = json.loads(out)["renderer"]
    return d, d["notes"]


def _forge(entry: Path, edit) -> None:
    """Edit the entry's value and give it a valid checksum again."""
    doc = json.loads(entry.read_text())
    edit(doc["value"]["cells"])
    body = {k: doc[k] for k in ("version", "format", "kind", "key", "value")}
    entry.write_text(json.dumps({**body, "sha256": canonical_sha256(body)}))


def _zero(cells):
    cells["brdf:1"] = {"rmse": 0.0, "mse": [0.0, 0.0, 0.0]}       # consistent, but 0


def _tiny_rmse(cells):
    cells["brdf:1"] = {"rmse": 1e-9, "mse": [16.0, 16.0, 16.0]}    # rmse² is not the mean


def _all_low(cells):
    for c in cells.values():
        c["rmse"] = c["rmse"] * 0.5                                # each cell off by 4x


@pytest.mark.parametrize("edit, why", [
    (_zero, "cell brdf:1: rmse = 0 for a map that is not constant"),
    (_tiny_rmse, "cell brdf:1: rmse = 1e-09 is not the root of the mean of its mse (16.0)"),
    (_all_low, "is not the root of the mean of its mse")])
def test_inconsistent_renderer_cells_are_recomputed(edit, why, sun_file, fresh, tmp_path):
    cache = tmp_path / "cache"
    first, _ = _advise(sun_file, cache)
    assert first["predictions"] == fresh["predictions"]
    assert first["recommendation"] == fresh["recommendation"]
    (entry,) = (cache / "advise" / "renderer_cells").glob("*.json")
    _forge(entry, edit)
    again, err = _advise(sun_file, cache)
    assert any(ln.startswith(f"cache: recomputed {entry}: invalid renderer_cells entry: ")
               and why in ln for ln in err), err
    assert again["recommendation"] == fresh["recommendation"]
    assert again["recommendation"]["spp"] > 1
    assert again["predictions"] == fresh["predictions"]
    assert again["model"]["passes"] >= 1
    third, err = _advise(sun_file, cache)                         # rewritten: used as is
    assert third["model"]["passes"] == 0 and not any("recomputed" in ln for ln in err)
    assert third["predictions"] == fresh["predictions"]


def test_a_constant_maps_zero_rmse_is_kept(tmp_path):
    """The other way: a constant map's BSDF-sampled diffuse cell is truly 0 (the estimator is
    exact): cached and read back without a note."""
    const = save_envmap(tmp_path / "const.exr", np.ones((16, 32, 3), np.float32))
    cache = tmp_path / "cache"
    runs = [_envfit("advise", const, *ADVISE, "--cache-dir", cache, "--json", "-")
            for _ in range(2)]
    (rc1, _, out1), (rc2, err2, out2) = runs
    d1, d2 = json.loads(out1)["renderer"], json.loads(out2)["renderer"]
    assert rc1 == rc2 == 0 and err2 == [] and not any("recomputed" in n for n in d2["notes"])
    assert d1["recommendation"]["predicted_rmse"] == 0.0 and d2["model"]["passes"] == 0
    assert d2["predictions"] == d1["predictions"]


@pytest.mark.parametrize("kind", ["fifo", "devzero", "socket", "loop"])
def test_a_renderer_cells_entry_that_is_no_file_is_recomputed(kind, sun_file, fresh, tmp_path):
    cache = tmp_path / "cache"
    _advise(sun_file, cache)
    (entry,) = (cache / "advise" / "renderer_cells").glob("*.json")
    entry.unlink()
    held = None
    if kind == "fifo":
        os.mkfifo(entry)
    elif kind == "devzero":
        os.symlink("/dev/zero", entry)
    elif kind == "socket":
        held = _socket(entry)
    else:
        os.symlink(entry.name, entry)
    try:
        again, err = _advise(sun_file, cache)
    finally:
        if held is not None:
            held.close()
    what = {"fifo": "a named pipe (FIFO)", "devzero": "a symbolic link to /dev/zero",
            "socket": "a socket", "loop": "a symbolic link loop"}[kind]
    assert any(ln.startswith(f"cache: recomputed {entry}: {what}") for ln in err), err
    assert again["predictions"] == fresh["predictions"]
    assert entry.is_file() and not entry.is_symlink()

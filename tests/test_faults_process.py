"""Faults from outside the process: SIGTERM mid-sweep, a map file that changes during a run.

Each asserts one line on stderr, no traceback, and that no finished result is lost (the
finished cells resume, with the values a fresh run computes).
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from envfit import cli
from envfit.maps import EnvMap
from envfit.maps import save_envmap
from envfit.base._errors import EnvMapFileError
from envfit.maps._lazy_maps import resolve_map_sources

GRID = ["--max-height", "32", "--s", "1.2,1.4,1.6,1.8", "--n", "100,200,400,800,1200,1600"]


def test_sigterm_mid_sweep_keeps_finished_cells(tmp_path, capsys):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "envfit.cli", "table2", *GRID, "--quiet",
                             "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=tmp_path)
    cells = out / "cells"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(cells.glob("*.json"))) < 2:
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    # 24 cells up to N = 1600: the sweep cannot finish within one 50 ms poll of its 2nd cell
    assert proc.poll() is None, "the sweep ended before SIGTERM was sent"
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert lines == ["envfit table2: terminated (SIGTERM); finished results are kept"]
    done = sorted(p.name for p in cells.glob("*.json"))
    assert len(done) >= 2 and not list(cells.glob(".*.tmp"))
    # the rerun resumes exactly those cells and equals a fresh run
    assert cli.main(["table2", *GRID, "--out", str(out), "--json", "-"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert cli.main(["table2", *GRID, "--json", "-"]) == 0
    fresh = json.loads(capsys.readouterr().out)
    assert [r["rmse"] for r in resumed["rows"]] == pytest.approx(
        [r["rmse"] for r in fresh["rows"]], rel=1e-13, abs=0)


def test_map_changed_during_a_library_run_is_refused(tmp_path):
    path = tmp_path / "m.exr"
    save_envmap(path, EnvMap(np.full((8, 16, 3), 0.5, dtype=np.float32)))
    src = resolve_map_sources([str(path)])[0]
    planned = src.identity()
    assert src.load().height == 8                      # unchanged: loads
    time.sleep(0.01)
    save_envmap(path, EnvMap(np.random.default_rng(0).random((8, 16, 3)).astype(np.float32)))
    os.utime(path, ns=(time.time_ns(), planned["mtime_ns"] + 10**9))
    with pytest.raises(EnvMapFileError, match="changed during the run"):
        src.load()
    assert src.identity() == planned                   # the stores keep the planned identity


def test_map_changed_through_the_cli_is_one_line(tmp_path, capsys, monkeypatch):
    a, b = tmp_path / "lib" / "a.exr", tmp_path / "lib" / "b.exr"
    for p in (a, b):
        save_envmap(p, EnvMap(np.random.default_rng(len(p.name)).random((8, 16, 3)).astype(np.float32)))
    from envfit.maps import _lazy_maps as mapsource
    real_load = mapsource.MapSource.load

    touched = []

    def load_then_touch(self):
        env = real_load(self)
        if self.path and not touched:            # the other map changes while this one is used
            other = b if self.path.endswith("a.exr") else a
            os.utime(other, ns=(time.time_ns(), time.time_ns() + 10**9))
            touched.append(other.name)
        return env
    monkeypatch.setattr(mapsource.MapSource, "load", load_then_touch)
    rc = cli.main(["table2", str(tmp_path / "lib"), "--s", "1.5", "--n", "50", "--workers", "1",
                   "--quiet", "--out", str(tmp_path / "out")])
    cap = capsys.readouterr()
    assert touched, "no map was loaded"
    assert rc == 2 and "Traceback" not in cap.err
    lines = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(lines) == 1 and f"{touched[0]} changed during the run" in lines[0]

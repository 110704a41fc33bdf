"""Faults at the CLI boundary (issue 12, reliability): outputs checked before any work, failed
writes that lose nothing, strict argument parsing, a broken subcommand module.

Every case: exit code 2, one non-empty line on stderr (argparse's errors too: no usage
block, issue 22), no traceback; the runs use tiny inputs (built-in map at 16 rows, small N).
Unwritable paths are made by going *through a regular file* (``afile/sub``), which fails for
root too (chmod does not); a full disk is simulated in-process (a write raising ENOSPC) and in
a real process by ``RLIMIT_FSIZE`` (writes past the limit fail with EFBIG, SIGXFSZ ignored).
"""
from __future__ import annotations

import argparse
import errno
import json
import os
import resource
import signal
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np
import pytest

import envfit.base._atomic as atomic
import envfit.cli as cli
import envfit.plots._save as plot_save
from envfit.cli import _common as common
from envfit.cli import _parse as parse
from envfit.base._errors import EnvfitError, OutputError

TINY = ["--max-height", "16"]


@pytest.fixture(autouse=True)
def _no_progress_bars(monkeypatch):
    # tqdm writes to stderr; these tests count the lines there
    import tqdm.auto
    monkeypatch.setattr(tqdm.auto, "tqdm", partial(tqdm.auto.tqdm, disable=True))


@pytest.fixture
def afile(tmp_path) -> Path:
    p = tmp_path / "afile"
    p.write_text("a regular file\n")
    return p


@pytest.fixture
def tiny_map(tmp_path) -> Path:
    from envfit.maps._io import save_envmap
    a = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32) + 0.1
    return save_envmap(tmp_path / "tiny.exr", a)


def _lines(err: str) -> list[str]:
    """Non-empty stderr lines."""
    return [ln for ln in err.splitlines() if ln.strip()]


def _one_error(capsys, rc: int) -> tuple[str, str]:
    """Assert exit 2, one error line on stderr (argparse's too: no usage block), no
    traceback; return (that line, stdout)."""
    cap = capsys.readouterr()
    assert rc == 2, cap.err
    assert "Traceback" not in cap.err and "Traceback" not in cap.out
    lines = _lines(cap.err)
    assert len(lines) == 1, cap.err
    return lines[0], cap.out


# ============================================================== preflight: before any work
def _commands(tmp_path, tiny_map) -> dict[str, list[str]]:
    return {
        "synth": ["synth", str(tmp_path / "m.exr"), "--height", "8"],
        "info": ["info", str(tiny_map)],
        "fit": ["fit", *TINY, "--n", "50"],
        "table2": ["table2", "--quick", *TINY, "--n", "50,100"],
        "theory wce": ["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "64"],
        "theory table1": ["theory", "table1"],
        "theory figures": ["theory", "figures", "--n", "32", "--nmax", "32", "--lmax", "12",
                           "--cutoff-max", "4", "--qmc-nmax", "64"],
        "validate": ["validate", "--quick", *TINY, "--s", "1.5"],
        "advise": ["advise", *TINY, "--target-rmse", "0.03", "--no-cache"],
    }


CMDS = ("synth", "info", "fit", "table2", "theory wce", "theory table1", "theory figures",
        "validate", "advise")


@pytest.mark.parametrize("cmd", CMDS)
def test_unwritable_out_fails_before_work(cmd, tmp_path, tiny_map, afile, capsys):
    argv = _commands(tmp_path, tiny_map)[cmd] + ["--out", str(afile / "sub")]
    t0 = time.perf_counter()
    rc = cli.main(argv)
    elapsed = time.perf_counter() - t0
    line, out = _one_error(capsys, rc)
    assert line == f"envfit {cmd}: error: cannot write --out {afile / 'sub'}: Not a directory"
    assert out == ""                          # nothing started (every run prints "map …" first)
    assert elapsed < 3.0
    assert not (tmp_path / "m.exr").exists()


@pytest.mark.parametrize("cmd", CMDS)
def test_json_naming_a_folder_fails_before_work(cmd, tmp_path, tiny_map, capsys):
    folder = tmp_path / "adir"
    folder.mkdir()
    t0 = time.perf_counter()
    rc = cli.main(_commands(tmp_path, tiny_map)[cmd] + ["--json", str(folder)])
    line, out = _one_error(capsys, rc)
    assert line == f"envfit {cmd}: error: cannot write --json {folder}: it is a folder, not a file"
    assert out == "" and time.perf_counter() - t0 < 3.0


@pytest.mark.parametrize("option", ["--out", "--json"])
def test_symlink_loop_as_output(option, tmp_path, capsys):
    loop = tmp_path / "loop"
    os.symlink("loop", loop)                  # ln -s loop loop
    rc = cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "64",
                   option, str(loop)])
    line, out = _one_error(capsys, rc)
    assert line == (f"envfit theory wce: error: cannot write {option} {loop}: Too many levels "
                    "of symbolic links")
    assert out == ""


def test_json_under_a_regular_file_and_synth_output(tmp_path, afile, capsys):
    rc = cli.main(["info", str(afile), "--json", str(afile / "x.json")])
    line, _ = _one_error(capsys, rc)
    assert line == f"envfit info: error: cannot write --json {afile / 'x.json'}: Not a directory"
    rc = cli.main(["synth", str(afile / "m.exr"), "--height", "8"])
    line, _ = _one_error(capsys, rc)
    assert line == f"envfit synth: error: cannot write {afile / 'm.exr'}: Not a directory"
    rc = cli.main(["synth", str(tmp_path), "--height", "8"])
    line, _ = _one_error(capsys, rc)
    assert line == f"envfit synth: error: cannot write {tmp_path}: it is a folder, not a file"


def test_out_that_is_a_file_and_missing_out_is_created(tmp_path, afile, capsys):
    rc = cli.main(["theory", "table1", "--out", str(afile)])
    line, _ = _one_error(capsys, rc)
    assert line == f"envfit theory table1: error: cannot write --out {afile}: exists and is not a folder"
    # a missing --out (and --json parent) is fine: created, proven writable, no probe left
    out, js = tmp_path / "new" / "deep", tmp_path / "j" / "k" / "w.json"
    assert cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "32",
                     "--out", str(out), "--json", str(js), "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["wce_spectrum.csv", "wce_spectrum.png"]
    assert json.loads(js.read_text())["n"] == 32


def test_check_writable_helpers(tmp_path, afile):
    assert atomic.check_writable_dir(tmp_path / "a" / "b", "--out").is_dir()
    assert list((tmp_path / "a" / "b").iterdir()) == []           # the probe is removed
    assert atomic.check_writable_file("-", "--json") is None
    assert atomic.check_writable_file(tmp_path / "x" / "y.json", "--json") == tmp_path / "x" / "y.json"
    assert not (tmp_path / "x").exists()                           # nothing created for a file
    dangling = tmp_path / "dangling"
    os.symlink(tmp_path / "nowhere", dangling)
    with pytest.raises(OutputError, match="dangling symbolic link"):
        atomic.check_writable_dir(dangling / "sub", "--out")
    with pytest.raises(OutputError, match="not a regular file"):
        atomic.check_writable_file("/dev/null", "--json")
    assert issubclass(OutputError, EnvfitError) and OutputError.__doc__


def test_check_writable_dir_reports_a_refusing_folder(tmp_path, monkeypatch):
    # what a read-only mount answers (os.access would say yes for root)
    def refuse(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))
    monkeypatch.setattr(atomic.os, "open", refuse)
    with pytest.raises(OutputError) as e:
        atomic.check_writable_dir(tmp_path, "--out")
    assert str(e.value) == f"cannot write --out {tmp_path}: Read-only file system"


def test_unwritable_cache_is_a_note_not_an_error_cli(tmp_path, afile, monkeypatch, capsys):
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(afile / "cache"))
    rc = cli.main(["advise", *TINY, "--target-rmse", "0.03", "--fit-n", "100", "--pointsets",
                   "sf", "--weights", "equal", "--bases", "none", "--nmax", "256",
                   "--no-renderer"])
    cap = capsys.readouterr()
    assert rc == 0 and "Traceback" not in cap.err
    err = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("envfit advise: note: the advisor cache ")
    assert "recommendation:" in cap.out and "cache switched off" not in cap.out  # said once


def test_unwritable_cache_is_a_note_not_an_error(tmp_path, afile, capsys):
    from envfit.base._notes import NoteKind
    from envfit.cli._output import CommandOutput
    args = argparse.Namespace(command="advise", out=None, json=None, cache_dir=afile / "c",
                              no_cache=False)
    output = CommandOutput.for_args(args)
    common.preflight_outputs(args, output)                 # no exception: not an error
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("envfit advise: note: the advisor cache ")
    assert "not writable (Not a directory)" in err[0] and "error" not in err[0]
    assert [n.kind for n in output.notes] == [NoteKind.CACHE_OFF]          # a note of a kind
    assert err[0] == f"envfit advise: note: {output.notes[0]}"
    assert not vars(args).keys() - {"command", "out", "json", "cache_dir", "no_cache"}
    args.no_cache = True                                   # --no-cache: nothing to check
    output = CommandOutput.for_args(args)
    common.preflight_outputs(args, output)
    assert capsys.readouterr().err == "" and not output.has_note(NoteKind.CACHE_OFF)


# ============================================================== failed writes after the work
def _fail_writes(monkeypatch, names, err=errno.ENOSPC):
    """Writes of files named ``names`` raise OSError(err); others go through."""
    orig = atomic.atomic_write_bytes

    def fake(path, data):
        if Path(path).name in names:
            raise OSError(err, os.strerror(err))
        return orig(path, data)
    monkeypatch.setattr(atomic, "atomic_write_bytes", fake)
    monkeypatch.setattr(plot_save, "atomic_write_bytes", fake)


def test_disk_full_after_table2_prints_the_table(tmp_path, monkeypatch, capsys):
    _fail_writes(monkeypatch, {"table2.csv", "table2_rmse.png"})
    out = tmp_path / "out"
    rc = cli.main(["table2", "--quick", *TINY, "--s", "1.5", "--n", "50,100", "--out", str(out)])
    line, stdout = _one_error(capsys, rc)
    assert line == (f"envfit table2: error: could not write {out / 'table2_rmse.png'}: No space "
                    "left on device; 1 more file(s) not written (the results above are complete)")
    assert "RMSE per pixel" in stdout and "s with the lowest RMSE at N = 100" in stdout
    assert "32x16" in stdout                                       # sizes are W x H
    assert not list(out.glob(".*.tmp"))


def test_disk_full_json_file_goes_to_stdout(tmp_path, monkeypatch, capsys):
    _fail_writes(monkeypatch, {"r.json"})
    js = tmp_path / "r.json"
    rc = cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "64",
                   "--json", str(js)])
    line, stdout = _one_error(capsys, rc)
    assert line == (f"envfit theory wce: error: could not write {js}: No space left on device "
                    "(the results above are complete)")
    assert "worst-case error E =" in stdout
    r = json.loads(stdout[stdout.index("{"):])                     # the JSON after the text
    assert r["n"] == 64 and not js.exists()


def test_disk_full_with_json_stdout_keeps_the_json(tmp_path, monkeypatch, capsys):
    _fail_writes(monkeypatch, {"wce_spectrum.csv"})
    rc = cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "64",
                   "--out", str(tmp_path / "o"), "--json", "-"])
    line, stdout = _one_error(capsys, rc)
    assert "could not write" in line and "wce_spectrum.csv: No space left on device" in line
    assert json.loads(stdout)["n"] == 64                           # stdout holds only the JSON


def test_disk_full_quiet_prints_the_json(tmp_path, monkeypatch, capsys):
    _fail_writes(monkeypatch, {"table1.csv", "table1_wce_by_L.csv"}, errno.EIO)
    rc = cli.main(["theory", "table1", "--out", str(tmp_path / "o"), "--quiet"])
    line, stdout = _one_error(capsys, rc)
    assert line.startswith("envfit theory table1: error: could not write ") and "Input/output error" in line
    assert json.loads(stdout)["target"] == 2.5e-3                  # not lost despite --quiet


def test_disk_full_fit_plot(tmp_path, monkeypatch, capsys):
    _fail_writes(monkeypatch, {"fit_likelihood.png"})
    out = tmp_path / "o"
    rc = cli.main(["fit", *TINY, "--n", "50", "--out", str(out)])
    line, stdout = _one_error(capsys, rc)
    assert line == (f"envfit fit: error: could not write {out / 'fit_likelihood.png'}: No space "
                    "left on device (the results above are complete)")
    assert "s = " in stdout and "32x16" in stdout and "wrote" not in stdout


def test_atomic_write_failure_leaves_old_file_and_no_temporary(tmp_path, monkeypatch):
    p = tmp_path / "r.json"
    atomic.atomic_write_json(p, {"old": 1})

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(atomic.os, "fsync", full)
    with pytest.raises(OSError):
        atomic.atomic_write_json(p, {"new": 2})
    assert json.loads(p.read_text()) == {"old": 1}
    assert [q.name for q in tmp_path.iterdir()] == ["r.json"]


def _limit_file_size(nbytes: int) -> None:  # pragma: no cover - runs in the child
    resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, nbytes))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def test_file_size_limit_in_a_real_process(tmp_path):
    out, js = tmp_path / "o", tmp_path / "w.json"
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    p = subprocess.run([sys.executable, "-m", "envfit.cli", "theory", "wce", "--brdf", "diffuse",
                        "--pointset", "sf", "--n", "64", "--out", str(out), "--json", str(js)],
                       capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path,
                       preexec_fn=partial(_limit_file_size, 256))
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr
    err = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert err == [f"envfit theory wce: error: could not write {out / 'wce_spectrum.csv'}: File "
                   "too large; 2 more file(s) not written (the results above are complete)"]
    assert "worst-case error E =" in p.stdout
    assert json.loads(p.stdout[p.stdout.index("{"):])["n"] == 64
    assert list(out.iterdir()) == [] and not js.exists()           # no temporary left behind


# ============================================================== strict parsing
WCE = ["theory", "wce", "--brdf", "glossy", "--pointset", "sf"]


@pytest.mark.parametrize("argv, message", [
    (["table2", "--n", "100.5"], "argument --n: 100.5 is not a whole number"),
    (["table2", "--n", "100,100"], "argument --n: 100 is given twice in '100,100'"),
    (["table2", "--n", "100,1e2"], "argument --n: 100 and 1e2 are the same value in '100,1e2'"),
    (["table2", "--n", "0,100"], "argument --n: 0 is outside 2 <= N <= W x H (the map's pixels: "
                                  "more samples add no information)"),
    (["table2", "--n", "100,,200"], "argument --n: empty entry in '100,,200'"),
    (["table2", "--s", ""], "argument --s: empty list; give comma-separated values"),
    (["table2", "--s", "1.5,1.5"], "argument --s: 1.5 is given twice in '1.5,1.5'"),
    (["table2", "--s", "1.5,1.50"], "argument --s: 1.5 and 1.50 are the same value in '1.5,1.50'"),
    (["table2", "--s", "1.5,nan"], "argument --s: nan is not a finite number"),
    (["table2", "--s", "inf"], "argument --s: inf is not a finite number"),
    (["table2", "--s", "x"], "argument --s: x is not a number"),
    (["table2", "--workers", "0"],
     f"argument --workers: 0 is outside 1 <= K <= {len(os.sched_getaffinity(0))}"),
    (["fit", "--n", "100.5"], "argument --n: 100.5 is not a whole number"),
    (["fit", "--n", "1e-3"], "argument --n: 1e-3 is not a whole number"),
    (["fit", "--n", "nan"], "argument --n: nan is not a whole number"),
    (["fit", "--n", "1e30"], "argument --n: 1e30 is outside 10 <= N <= W x H (the map's pixels: "
                              "more samples add no information)"),
    (["fit", "--seed", "-1"], "argument --seed: -1 is not >= 0"),
    (["fit", "--seed", "1.5"], "argument --seed: 1.5 is not a whole number"),
    (["fit", "--max-height", "0"], "argument --max-height: 0 is not positive"),
    (["fit", "--max-height", "16.5"], "argument --max-height: 16.5 is not a whole number"),
    ([*WCE, "--n", "64", "--lmax", "-1"], "argument --lmax: -1 is outside 0 <= LMAX <= 4096"),
    ([*WCE, "--n", "64", "--shininess", "0"], "argument --shininess: 0 is outside 0 < n <= 10000"),
    ([*WCE, "--n", "64", "--shininess", "nan"], "argument --shininess: nan is not a finite number"),
    ([*WCE, "--n", "64.5"], "argument --n: 64.5 is not a whole number"),
    (["theory", "figures", "--nmax", "2048.5"], "argument --nmax: 2048.5 is not a whole number"),
    (["validate", "--axes", "0"], "argument --axes: 0 is outside 2 <= M <= 100000"),
    (["validate", "--sh-L", "0,1,1"], "argument --sh-L: 1 is given twice in '0,1,1'"),
    (["validate", "--shininess", "-3"], "argument --shininess: -3 is outside 0 < n <= 10000"),
    (["advise", "--target-rmse", "nan"], "argument --target-rmse: nan is not a finite number"),
    (["advise", "--target-rmse", "0.01", "--fit-n", "3000.5"],
     "argument --fit-n: 3000.5 is not a whole number"),
    (["synth", "x.exr", "--height", "8.5"], "argument --height: 8.5 is not a whole number"),
    (["synth", "x.exr", "--offset", "nan"], "argument --offset: nan is not a finite number"),
])
def test_bad_values_are_one_line_usage_errors(argv, message, capsys):
    rc = cli.main(argv)
    line, out = _one_error(capsys, rc)          # no usage block: the one line only
    prog = "envfit " + " ".join(argv[:2] if argv[0] == "theory" else argv[:1])
    assert line == f"{prog}: error: {message} (see '{prog} --help')"


def test_whole_numbers_and_lists_accepted():
    assert common.int_list("100,1e3, 2500") == [100, 1000, 2500]
    assert parse.positive_int("1e3") == 1000 and parse.positive_int("100.0") == 100
    assert parse.positive_int("12345678901234567") == 12345678901234567     # exact, no float
    assert parse.nonneg_int("0") == 0 and common.nonneg_int_list("0,1,2") == [0, 1, 2]
    assert common.float_list("1.1,1.5,1.9") == [1.1, 1.5, 1.9]
    assert common.colour_list("0.5,0.5,0.5") == [0.5, 0.5, 0.5]             # repeats: a colour
    for bad in ("", " ", "1.5,", "1,x"):
        with pytest.raises(argparse.ArgumentTypeError):
            common.float_list(bad)
    with pytest.raises(argparse.ArgumentTypeError):
        common.str_list(" , ")


# ============================================================== broken subcommand module
def test_broken_subcommand_module_is_an_error(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "envfit.cli._validate", None)    # import now fails
    rc = cli.main(["validate", "--quick"])
    line, out = _one_error(capsys, rc)
    assert line.startswith("envfit validate: error: cannot load the 'validate' subcommand: "
                           "envfit.cli._validate failed to import (ModuleNotFoundError")
    assert out == ""
    rc = cli.main(["--help"])       # the summary looks each module up: not silently without it
    line, out = _one_error(capsys, rc)
    assert line.startswith("envfit: error: cannot load the 'validate' subcommand")


def test_missing_subcommand_module_is_an_error(monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", (*cli.COMMANDS, "nosuch"))
    rc = cli.main(["nosuch"])
    line, _ = _one_error(capsys, rc)
    assert line.startswith("envfit nosuch: error: cannot load the 'nosuch' subcommand: "
                           "envfit.cli._nosuch failed to import (ModuleNotFoundError")


def test_subcommand_raising_on_import_is_an_error(tmp_path, capsys):
    # a real process whose envfit.cli._info raises on import (a broken install)
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(
        "import sys, importlib.abc\n"
        "class F(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name == 'envfit.cli._info':\n"
        "            raise SyntaxError('invalid syntax (info.py, line 1)')\n"
        "sys.meta_path.insert(0, F())\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(site)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    p = subprocess.run([sys.executable, "-m", "envfit.cli", "info", "x.exr"],
                       capture_output=True, text=True, env=env, timeout=60, cwd=tmp_path)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    err = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("envfit info: error: cannot load the 'info' "
                                               "subcommand") and "SyntaxError" in err[0]


def test_disk_full_mid_run_keeps_every_cell_and_names_the_file(tmp_path, monkeypatch, capsys):
    """A resumable cell that cannot be written mid-run (disk full): the sweep goes on with the
    cell in memory, the table is printed complete, one note says resumability is lost, and
    the run ends with exit 2 naming the file. The RMSEs equal a run that wrote everything."""
    import envfit.base._store as store_mod
    orig = store_mod.atomic_write_json

    def fake(path, obj):
        if Path(path).parent.name == "cells" and "n100" in Path(path).name:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return orig(path, obj)
    monkeypatch.setattr(store_mod, "atomic_write_json", fake)
    out = tmp_path / "out"
    args = ["table2", "--quick", *TINY, "--s", "1.5", "--n", "50,100", "--json", "-"]
    rc = cli.main([*args, "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 2 and "Traceback" not in cap.err
    err = [ln for ln in cap.err.splitlines() if ln.strip()]
    notes = [ln for ln in err if "note:" in ln]
    errors = [ln for ln in err if ln.startswith("envfit table2: error:")]
    assert len(notes) == 1 and "a rerun will compute them again" in notes[0]
    assert len(errors) == 1 and "s1.5000_n100.json: No space left on device" in errors[0]
    got = json.loads(cap.out)
    monkeypatch.setattr(store_mod, "atomic_write_json", orig)
    assert cli.main([*args, "--out", str(tmp_path / "clean")]) == 0
    ref = json.loads(capsys.readouterr().out)
    assert [r["rmse"] for r in got["rows"]] == [r["rmse"] for r in ref["rows"]]
    assert got["unwritten"] and not ref["unwritten"]
    assert not (out / "cells" / "s1.5000_n100.json").exists()


@pytest.mark.parametrize("where", ["open", "fsync", "replace"])
def test_atomic_write_interrupted_at_each_step_leaves_no_temporary(tmp_path, monkeypatch, where):
    """A SIGTERM (turned into an exception) or Ctrl-C right after each system call of the
    write: the old file stays and no ``.r.json.*.tmp`` is left (an interrupted sweep once
    left one when the signal came the instant after ``tempfile.mkstemp`` created it)."""
    p = tmp_path / "r.json"
    atomic.atomic_write_json(p, {"old": 1})
    owner = atomic if where == "open" else atomic.os
    real = open if where == "open" else getattr(atomic.os, where)
    opened = []

    def then_interrupted(*a, **k):
        opened.append(real(*a, **k))
        raise KeyboardInterrupt
    monkeypatch.setattr(owner, where, then_interrupted, raising=False)
    with pytest.raises(KeyboardInterrupt):
        atomic.atomic_write_json(p, {"new": 2})
    monkeypatch.undo()
    for fh in opened:
        if hasattr(fh, "close"):
            fh.close()
    assert [q.name for q in tmp_path.iterdir()] == ["r.json"]
    expected = {"new": 2} if where == "replace" else {"old": 1}
    assert json.loads(p.read_text()) == expected


def test_save_envmap_interrupted_after_the_write_leaves_no_temporary(tmp_path, monkeypatch):
    """``save_envmap`` writes through OpenImageIO to a temporary named before it exists: a
    Ctrl-C after the image is written and before the move leaves the old file and nothing
    else (the name was bound only on ``mkstemp``'s return before)."""
    from envfit.maps import _io
    from envfit.maps import load_envmap, save_envmap
    p = tmp_path / "m.exr"
    save_envmap(p, np.ones((4, 8, 3)))
    real = _io._write_image

    def written_then_interrupted(*a, **k):
        real(*a, **k)
        raise KeyboardInterrupt
    monkeypatch.setattr(_io, "_write_image", written_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        save_envmap(p, np.full((4, 8, 3), 2.0))
    monkeypatch.undo()
    assert [q.name for q in tmp_path.iterdir()] == ["m.exr"]
    assert float(load_envmap(p).data.max()) == 1.0


def test_cache_probe_interrupted_leaves_no_temporary(tmp_path, monkeypatch):
    """The advisor cache's write check, interrupted between creating its probe file and
    removing it, removes the probe anyway."""
    from envfit.advisor._cache import cache_write_problem
    real = atomic.os.unlink
    calls = []

    def interrupted_once(path, *a, **k):
        calls.append(path)
        if len(calls) == 1:
            raise KeyboardInterrupt
        return real(path, *a, **k)
    monkeypatch.setattr(atomic.os, "unlink", interrupted_once)
    with pytest.raises(KeyboardInterrupt):
        cache_write_problem(tmp_path)
    monkeypatch.undo()
    assert len(calls) == 2 and list((tmp_path / "advise").iterdir()) == []

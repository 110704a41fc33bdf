"""Issue 22: argparse errors are one line with a pointer to ``--help`` (item 9), and no output
may name an input (item 4). Every refusal: exit 2, exactly one line on stderr, no traceback,
nothing written, the input untouched."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import envfit.cli as cli

WCE = ["theory", "wce", "--brdf", "diffuse", "--pointset", "sf"]


def _one_line(capsys, rc: int) -> str:
    cap = capsys.readouterr()
    assert rc == 2, cap.err
    assert "Traceback" not in cap.err + cap.out and cap.out == ""
    lines = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(lines) == 1, cap.err
    return lines[0]


# ============================================================== item 9: argparse, one line
@pytest.mark.parametrize("argv, prog, what", [
    (["synth", "x.exr", "--kind", "nope"], "envfit synth",
     "argument --kind: invalid choice: 'nope' (choose from 'gp', 'sun-gp', 'constant', 'sky', "
     "'sun', 'step', 'marker')"),
    (["info"], "envfit info", "the following arguments are required: MAP"),
    (["fit", "--n", "0"], "envfit fit", "argument --n: 0 is outside 10 <= N <= W x H (the "
     "map's pixels: more samples add no information)"),
    (["table2", "--s", ""], "envfit table2", "argument --s: empty list; give comma-separated values"),
    ([*WCE[:2]], "envfit theory wce",
     "the following arguments are required: --brdf, --pointset, --n"),
    (["theory", "table1", "--s", "x"], "envfit theory table1", "argument --s: x is not a number"),
    (["theory", "figures", "--only"], "envfit theory figures",
     "argument --only: expected one argument"),
    (["validate", "--axes", "-2"], "envfit validate", "argument --axes: -2 is outside 2 <= M <= 100000"),
    (["advise", "--axes", "1"], "envfit advise", "argument --axes: 1 is outside 2 <= M <= 100000"),
    (["advise", "--target-rmse", "1", "--target-relative", "0.1"], "envfit advise",
     "argument --target-relative: not allowed with argument --target-rmse"),
    (["sh", "--lmax", "2", "--window", "x"], "envfit sh",
     "argument --window: invalid choice: 'x' (choose from 'none', 'hanning', 'lanczos', 'sloan')"),
    (["sh"], "envfit sh", "the following arguments are required: --lmax"),
    (["info", "m.exr", "--bogus", "1"], "envfit info", "unrecognized arguments: --bogus 1"),
    ([*WCE, "--n", "8", "--zz"], "envfit theory wce", "unrecognized arguments: --zz"),
    (["theory", "nope"], "envfit theory",
     "argument WHAT: invalid choice: 'nope' (choose from 'wce', 'table1', 'figures')"),
    (["nosuch"], "envfit", "argument COMMAND: invalid choice: 'nosuch' (choose from 'synth', "
     "'info', 'fit', 'table2', 'theory', 'validate', 'advise', 'sh', 'frame')"),
    (["--bogus"], "envfit", "unrecognized arguments: --bogus"),
])
def test_argparse_errors_are_one_line_with_a_pointer_to_help(argv, prog, what, capsys):
    line = _one_line(capsys, cli.main(argv))
    assert line == f"{prog}: error: {what} (see '{prog} --help')"


@pytest.mark.parametrize("argv, first", [
    (["--help"], "usage: envfit [-h] [--version] COMMAND ..."),
    (["sh", "--help"], "usage: envfit sh [-h]"),
    (["theory", "wce", "-h"], "usage: envfit theory wce [-h]"),
    (["advise", "--help"], "usage: envfit advise [-h]"),
])
def test_help_still_prints_the_full_help_and_exits_0(argv, first, capsys):
    rc = cli.main(argv)
    cap = capsys.readouterr()
    assert rc == 0 and cap.err == ""
    assert cap.out.startswith(first)
    assert "options:" in cap.out and len(cap.out.splitlines()) > 8     # the full help, not usage


def test_no_command_prints_help_exit_2(capsys):
    assert cli.main([]) == 2
    cap = capsys.readouterr()
    assert cap.out.startswith("usage: envfit") and "advise" in cap.out and cap.err == ""
    assert cli.main(["theory"]) == 2                      # no WHAT: theory's help
    assert "table1" in capsys.readouterr().out


def test_version_exits_0(capsys):
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("envfit ")


def test_one_line_in_a_real_process(tmp_path):
    p = subprocess.run([sys.executable, "-m", "envfit.cli", "fit", "--n", "100.5"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr == ("envfit fit: error: argument --n: 100.5 is not a whole number "
                        "(see 'envfit fit --help')\n")


# ============================================================== item 4: outputs vs inputs
@pytest.fixture
def tiny(tmp_path) -> Path:
    from envfit.maps._io import save_envmap
    a = np.random.default_rng(1).random((8, 16, 3)).astype(np.float32) + 0.1
    return save_envmap(tmp_path / "tiny.exr", a)


def _digest(p: Path) -> bytes:
    return p.read_bytes()


def _refused(capsys, argv, *inputs) -> str:
    """Run argv: refused in one line before any work; the inputs byte for byte unchanged."""
    before = {p: _digest(p) for p in inputs}
    t0 = time.perf_counter()
    line = _one_line(capsys, cli.main([str(a) for a in argv]))
    assert time.perf_counter() - t0 < 5.0
    assert all(_digest(p) == b for p, b in before.items())
    return line


def test_json_naming_the_input_map(tiny, tmp_path, capsys):
    line = _refused(capsys, ["info", tiny, "--json", tiny], tiny)
    assert line == (f"envfit info: error: --json {tiny} is the input map {tiny}: an output file "
                    "may not replace an input; choose another path")


@pytest.mark.parametrize("how", ["symlink", "hardlink", "dotdot", "relative"])
def test_json_naming_the_input_by_another_path(how, tiny, tmp_path, capsys, monkeypatch):
    if how == "symlink":
        other = tmp_path / "link.exr"
        os.symlink(tiny.name, other)
    elif how == "hardlink":
        other = tmp_path / "hard.exr"
        os.link(tiny, other)
        assert os.path.realpath(other) != os.path.realpath(tiny)     # only the inode is shared
    elif how == "dotdot":
        (tmp_path / "d").mkdir()
        other = tmp_path / "d" / ".." / tiny.name
    else:
        monkeypatch.chdir(tmp_path)
        other = Path(tiny.name)
    line = _refused(capsys, ["info", tiny, "--json", other], tiny)
    assert line.startswith(f"envfit info: error: --json {other} is the input map {tiny}")


@pytest.mark.parametrize("cmd", [
    ["fit", "--n", "50"], ["table2", "--quick", "--n", "50"], ["validate", "--quick"],
    ["advise", "--no-cache", "--target-rmse", "0.1"], ["sh", "--lmax", "2"],
])
def test_every_map_command_refuses_json_over_its_map(cmd, tiny, capsys):
    line = _refused(capsys, [*cmd, tiny, "--json", tiny], tiny)
    assert f"--json {tiny} is the input map {tiny}" in line


def test_synth_output_and_json_naming_one_file(tmp_path, capsys):
    out = tmp_path / "x.exr"
    line = _refused(capsys, ["synth", out, "--height", "8", "--json", out])
    assert line == (f"envfit synth: error: --json {out} and the map {out} name the same file: "
                    "each output needs its own path")
    assert not out.exists()
    old = tmp_path / "old.exr"                # an existing map is an output of synth: allowed
    assert cli.main(["synth", str(old), "--height", "8", "-q"]) == 0
    assert cli.main(["synth", str(old), "--height", "8", "-q", "--seed", "3"]) == 0


def test_out_folder_and_cache_folder_naming_the_input(tiny, capsys):
    line = _refused(capsys, ["info", tiny, "--out", tiny], tiny)
    assert line.startswith(f"envfit info: error: --out {tiny} is the input map {tiny}")
    line = _refused(capsys, ["advise", tiny, "--cache-dir", tiny], tiny)
    assert line.startswith(f"envfit advise: error: --cache-dir {tiny} is the input map {tiny}")


def test_input_inside_out_under_a_name_the_command_writes(tmp_path, tiny, capsys):
    png = tmp_path / "sh.png"                 # a PNG map named as sh's plot
    from envfit.maps._io import save_envmap
    save_envmap(png, np.full((8, 16, 3), 0.5, dtype=np.float32))
    line = _refused(capsys, ["sh", png, "--lmax", "1", "--out", tmp_path], png)
    assert line == (f"envfit sh: error: --out {tmp_path} holds the input map {png}, which the "
                    "command writes there (sh.png); choose another --out folder or move the map")
    # the same folder with a map of another name is fine: nothing is overwritten
    assert cli.main(["info", str(tiny), "--out", str(tmp_path), "-q"]) == 0
    assert (tmp_path / "tiny_preview.png").exists() and _digest(tiny)


def test_json_among_the_files_of_out(tiny, tmp_path, capsys):
    out = tmp_path / "o"
    line = _refused(capsys, ["info", tiny, "--out", out, "--json", out / "tiny_info.json"])
    assert line == (f"envfit info: error: --json {out / 'tiny_info.json'} is also written by "
                    f"--out {out} (tiny_info.json): each output needs its own path")


def test_library_out_or_map_file_inside_an_input_folder(tmp_path, tiny, capsys):
    lib = tmp_path / "lib"
    lib.mkdir()
    os.replace(tiny, lib / "a.exr")
    line = _refused(capsys, ["fit", lib, "--n", "50", "--out", lib], lib / "a.exr")
    assert line.startswith(f"envfit fit: error: --out {lib} is the folder of input maps {lib}")
    line = _refused(capsys, ["table2", lib, "--n", "50", "--json", lib / "r.png"])
    assert line.startswith(f"envfit table2: error: --json {lib / 'r.png'} lies in the folder "
                           f"of input maps {lib}")
    line = _refused(capsys, ["table2", str(lib / "*.exr"), "--n", "50", "--json",
                             lib / "a.exr"], lib / "a.exr")                   # a pattern
    assert f"is the input map {lib / 'a.exr'}" in line
    line = _refused(capsys, ["table2", str(lib / "*.exr"), "--n", "50", "--json",
                             lib / "new.exr"])                  # a future match of the pattern
    assert line == (f"envfit table2: error: --json {lib / 'new.exr'} matches the input pattern "
                    f"{lib / '*.exr'} and would be read as a map by the next run; choose "
                    "another path")
    import argparse
    from envfit.cli._overlap import check_no_overlap
    check_no_overlap(argparse.Namespace(command="table2", map=[str(lib / "*.exr")],
                                        json=lib / "new.json"), None, None)   # no match: fine


def test_theory_json_among_its_out_files_and_validate_name_collision(tmp_path, tiny, capsys):
    out = tmp_path / "figs"
    line = _refused(capsys, [*WCE, "--n", "16", "--out", out, "--json", out / "wce_spectrum.csv"])
    assert line == (f"envfit theory wce: error: --json {out / 'wce_spectrum.csv'} is also "
                    f"written by --out {out} (wce_spectrum.csv): each output needs its own path")
    # a map whose name validate writes (its figures) inside --out; another name is fine
    png = tmp_path / "validate_s_choice.png"
    from envfit.maps._io import save_envmap
    save_envmap(png, np.full((8, 16, 3), 0.5, dtype=np.float32))
    line = _refused(capsys, ["validate", png, "--quick", "--out", tmp_path], png)
    assert "which the command writes there (validate_s_choice.png)" in line
    from envfit.cli._overlap import check_no_overlap
    import argparse
    ok = argparse.Namespace(command="validate", map=str(tmp_path / "validate_map.exr"),
                            json=None, out=tmp_path)
    (tmp_path / "validate_map.exr").write_bytes(b"x")      # not a name validate writes
    check_no_overlap(ok, tmp_path, None)

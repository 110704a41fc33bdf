"""CommandOutput, the explicit output of a command run (no state on the argparse Namespace):
printing, the result, failed writes reported after the results, notes by kind."""
from __future__ import annotations

import argparse
import errno
import json
import os

from envfit.base._errors import EnvMapFileError
from envfit.base._notes import Note, NoteKind, note_kind
from envfit.cli._output import CommandOutput, WriteFailure


def _output(**kw) -> CommandOutput:
    args = argparse.Namespace(command="fit", json=None, quiet=False, **kw)
    return CommandOutput.for_args(args)


def test_say_is_silent_with_quiet_or_json_on_stdout(capsys):
    _output().say("a", "b")
    assert capsys.readouterr().out == "a\nb\n"
    CommandOutput("fit", quiet=True).say("a")
    CommandOutput("fit", json_path="-").say("a")
    assert capsys.readouterr().out == ""


def test_failed_json_write_goes_to_stdout_then_one_error_line(tmp_path, capsys):
    out = CommandOutput("fit", json_path=tmp_path / "no" / "such" / "dir" / "r.json")
    (tmp_path / "no").write_text("a file where a folder should be")
    out.emit_json({"s": 1.5})
    cap = capsys.readouterr()
    assert json.loads(cap.out) == {"s": 1.5} and out.json_on_stdout and out.result == {"s": 1.5}
    assert [f.path for f in out.write_failures] == [str(out.json_path)]
    assert out.report_write_failures() == 2
    cap = capsys.readouterr()
    assert cap.out == ""                              # the JSON is already on stdout, once
    assert cap.err.startswith(f"envfit fit: error: could not write {out.json_path}: ")
    assert cap.err.endswith("(the results above are complete)\n")


def test_quiet_run_prints_its_result_when_a_write_fails(tmp_path, capsys):
    out = CommandOutput("table2", json_path=tmp_path / "r.json", quiet=True)
    out.emit_json({"n": [1, 2]})
    assert json.loads((tmp_path / "r.json").read_text()) == {"n": [1, 2]}
    assert out.guarded_write("plot.png", _raise_enospc) is None
    out.record_unwritten([("cell.json", "disk full")])
    out.record_write_failure("m.exr", EnvMapFileError("m.exr: write failed: EIO"))
    assert out.write_failures == [WriteFailure("plot.png", os.strerror(errno.ENOSPC)),
                                  WriteFailure("cell.json", "disk full"),
                                  WriteFailure("m.exr", "write failed: EIO")]
    assert out.report_write_failures() == 2
    cap = capsys.readouterr()
    assert json.loads(cap.out) == {"n": [1, 2]}         # --quiet: nowhere else to see it
    assert cap.err == (f"envfit table2: error: could not write plot.png: "
                       f"{os.strerror(errno.ENOSPC)}; 2 more file(s) not written (the results "
                       "above are complete)\n")


def _raise_enospc():
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_notes_have_a_kind(capsys):
    out = _output()
    assert not out.has_note(NoteKind.CACHE_OFF)
    out.note(NoteKind.CACHE_OFF, "the advisor cache /x is not writable")
    assert capsys.readouterr().err == "envfit fit: note: the advisor cache /x is not writable\n"
    assert out.has_note(NoteKind.CACHE_OFF) and out.notes[0].kind is NoteKind.CACHE_OFF
    n = Note("cache switched off: cannot write under /x (EROFS)", NoteKind.CACHE_OFF)
    assert json.dumps([n]) == json.dumps([str(n)])     # still a string wherever it goes
    assert note_kind(n) is NoteKind.CACHE_OFF and note_kind("cache switched off") is None
